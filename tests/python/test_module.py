"""The Python module gives the same results as the C++ library, from the system Python."""
import os
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


if __name__ == "__main__":
    unittest.main()
