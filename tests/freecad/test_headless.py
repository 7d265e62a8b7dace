"""Headless FreeCAD test of the Sagitta workbench (run by freecadcmd through run_freecad.sh).

A document with a Bézier face and a B-spline face; each kind of feature is created through the code
the commands use (SagittaCore), recomputed, and compared with the independent reference: the
`sagitta` CLI on the same patches (facet counts from `tessellate --stats`, validation fields from
`validate --json`). Also: Undo after Tessellate, wrong selections, recompute on change, the source
never modified, the .bpt importer."""
import json
import math
import os
import subprocess
import sys
import tempfile
import types
import time
import traceback
import unittest

sys.path.insert(0, os.environ["SAGITTA_PYTHON_DIR"])
sys.path.insert(0, os.environ["SAGITTA_WORKBENCH_DIR"])

import FreeCAD  # noqa: E402
import Part  # noqa: E402

import Init  # noqa: E402,F401  (the workbench's non-GUI init: the import type)
import SagittaCore  # noqa: E402
import SagittaImport  # noqa: E402

CLI = os.environ["SAGITTA_CLI"]
SHARED = os.environ.get("SHARED_DATA", "")
WORK = tempfile.mkdtemp(prefix="sagitta-fc-")
TEAPOT = os.path.join(SHARED, "teapot.bpt")
# A fit that runs for about 10 s uncancelled (measured: see test_cancel_from_another_thread_stops_a_fit).
LONG_FIT = ("uniform", 3e-5)


def bezier_face():
    """A bicubic Bézier face with a bumpy, non-planar control net."""
    s = Part.BezierSurface()
    s.increase(3, 3)
    for i in range(4):
        for j in range(4):
            z = 0.6 * ((i * 7 + j * 3) % 5) / 4.0 - 0.2 * i * (3 - j) / 3.0
            s.setPole(i + 1, j + 1, FreeCAD.Vector(i * 1.0, j * 1.0, z))
    return Part.Face(s)


def bspline_face():
    """A cubic x quadratic B-spline face with interior knots (several Bézier spans per direction)
    and a few weights != 1."""
    nu, nv = 6, 4
    poles = [[FreeCAD.Vector(i * 0.8, j * 1.1, 0.3 * ((i + 2 * j) % 3) - 0.1 * i) for j in range(nv)] for i in range(nu)]
    weights = [[1.0 + 0.25 * ((i * j) % 2) for j in range(nv)] for i in range(nu)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4, 1, 1, 4], [3, 1, 3], [0.0, 0.3, 0.7, 1.0], [0.0, 0.5, 1.0],
                               False, False, 3, 2, weights)
    return Part.Face(s)


def heavy_weight_shell():
    """A shell of one rational B-spline face whose weights lie 1e70 apart: a real part (meshed whole)
    whose face the certificate cannot bound (beyond the 1e60 weight span the certified arithmetic
    carries: docs/VALIDATION.md), the case of an uncertified face."""
    poles = [[FreeCAD.Vector(i, j, 0.3 * ((i - 1) ** 2 - (j - 1) ** 2)) for j in range(3)] for i in range(3)]
    weights = [[1.0, 1.0, 1.0], [1.0, 1e-70, 1.0], [1.0, 1.0, 1.0]]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [3, 3], [3, 3], [0.0, 1.0], [0.0, 1.0], False, False, 2, 2, weights)
    return Part.Shell([Part.Face(s)])


def plate_with_hole_body(doc):
    """A PartDesign Body as a user makes it: a 60 x 40 rectangle padded 10, then a circle r 8 on the
    top pocketed through all (a plate with a round hole: its top and bottom faces are trimmed)."""
    import PartDesign  # noqa: F401  (registers PartDesign::Body)
    import Sketcher
    body = doc.addObject("PartDesign::Body", "Body")
    xy = [f for f in body.Origin.OriginFeatures if f.Role == "XY_Plane"][0]

    def sketch(name, z):
        s = body.newObject("Sketcher::SketchObject", name)
        s.Support = (xy, [""])
        s.MapMode = "FlatFace"
        s.AttachmentOffset = FreeCAD.Placement(FreeCAD.Vector(0, 0, z), FreeCAD.Rotation())
        return s
    pad_sketch = sketch("PadSketch", 0)
    corners = [FreeCAD.Vector(x, y, 0) for x, y in ((0, 0), (60, 0), (60, 40), (0, 40))]
    for i in range(4):
        pad_sketch.addGeometry(Part.LineSegment(corners[i], corners[(i + 1) % 4]))
    for i in range(4):
        pad_sketch.addConstraint(Sketcher.Constraint("Coincident", i, 2, (i + 1) % 4, 1))
    pad = body.newObject("PartDesign::Pad", "Pad")
    pad.Profile = pad_sketch
    pad.Length = 10
    hole_sketch = sketch("HoleSketch", 10)
    hole_sketch.addGeometry(Part.Circle(FreeCAD.Vector(20, 20, 0), FreeCAD.Vector(0, 0, 1), 8))
    pocket = body.newObject("PartDesign::Pocket", "Pocket")
    pocket.Profile = hole_sketch
    pocket.Type = "ThroughAll"
    doc.recompute()
    return body


def mesh_edge_uses(mesh):
    """How many facets use each undirected edge of a FreeCAD mesh (from its point indices)."""
    uses = {}
    for facet in mesh.Topology[1]:
        for k in range(3):
            a, b = facet[k], facet[(k + 1) % 3]
            key = (min(a, b), max(a, b))
            uses[key] = uses.get(key, 0) + 1
    return uses


def cli_json(args, name):
    """Runs the CLI with a JSON output and returns the parsed document."""
    out = os.path.join(WORK, name)
    subprocess.run([CLI] + args + ([out] if args[-1] in ("--stats", "--json") else []), check=True,
                   stdout=subprocess.DEVNULL)
    with open(out) as f:
        return json.load(f)


def scheme_args(params):
    args = ["--scheme", params["scheme"], "--level", str(params["level"])]
    if "threshold" in params:
        args += ["--threshold", repr(params["threshold"])]
    if "base_level" in params:
        args += ["--base-level", str(params["base_level"])]
    return args


SCHEMES = [
    {"scheme": "uniform", "level": 3},
    {"scheme": "esc", "level": 3, "threshold": 0.002},
    {"scheme": "pn", "level": 2, "base_level": 2},
]


class HeadlessTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.doc = FreeCAD.newDocument("SagittaHeadless")
        cls.doc.UndoMode = 1  # freecadcmd documents start without undo
        cls.bezier = cls.doc.addObject("Part::Feature", "BezierFace")
        cls.bezier.Shape = bezier_face()
        cls.bspline = cls.doc.addObject("Part::Feature", "BSplineFace")
        cls.bspline.Shape = bspline_face()
        cls.doc.recompute()

    def model_file(self, obj):
        """The patches Sagitta reads from the object, written as .bpt for the CLI."""
        model, _ = SagittaCore.shape_model([(obj, [])], obj.Label)
        path = os.path.join(WORK, obj.Name + ".bpt")
        with open(path, "w") as f:
            f.write(SagittaCore.model_to_bpt(model))
        return path, model

    def assert_interval(self, ours, cli):
        self.assertAlmostEqual(ours["lower"], cli["lower"], delta=1e-12 * max(1.0, abs(cli["lower"])))
        if cli["upper"] is None:
            self.assertIsNone(ours["upper"])
        else:
            self.assertAlmostEqual(ours["upper"], cli["upper"], delta=1e-12 * max(1.0, abs(cli["upper"])))
        self.assertEqual(ours["upper_certified"], cli["upper_certified"])

    def test_features_match_cli(self):
        for source in (self.bezier, self.bspline):
            brep_before = source.Shape.exportBrepToString()
            path, model = self.model_file(source)
            self.assertGreaterEqual(model.patch_count, 6 if source is self.bspline else 1)
            for params in SCHEMES:
                with self.subTest(source=source.Label, scheme=params["scheme"]):
                    kwargs = {k: v for k, v in params.items()}
                    obj = SagittaCore.make_tessellation(self.doc, [(source, [])], **kwargs)
                    stats = cli_json(["tessellate", path] + scheme_args(params) + ["--stats"], "stats.json")
                    self.assertEqual(obj.Mesh.CountFacets, stats["triangles"])
                    self.assertEqual(obj.Triangles, stats["triangles"])
                    self.assertEqual(obj.Mesh.CountPoints, stats["vertices"])
                    self.assertEqual(obj.DegenerateTriangles, stats["degenerate_triangles"])
                    self.assertEqual(obj.Patches, stats["patches"])

                    report = SagittaCore.validate_tessellation(obj, max_depth=6)
                    cli = cli_json(["validate", path] + scheme_args(params) + ["--max-depth", "6", "--json"], "validate.json")
                    for key in ("hausdorff", "mesh_to_surface", "surface_to_mesh"):
                        self.assert_interval(report[key], cli[key])
                    for key in ("triangles", "vertices", "certified", "coverage_ok", "method", "subtriangles",
                                "triangles_at_depth_budget"):
                        self.assertEqual(report[key], cli[key], key)
                    for key in ("edges", "open_edges", "model_boundary_edges", "crack_edges", "t_junctions",
                                "non_manifold_edges", "inconsistent_orientation_edges", "degenerate_triangles",
                                "duplicated_faces", "watertight"):
                        self.assertEqual(report["topology"][key], cli["topology"][key], key)
                    self.assertAlmostEqual(obj.ErrorLower, cli["hausdorff"]["lower"], delta=1e-12)
                    self.assertEqual(len(obj.FaceColors), obj.Mesh.CountFacets)
            self.assertEqual(source.Shape.exportBrepToString(), brep_before, "the source shape was modified")

    def test_freecad_mesh_validated_like_cli_mesh_input(self):
        """FreeCAD's own mesh (MeshPart) of the B-spline face, validated against the exact face,
        gives the interval `sagitta validate --mesh` gives for the same triangles."""
        import _sagitta
        path, _ = self.model_file(self.bspline)
        mesh_obj = SagittaCore.freecad_mesh_of(self.doc, [(self.bspline, [])], linear_deflection=0.05)
        report = SagittaCore.validate_mesh_object(mesh_obj, [(self.bspline, [])], max_depth=6)
        self.assertEqual(report["method"], "reference")
        points, facets = mesh_obj.Mesh.Topology
        ply = os.path.join(WORK, "freecad-mesh.ply")
        _sagitta.write_mesh(_sagitta.mesh_from_arrays([tuple(p) for p in points], facets), ply)
        cli = cli_json(["validate", path, "--mesh", ply, "--max-depth", "6", "--json"], "freecad-mesh.json")
        self.assertEqual(report["triangles"], cli["triangles"])
        for key in ("hausdorff", "mesh_to_surface", "surface_to_mesh"):
            self.assert_interval(report[key], cli[key])

    def test_fit_matches_cli_and_meets_target(self):
        path, _ = self.model_file(self.bezier)
        target = 2e-3
        for scheme in ("uniform", "esc"):
            with self.subTest(scheme=scheme):
                obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme=scheme, level=1)
                result = SagittaCore.fit_tessellation(obj, target)
                cli = cli_json(["fit", path, "--scheme", scheme, "--target-error", repr(target), "--json"], "fit.json")
                self.assertTrue(result["met"])
                self.assertEqual(obj.TargetError, target)
                if scheme == "uniform":
                    self.assertEqual(obj.Segments, cli["segments"])
                    args = ["--segments", str(obj.Segments)]
                else:
                    self.assertEqual((obj.Level, obj.Threshold), (cli["level"], cli["threshold"]))
                    args = ["--scheme", "esc", "--level", str(obj.Level), "--threshold", repr(obj.Threshold)]
                self.assertEqual(obj.Triangles, cli["triangles"])
                # Independently: the CLI's validator certifies the chosen parameters within the target.
                check = cli_json(["validate", path] + args + ["--json"], "fit-check.json")
                self.assertLessEqual(check["hausdorff"]["upper"], target)

    def test_recomputes_on_property_and_source_change(self):
        obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme="uniform", level=3)
        self.assertEqual(obj.Triangles, 2 * 8 * 8)
        obj.Level = 2
        self.doc.recompute()
        self.assertEqual(obj.Mesh.CountFacets, 2 * 4 * 4)
        moved = self.doc.addObject("Part::Feature", "Moving")
        moved.Shape = bezier_face()
        follower = SagittaCore.make_tessellation(self.doc, [(moved, [])], scheme="uniform", level=1)
        moved.Shape = bezier_face().translated(FreeCAD.Vector(0, 0, 5))
        self.doc.recompute()
        # FreeCAD meshes keep float coordinates.
        self.assertAlmostEqual(follower.Mesh.BoundBox.ZMin, moved.Shape.BoundBox.ZMin, delta=1e-5)

    def test_saved_document_reopens_and_recomputes(self):
        doc = FreeCAD.newDocument("Saved")
        face = doc.addObject("Part::Feature", "Face")
        face.Shape = bezier_face()
        obj = SagittaCore.make_tessellation(doc, [(face, [])], scheme="esc", level=3, threshold=0.01)
        triangles, name = obj.Triangles, obj.Name
        path = os.path.join(WORK, "saved.FCStd")
        doc.saveAs(path)
        FreeCAD.closeDocument(doc.Name)
        doc = FreeCAD.openDocument(path)
        obj = doc.getObject(name)
        self.assertTrue(SagittaCore.is_tessellation(obj))
        self.assertEqual((obj.Scheme, obj.Level, obj.Triangles), ("esc", 3, triangles))
        obj.touch()
        doc.recompute()
        self.assertEqual(obj.Mesh.CountFacets, triangles)
        FreeCAD.closeDocument(doc.Name)

    def test_undo_restores_document(self):
        names = sorted(o.Name for o in self.doc.Objects)
        obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, ["Face1"])])
        self.assertIn(obj.Name, [o.Name for o in self.doc.Objects])
        self.doc.undo()
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), names)
        self.doc.redo()
        self.assertEqual(len(self.doc.Objects), len(names) + 1)
        self.doc.undo()

    def test_core_never_imports_the_gui(self):
        """SagittaCore imports no GUI module (the GUI imports Core, never the reverse): neither in its
        source nor at run time after creating, validating and fitting a feature."""
        import ast
        with open(SagittaCore.__file__, encoding="utf-8") as f:
            tree = ast.parse(f.read())
        imported = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
                    for alias in node.names}
        imported |= {node.module.split(".")[0] for node in ast.walk(tree)
                     if isinstance(node, ast.ImportFrom) and node.module}
        for gui in ("SagittaGui", "FreeCADGui", "PySide"):
            self.assertNotIn(gui, imported)
        obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme="uniform", level=1)
        SagittaCore.validate_tessellation(obj, max_depth=2)
        SagittaCore.fit_tessellation(obj, 0.05)
        self.assertNotIn("SagittaGui", sys.modules)

    def test_partdesign_plate_with_hole_is_meshed_whole(self):
        """Tessellate on a PartDesign Body with a hole meshes every face, closed: the same mesh as the
        module's mesh_part_brep on the body's BREP text, one mesh segment per face, closed and outward
        by FreeCAD's own mesh checks with the solid's volume; Validate reports each solid closed and the
        certified distance; Undo removes the feature; the body is untouched."""
        import _sagitta
        doc = FreeCAD.newDocument("PlateWithHole")
        doc.UndoMode = 1
        body = plate_with_hole_body(doc)
        self.assertTrue(body.isValid() and len(body.Shape.Solids) == 1)
        faces = len(body.Shape.Faces)
        brep_before, volume = body.Shape.exportBrepToString(), body.Shape.Volume
        names, undo_count = sorted(o.Name for o in doc.Objects), doc.UndoCount

        obj = SagittaCore.make_tessellation(doc, [(body, [])], scheme="uniform", level=2)
        reference = _sagitta.mesh_part_brep(brep_before, "reference", level=2)
        self.assertTrue(obj.WholePart)
        self.assertEqual(reference.faces_tessellated, faces)
        self.assertGreater(reference.faces_trimmed, 0)
        self.assertEqual(obj.Mesh.CountFacets, reference.mesh.triangle_count)
        self.assertEqual(obj.Mesh.CountPoints, reference.mesh.vertex_count)
        self.assertEqual(list(obj.TriangleFace), reference.triangle_face.tolist())
        self.assertEqual(len(obj.SourceFaces), faces)
        self.assertEqual(obj.Mesh.countSegments(), faces)
        for k in range(faces):
            self.assertEqual(sorted(obj.Mesh.getSegment(k)),
                             [t for t, f in enumerate(obj.TriangleFace) if f == k])
        # Closed and consistently oriented, by FreeCAD's mesh kernel and by counting edge uses.
        self.assertTrue(obj.Mesh.isSolid())
        self.assertFalse(obj.Mesh.hasNonManifolds())
        self.assertEqual(obj.Mesh.countNonUniformOrientedFacets(), 0)
        self.assertEqual(set(mesh_edge_uses(obj.Mesh).values()), {2})
        self.assertAlmostEqual(obj.Mesh.Volume, volume, delta=0.01 * volume)

        report = SagittaCore.validate_tessellation(obj)
        self.assertEqual(report["kind"], "part")
        self.assertEqual([c["solid"] for c in report["solids"]], [0])
        check = report["solids"][0]
        self.assertEqual((check["open_edges"], check["crack_edges"], check["t_junctions"]), (0, 0, 0))
        self.assertTrue(check["closed"] and check["cgal_closed"] and check["cgal_outward"])
        self.assertEqual(check["euler_characteristic"], 0)  # genus 1: the hole
        self.assertEqual(obj.TopologyVerdict, "solid 1: closed")
        # The certificate is the one `sagitta validate` gives for the body's BREP file at the same level.
        brep = os.path.join(WORK, "plate_with_hole.brep")
        body.Shape.exportBrep(brep)
        cli = cli_json(["validate", brep, "--level", "2", "--json"], "plate_with_hole.json")["certificate"]
        self.assertEqual(obj.Certification, "certified")
        self.assertTrue(cli["certified"] and report["certified"] and report["hausdorff"]["upper_certified"])
        self.assertEqual((obj.ErrorLower, obj.ErrorUpper), (cli["hausdorff"]["lower"], cli["hausdorff"]["upper"]))
        self.assertTrue(0 < obj.ErrorLower <= obj.ErrorUpper < math.inf)
        self.assertEqual([f["name"] for f in report["face_certificates"]], ["Face%d" % (k + 1) for k in range(faces)])
        # Coloured by certified error: the colours certified_error_colours gives the library's bounds.
        errors = _sagitta.certify_part(_sagitta.mesh_part_brep(brep_before, "plate", level=2), 8)["triangle_error"]
        self.assertEqual(len(errors), obj.Mesh.CountFacets)
        expected, top = SagittaCore.certified_error_colours(errors.tolist())
        self.assertEqual((report["colour_scale_top"], report["uncertified_triangles"]), (top, 0))
        self.assertEqual(report["faces_to_check"], [])  # closed and certified: nothing to look at
        self.assertTrue(0 < top <= obj.ErrorUpper)
        self.assertEqual(len(obj.FaceColors), obj.Mesh.CountFacets)
        for got, want in zip(obj.FaceColors, expected):
            self.assertEqual(tuple(round(c, 2) for c in got[:3]), tuple(round(c, 2) for c in want))
        self.assertNotIn(SagittaCore.UNCERTIFIED_COLOUR, [tuple(c[:3]) for c in obj.FaceColors])
        html_path = os.path.join(WORK, "part.html")
        SagittaCore.write_html_report(report, obj.Label, html_path)
        with open(html_path) as f:
            self.assertIn("Distance: certified", f.read())
        with self.assertRaises(SagittaCore.SagittaError):  # pn is for triangle meshes: refused, nothing added
            SagittaCore.make_tessellation(doc, [(body, [])], scheme="pn", level=2, base_level=1)

        doc.undo()  # the validation
        doc.undo()  # the creation
        self.assertEqual(sorted(o.Name for o in doc.Objects), names)
        self.assertEqual(doc.UndoCount, undo_count)
        self.assertEqual(body.Shape.exportBrepToString(), brep_before, "the source shape was modified")
        self.assertEqual(body.Shape.Volume, volume)
        FreeCAD.closeDocument(doc.Name)

    def test_whole_part_reopens_with_its_face_segments(self):
        """FreeCAD does not save mesh segments; a reopened whole-part feature has them again."""
        doc = FreeCAD.newDocument("SavedPart")
        plate = doc.addObject("Part::Feature", "Plate")
        plate.Shape = Part.makeBox(10, 10, 2).cut(Part.makeCylinder(2, 5, FreeCAD.Vector(5, 5, -1)))
        obj = SagittaCore.make_tessellation(doc, [(plate, [])], scheme="uniform", level=2)
        segments = [sorted(obj.Mesh.getSegment(k)) for k in range(obj.Mesh.countSegments())]
        self.assertEqual(len(segments), len(plate.Shape.Faces))
        path, name = os.path.join(WORK, "part.FCStd"), obj.Name
        doc.saveAs(path)
        FreeCAD.closeDocument(doc.Name)
        doc = FreeCAD.openDocument(path)
        obj = doc.getObject(name)
        self.assertTrue(obj.WholePart)
        self.assertEqual([sorted(obj.Mesh.getSegment(k)) for k in range(obj.Mesh.countSegments())], segments)
        FreeCAD.closeDocument(doc.Name)

    def test_selected_faces_of_a_part(self):
        """Faces selected on a solid are meshed together, sharing their common edges: the mesh's only
        open edges are the selection's rim (model boundary), never cracks between the faces."""
        doc = FreeCAD.newDocument("PlateFaces")
        body = plate_with_hole_body(doc)
        brep_before = body.Shape.exportBrepToString()
        cylinders = [k + 1 for k, f in enumerate(body.Shape.Faces) if f.Surface.TypeId == "Part::GeomCylinder"]
        top = [k + 1 for k, f in enumerate(body.Shape.Faces)
               if f.Surface.TypeId == "Part::GeomPlane" and abs(f.CenterOfMass.z - 10) < 1e-9]
        self.assertEqual((len(cylinders), len(top)), (1, 1))
        subs = ["Face%d" % cylinders[0], "Face%d" % top[0]]
        obj = SagittaCore.make_tessellation(doc, [(body, subs)], scheme="uniform", level=2)
        self.assertTrue(obj.WholePart)
        self.assertEqual(obj.Mesh.countSegments(), 2)
        self.assertEqual(len(obj.SourceFaces), 2)
        uses = mesh_edge_uses(obj.Mesh)
        self.assertEqual(set(uses.values()), {1, 2})
        report = SagittaCore.validate_tessellation(obj)
        rim = sum(1 for n in uses.values() if n == 1)
        self.assertEqual([c["solid"] for c in report["solids"]], [-1])  # faces outside any solid
        self.assertEqual(report["solids"][0]["crack_edges"], 0)
        self.assertEqual(report["solids"][0]["model_boundary_edges"], rim)
        self.assertEqual(body.Shape.exportBrepToString(), brep_before, "the source shape was modified")
        FreeCAD.closeDocument(doc.Name)

    def test_wrong_selection_changes_nothing(self):
        mesh_obj = self.doc.addObject("Mesh::Feature", "NotAShape")
        self.doc.recompute()
        names = sorted(o.Name for o in self.doc.Objects)
        undo_count = self.doc.UndoCount
        for links in ([], [(mesh_obj, [])]):
            with self.assertRaises(SagittaCore.SagittaError):
                SagittaCore.make_tessellation(self.doc, links)
        obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme="uniform", level=1)
        undo_count = self.doc.UndoCount
        names = sorted(o.Name for o in self.doc.Objects)
        with self.assertRaises(SagittaCore.SagittaError):  # invalid parameter: refused, old values kept
            SagittaCore.edit_tessellation(obj, Scheme="esc", Level=-1)
        self.assertEqual(obj.Scheme, "uniform")
        self.assertEqual(obj.Level, 1)
        with self.assertRaises(SagittaCore.SagittaError):
            SagittaCore.validate_tessellation(self.bezier)
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), names)
        self.assertEqual(self.doc.UndoCount, undo_count)

    def test_import_teapot_and_time_level_4(self):
        path = os.path.join(SHARED, "teapot.bpt")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        doc = FreeCAD.newDocument("Teapot")
        SagittaImport.insert(path, doc.Name)
        teapot = doc.Objects[0]
        self.assertEqual(len(teapot.Shape.Faces), 32)
        self.assertTrue(all(isinstance(f.Surface, Part.BezierSurface) for f in teapot.Shape.Faces))
        start, cpu_start = time.perf_counter(), time.process_time()
        obj = SagittaCore.make_tessellation(doc, [(teapot, [])], scheme="uniform", level=4)
        report = SagittaCore.validate_tessellation(obj)
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu_start
        # The reference reads the original file, not what the importer made of it.
        cli = cli_json(["validate", path, "--level", "4", "--json"], "teapot.json")
        self.assertEqual(obj.Mesh.CountFacets, cli["triangles"])
        self.assert_interval(report["hausdorff"], cli["hausdorff"])
        print("\nTIMING teapot level 4 Tessellate + Validate inside FreeCAD: %.3f s wall, %.3f s CPU (validation %.3f s wall)"
              % (seconds, cpu, report["seconds"]), flush=True)
        FreeCAD.closeDocument(doc.Name)

    def test_step_shape_through_the_occt_adapter(self):
        """A STEP solid read by FreeCAD is meshed whole, as the module meshes the same file, and each
        closed, valid solid comes out closed."""
        import _sagitta
        path = os.path.join(SHARED, "cad", "screw.step")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        screw = self.doc.addObject("Part::Feature", "Screw")
        screw.Shape = Part.read(path)
        self.doc.recompute()
        obj = SagittaCore.make_tessellation(self.doc, [(screw, [])], scheme="uniform", level=2)
        reference = _sagitta.mesh_part(path, level=2)
        self.assertTrue(obj.WholePart)
        self.assertEqual(obj.Triangles, reference.mesh.triangle_count)
        self.assertEqual(obj.Patches, reference.model.patch_count)
        self.assertEqual(len(obj.SourceFaces), len(screw.Shape.Faces))  # one line per face: tessellated or why not
        self.assertEqual(reference.faces_tessellated, len(screw.Shape.Faces))
        report = SagittaCore.validate_tessellation(obj)
        for check in report["solids"]:
            if check["brep_closed"] and check["brep_valid"]:
                self.assertTrue(check["closed"], check)
                self.assertEqual(check["crack_edges"], 0)

    def test_bspline_face_matches_cli_on_its_brep_file(self):
        """The B-spline face exported as a BREP file and read by the CLI (no .bpt in between)."""
        path = os.path.join(WORK, "bspline.brep")
        self.bspline.Shape.exportBrep(path)
        obj = SagittaCore.make_tessellation(self.doc, [(self.bspline, [])], scheme="esc", level=3, threshold=0.002)
        stats = cli_json(["tessellate", path, "--scheme", "esc", "--level", "3", "--threshold", "0.002", "--stats"],
                         "bspline-brep.json")
        self.assertEqual(obj.Triangles, stats["triangles"])

    def test_open_rib_file(self):
        """File -> Open of a .rib goes to the Sagitta importer and gives one Bézier face with the
        file's corner points."""
        self.assertIn("SagittaImport", str(FreeCAD.getImportType("rib")))
        points = [(float(i), float(j), float((i * j) % 3)) for j in range(4) for i in range(4)]
        values = [c for p in points for c in p]
        path = os.path.join(WORK, "one.rib")
        with open(path, "w") as f:
            f.write('Patch "bicubic" "P" [%s]\n' % " ".join(repr(v) for v in values))
        doc = SagittaImport.open(path)
        faces = doc.Objects[0].Shape.Faces
        self.assertEqual(len(faces), 1)
        self.assertIsInstance(faces[0].Surface, Part.BezierSurface)
        self.assertEqual((faces[0].Surface.UDegree, faces[0].Surface.VDegree), (3, 3))
        corners = sorted(tuple(round(c, 12) for c in v.Point) for v in faces[0].Vertexes)
        self.assertEqual(corners, sorted({points[0], points[3], points[12], points[15]}))
        FreeCAD.closeDocument(doc.Name)

    def test_face_names_are_freecads(self):
        """Messages name faces as FreeCAD's selection does (a cylinder's top is Face2, not the first
        face Sagitta read): each SourceFaces line's name has the surface type FreeCAD gives that name."""
        doc = FreeCAD.newDocument("FaceNames")
        cylinder = doc.addObject("Part::Feature", "Cylinder")
        cylinder.Shape = Part.makeCylinder(5, 10)
        doc.recompute()
        kinds = {"Part::GeomCylinder": "Cylinder", "Part::GeomPlane": "Plane"}

        def check_notes(notes, expected):
            self.assertEqual([n.split(" ")[0].rstrip(":") for n in notes], expected)
            for note in notes:
                name = note.split(" ")[0].rstrip(":").split(".")[-1]
                self.assertIn(kinds[cylinder.Shape.getElement(name).Surface.TypeId], note, note)
        for subs, expected in ((["Face3", "Face2"], ["Face3", "Face2"]), ([], ["Face1", "Face2", "Face3"])):
            obj = SagittaCore.make_tessellation(doc, [(cylinder, subs)], scheme="uniform", level=2)
            check_notes(list(obj.SourceFaces), expected)
        # The patch path: two objects, each face named with its object's label.
        _, notes = SagittaCore.shape_model([(self.bezier, []), (cylinder, ["Face3"])])
        self.assertEqual([n.split(":")[0] for n in notes], ["BezierFace.Face1", "Cylinder.Face3"])
        self.assertIn("trimmed", notes[1])
        with self.assertRaises(SagittaCore.SagittaError) as refused:  # a refusal names the face as FreeCAD does
            SagittaCore.shape_model([(cylinder, ["Face2"])])
        self.assertIn("Face2: trimmed", str(refused.exception))
        FreeCAD.closeDocument(doc.Name)

    def test_uncertified_upper_bound_is_never_below_the_lower(self):
        """ErrorUpper is a certified bound or inf (before Validate, or when Validate certifies none),
        never 0 below ErrorLower; inf survives save + reopen."""
        doc = FreeCAD.newDocument("Uncertified")
        face = doc.addObject("Part::Feature", "Face")
        face.Shape = bezier_face()
        heavy = doc.addObject("Part::Feature", "Heavy")
        heavy.Shape = heavy_weight_shell()
        doc.recompute()
        obj = SagittaCore.make_tessellation(doc, [(face, [])], scheme="uniform", level=2)
        self.assertEqual((obj.ErrorLower, obj.ErrorUpper, obj.Certification), (0.0, math.inf, "not validated"))
        report = SagittaCore.validate_tessellation(obj, max_depth=4)
        self.assertTrue(report["hausdorff"]["upper_certified"])
        self.assertEqual(obj.ErrorUpper, report["hausdorff"]["upper"])
        # A whole part whose one face the arithmetic cannot certify (heavy_weight_shell).
        part = SagittaCore.make_tessellation(doc, [(heavy, [])], scheme="uniform", level=2)
        self.assertTrue(part.WholePart)
        SagittaCore.validate_tessellation(part)
        self.assertTrue(part.Certification.startswith("not certified (1 of 1 faces): Face1: not certified: patch 0's "
                                                      "weights span"), part.Certification)
        self.assertEqual(part.ErrorUpper, math.inf)
        self.assertGreaterEqual(part.ErrorUpper, part.ErrorLower)
        self.assertEqual(SagittaCore.certified_upper({"upper": None, "upper_certified": False}), math.inf)
        self.assertEqual(SagittaCore.certified_upper({"upper": 0.5, "upper_certified": False}), math.inf)
        path, name = os.path.join(WORK, "uncertified.FCStd"), part.Name
        doc.saveAs(path)
        FreeCAD.closeDocument(doc.Name)
        doc = FreeCAD.openDocument(path)
        self.assertEqual(doc.getObject(name).ErrorUpper, math.inf)
        FreeCAD.closeDocument(doc.Name)

    def test_refused_edit_leaves_the_feature_valid(self):
        """A refused edit (panel or property editor) puts the old values and their mesh back, the
        feature not Invalid, and says why in property names, not command-line options."""
        obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme="uniform", level=2)
        facets = obj.Mesh.CountFacets
        for values in ({"Scheme": "esc", "Level": -1}, {"Scheme": "pn", "Level": 0}, {"Scheme": "esc", "Threshold": -1.0}):
            with self.subTest(values=values):
                with self.assertRaises(SagittaCore.SagittaError) as refused:
                    SagittaCore.edit_tessellation(obj, **values)
                message = str(refused.exception)
                self.assertNotIn("--", message)
                self.assertTrue(any(key in message for key in values if key != "Scheme"), message)
                self.assertEqual((obj.Scheme, obj.Level, obj.Threshold), ("uniform", 2, 0.01))
                self.assertEqual(obj.Mesh.CountFacets, facets)
                self.assertNotIn("Invalid", obj.State)
                self.assertNotIn("Touched", obj.State)
        obj.Level = -1  # the property editor: set, then recompute
        self.doc.recompute()
        self.assertEqual((obj.Level, obj.Mesh.CountFacets), (2, facets))
        self.assertNotIn("Invalid", obj.State)
        self.assertEqual(SagittaCore.in_property_words("uniform scheme: give exactly one of --level L or --segments N"),
                         "uniform scheme: give exactly one of Level or Segments")

    def test_refused_validate_adds_no_mesh(self):
        """Validate of a Part object Sagitta cannot measure (a face on an offset of a B-spline: no exact
        rational form) is refused and leaves no FreeCADMesh object behind. A disk (one trimmed face)
        is measured face by face and certified."""
        offset = self.doc.addObject("Part::Feature", "Offset")
        # (an offset of a cylinder is a cylinder, and is measured: the basis here is a B-spline)
        basis = Part.BSplineSurface()
        basis.interpolate([[FreeCAD.Vector(i, j, 0.3 * (i - 1) * (j - 1)) for j in range(3)] for i in range(3)])
        offset.Shape = Part.OffsetSurface(basis, 0.5).toShape()
        self.doc.recompute()
        names, undo_count = sorted(o.Name for o in self.doc.Objects), self.doc.UndoCount
        with self.assertRaises(SagittaCore.SagittaError) as refused:
            SagittaCore.validate_freecad_mesh(self.doc, [(offset, [])])
        self.assertIn("offset", str(refused.exception))
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), names)
        self.assertEqual(self.doc.UndoCount, undo_count)
        disk = self.doc.addObject("Part::Feature", "Disk")
        disk.Shape = Part.Face(Part.Wire(Part.makeCircle(5)))
        self.doc.recompute()
        mesh_obj, report = SagittaCore.validate_freecad_mesh(self.doc, [(disk, [])], max_depth=4)
        self.assertEqual((report["kind"], report["certified"]), ("part", True), report["distance"])
        self.doc.removeObject(mesh_obj.Name)
        mesh_obj, report = SagittaCore.validate_freecad_mesh(self.doc, [(self.bezier, [])], max_depth=4)
        self.assertEqual(mesh_obj.TypeId, "Mesh::Feature")
        self.assertEqual(report["triangles"], mesh_obj.Mesh.CountFacets)

    def test_uncertified_faces_have_their_own_colour(self):
        """A whole part whose face is not certified (heavy_weight_shell) is coloured magenta there (no
        bound: not on the error scale), and the colours survive save + reopen."""
        doc = FreeCAD.newDocument("UncertifiedColour")
        heavy = doc.addObject("Part::Feature", "Heavy")
        heavy.Shape = heavy_weight_shell()
        doc.recompute()
        obj = SagittaCore.make_tessellation(doc, [(heavy, [])], scheme="uniform", level=2)
        self.assertTrue(obj.WholePart)
        report = SagittaCore.validate_tessellation(obj, max_depth=4)
        self.assertFalse(report["certified"])
        self.assertEqual(report["uncertified_triangles"], obj.Mesh.CountFacets)  # its one face
        self.assertEqual([(f["name"], f["face_index"]) for f in report["faces_to_check"]], [("Face1", 0)])
        self.assertIn("weights span", report["faces_to_check"][0]["why"])
        html_path = os.path.join(WORK, "heavy.html")
        SagittaCore.write_html_report(report, obj.Label, html_path)
        with open(html_path, encoding="utf-8") as f:
            page = f.read()
        self.assertIn("<h2>Faces to check: 1</h2>\n<ul><li>Face1: not certified: patch 0&#x27;s weights span", page)
        self.assertEqual({tuple(c[:3]) for c in obj.FaceColors}, {SagittaCore.UNCERTIFIED_COLOUR})
        path, name = os.path.join(WORK, "uncertified-colour.FCStd"), obj.Name
        doc.saveAs(path)
        FreeCAD.closeDocument(doc.Name)
        doc = FreeCAD.openDocument(path)
        self.assertEqual({tuple(c[:3]) for c in doc.getObject(name).FaceColors}, {SagittaCore.UNCERTIFIED_COLOUR})
        FreeCAD.closeDocument(doc.Name)
        colours, top = SagittaCore.certified_error_colours([0.5, math.inf, 1.0, 0.0])
        self.assertEqual(top, 1.0)
        self.assertEqual(colours, [SagittaCore.legend_colour(0.5), SagittaCore.UNCERTIFIED_COLOUR,
                                   SagittaCore.legend_colour(1.0), SagittaCore.legend_colour(0.0)])

    def test_crack_faces_are_the_faces_along_open_edges_that_are_not_model_boundary(self):
        """crack_faces counts, per face, the open mesh edges that are not model boundary: two triangles
        of faces 0 and 1 sharing an edge; their four other edges are open, one of them model boundary."""
        part = types.SimpleNamespace(mesh=types.SimpleNamespace(triangles=[[0, 1, 2], [2, 1, 3]]),
                                     boundary_edges=[[3, 2]], triangle_face=[0, 1])
        self.assertEqual(SagittaCore.crack_faces(part), {0: 2, 1: 1})
        part.boundary_edges = [[0, 1], [1, 3], [2, 3], [0, 2]]
        self.assertEqual(SagittaCore.crack_faces(part), {})

    def test_level_beyond_memory_is_refused_before_allocating(self):
        """Issue 18: a level beyond memory is refused before anything is allocated, with a message
        that says how much it would need, how much there is and which Level fits; the document, or
        the feature being edited, stays as it was. The teapot at Level 10 (67 million triangles)
        with Maximum memory 3 GiB: refused in well under 5 s, the process's peak memory not grown by
        more than 200 MB; with the automatic limit (a share of MemAvailable) Level 12 (1 TiB)."""
        import _sagitta
        import resource
        path = os.path.join(SHARED, "teapot.bpt")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        params = FreeCAD.ParamGet(SagittaCore.PARAM_PATH)
        doc = FreeCAD.newDocument("TeapotMemory")
        doc.UndoMode = 1
        SagittaImport.insert(path, doc.Name)
        teapot = doc.Objects[0]
        names, undo_count = sorted(o.Name for o in doc.Objects), doc.UndoCount

        def peak_kib():
            return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        try:
            params.SetInt("MaxMemoryMiB", 3072)
            before, start = peak_kib(), time.perf_counter()
            with self.assertRaises(SagittaCore.MemoryRefused) as refused:
                SagittaCore.make_tessellation(doc, [(teapot, [])], scheme="uniform", level=10)
            seconds, grown_mb = time.perf_counter() - start, (peak_kib() - before) / 1024.0
            message = str(refused.exception)
            print("\nMEMORY teapot Level 10 refused in %.3f s, peak RSS grown %.0f MB: %s"
                  % (seconds, grown_mb, message), flush=True)
            self.assertLess(seconds, 5.0)
            self.assertLess(grown_mb, 200.0)
            self.assertIn("Level 10 would need about 64.0 GiB of memory, more than the 3.0 GiB available "
                          "(the Maximum memory preference); choose Level ≤ 7", message)
            self.assertEqual(sorted(o.Name for o in doc.Objects), names)
            self.assertEqual(doc.UndoCount, undo_count)

            # An edit (panel or property editor) to a level beyond memory: the feature as it was.
            obj = SagittaCore.make_tessellation(doc, [(teapot, [])], scheme="uniform", level=3)
            facets, undo_count = obj.Mesh.CountFacets, doc.UndoCount
            for values in ({"Level": 10}, {"Segments": 5000}, {"Scheme": "pn", "Level": 200, "BaseLevel": 3}):
                with self.subTest(values=values):
                    before = peak_kib()
                    with self.assertRaises(SagittaCore.SagittaError) as refused:
                        SagittaCore.edit_tessellation(obj, **values)
                    self.assertLess((peak_kib() - before) / 1024.0, 200.0)
                    key = "Segments" if "Segments" in values else "Level"
                    self.assertRegex(str(refused.exception),
                                     r"%s \d+ would need about .* choose %s ≤ \d+$" % (key, key))
                    self.assertNotIn("--", str(refused.exception))
                    self.assertEqual((obj.Scheme, obj.Level, obj.Segments, obj.Mesh.CountFacets),
                                     ("uniform", 3, 0, facets))
                    self.assertNotIn("Invalid", obj.State)
            self.assertEqual(doc.UndoCount, undo_count)
            # The suggestion fits: Segments = the number offered is accepted.
            with self.assertRaises(SagittaCore.SagittaError) as refused:
                SagittaCore.edit_tessellation(obj, Segments=5000)
            offered = int(str(refused.exception).rsplit("≤ ", 1)[1])
            self.assertLessEqual(_sagitta.estimated_triangles(SagittaCore.shape_model([(teapot, [])])[0], "uniform",
                                                              segments=offered) * SagittaCore.BYTES_PER_TRIANGLE,
                                 3072 * 2 ** 20)
            self.assertGreater(_sagitta.estimated_triangles(SagittaCore.shape_model([(teapot, [])])[0], "uniform",
                                                            segments=offered + 1) * SagittaCore.BYTES_PER_TRIANGLE,
                               3072 * 2 ** 20)

            # Validate is checked too: with 1 MiB the Level 3 feature's validation is refused, nothing stored.
            params.SetInt("MaxMemoryMiB", 1)
            with self.assertRaises(SagittaCore.MemoryRefused) as refused:
                SagittaCore.validate_tessellation(obj)
            self.assertTrue(str(refused.exception).startswith(
                "Validate: Level 3 would need about 4 MiB of memory, more than the 1 MiB available"), str(refused.exception))
            self.assertEqual((obj.Certification, obj.ErrorUpper, doc.UndoCount),
                             ("not validated", math.inf, undo_count))

            # The library's own refusal (its limit set by the check), in the workbench's words.
            with self.assertRaises(SagittaCore.MemoryRefused) as refused:
                SagittaCore.tessellate_model(_sagitta.read_model(path), {"scheme": "uniform", "level": 6})
            self.assertIn("more than the 0.000977 GiB Sagitta may use", str(refused.exception))
            self.assertNotIn("--", str(refused.exception))

            # The automatic limit: a share of the memory available now.
            params.SetInt("MaxMemoryMiB", 0)
            limit, source = SagittaCore.memory_limit()
            # (memory available moves between the two reads while other processes run)
            self.assertAlmostEqual(limit / (SagittaCore.AVAILABLE_SHARE * SagittaCore.available_memory()), 1.0, places=2)
            self.assertIn("of the memory available now", source)
            before = peak_kib()
            with self.assertRaises(SagittaCore.SagittaError) as refused:
                SagittaCore.edit_tessellation(obj, Level=12)
            self.assertIn("Level 12 would need about 1024.0 GiB", str(refused.exception))
            self.assertLess((peak_kib() - before) / 1024.0, 200.0)
            self.assertEqual((obj.Level, obj.Mesh.CountFacets), (3, facets))
        finally:
            params.RemInt("MaxMemoryMiB")
            _sagitta.reset_budget()
        FreeCAD.closeDocument(doc.Name)

    def test_foreign_mesh_of_a_part_is_certified_face_by_face(self):
        """Validate of a mesh that is not Sagitta's (FreeCAD's MeshPart) against a Part Cylinder, a solid
        whose caps are trimmed planes: the library finds the mesh's vertices and triangles on the
        cylinder's faces and certifies each face (FreeCAD's names), as `sagitta validate PART --mesh`;
        the brute-force distance from the mesh's vertices to the exact cylinder stays within the bound.
        Nothing is added to the document. A Bézier face still validates through its patch."""
        cylinder = self.doc.addObject("Part::Cylinder", "Cylinder")
        self.doc.recompute()
        mesh_obj = SagittaCore.freecad_mesh_of(self.doc, [(cylinder, [])], linear_deflection=0.05)
        names, undo_count = sorted(o.Name for o in self.doc.Objects), self.doc.UndoCount
        report = SagittaCore.validate_mesh_object(mesh_obj, [(cylinder, [])], max_depth=4)
        self.assertEqual(report["kind"], "part")
        self.assertTrue(report["certified"], report["distance"])
        self.assertEqual(sorted(f["name"] for f in report["face_certificates"]), ["Face1", "Face2", "Face3"])
        self.assertEqual(report["unassigned_triangles"], 0)
        self.assertEqual(report["triangles"], mesh_obj.Mesh.CountFacets)
        upper = report["hausdorff"]["upper"]
        self.assertLessEqual(report["hausdorff"]["lower"], upper)
        # Every mesh point lies within the bound of the exact solid's surface (vertices and centroids).
        shape = cylinder.Shape
        points = [FreeCAD.Vector(*p) for p in mesh_obj.Mesh.Topology[0]]
        points += [sum((FreeCAD.Vector(*q) for q in f.Points), FreeCAD.Vector()) * (1.0 / 3.0)
                   for f in mesh_obj.Mesh.Facets]
        worst = max(shape.distToShape(Part.Vertex(p))[0] for p in points[::max(1, len(points) // 400)])
        self.assertLessEqual(worst, upper * (1 + 1e-9) + 1e-9)
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), names)
        self.assertEqual(self.doc.UndoCount, undo_count)
        self.doc.removeObject(mesh_obj.Name)
        self.doc.removeObject(cylinder.Name)
        mesh_obj, report = SagittaCore.validate_freecad_mesh(self.doc, [(self.bezier, [])], max_depth=4)
        self.assertTrue(report["hausdorff"]["upper_certified"])
        self.doc.removeObject(mesh_obj.Name)

    def test_cancel_from_another_thread_stops_a_fit(self):
        """_sagitta.request_cancel from another thread stops a long fit (the teapot, uniform to 3e-5: about
        10 s uncancelled; since the validator's cheap bound, 1e-4 ends in 3 s), early or in its validations
        (3 s in: the validator's first pass once kept it 5-11 s before it checked the budget), with _sagitta.Interrupted within about a second; through SagittaCore the
        feature is unchanged and no Undo step is left; the next run is not stopped by the old request."""
        import threading
        import _sagitta
        if not os.path.exists(TEAPOT):
            self.skipTest("shared data absent")
        model = _sagitta.read_model(TEAPOT)

        def cancel_after(seconds, when):
            def cancel():
                time.sleep(seconds)
                when.append(time.perf_counter())
                _sagitta.request_cancel()
            thread = threading.Thread(target=cancel)
            thread.start()
            return thread
        for delay in (0.5, 3.0):
            when = []
            canceller = cancel_after(delay, when)
            SagittaCore.start_run()
            with self.assertRaises(_sagitta.Interrupted):
                _sagitta.fit(model, LONG_FIT[0], LONG_FIT[1])
            latency = time.perf_counter() - when[0]
            canceller.join()
            print("fit cancelled %.3f s after request_cancel (%.1f s in)" % (latency, delay), flush=True)
            self.assertLess(latency, 1.5)
            self.assertTrue(_sagitta.cancel_requested())

        # Through the workbench (headless: synchronous): the feature as it was.
        obj = SagittaCore.make_tessellation(self.doc, [(self.teapot(), [])], scheme=LONG_FIT[0], level=2)
        before, undo_count = SagittaCore.parameter_values(obj), self.doc.UndoCount
        triangles, target = obj.Triangles, obj.TargetError
        when = []
        canceller = cancel_after(0.5, when)
        with self.assertRaises(_sagitta.Interrupted):
            SagittaCore.fit_tessellation(obj, LONG_FIT[1])
        latency = time.perf_counter() - when[0]
        canceller.join()
        self.assertLess(latency, 1.5)
        self.assertEqual((SagittaCore.parameter_values(obj), obj.Triangles, obj.TargetError, self.doc.UndoCount),
                         (before, triangles, target, undo_count))
        self.assertNotIn("Invalid", obj.State)
        result = SagittaCore.fit_tessellation(obj, 0.05)  # a new run: the old request is cleared
        self.assertTrue(result["met"])

    def test_tessellate_panel_meshes_through_run_long(self):
        """Tessellate's panel (apply_with_progress): the meshing runs once, through the long-work runner
        (the GUI's worker thread), and the recompute takes its mesh (the same a plain recompute gives);
        nothing is kept afterwards. Cancelled there: the feature and the Undo stack as they were."""
        obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme="uniform", level=2)
        titles, meshings = [], []
        original_runner, original_tessellate = SagittaCore._long_runner, SagittaCore.tessellate_model

        def counting(model, params):
            meshings.append(params)
            return original_tessellate(model, params)
        SagittaCore.tessellate_model = counting
        SagittaCore.set_long_runner(lambda title, work: titles.append(title) or work())
        try:
            SagittaCore.apply_with_progress(obj, {"Level": 4})
        finally:
            SagittaCore.set_long_runner(original_runner)
            SagittaCore.tessellate_model = original_tessellate
        self.assertEqual((titles, len(meshings)), (["Tessellating " + obj.Label], 1))
        self.assertEqual((obj.Level, obj.Triangles + obj.DegenerateTriangles), (4, 2 * 16 * 16))
        self.assertIsNone(obj.Proxy.prepared)
        topology = obj.Mesh.Topology
        obj.touch()
        self.doc.recompute()
        self.assertEqual(obj.Mesh.Topology, topology)

        def cancelled(title, work):
            raise SagittaCore.Cancelled(title + ": cancelled")
        undo_count = self.doc.UndoCount
        SagittaCore.set_long_runner(cancelled)
        try:
            with self.assertRaises(SagittaCore.Cancelled):
                SagittaCore.apply_with_progress(obj, {"Level": 5})
        finally:
            SagittaCore.set_long_runner(original_runner)
        self.assertEqual((obj.Level, obj.Mesh.Topology, self.doc.UndoCount), (4, topology, undo_count))
        self.assertIsNone(obj.Proxy.prepared)

    def test_cancelled_validations_change_nothing(self):
        """Validate cancelled in its long work (a runner that raises Cancelled, as the GUI's does on
        Cancel): of a patch tessellation, of a whole part, of FreeCAD's mesh of a Part object: the
        document as it was (objects, the features' validation properties, the Undo stack)."""
        box = self.doc.addObject("Part::Box", "CancelBox")
        self.doc.recompute()
        patches = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme="uniform", level=2)
        part = SagittaCore.make_tessellation(self.doc, [(box, [])], scheme="uniform", level=1)
        self.assertTrue(part.WholePart)
        keys = ("ErrorLower", "ErrorUpper", "TopologyVerdict", "Certification", "FaceColors")

        def state():
            return (sorted(o.Name for o in self.doc.Objects), self.doc.UndoCount,
                    [[getattr(o, k) for k in keys] for o in (patches, part)])

        def cancelled(title, work):
            raise SagittaCore.Cancelled(title + ": cancelled")
        before = state()
        original = SagittaCore._long_runner
        SagittaCore.set_long_runner(cancelled)
        try:
            for validate in (lambda: SagittaCore.validate_tessellation(patches, max_depth=4),
                             lambda: SagittaCore.validate_tessellation(part, max_depth=4),
                             lambda: SagittaCore.validate_freecad_mesh(self.doc, [(self.bezier, [])], max_depth=4)):
                with self.assertRaises(SagittaCore.Cancelled):
                    validate()
                self.assertEqual(state(), before)
        finally:
            SagittaCore.set_long_runner(original)
        for obj in (patches, part, box):
            self.doc.removeObject(obj.Name)

    def teapot(self):
        """The teapot's 32 Bézier faces as one Part object (the importer's)."""
        existing = [o for o in self.doc.Objects if o.Label.startswith("teapot")]
        if existing:
            return existing[0]
        obj = SagittaImport.import_file(TEAPOT, self.doc)
        self.doc.recompute()
        return obj

    def test_fit_of_a_whole_part_meets_the_target(self):
        """Fit of a whole part (a PartDesign plate with a hole) as `sagitta fit PART`: uniform Segments and
        an EdgeTolerance (half the target or the coarser one the fit kept), set in one Undo step; Validate of the refitted feature then
        certifies every face with the fit's certified error, <= the target; Undo restores the old values."""
        doc = FreeCAD.newDocument("FitPart")
        doc.UndoMode = 1
        body = plate_with_hole_body(doc)
        obj = SagittaCore.make_tessellation(doc, [(body, [])], scheme="esc", level=2, threshold=0.01)
        self.assertTrue(obj.WholePart)
        undo_count, facets = doc.UndoCount, obj.Mesh.CountFacets
        target = 0.01
        result = SagittaCore.fit_tessellation(obj, target)
        self.assertTrue(result["met"])
        self.assertLessEqual(result["certified_error"], target)
        self.assertEqual((obj.Scheme, obj.Segments, obj.EdgeTolerance, obj.TargetError),
                         ("uniform", result["segments"], result["edge_tolerance"], target))
        # E / 2, or the coarser tolerance the fit's last phase kept (docs/FITTING.md).
        self.assertIn(obj.EdgeTolerance, [f * target for f in (0.5, 0.75, 1.0, 1.4, 2.0)])
        self.assertEqual(obj.Mesh.CountFacets, result["triangles"])
        self.assertEqual(doc.UndoCount, undo_count + 1)
        report = SagittaCore.validate_tessellation(obj)
        self.assertTrue(report["certified"])
        self.assertEqual(report["hausdorff"]["upper"], result["certified_error"])
        # The fewest segments of the family: one fewer misses the target (or none is tried below 1).
        self.assertTrue(result["segments"] == 1 or any(
            s["segments"] == result["segments"] - 1 and not (s["certified"] and s["upper"] <= target)
            for s in result["steps"]))
        doc.undo()  # the validation
        doc.undo()  # the fit
        doc.recompute()
        self.assertEqual((obj.Scheme, obj.Level, obj.Segments, obj.EdgeTolerance), ("esc", 2, 0, 0.0))
        self.assertEqual(obj.Mesh.CountFacets, facets)
        with self.assertRaises(SagittaCore.SagittaError) as refused:  # a negative edge tolerance
            SagittaCore.edit_tessellation(obj, EdgeTolerance=-1.0)
        self.assertIn("EdgeTolerance", str(refused.exception))
        self.assertEqual(obj.EdgeTolerance, 0.0)
        FreeCAD.closeDocument(doc.Name)

    def test_iges_import_of_free_faces_is_sewn_into_one_closed_mesh(self):
        """FreeCAD imports UKI60998.igs as a compound of 11 free faces. The part route sews them as
        `sagitta validate UKI60998.igs` does (one closed solid): the mesh is closed where the faces
        meet (unsewn: 150 model-boundary edges and 3 T-junctions), every face is certified, and the
        document's shape is untouched."""
        path = os.path.join(SHARED, "cad", "step", "UKI60998.igs")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        doc = FreeCAD.newDocument("IgesSewn")
        part = doc.addObject("Part::Feature", "Uki60998")
        part.Shape = Part.read(path)
        doc.recompute()
        self.assertEqual((len(part.Shape.Faces), len(part.Shape.Shells)), (11, 0))
        brep_before = part.Shape.exportBrepToString()
        obj = SagittaCore.make_tessellation(doc, [(part, [])], scheme="uniform", level=2)
        self.assertTrue(obj.WholePart)
        report = SagittaCore.validate_tessellation(obj)
        self.assertTrue(report["certified"])
        self.assertEqual([(s["brep_closed"], s["crack_edges"], s["model_boundary_edges"], s["t_junctions"])
                          for s in report["solids"]], [(True, 0, 0, 0)])
        self.assertEqual(part.Shape.exportBrepToString(), brep_before, "the source shape was modified")
        FreeCAD.closeDocument(doc.Name)

    def test_fit_sets_the_faces_edge_tolerances_the_tightness_pass_chose(self):
        """Fit of occ22470 (IGES, 18 faces) at 1e-3 of its diagonal: the tightness pass gives three
        trimmed faces tighter edges (FaceEdgeTolerances); the recomputed feature is the mesh the fit
        certified, and Undo clears them with the rest of the fit."""
        path = os.path.join(SHARED, "cad", "step", "occ22470.igs")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        doc = FreeCAD.newDocument("FitTight")
        doc.UndoMode = 1
        part = doc.addObject("Part::Feature", "Occ22470")
        part.Shape = Part.read(path)
        doc.recompute()
        obj = SagittaCore.make_tessellation(doc, [(part, [])], scheme="uniform", level=1)
        target = 1e-3 * part.Shape.BoundBox.DiagonalLength
        result = SagittaCore.fit_tessellation(obj, target)
        self.assertTrue(result["met"])
        self.assertLessEqual(result["certified_error"], target)
        self.assertEqual(list(obj.FaceEdgeTolerances), result["face_edge_tolerance"])
        self.assertGreater(sum(1 for t in obj.FaceEdgeTolerances if t > 0), 0)
        self.assertEqual(list(obj.FaceGradedSegments), result.get("face_graded_segments", []))
        self.assertEqual(obj.Mesh.CountFacets, result["triangles"])
        doc.undo()
        doc.recompute()
        self.assertEqual(list(obj.FaceEdgeTolerances), [])
        self.assertEqual(list(obj.FaceGradedSegments), [])
        FreeCAD.closeDocument(doc.Name)

    def test_fit_refuses_a_target_that_is_not_a_positive_number(self):
        obj = SagittaCore.make_tessellation(self.doc, [(self.bezier, [])], scheme="uniform", level=1)
        for target in (0.0, -1e-3, math.inf, math.nan):
            with self.subTest(target=target):
                with self.assertRaises(SagittaCore.SagittaError) as refused:
                    SagittaCore.fit_tessellation(obj, target)
                self.assertIn("finite number > 0", str(refused.exception))
                self.assertEqual((obj.Segments, obj.Level, obj.TargetError), (0, 1, 0.01))
        # Unreachable: the message gives the fit's last parameters and their certified error, not a
        # "best" error (finer parameters may do better); nothing is changed.
        with self.assertRaises(SagittaCore.SagittaError) as refused:
            SagittaCore.fit_tessellation(obj, 1e-9)
        self.assertIn("the fit stopped at Segments = ", str(refused.exception))
        self.assertNotIn("best", str(refused.exception))
        self.assertEqual((obj.Segments, obj.Level, obj.TargetError), (0, 1, 0.01))

    def test_import_rejects_malformed_file(self):
        bad = os.path.join(WORK, "bad.bpt")
        with open(bad, "w") as f:
            f.write("1\n3 3\n0 0 0\n")
        doc = FreeCAD.newDocument("Bad")
        self.assertIsNone(SagittaImport.import_file(bad, doc))
        self.assertEqual(len(doc.Objects), 0)
        documents = sorted(FreeCAD.listDocuments())
        for target in (doc, None):  # the Import command: an error naming the file, no new document
            with self.assertRaises(SagittaImport.PatchFileError) as refused:
                SagittaImport.load(bad, target)
            self.assertIn("bad.bpt", str(refused.exception))
        self.assertEqual(sorted(FreeCAD.listDocuments()), documents)
        self.assertEqual(len(doc.Objects), 0)
        with open(bad) as f:
            self.assertEqual(f.read(), "1\n3 3\n0 0 0\n")
        FreeCAD.closeDocument(doc.Name)


def main():
    try:
        result = unittest.TextTestRunner(stream=sys.stdout, verbosity=2).run(
            unittest.defaultTestLoader.loadTestsFromTestCase(HeadlessTest))
        code = 0 if result.wasSuccessful() else 1
    except BaseException:
        traceback.print_exc()
        code = 2
    if code == 0:
        with open(os.environ["SAGITTA_TEST_RESULT"], "w") as f:
            f.write("passed")
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # freecadcmd would otherwise not pass the code on


main()
