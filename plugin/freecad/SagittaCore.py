"""Sagitta in FreeCAD without the GUI: shapes to patch models, the parametric tessellation feature,
validation and fitting. The GUI commands and the headless tests call exactly these functions.

Nothing here modifies a source shape: shapes are read (poles, or their BREP text) and every result
goes into new or Sagitta-owned objects, inside a document transaction so that Undo works.

This module never imports SagittaGui (the GUI imports it, not the reverse): the GUI command gives the
feature that make_tessellation returns its view provider."""
import os
import tempfile

import FreeCAD
import Mesh
import Part

import _sagitta

# The schemes, as the library names them (the same list and order as the CLI's --scheme).
SCHEMES = list(_sagitta.scheme_names())
PARAM_PATH = "User parameter:BaseApp/Preferences/Mod/Sagitta"


class SagittaError(Exception):
    """A problem the user can act on (bad selection, unsupported face, invalid parameter)."""


def preferences():
    """The user's defaults (preferences page), with built-in values where none are set."""
    p = FreeCAD.ParamGet(PARAM_PATH)
    scheme = p.GetString("DefaultScheme", "uniform")
    return {
        "scheme": scheme if scheme in SCHEMES else "uniform",
        "level": p.GetInt("DefaultLevel", 3),
        "threshold": p.GetFloat("DefaultThreshold", 0.01),
        "target_error": p.GetFloat("DefaultTargetError", 0.01),
        "max_depth": p.GetInt("MaxDepth", 8),
    }


# ---------------------------------------------------------------------------------------------
# Shapes -> patch models


def source_faces(links):
    """(label, [(face name, face)]) per linked object: the selected faces, or all faces of the shape."""
    if not links:
        raise SagittaError("Nothing to tessellate: the source is empty")
    out = []
    for obj, subs in links:
        shape = getattr(obj, "Shape", None)
        if shape is None or shape.isNull() or not shape.Faces:
            raise SagittaError("%s has no faces to tessellate" % obj.Label)
        names = [s for s in subs if s.startswith("Face")] if subs else []
        if names:
            faces = [(n, shape.getElement(n)) for n in names]
        else:
            faces = [("Face%d" % (k + 1), f) for k, f in enumerate(shape.Faces)]
        out.append((obj.Label, faces))
    return out


def shape_model(links, name="selection"):
    """The patch model of the linked shapes/faces and one report line per face, through the OCCT
    adapter: the faces are copied into a compound whose BREP text `read_brep_string` converts,
    exactly as `sagitta tessellate file.brep` does. Raises SagittaError when no face converts."""
    groups = source_faces(links)
    # Copies: putting the document's own faces into a compound would flag their shared OCCT data.
    faces = [f.copy() for _, fs in groups for _, f in fs]
    try:
        cad = _sagitta.read_brep_string(Part.makeCompound(faces).exportBrepToString(), name)
    except ValueError as error:
        raise SagittaError(str(error))
    notes = ["%s: %s%s" % (f["name"], f["status"], (" (" + f["reason"] + ")") if f["reason"] else "")
             for f in cad["faces"]]
    if cad["model"].patch_count == 0:
        raise SagittaError("%s: no face could be converted: %s" % (name, "; ".join(notes)))
    return cad["model"], notes


def model_to_bpt(model):
    """.bpt text of a model, every coordinate at full double precision (repr): the patches Sagitta
    sees in a FreeCAD shape, for reproducing a result with the `sagitta` command."""
    lines = [str(model.patch_count)]
    for p in model.patches:
        lines.append("%d %d" % (p["degree_u"], p["degree_v"]))
        weights = p["weights"]
        for k, point in enumerate(p["points"]):
            values = [repr(float(c)) for c in point]
            if weights is not None:
                values.append(repr(float(weights[k])))
            lines.append(" ".join(values))
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# The tessellation feature

STAT_PROPERTIES = [
    ("App::PropertyInteger", "Patches", "Bézier patches tessellated"),
    ("App::PropertyInteger", "Triangles", "Triangles emitted"),
    ("App::PropertyInteger", "Vertices", "Vertices emitted"),
    ("App::PropertyInteger", "DegenerateTriangles", "Collapsed triangles, counted but not emitted"),
    ("App::PropertyFloat", "TessellationSeconds", "Time the scheme took"),
    ("App::PropertyStringList", "SourceFaces", "What became of each source face"),
    ("App::PropertyFloat", "ErrorLower", "Certified lower bound of the Hausdorff distance (after Validate)"),
    ("App::PropertyFloat", "ErrorUpper", "Certified upper bound of the Hausdorff distance (after Validate)"),
    ("App::PropertyString", "TopologyVerdict", "Watertightness verdict (after Validate)"),
    ("App::PropertyColorList", "FaceColors", "Per-triangle error colours (after Validate)"),
]


class TessellationFeature:
    """Proxy of a Mesh::FeaturePython whose mesh is the tessellation of its Source faces; recomputes
    when the source or a parameter changes. Statistics are read-only properties."""

    def __init__(self, obj):
        obj.Proxy = self
        self.setup(obj)

    def setup(self, obj):
        """Adds the properties a tessellation feature has (idempotent)."""
        existing = obj.PropertiesList
        def add(kind, name, group, doc):
            if name not in existing:
                obj.addProperty(kind, name, group, doc)
        add("App::PropertyLinkSubList", "Source", "Sagitta", "Part objects or faces to tessellate")
        add("App::PropertyEnumeration", "Scheme", "Sagitta", "uniform, esc (adaptive) or pn (PN triangles)")
        add("App::PropertyInteger", "Level", "Sagitta",
            "uniform: 2^L segments per side; esc: pattern level; pn: segments per edge")
        add("App::PropertyInteger", "BaseLevel", "Sagitta", "pn: the uniform base level it refines")
        add("App::PropertyInteger", "Segments", "Sagitta", "uniform: N segments per side instead of 2^Level when > 0")
        add("App::PropertyFloat", "Threshold", "Sagitta", "esc: distance threshold (model units)")
        add("App::PropertyFloat", "TargetError", "Sagitta", "Fit to target error: the certified error wanted")
        if "Scheme" not in existing:
            obj.Scheme = SCHEMES
        for kind, name, doc in STAT_PROPERTIES:
            add(kind, name, "Statistics", doc)
            obj.setEditorMode(name, 1)  # read-only in the property editor
        obj.setEditorMode("FaceColors", 2)  # hidden: shown as colours

    def onDocumentRestored(self, obj):
        self.setup(obj)

    def execute(self, obj):
        """Rebuilds the mesh from the source; clears validation results (they belong to the old mesh)."""
        model, notes = shape_model(obj.Source, obj.Label)
        mesh, stats = tessellate_model(model, scheme_parameters(obj))
        obj.Mesh = to_freecad_mesh(mesh)
        obj.Patches = stats["patches"]
        obj.Triangles = stats["triangles"]
        obj.Vertices = stats["vertices"]
        obj.DegenerateTriangles = stats["degenerate_triangles"]
        obj.TessellationSeconds = stats["seconds"]
        obj.SourceFaces = notes
        obj.ErrorLower = 0.0
        obj.ErrorUpper = 0.0
        obj.TopologyVerdict = ""
        obj.FaceColors = []

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None


def scheme_parameters(obj):
    """The feature's parameters as keyword arguments of _sagitta.tessellate (the CLI's options)."""
    if obj.Scheme == "uniform" and obj.Segments > 0:
        return {"scheme": "uniform", "segments": obj.Segments}
    params = {"scheme": obj.Scheme, "level": obj.Level}
    if obj.Scheme == "esc":
        params["threshold"] = obj.Threshold
    if obj.Scheme == "pn":
        params["base_level"] = obj.BaseLevel
    return params


def tessellate_model(model, params):
    """Runs a scheme; invalid parameters become SagittaError with the library's message."""
    try:
        return _sagitta.tessellate(model, **params)
    except ValueError as error:
        raise SagittaError(str(error))


def to_freecad_mesh(mesh):
    """A Mesh.Mesh with the same vertices and triangles, in the same order."""
    vectors = [FreeCAD.Vector(*p) for p in mesh.positions.tolist()]
    result = Mesh.Mesh()
    result.addFacets((vectors, [tuple(t) for t in mesh.triangles.tolist()]))
    return result


def is_tessellation(obj):
    return obj is not None and isinstance(getattr(obj, "Proxy", None), TessellationFeature)


def _transaction(doc, title, work):
    """Runs work() inside a document transaction: committed when it succeeds, aborted (the document
    left as it was) when it raises."""
    doc.openTransaction(title)
    try:
        result = work()
    except Exception:
        doc.abortTransaction()
        raise
    doc.commitTransaction()
    return result


def make_tessellation(doc, links, scheme=None, level=None, threshold=None, base_level=None, target_error=None):
    """Creates a tessellation feature of `links` [(object, [sub-element names])] in one transaction
    and recomputes it. Parameters left None come from the preferences. Raises SagittaError (and
    leaves the document unchanged) for an empty selection, unsupported faces or bad parameters.
    The feature has FreeCAD's default mesh view; SagittaGui.attach_view_provider adds the workbench's."""
    if not links:
        raise SagittaError("Select Part objects or faces to tessellate")
    shape_model(links)  # refuse unsupported selections before anything is added
    prefs = preferences()

    def work():
        obj = doc.addObject("Mesh::FeaturePython", "Tessellation")
        TessellationFeature(obj)
        obj.Source = [(o, tuple(subs) if subs else "") for o, subs in links]
        obj.Scheme = scheme or prefs["scheme"]
        obj.Level = prefs["level"] if level is None else level
        obj.BaseLevel = 2 if base_level is None else base_level
        obj.Threshold = prefs["threshold"] if threshold is None else threshold
        obj.TargetError = prefs["target_error"] if target_error is None else target_error
        obj.recompute()
        if "Invalid" in obj.State:
            raise SagittaError("Tessellation failed; see the report view")
        return obj
    return _transaction(doc, "Sagitta tessellate", work)


def edit_tessellation(obj, **values):
    """Sets feature parameters (Scheme, Level, Segments, Threshold, BaseLevel, TargetError) and recomputes, in
    one transaction; on failure the old values are restored."""
    def work():
        for key, value in values.items():
            setattr(obj, key, value)
        obj.recompute()
        if "Invalid" in obj.State:
            raise SagittaError("Tessellation failed with these parameters; see the report view")
    _transaction(obj.Document, "Sagitta edit tessellation", work)


# ---------------------------------------------------------------------------------------------
# Validation

def error_colours(errors, top):
    """Blue (0) -> green -> red (>= top) per triangle: the legend's scale."""
    colours = []
    for e in errors:
        t = 0.0 if top <= 0 else min(1.0, max(0.0, e / top))
        colours.append(legend_colour(t))
    return colours


def legend_colour(t):
    """Colour at position t in [0, 1] of the error scale (blue, cyan, green, yellow, red)."""
    stops = [(0.0, 0.0, 1.0), (0.0, 1.0, 1.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.0), (1.0, 0.0, 0.0)]
    x = t * (len(stops) - 1)
    k = min(int(x), len(stops) - 2)
    f = x - k
    return tuple(a + (b - a) * f for a, b in zip(stops[k], stops[k + 1]))


def validate_tessellation(obj, max_depth=None):
    """Certifies a tessellation feature against its exact source (a fresh model of the source, the
    mesh re-made with surface data) and stores the interval, the verdict and per-triangle colours on
    the feature in one transaction. Returns the report (the fields of `sagitta validate --json`)."""
    if not is_tessellation(obj):
        raise SagittaError("%s is not a Sagitta tessellation" % obj.Label)
    depth = preferences()["max_depth"] if max_depth is None else max_depth
    model, _ = shape_model(obj.Source, obj.Label)
    mesh, _ = tessellate_model(model, scheme_parameters(obj))
    report = run_validation(model, mesh, depth)
    errors = report["triangle_error"]
    report["colour_scale_top"] = float(errors.max()) if len(errors) else 0.0

    def work():
        obj.ErrorLower = report["hausdorff"]["lower"]
        obj.ErrorUpper = report["hausdorff"]["upper"] or 0.0
        obj.TopologyVerdict = verdict_text(report)
        obj.FaceColors = error_colours(errors.tolist(), report["colour_scale_top"])
        obj.purgeTouched()
    _transaction(obj.Document, "Sagitta validate", work)
    if FreeCAD.GuiUp:
        obj.ViewObject.Coloring = True
    return report


def run_validation(model, mesh, max_depth, reference_segments=32):
    try:
        return _sagitta.validate(model, mesh, max_depth=max_depth, reference_segments=reference_segments)
    except ValueError as error:
        raise SagittaError(str(error))


def validate_mesh_object(mesh_obj, links, max_depth=None):
    """Certifies any Mesh object (no (u, v): through a certified reference tessellation) against the
    exact shape of `links`. Changes nothing in the document."""
    depth = preferences()["max_depth"] if max_depth is None else max_depth
    model, _ = shape_model(links, mesh_obj.Label)
    points, facets = mesh_obj.Mesh.Topology
    if not facets:
        raise SagittaError("%s has no triangles" % mesh_obj.Label)
    placement = mesh_obj.Placement
    positions = [tuple(placement.multVec(p)) for p in points]
    mesh = _sagitta.mesh_from_arrays(positions, facets)
    return run_validation(model, mesh, depth)


def freecad_mesh_of(doc, links, linear_deflection=0.1, angular_deflection=0.5):
    """FreeCAD's own tessellation (MeshPart) of the linked shapes as a new Mesh feature, in a
    transaction: what Validate compares with ours."""
    import MeshPart
    shapes = [o.Shape if not subs else Part.makeCompound([o.Shape.getElement(s) for s in subs]) for o, subs in links]

    def work():
        obj = doc.addObject("Mesh::Feature", "FreeCADMesh")
        obj.Mesh = MeshPart.meshFromShape(Shape=Part.makeCompound(shapes), LinearDeflection=linear_deflection,
                                          AngularDeflection=angular_deflection, Relative=False)
        return obj
    return _transaction(doc, "Sagitta FreeCAD mesh", work)


def verdict_text(report):
    t = report["topology"]
    if t["watertight"]:
        return "watertight (%d model boundary edges)" % t["model_boundary_edges"]
    return "not watertight: %d cracks, %d T-junctions, %d non-manifold edges" % (
        t["crack_edges"], t["t_junctions"], t["non_manifold_edges"])


def write_html_report(report, label, path):
    """A small self-contained HTML page with the certified intervals and the topology counts,
    written atomically (temporary file in the same folder, then renamed)."""
    import html

    def row(name, interval):
        upper = interval["upper"]
        return "<tr><td>%s</td><td>%.6g</td><td>%s</td><td>%s</td></tr>" % (
            name, interval["lower"], "%.6g" % upper if upper is not None else "not certified",
            "yes" if interval["upper_certified"] else "no")
    t = report["topology"]
    body = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>Sagitta validation: %s</title></head><body>" % html.escape(label),
        "<h1>Sagitta validation: %s</h1>" % html.escape(label),
        "<p>%d triangles, %d vertices, %d patches; method %s; %.3f s</p>" % (
            report["triangles"], report["vertices"], report["patches"], report["method"], report["seconds"]),
        "<h2>Certified distance (lower &le; true &le; upper)</h2><table border='1'>",
        "<tr><th>direction</th><th>lower</th><th>upper</th><th>upper certified</th></tr>",
        row("Hausdorff (symmetric)", report["hausdorff"]), row("mesh &rarr; surface", report["mesh_to_surface"]),
        row("surface &rarr; mesh", report["surface_to_mesh"]), "</table>",
        "<h2>Topology: %s</h2><table border='1'>" % html.escape(verdict_text(report)),
    ]
    for key in ("edges", "open_edges", "model_boundary_edges", "crack_edges", "t_junctions", "non_manifold_edges",
                "inconsistent_orientation_edges", "degenerate_triangles", "duplicated_faces"):
        body.append("<tr><td>%s</td><td>%d</td></tr>" % (key.replace("_", " "), t[key]))
    body.append("</table></body></html>\n")
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".sagitta-report-")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write("\n".join(body))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# ---------------------------------------------------------------------------------------------
# Fitting

def fit_tessellation(obj, target_error):
    """Fits the feature's scheme to a certified target error with the library's fit (`sagitta fit`)
    and sets the chosen parameters (uniform: Segments; esc: Level and Threshold; pn: Level and
    BaseLevel) and TargetError in one transaction. Returns the fit report (the fields of `sagitta
    fit --json`). Raises SagittaError, changing nothing, when the target cannot be met."""
    if not is_tessellation(obj):
        raise SagittaError("%s is not a Sagitta tessellation" % obj.Label)
    if not target_error > 0:
        raise SagittaError("The target error must be > 0")
    model, _ = shape_model(obj.Source, obj.Label)
    try:
        result = _sagitta.fit(model, obj.Scheme, target_error)
    except ValueError as error:
        raise SagittaError(str(error))
    if not result["met"]:
        raise SagittaError("The %s scheme cannot meet the target %g (best certified error %s)"
                           % (obj.Scheme, target_error, result["certified_error"]))
    values = {"TargetError": target_error}
    if obj.Scheme == "uniform":
        values["Segments"] = result["segments"]
    else:
        values["Level"] = result["level"]
        if obj.Scheme == "esc":
            values["Threshold"] = result["threshold"]
        else:
            values["BaseLevel"] = result["base_level"]
    edit_tessellation(obj, **values)
    return result
