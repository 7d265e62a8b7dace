"""The Python module gives the same results as the C++ library, from the system Python."""
import json
import os
import subprocess
import tempfile
import unittest

import numpy as np

import _sagitta


class ModuleTest(unittest.TestCase):
    def test_default_model_is_closed(self):
        model = _sagitta.default_model()
        self.assertEqual(model.patch_count, 22)
        topo = _sagitta.topology(model)
        self.assertEqual(topo["free_boundary_edges"], 0)
        mesh = _sagitta.tessellate_uniform(model, level=2)
        tris = mesh["triangles"]
        self.assertEqual(tris.shape, (22 * 2 * 16, 3))
        # Closed: every undirected edge is used exactly twice.
        edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        self.assertTrue(np.all(counts == 2))
        np.testing.assert_allclose(np.linalg.norm(mesh["normals"], axis=1), 1.0, atol=1e-12)

    def test_teapot_counts(self):
        path = os.path.join(os.environ.get("SHARED_DATA", ""), "teapot.bpt")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        mesh = _sagitta.tessellate_uniform(_sagitta.read_model(path), level=3)
        self.assertEqual(len(mesh["triangles"]) + mesh["degenerate_triangles"], 4096)

    def test_errors_are_value_errors(self):
        with self.assertRaises(ValueError) as ctx:
            _sagitta.read_model("/nonexistent/model.bpt")
        self.assertIn("cannot open", str(ctx.exception))
        with self.assertRaises(ValueError):
            _sagitta.tessellate_uniform(_sagitta.default_model(), level=2, segments=3)


def cli_json(*args):
    """Runs the sagitta command with its JSON output in a temporary file; returns the document."""
    with tempfile.TemporaryDirectory() as folder:
        out = os.path.join(folder, "out.json")
        subprocess.run([os.environ["SAGITTA_CLI"]] + list(args) + [out], check=True, stdout=subprocess.DEVNULL)
        with open(out) as f:
            return json.load(f)


class CliAgreementTest(unittest.TestCase):
    """tessellate / validate / fit give the numbers the CLI gives (the default model: no data needed)."""

    def setUp(self):
        if not os.environ.get("SAGITTA_CLI"):
            self.skipTest("SAGITTA_CLI not set")
        self.model = _sagitta.default_model()

    def test_tessellate_stats(self):
        for args, kwargs in ((["--level", "2"], {"level": 2}),
                             (["--scheme", "esc", "--level", "3", "--threshold", "0.01"],
                              {"scheme": "esc", "level": 3, "threshold": 0.01}),
                             (["--scheme", "pn", "--base-level", "1", "--level", "3"],
                              {"scheme": "pn", "base_level": 1, "level": 3})):
            with self.subTest(args=args):
                mesh, stats = _sagitta.tessellate(self.model, **kwargs)
                cli = cli_json("tessellate", "default", *args, "--stats")
                for key in ("triangles", "vertices", "degenerate_triangles", "patches"):
                    self.assertEqual(stats[key], cli[key], key)
                self.assertEqual(mesh.triangle_count, cli["triangles"])
                self.assertTrue(mesh.has_surface)

    def test_validate_fields(self):
        mesh, _ = _sagitta.tessellate(self.model, level=2)
        ours = _sagitta.validate(self.model, mesh, max_depth=6)
        cli = cli_json("validate", "default", "--level", "2", "--max-depth", "6", "--json")
        for direction in ("hausdorff", "mesh_to_surface", "surface_to_mesh"):
            for bound in ("lower", "upper"):
                self.assertAlmostEqual(ours[direction][bound], cli[direction][bound], delta=1e-12)
        self.assertEqual(ours["topology"]["crack_edges"], cli["topology"]["crack_edges"])
        self.assertEqual(ours["topology"]["watertight"], cli["topology"]["watertight"])
        errors = ours["triangle_error"]
        self.assertEqual(len(errors), mesh.triangle_count)
        self.assertAlmostEqual(float(errors.max()), ours["hausdorff"]["upper"], delta=1e-12)

    def test_mesh_without_uv_uses_the_reference_route(self):
        mesh, _ = _sagitta.tessellate(self.model, level=2)
        plain = _sagitta.mesh_from_arrays(mesh.positions, mesh.triangles.astype(np.int64))
        self.assertFalse(plain.has_surface)
        report = _sagitta.validate(self.model, plain, max_depth=4)
        self.assertEqual(report["method"], "reference")
        self.assertEqual(len(report["triangle_error"]), 0)

    def test_fit(self):
        ours = _sagitta.fit(self.model, "uniform", 0.01)
        cli = cli_json("fit", "default", "--scheme", "uniform", "--target-error", "0.01", "--json")
        self.assertTrue(ours["met"])
        self.assertEqual(ours["segments"], cli["segments"])
        self.assertLessEqual(ours["certified_error"], 0.01)

    def test_model_from_patches_round_trip_and_errors(self):
        copy = _sagitta.model_from_patches("copy", self.model.patches)
        _, a = _sagitta.tessellate(self.model, level=2)
        _, b = _sagitta.tessellate(copy, level=2)
        self.assertEqual((a["triangles"], a["vertices"]), (b["triangles"], b["vertices"]))
        bad = dict(self.model.patches[0])
        bad["points"] = bad["points"][:-1]
        with self.assertRaises(ValueError):
            _sagitta.model_from_patches("bad", [bad])
        with self.assertRaises(ValueError):
            _sagitta.mesh_from_arrays(np.zeros((3, 3)), np.array([[0, 1, 5]]))
        with self.assertRaises(ValueError):
            _sagitta.fit(self.model, "uniform", -1.0)


    def test_memory_limit_refuses_before_allocating(self):
        """set_max_memory: the teapot at level 10 (67 million triangles, ~6 GiB) is refused before
        anything is allocated (quickly, the process's peak memory not grown), with a MemoryError
        naming the work and the limit; estimated_triangles gives the size it was judged by; a level
        that fits still runs; reset_budget lifts the limit."""
        import resource
        import time
        path = os.path.join(os.environ.get("SHARED_DATA", ""), "teapot.bpt")
        if not os.path.exists(path):
            self.skipTest("shared data absent")
        teapot = _sagitta.read_model(path)
        self.assertEqual(_sagitta.estimated_triangles(teapot, "uniform", level=10), 2 * 1024 ** 2 * 32)
        mesh, stats = _sagitta.tessellate(teapot, level=3)
        self.assertEqual(_sagitta.estimated_triangles(teapot, "uniform", level=3),
                         stats["triangles"] + stats["degenerate_triangles"])
        self.assertEqual(_sagitta.estimated_triangles(teapot, "pn", level=3, base_level=2), 9 * 2 * 16 * 32)
        self.assertGreaterEqual(_sagitta.estimated_triangles(teapot, "esc", level=3),
                                _sagitta.tessellate(teapot, scheme="esc", level=3, threshold=0.01)[1]["triangles"])
        try:
            _sagitta.set_max_memory(2 ** 30)
            self.assertEqual(_sagitta.max_memory(), 2 ** 30)
            before, start = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.perf_counter()
            for scheme, kwargs in (("uniform", {"level": 10}), ("pn", {"level": 64, "base_level": 4})):
                with self.subTest(scheme=scheme):
                    with self.assertRaises(_sagitta.MemoryLimitExceeded) as refused:
                        _sagitta.tessellate(teapot, scheme=scheme, **kwargs)
                    self.assertIsInstance(refused.exception, MemoryError)
                    self.assertIn("more than --max-memory 1 GiB", str(refused.exception))
            self.assertLess(time.perf_counter() - start, 5.0)
            self.assertLess(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before, 50 * 1024)  # KiB
            self.assertEqual(_sagitta.tessellate(teapot, level=3)[1]["triangles"], stats["triangles"])
            # Validation estimates its own memory (512 bytes a triangle): the teapot at level 7 (a
            # million triangles) is made under 256 MiB, its validation refused before it starts.
            _sagitta.set_max_memory(256 * 2 ** 20)
            big, _ = _sagitta.tessellate(teapot, level=7)
            before, start = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.perf_counter()
            with self.assertRaises(_sagitta.MemoryLimitExceeded) as refused:
                _sagitta.validate(teapot, big)
            self.assertIn("validating %d triangles would need about" % big.triangle_count, str(refused.exception))
            self.assertLess(time.perf_counter() - start, 1.0)
            self.assertLess(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before, 50 * 1024)  # KiB
        finally:
            _sagitta.reset_budget()
        self.assertEqual(_sagitta.max_memory(), 0.0)


if __name__ == "__main__":
    unittest.main()
