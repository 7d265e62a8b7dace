// The `_sagitta` Python module: the same C++ code as the CLI, for FreeCAD 0.20's Python (the system
// Python 3.11) and for scripts. Arrays come back as NumPy arrays; errors as ValueError.
#include "sagitta/fixtures.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/uniform.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <optional>

namespace py = pybind11;
using namespace sagitta;

namespace {

py::array_t<double> vectors(const std::vector<Vec3>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  auto m = a.mutable_unchecked<2>();
  for (size_t k = 0; k < v.size(); ++k) {
    for (int c = 0; c < 3; ++c) m(static_cast<py::ssize_t>(k), c) = v[k][c];
  }
  return a;
}

py::dict mesh_dict(const Tessellation& t, double seconds) {
  py::array_t<uint32_t> tris({static_cast<py::ssize_t>(t.triangles.size()), py::ssize_t{3}});
  auto m = tris.mutable_unchecked<2>();
  for (size_t k = 0; k < t.triangles.size(); ++k) {
    for (int c = 0; c < 3; ++c) m(static_cast<py::ssize_t>(k), c) = t.triangles[k][static_cast<size_t>(c)];
  }
  py::dict d;
  d["positions"] = vectors(t.positions);
  d["normals"] = vectors(t.normals);
  d["triangles"] = tris;
  d["degenerate_triangles"] = t.degenerate_triangles;
  d["seconds"] = seconds;
  return d;
}

py::dict topology_dict(const Model& model) {
  const Topology topo = build_topology(model);
  py::dict d;
  d["patches"] = model.patches.size();
  d["shared_edges"] = topo.shared_edges();
  d["free_boundary_edges"] = topo.free_edges();
  d["nonmanifold_edges"] = topo.nonmanifold_edges();
  d["collapsed_sides"] = topo.collapsed_sides();
  d["near_misses"] = topo.near_misses.size();
  return d;
}

}  // namespace

PYBIND11_MODULE(_sagitta, m) {
  m.doc() = "Sagitta: tessellate Bézier surfaces and certify the distance to the exact surface";
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);

  py::class_<Model>(m, "Model")
      .def_readonly("name", &Model::name)
      .def_property_readonly("patch_count", [](const Model& model) { return model.patches.size(); })
      .def("__repr__", [](const Model& model) {
        return "<sagitta.Model '" + model.name + "' with " + std::to_string(model.patches.size()) + " patches>";
      });

  m.def("read_model", &io::read_patch_model, py::arg("path"), "Read a .bpt or .rib patch file");
  m.def("default_model", &fixtures::default_model, "The built-in default model (pillow box + rational torus)");
  m.def("replicate", &replicate, py::arg("model"), py::arg("copies"), "K translated instances of a model");
  m.def("topology", &topology_dict, py::arg("model"), "Shared, free and collapsed patch sides");
  m.def(
      "tessellate_uniform",
      [](const Model& model, std::optional<int> level, std::optional<int> segments) {
        if (level.has_value() == segments.has_value()) throw InputError("give exactly one of level or segments");
        UniformParams params;
        params.segments = level ? segments_for_level(*level) : *segments;
        params.surface_data = false;
        const Topology topo = build_topology(model);
        py::gil_scoped_release release;
        const auto start = std::chrono::steady_clock::now();
        Tessellation t = tessellate_uniform(model, topo, params);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        py::gil_scoped_acquire acquire;
        return mesh_dict(t, seconds);
      },
      py::arg("model"), py::arg("level") = py::none(), py::arg("segments") = py::none(),
      "Uniform tessellation: positions (N,3), normals (N,3), triangles (M,3), degenerate_triangles, seconds");
}
