"""Whole parts through the Python module: mesh_part / mesh_part_brep mesh every face, and
check_solids checks each solid. The references are independent of the mesher: facts.json of the
shared STEP files and of the CAD fixtures (written from FreeCAD's reading of the shapes), the
triangles' own edges counted with NumPy, and the C++ checker against a NumPy recount.
Environment: SHARED_DATA (the shared data folder), CAD_FIXTURES (the folder fixtures/cad wrote; empty
when FreeCAD is not installed)."""
import json
import os
import unittest

import numpy as np

import _sagitta

SHARED = os.environ.get("SHARED_DATA", "")
FIXTURES = os.environ.get("CAD_FIXTURES", "")


def facts_of(path, name):
    with open(path) as f:
        facts = json.load(f)
    facts = facts["parts"] if isinstance(facts, dict) else facts
    return next(f for f in facts if f["file"] == name)


def edge_uses(triangles):
    """Each undirected edge of the triangles and how many triangles use it."""
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0, return_counts=True)


class PartTest(unittest.TestCase):
    def assert_consistent(self, part):
        """Every face tessellated, per-triangle arrays of the mesh's size, face reports adding up."""
        faces = part.faces
        self.assertEqual(part.faces_tessellated, len(faces))
        self.assertEqual(part.faces_skipped, 0)
        self.assertEqual(sum(f["trimmed"] for f in faces), part.faces_trimmed)
        n = part.mesh.triangle_count
        self.assertGreater(n, 0)
        self.assertEqual(part.triangle_face.shape, (n,))
        self.assertEqual(part.triangle_solid.shape, (n,))
        counts = np.bincount(part.triangle_face, minlength=len(faces))
        self.assertEqual(counts.tolist(), [f["triangles"] for f in faces])
        for f in faces:
            self.assertEqual(f["status"], "tessellated", f["name"])

    def test_certify_part(self):
        """certify_part: every face of pr1ct certified (its trimmed plane by the loops route), the
        per-triangle bounds finite and at most the part's upper bound, which is at least every
        face's lower bound; the same numbers as the CLI's JSON certificate would carry."""
        path = os.path.join(SHARED, "cad", "step", "pr1ct.stp")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        part = _sagitta.mesh_part(path, level=2)
        cert = _sagitta.certify_part(part)
        self.assertTrue(cert["certified"])
        self.assertEqual(cert["faces_certified"], len(part.faces))
        self.assertEqual([f["face"] for f in cert["faces"]], [f["name"] for f in part.faces])
        self.assertTrue(any(f["route"] == "loops" and f["trimmed"] for f in cert["faces"]))
        upper = cert["hausdorff"]["upper"]
        error = cert["triangle_error"]
        self.assertEqual(error.shape, (part.mesh.triangle_count,))
        self.assertTrue(np.all(np.isfinite(error)))
        self.assertLessEqual(error.max(), upper)
        for f in cert["faces"]:
            self.assertLessEqual(f["lower"], upper)
            self.assertLessEqual(f["lower"], f["upper"])
        with self.assertRaises(_sagitta.InputError):
            _sagitta.certify_part(part, max_depth=11)

    def test_memory_limit_refuses_a_part_before_meshing(self):
        """With a memory limit (set_max_memory) a part whose estimate (every face's scheme, summed)
        exceeds it is refused before any face is meshed, quickly and without growing the process;
        the same part at a level that fits is meshed, and reset_budget lifts the limit."""
        import resource
        import time
        path = os.path.join(SHARED, "cad", "step", "pr1ct.stp")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        small = _sagitta.mesh_part(path, level=2)
        try:
            _sagitta.set_max_memory(256 * 2 ** 20)
            before, start = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.perf_counter()
            with self.assertRaises(_sagitta.MemoryLimitExceeded) as refused:
                _sagitta.mesh_part(path, level=11)
            self.assertLess(time.perf_counter() - start, 10.0)
            self.assertLess(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before, 100 * 1024)  # KiB
            self.assertIn("meshing the part", str(refused.exception))
            self.assertIn("more than --max-memory 0.25 GiB", str(refused.exception))
            self.assertIsInstance(refused.exception, MemoryError)
            self.assertEqual(_sagitta.mesh_part(path, level=2).mesh.triangle_count, small.mesh.triangle_count)
            _sagitta.set_max_memory(512.0 * small.mesh.triangle_count - 1)  # certify_part's estimate: just over
            with self.assertRaises(_sagitta.MemoryLimitExceeded) as refused:
                _sagitta.certify_part(small)
            self.assertIn("certifying %d triangles" % small.mesh.triangle_count, str(refused.exception))
            _sagitta.set_max_memory(512.0 * small.mesh.triangle_count)
            self.assertTrue(_sagitta.certify_part(small)["certified"])
        finally:
            _sagitta.reset_budget()
        self.assertEqual(_sagitta.max_memory(), 0.0)

    def test_shared_step_part(self):
        path = os.path.join(SHARED, "cad", "step", "pr1ct.stp")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        facts = facts_of(os.path.join(SHARED, "cad", "step", "facts.json"), "pr1ct.stp")
        part = _sagitta.mesh_part(path, level=2)
        self.assert_consistent(part)
        self.assertEqual(len(part.faces), facts["faces"])
        self.assertEqual(len(part.solids), facts["solids"])
        again = _sagitta.mesh_part(path, level=2)
        self.assertEqual(again.mesh.triangle_count, part.mesh.triangle_count)
        np.testing.assert_array_equal(again.mesh.triangles, part.mesh.triangles)
        np.testing.assert_array_equal(again.mesh.positions, part.mesh.positions)
        # Every solid is closed and valid (facts.json): each edge of its triangles is used twice.
        for solid in range(facts["solids"]):
            _, uses = edge_uses(part.mesh.triangles[part.triangle_solid == solid])
            self.assertTrue(np.all(uses == 2), "solid %d" % solid)
        finer = _sagitta.mesh_part(path, level=3)
        self.assertGreater(finer.mesh.triangle_count, part.mesh.triangle_count)

    def test_fixture_plate_with_holes(self):
        if not FIXTURES:
            self.skipTest("CAD fixtures not built (FreeCAD absent)")
        facts = facts_of(os.path.join(FIXTURES, "facts.json"), "plate_with_holes.brep")
        with open(os.path.join(FIXTURES, "plate_with_holes.brep")) as f:
            text = f.read()
        part = _sagitta.mesh_part_brep(text, "plate_with_holes", level=2)
        self.assert_consistent(part)
        self.assertEqual(len(part.faces), facts["faces"])
        self.assertEqual(part.faces_trimmed, facts["trimmed_faces"])
        self.assertEqual(_sagitta.mesh_part_brep(text, "again", level=2).mesh.triangle_count, part.mesh.triangle_count)
        checks = _sagitta.check_solids(part.mesh, part.triangle_solid, part.boundary_edges)
        self.assertEqual([c["solid"] for c in checks], list(range(facts["solids"])))
        for check, solid, euler in zip(checks, part.solids, facts["euler_per_solid"]):
            self.assertTrue(solid["closed"] and solid["valid"])
            self.assertEqual(check["open_edges"], 0)
            self.assertEqual(check["crack_edges"], 0)
            self.assertEqual(check["t_junctions"], 0)
            self.assertEqual(check["non_manifold_edges"], 0)
            self.assertTrue(check["closed"])
            self.assertEqual(check["euler_characteristic"], euler)
            self.assertAlmostEqual(check["signed_volume"], facts["volume"], delta=0.01 * facts["volume"])
            # The checker's counts against a recount of the solid's triangles.
            edges, uses = edge_uses(part.mesh.triangles[part.triangle_solid == check["solid"]])
            self.assertEqual(check["edges"], len(edges))
            self.assertEqual(check["triangles"], solid["triangles"])

    def test_check_solids_finds_a_hole(self):
        """Removing one triangle of a closed solid opens three edges: cracks, since none lies on a
        free B-rep edge."""
        if not FIXTURES:
            self.skipTest("CAD fixtures not built (FreeCAD absent)")
        part = _sagitta.mesh_part(os.path.join(FIXTURES, "plate_with_holes.brep"), level=1)
        triangles = part.mesh.triangles[1:].astype(np.int64)
        holed = _sagitta.mesh_from_arrays(part.mesh.positions, triangles)
        check = _sagitta.check_solids(holed, part.triangle_solid[1:], part.boundary_edges, cgal=False)[0]
        self.assertFalse(check["closed"])
        self.assertEqual(check["open_edges"], 3)
        self.assertEqual(check["crack_edges"], 3)
        self.assertTrue(any(f["kind"] == "crack_edge" for f in check["findings"]))

    def test_open_shell_boundary_is_not_a_crack(self):
        if not FIXTURES:
            self.skipTest("CAD fixtures not built (FreeCAD absent)")
        part = _sagitta.mesh_part(os.path.join(FIXTURES, "open_box_shell.brep"), level=2)
        self.assert_consistent(part)
        self.assertGreater(len(part.boundary_edges), 0)
        checks = _sagitta.check_solids(part.mesh, part.triangle_solid, part.boundary_edges)
        self.assertEqual(sum(c["crack_edges"] for c in checks), 0)
        self.assertEqual(sum(c["model_boundary_edges"] for c in checks), len(part.boundary_edges))

    def test_errors_are_value_errors(self):
        with self.assertRaises(ValueError):
            _sagitta.mesh_part("/nonexistent/part.step")
        with self.assertRaises(ValueError):
            _sagitta.mesh_part_brep("not a brep", "junk")
        box = os.path.join(FIXTURES, "filleted_box.brep") if FIXTURES else ""
        if box:
            with self.assertRaises(ValueError):
                _sagitta.mesh_part(box, scheme="pn")
            part = _sagitta.mesh_part(box, level=1)
            with self.assertRaises(ValueError):
                _sagitta.check_solids(part.mesh, part.triangle_solid[1:], part.boundary_edges)


if __name__ == "__main__":
    unittest.main()
