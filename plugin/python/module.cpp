// The `_sagitta` Python module: the same C++ code as the CLI, for FreeCAD 0.20's Python (the system
// Python 3.11) and for scripts. Arrays come back as NumPy arrays; errors as ValueError. Tessellation
// and validation go through the application layer the CLI uses (sagitta::tessellate, app::validate_mesh
// and its report), so the numbers here are the numbers `sagitta tessellate --stats` and
// `sagitta validate --json` print.
#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"
#include "sagitta/app/part.hpp"
#include "sagitta/app/validate.hpp"
#include "sagitta/budget.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/occt/cad.hpp"
#include "sagitta/occt/part.hpp"
#include "sagitta/pn.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/solid_check.hpp"
#include "sagitta/uniform.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <optional>

namespace py = pybind11;
using namespace sagitta;

namespace {

// An (N, 3) float64 array of the vectors.
py::array_t<double> vectors(const std::vector<Vec3>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  auto m = a.mutable_unchecked<2>();
  for (size_t k = 0; k < v.size(); ++k) {
    for (int c = 0; c < 3; ++c) m(static_cast<py::ssize_t>(k), c) = v[k][c];
  }
  return a;
}

// An (M, 3) uint32 array of the triangles' vertex indices.
py::array_t<uint32_t> triangle_array(const std::vector<Triangle>& triangles) {
  py::array_t<uint32_t> a({static_cast<py::ssize_t>(triangles.size()), py::ssize_t{3}});
  auto m = a.mutable_unchecked<2>();
  for (size_t k = 0; k < triangles.size(); ++k) {
    for (int c = 0; c < 3; ++c) m(static_cast<py::ssize_t>(k), c) = triangles[k][static_cast<size_t>(c)];
  }
  return a;
}

py::dict mesh_dict(const Tessellation& t, double seconds) {
  py::dict d;
  d["positions"] = vectors(t.positions);
  d["normals"] = vectors(t.normals);
  d["triangles"] = triangle_array(t.triangles);
  d["degenerate_triangles"] = t.degenerate_triangles;
  d["seconds"] = seconds;
  return d;
}

// The same value as a Python object (dict, list, int, float, str, bool, None).
py::object to_python(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::object: {
      py::dict d;
      for (auto it = j.begin(); it != j.end(); ++it) d[py::str(it.key())] = to_python(it.value());
      return std::move(d);
    }
    case nlohmann::json::value_t::array: {
      py::list l;
      for (const auto& item : j) l.append(to_python(item));
      return std::move(l);
    }
    case nlohmann::json::value_t::string: return py::str(j.get<std::string>());
    case nlohmann::json::value_t::boolean: return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer: return py::int_(j.get<int64_t>());
    case nlohmann::json::value_t::number_unsigned: return py::int_(j.get<uint64_t>());
    case nlohmann::json::value_t::number_float: return py::float_(j.get<double>());
    default: return py::none();
  }
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

// A patch from Python: degree_u, degree_v, points as (deg_u+1)*(deg_v+1) rows of x, y, z (row-major,
// the u index first, as in .bpt files) and optional weights. Checked like a file's patch.
BezierPatch patch_from_python(int degree_u, int degree_v, py::array_t<double, py::array::c_style | py::array::forcecast> points,
                              std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>> weights,
                              const std::string& what) {
  BezierPatch p;
  p.degree_u = degree_u;
  p.degree_v = degree_v;
  if (degree_u < 1 || degree_v < 1 || degree_u > kMaxDegree || degree_v > kMaxDegree) {
    throw InputError(what + ": degrees must be in 1.." + std::to_string(kMaxDegree));
  }
  const auto expected = static_cast<py::ssize_t>((degree_u + 1) * (degree_v + 1));
  if (points.size() != expected * 3) {
    throw InputError(what + ": expected " + std::to_string(expected) + " control points of 3 coordinates");
  }
  const double* data = points.data();
  for (py::ssize_t k = 0; k < expected; ++k) p.points.emplace_back(data[3 * k], data[3 * k + 1], data[3 * k + 2]);
  if (weights && weights->size() > 0) {
    if (weights->size() != expected) throw InputError(what + ": expected " + std::to_string(expected) + " weights");
    p.weights.assign(weights->data(), weights->data() + expected);
  }
  validate_patch(p, what);
  return p;
}

// A mesh without surface data from vertex and triangle arrays (a FreeCAD Mesh, any STL).
Tessellation mesh_from_arrays(py::array_t<double, py::array::c_style | py::array::forcecast> positions,
                              py::array_t<int64_t, py::array::c_style | py::array::forcecast> triangles) {
  if (positions.ndim() != 2 || positions.shape(1) != 3) throw InputError("positions must be an (N, 3) array");
  if (triangles.ndim() != 2 || triangles.shape(1) != 3) throw InputError("triangles must be an (M, 3) array");
  Tessellation t;
  const double* p = positions.data();
  for (py::ssize_t k = 0; k < positions.shape(0); ++k) {
    const Vec3 v(p[3 * k], p[3 * k + 1], p[3 * k + 2]);
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) throw InputError("mesh vertex " + std::to_string(k) + " is not finite");
    t.positions.push_back(v);
  }
  const int64_t* tri = triangles.data();
  for (py::ssize_t k = 0; k < triangles.shape(0); ++k) {
    Triangle out{};
    for (int c = 0; c < 3; ++c) {
      const int64_t index = tri[3 * k + c];
      if (index < 0 || index >= positions.shape(0)) throw InputError("mesh triangle " + std::to_string(k) + " refers to a missing vertex");
      out[static_cast<size_t>(c)] = static_cast<uint32_t>(index);
    }
    t.triangles.push_back(out);
  }
  if (t.triangles.empty()) throw InputError("the mesh has no triangles");
  return t;
}

// Runs a scheme exactly as `sagitta tessellate` does and returns the mesh (with surface data, so it
// can be validated) and the statistics the CLI writes with --stats (less input and topology).
std::pair<Tessellation, py::dict> tessellate(const Model& model, const SchemeSpec& spec_in) {
  SchemeSpec spec = spec_in;
  spec.surface_data = true;
  nlohmann::json stats;
  Tessellation mesh;
  {
    py::gil_scoped_release release;
    const Topology topology = build_topology(model);
    SchemeStats scheme_stats;
    const app::Stopwatch clock;
    mesh = sagitta::tessellate(model, topology, spec, &scheme_stats);
    stats = app::scheme_stats_json(scheme_stats);
    stats["seconds"] = clock.seconds();
    stats["patches"] = model.patches.size();
    stats["vertices"] = mesh.positions.size();
    stats["triangles"] = mesh.triangles.size();
    stats["degenerate_triangles"] = mesh.degenerate_triangles;
  }
  return {std::move(mesh), to_python(stats).cast<py::dict>()};
}

// Certifies a mesh against the model and checks its topology; the fields are those of
// `sagitta validate --json`, plus "triangle_error" (per triangle certified upper bound, empty for a
// mesh without (u, v)).
py::dict validate(const Model& model, const Tessellation& mesh, int max_depth, int reference_segments) {
  if (max_depth < 0 || max_depth > 10) throw InputError("max_depth must be in 0..10");
  if (reference_segments < 1 || reference_segments > 1024) throw InputError("reference_segments must be in 1..1024");
  nlohmann::json doc;
  app::Validation validation;
  {
    py::gil_scoped_release release;
    const Topology topology = build_topology(model);
    app::ValidationOptions options;
    options.max_depth = max_depth;
    options.reference_segments = reference_segments;
    validation = app::validate_mesh(model, topology, mesh, options);
    doc = app::validation_json(model, topology, mesh, options, validation);
  }
  const DistanceReport& distance = validation.distance;
  py::dict out = to_python(doc).cast<py::dict>();
  py::array_t<double> error(static_cast<py::ssize_t>(distance.triangle_upper.size()));
  std::copy(distance.triangle_upper.begin(), distance.triangle_upper.end(), error.mutable_data());
  out["triangle_error"] = error;
  return out;
}

// A CAD model as a dict: the patch model, one report per B-rep face and the conversion counts.
py::dict cad_dict(const occt::CadModel& cad) {
  py::list faces;
  for (const occt::FaceReport& f : cad.faces) {
    py::dict d;
    d["face_index"] = f.face_index;
    d["name"] = f.name;
    d["surface_type"] = f.surface_type;
    d["status"] = f.status;
    d["reason"] = f.reason;
    d["first_patch"] = f.first_patch;
    d["patch_count"] = f.patch_count;
    faces.append(d);
  }
  py::dict d;
  d["model"] = cad.model;
  d["faces"] = faces;
  d["patch_face"] = cad.patch_face;
  d["faces_tessellated"] = cad.faces_tessellated;
  d["faces_trimmed"] = cad.faces_trimmed;
  d["faces_skipped"] = cad.faces_skipped;
  d["solids"] = cad.solids;
  d["shells"] = cad.shells;
  d["whole_part"] = occt::is_whole_part(cad);
  Model trimmed;
  trimmed.name = cad.model.name;
  trimmed.patches = cad.trimmed_patches;
  d["trimmed_model"] = trimmed;  // the trimmed faces' patches (untrimmed): what a whole part meshes more
  return d;
}

// The Model class and the ways to make one (patch files, .bpt text, the built-in model, copies,
// Python lists), and its patch topology.
void bind_model(py::module_& m) {
  py::class_<Model>(m, "Model")
      .def_readonly("name", &Model::name)
      .def_property_readonly("patch_count", [](const Model& model) { return model.patches.size(); })
      .def_property_readonly(
          "patches",
          [](const Model& model) {
            py::list out;
            for (const BezierPatch& p : model.patches) {
              py::dict d;
              d["degree_u"] = p.degree_u;
              d["degree_v"] = p.degree_v;
              d["points"] = vectors(p.points);
              d["weights"] = p.rational() ? py::cast(p.weights) : py::none();
              out.append(d);
            }
            return out;
          },
          "The patches as dicts, in the form model_from_patches takes")
      .def("__repr__", [](const Model& model) {
        return "<sagitta.Model '" + model.name + "' with " + std::to_string(model.patches.size()) + " patches>";
      });

  m.def("read_model", &io::read_patch_model, py::arg("path"), "Read a .bpt or .rib patch file");
  m.def("parse_bpt", &io::parse_bpt, py::arg("text"), py::arg("name"), "A patch model from .bpt text; `name` names it in messages");
  m.def("default_model", &fixtures::default_model, "The built-in default model (pillow box + rational torus)");
  m.def("replicate", &replicate, py::arg("model"), py::arg("copies"), "K translated instances of a model");
  m.def("topology", &topology_dict, py::arg("model"), "Shared, free and collapsed patch sides");
  m.def(
      "model_from_patches",
      [](const std::string& name, const py::list& patches) {
        Model model;
        model.name = name;
        for (size_t k = 0; k < patches.size(); ++k) {
          const py::dict p = patches[k].cast<py::dict>();
          std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>> weights;
          if (p.contains("weights") && !p["weights"].is_none()) weights = p["weights"].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
          model.patches.push_back(patch_from_python(p["degree_u"].cast<int>(), p["degree_v"].cast<int>(),
                                                    p["points"].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>(),
                                                    weights, name + ": patch " + std::to_string(k)));
        }
        validate_model(model, name);
        normalize_weights(model);
        return model;
      },
      py::arg("name"), py::arg("patches"),
      "A model from a list of dicts {degree_u, degree_v, points ((du+1)*(dv+1), 3) row-major by u index, weights or None}");
}

// The Mesh class, meshes from NumPy arrays, and mesh files.
void bind_mesh(py::module_& m) {
  py::class_<Tessellation>(m, "Mesh",
                           "A triangle mesh; meshes made by tessellate() also carry each vertex's (patch, u, v)")
      .def_property_readonly("positions", [](const Tessellation& t) { return vectors(t.positions); })
      .def_property_readonly("normals", [](const Tessellation& t) { return vectors(t.normals); })
      .def_property_readonly("triangles", [](const Tessellation& t) { return triangle_array(t.triangles); })
      .def_property_readonly("triangle_patch", [](const Tessellation& t) { return t.triangle_patch; })
      .def_property_readonly("vertex_count", [](const Tessellation& t) { return t.positions.size(); })
      .def_property_readonly("triangle_count", [](const Tessellation& t) { return t.triangles.size(); })
      .def_readonly("degenerate_triangles", &Tessellation::degenerate_triangles)
      .def_property_readonly("has_surface", &Tessellation::has_surface)
      .def("__repr__", [](const Tessellation& t) {
        return "<sagitta.Mesh with " + std::to_string(t.positions.size()) + " vertices, " +
               std::to_string(t.triangles.size()) + " triangles>";
      });

  m.def("mesh_from_arrays", &mesh_from_arrays, py::arg("positions"), py::arg("triangles"),
        "A mesh without surface data (validated through a certified reference tessellation)");
  m.def("read_mesh", &io::read_mesh, py::arg("path"), "Read an .obj, .ply or .stl mesh");
  m.def("write_mesh", [](const Tessellation& mesh, const std::string& path) { io::write_mesh(mesh, path); }, py::arg("mesh"),
        py::arg("path"), "Write .obj, .ply or .stl atomically");
}

// Tessellation by scheme as `sagitta tessellate` runs it, and the bare uniform kernel.
void bind_tessellate(py::module_& m) {
  m.def("scheme_names", &scheme_names, "The schemes tessellate() accepts, in the CLI's order (uniform, pn, esc)");
  m.def(
      "tessellate",
      [](const Model& model, const std::string& scheme, int level, int segments, double threshold, int base_level,
         const std::string& pattern, const std::string& pn_variant, double tess_factor, uint64_t max_triangles) {
        SchemeSpec spec;
        spec.scheme = parse_scheme(scheme);
        spec.level = level;
        spec.segments = segments;
        spec.threshold = threshold;
        spec.base_level = base_level;
        spec.pattern = parse_pn_pattern(pattern);
        spec.pn_variant = parse_pn_variant(pn_variant);
        spec.tess_factor = tess_factor;
        spec.max_triangles = max_triangles;
        return tessellate(model, spec);
      },
      py::arg("model"), py::arg("scheme") = "uniform", py::arg("level") = -1, py::arg("segments") = -1,
      py::arg("threshold") = 0.0, py::arg("base_level") = -1, py::arg("pattern") = "integer",
      py::arg("pn_variant") = "basic", py::arg("tess_factor") = -1.0, py::arg("max_triangles") = uint64_t{200'000'000},
      "Tessellate with a scheme (uniform | esc | pn), parameters as in `sagitta tessellate`; returns (Mesh, stats "
      "dict)");
  m.def(
      "estimated_triangles",
      [](const Model& model, const std::string& scheme, int level, int segments, int base_level) {
        SchemeSpec spec;
        spec.scheme = parse_scheme(scheme);
        spec.level = level;
        spec.segments = segments;
        spec.base_level = base_level;
        double triangles = estimated_triangles(model, spec);
        if (spec.scheme == Scheme::kPn && level >= 1) {  // the base's refinement (integer pattern)
          PnParams params;
          params.factor = level;
          triangles *= static_cast<double>(pn_triangles_per_input(params));
        }
        return triangles;
      },
      py::arg("model"), py::arg("scheme") = "uniform", py::arg("level") = -1, py::arg("segments") = -1,
      py::arg("base_level") = -1,
      "Triangles tessellate() makes at most with these parameters (esc: its full pattern; pn: the uniform base "
      "times the integer pattern's triangles), computed without tessellating: the size guard's estimate");
  m.def(
      "tessellate_uniform",
      [](const Model& model, std::optional<int> level, std::optional<int> segments) {
        if (level.has_value() == segments.has_value()) throw InputError("give exactly one of level or segments");
        SchemeSpec spec;
        spec.segments = level ? segments_for_level(*level) : *segments;
        spec.surface_data = false;
        spec.guard = false;  // as the kernel alone: no size guard
        const Topology topo = build_topology(model);
        py::gil_scoped_release release;
        const app::Stopwatch clock;
        Tessellation t = sagitta::tessellate(model, topo, spec);
        const double seconds = clock.seconds();
        py::gil_scoped_acquire acquire;
        return mesh_dict(t, seconds);
      },
      py::arg("model"), py::arg("level") = py::none(), py::arg("segments") = py::none(),
      "Uniform tessellation: positions (N,3), normals (N,3), triangles (M,3), degenerate_triangles, seconds");
}

// Certified validation, as `sagitta validate --json`.
void bind_validate(py::module_& m) {
  m.def("validate", &validate, py::arg("model"), py::arg("mesh"), py::arg("max_depth") = 8, py::arg("reference_segments") = 32,
        "Certified distance intervals (hausdorff, mesh_to_surface, surface_to_mesh) and topology verdict, as in "
        "`sagitta validate --json`, plus triangle_error (per-triangle certified bound; empty without (u, v))");
}

// Fitting a scheme to a certified target error, as `sagitta fit --json`.
void bind_fit(py::module_& m) {
  m.def(
      "fit",
      [](const Model& model, const std::string& scheme, double target_error, int max_refinements) {
        if (!(target_error > 0.0) || !std::isfinite(target_error)) throw InputError("the target error must be a positive number");
        const Scheme fit_scheme = parse_scheme(scheme);
        nlohmann::json doc;
        {
          py::gil_scoped_release release;
          FitOptions options;
          options.max_refinements = max_refinements;
          doc = app::fit_result_json(fit_to_error(model, build_topology(model), fit_scheme, target_error, options));
        }
        return to_python(doc);
      },
      py::arg("model"), py::arg("scheme"), py::arg("target_error"), py::arg("max_refinements") = 12,
      "Fit the scheme's parameters to a certified target error, as `sagitta fit --json` reports it (uniform: "
      "segments; esc: level and threshold; pn: base_level and level)");
}

// CAD input through the OCCT adapter.
void bind_cad(py::module_& m) {
  m.def(
      "read_brep_string",
      [](const std::string& text, const std::string& name) {
        occt::CadModel cad;
        {
          py::gil_scoped_release release;
          cad = occt::read_brep_string(text, name);
        }
        return cad_dict(cad);
      },
      py::arg("brep_text"), py::arg("name"),
      "A shape's BREP text (FreeCAD: shape.exportBrepToString()) as {model, faces, ...} through the OCCT adapter");
  m.def(
      "read_cad_file",
      [](const std::string& path) {
        occt::CadModel cad;
        {
          py::gil_scoped_release release;
          cad = occt::read_cad_file(path);
        }
        return cad_dict(cad);
      },
      py::arg("path"), "A .step/.iges/.brep file as {model, faces, ...} through the OCCT adapter");
}

// Per-face reports of a whole part as dicts (PartFace's fields).
py::list part_faces(const occt::PartMesh& part) {
  py::list faces;
  for (const occt::PartFace& f : part.faces) {
    py::dict d;
    d["face_index"] = f.face_index;
    d["name"] = f.name;
    d["surface_type"] = f.surface_type;
    d["trimmed"] = f.trimmed;
    d["solid"] = f.solid;
    d["status"] = f.status;
    d["reason"] = f.reason;
    d["first_patch"] = f.first_patch;
    d["patch_count"] = f.patch_count;
    d["triangles"] = f.triangles;
    d["scheme_triangles"] = f.scheme_triangles;
    d["boundary_vertices"] = f.boundary_vertices;
    d["max_boundary_offset"] = f.max_boundary_offset;
    faces.append(d);
  }
  return faces;
}

// Per-solid facts of a whole part as dicts (PartSolid's fields).
py::list part_solids(const occt::PartMesh& part) {
  py::list solids;
  for (const occt::PartSolid& s : part.solids) {
    py::dict d;
    d["index"] = s.index;
    d["closed"] = s.closed;
    d["valid"] = s.valid;
    d["volume"] = s.volume;
    d["faces"] = s.faces;
    d["triangles"] = s.triangles;
    solids.append(d);
  }
  return solids;
}

// A 1-D NumPy array holding a copy of the values.
template <typename T>
py::array_t<T> array_of(const std::vector<T>& values) {
  py::array_t<T> a(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), a.mutable_data());
  return a;
}

// The part options from the keyword arguments through app::part_options (as the CLI does):
// `segments` (uniform) replaces `level` when given; esc takes `level` and `threshold`. The schemes
// check their parameters when the part is meshed.
occt::PartOptions part_options(const std::string& scheme, int level, std::optional<int> segments,
                               std::optional<double> threshold, double edge_tolerance) {
  SchemeSpec spec;
  spec.scheme = parse_scheme(scheme);
  spec.level = segments ? -1 : level;
  spec.segments = segments.value_or(-1);
  spec.threshold = threshold.value_or(0.0);
  return app::part_options(spec, edge_tolerance);
}

// One solid's verdict as a dict (SolidCheck's fields; findings as dicts).
py::dict solid_check_dict(const SolidCheck& c) {
  py::dict d;
  d["solid"] = c.solid;
  d["triangles"] = c.triangles;
  d["vertices"] = c.vertices;
  d["edges"] = c.edges;
  d["open_edges"] = c.open_edges;
  d["model_boundary_edges"] = c.model_boundary_edges;
  d["crack_edges"] = c.crack_edges;
  d["non_manifold_edges"] = c.non_manifold_edges;
  d["t_junctions"] = c.t_junctions;
  d["inconsistent_orientation_edges"] = c.inconsistent_orientation_edges;
  d["degenerate_triangles"] = c.degenerate_triangles;
  d["components"] = c.components;
  d["euler_characteristic"] = c.euler_characteristic;
  d["closed"] = c.closed;
  d["signed_volume"] = c.signed_volume;
  d["cgal_checked"] = c.cgal_checked;
  d["cgal_note"] = c.cgal_note;
  d["cgal_closed"] = c.cgal_closed;
  d["cgal_outward"] = c.cgal_outward;
  d["cgal_self_intersections"] = c.cgal_self_intersections;
  d["cgal_volume"] = c.cgal_volume;
  py::list findings;
  for (const TopologyFinding& f : c.findings) {
    py::dict fd;
    fd["kind"] = f.kind;
    fd["position"] = py::make_tuple(f.position.x, f.position.y, f.position.z);
    fd["patch"] = f.patch;
    fd["triangle"] = f.triangle;
    fd["vertices"] = py::make_tuple(f.vertices[0], f.vertices[1]);
    findings.append(fd);
  }
  d["findings"] = findings;
  return d;
}

// Checks every solid of a whole-part mesh (sagitta/solid_check.hpp) from Python arrays.
py::list check_solids_python(const Tessellation& mesh,
                             py::array_t<int32_t, py::array::c_style | py::array::forcecast> triangle_solid,
                             py::array_t<int64_t, py::array::c_style | py::array::forcecast> boundary_edges, bool cgal,
                             bool self_intersections) {
  if (triangle_solid.ndim() != 1) throw InputError("triangle_solid must be a 1-D array");
  const bool no_edges = boundary_edges.size() == 0;
  if (!no_edges && (boundary_edges.ndim() != 2 || boundary_edges.shape(1) != 2)) {
    throw InputError("boundary_edges must be a (K, 2) array");
  }
  const std::vector<int32_t> solid(triangle_solid.data(), triangle_solid.data() + triangle_solid.size());
  std::vector<std::array<uint32_t, 2>> edges;
  const int64_t* e = boundary_edges.data();
  for (py::ssize_t k = 0; !no_edges && k < boundary_edges.shape(0); ++k) {
    if (e[2 * k] < 0 || e[2 * k + 1] < 0 || e[2 * k] >= int64_t(mesh.positions.size()) ||
        e[2 * k + 1] >= int64_t(mesh.positions.size())) {
      throw InputError("boundary edge " + std::to_string(k) + " refers to a missing vertex");
    }
    edges.push_back({static_cast<uint32_t>(e[2 * k]), static_cast<uint32_t>(e[2 * k + 1])});
  }
  SolidCheckOptions options;
  options.cgal = cgal;
  options.self_intersections = self_intersections;
  std::vector<SolidCheck> checks;
  {
    py::gil_scoped_release release;
    checks = check_solids(mesh, solid, edges, options);
  }
  py::list out;
  for (const SolidCheck& c : checks) out.append(solid_check_dict(c));
  return out;
}

// Whole CAD parts: every face meshed into one watertight indexed mesh, and the per-solid check.
void bind_part(py::module_& m) {
  py::class_<occt::PartMesh>(m, "PartMesh",
                             "A whole part as one indexed mesh: per-triangle face and solid ids, the free B-rep "
                             "edges' mesh edges, one report per face and per solid")
      .def_readonly("name", &occt::PartMesh::name)
      .def_readonly("model", &occt::PartMesh::model, "The tessellated faces' Bézier patches, in face order")
      .def_readonly("mesh", &occt::PartMesh::mesh)
      .def_property_readonly("triangle_face", [](const occt::PartMesh& p) { return array_of(p.triangle_face); })
      .def_property_readonly("triangle_solid", [](const occt::PartMesh& p) { return array_of(p.triangle_solid); })
      .def_property_readonly(
          "boundary_edges",
          [](const occt::PartMesh& p) {
            py::array_t<uint32_t> a({static_cast<py::ssize_t>(p.boundary_edges.size()), py::ssize_t{2}});
            auto w = a.mutable_unchecked<2>();
            for (size_t k = 0; k < p.boundary_edges.size(); ++k) {
              w(static_cast<py::ssize_t>(k), 0) = p.boundary_edges[k][0];
              w(static_cast<py::ssize_t>(k), 1) = p.boundary_edges[k][1];
            }
            return a;
          })
      .def_property_readonly("faces", &part_faces)
      .def_property_readonly("solids", &part_solids)
      .def_readonly("faces_tessellated", &occt::PartMesh::faces_tessellated)
      .def_readonly("faces_skipped", &occt::PartMesh::faces_skipped)
      .def_readonly("unassigned_triangles", &occt::PartMesh::unassigned_triangles, "A foreign mesh's triangles on no single face")
      .def_readonly("welded", &occt::PartMesh::welded, "A foreign mesh's largest vertex move when welding (added to the bounds)")
      .def_readonly("faces_trimmed", &occt::PartMesh::faces_trimmed)
      .def_readonly("edges", &occt::PartMesh::edges)
      .def_readonly("edge_vertices", &occt::PartMesh::edge_vertices)
      .def_readonly("seconds", &occt::PartMesh::seconds)
      .def("__repr__", [](const occt::PartMesh& p) {
        return "<sagitta.PartMesh '" + p.name + "': " + std::to_string(p.faces.size()) + " faces, " +
               std::to_string(p.mesh.triangles.size()) + " triangles>";
      });

  m.def(
      "mesh_part",
      [](const std::string& path, const std::string& scheme, int level, std::optional<int> segments,
         std::optional<double> threshold, double edge_tolerance) {
        const occt::PartOptions options = part_options(scheme, level, segments, threshold, edge_tolerance);
        py::gil_scoped_release release;
        return occt::mesh_part_file(path, options);
      },
      py::arg("path"), py::arg("scheme") = "uniform", py::arg("level") = 2, py::arg("segments") = py::none(),
      py::arg("threshold") = py::none(), py::arg("edge_tolerance") = 0.0,
      "Every face of a .step/.iges/.brep file in one mesh, watertight across faces (uniform: level or segments; "
      "esc: level and threshold)");
  m.def(
      "sew_free_faces_brep",
      [](const std::string& text, const std::string& name) {
        py::gil_scoped_release release;
        return occt::sew_free_faces_brep_string(text, name);
      },
      py::arg("brep_text"), py::arg("name"),
      "A compound of free faces (FreeCAD's import of an IGES file) sewn as the CLI sews an IGES file, in "
      "the same face order, as BREP text; any other shape's text unchanged");
  m.def(
      "mesh_part_brep",
      [](const std::string& text, const std::string& name, const std::string& scheme, int level,
         std::optional<int> segments, std::optional<double> threshold, double edge_tolerance,
         const std::vector<int>& face_segments, const std::vector<double>& face_edge_tolerance,
         const std::vector<double>& face_graded_segments) {
        occt::PartOptions options = part_options(scheme, level, segments, threshold, edge_tolerance);
        options.face_segments = face_segments;
        options.face_edge_tolerance = face_edge_tolerance;
        options.face_graded_segments = face_graded_segments;
        py::gil_scoped_release release;
        return occt::mesh_part_brep_string(text, name, options);
      },
      py::arg("brep_text"), py::arg("name"), py::arg("scheme") = "uniform", py::arg("level") = 2,
      py::arg("segments") = py::none(), py::arg("threshold") = py::none(), py::arg("edge_tolerance") = 0.0,
      py::arg("face_segments") = std::vector<int>{}, py::arg("face_edge_tolerance") = std::vector<double>{},
      py::arg("face_graded_segments") = std::vector<double>{},
      "mesh_part on a shape's BREP text (FreeCAD: shape.exportBrepToString()); `name` names it in messages; "
      "face_segments (uniform): segments per patch side of each face by face index, overriding `segments` "
      "where > 0; face_edge_tolerance: a tighter edge tolerance for each face's edges where > 0; "
      "face_graded_segments (uniform): a real N for each face's graded grid where > 0 (all three "
      "fit_part_brep's choice)");
  m.def(
      "mesh_on_part_brep",
      [](const std::string& text, const std::string& name, const Tessellation& mesh) {
        py::gil_scoped_release release;
        return occt::mesh_on_part_brep_string(text, name, mesh);
      },
      py::arg("brep_text"), py::arg("name"), py::arg("mesh"),
      "Any mesh of a part (no (u, v), no face ids) found face by face on the part's B-rep, as a PartMesh to "
      "certify_part (`sagitta validate PART --mesh`)");
  m.def(
      "fit_part_brep",
      [](const std::string& text, const std::string& name, double target_error, int max_depth) {
        if (!(target_error > 0.0) || !std::isfinite(target_error))
          throw InputError("the target error must be a positive number");
        if (max_depth < 0 || max_depth > 10) throw InputError("max_depth must be in 0..10");
        nlohmann::json doc;
        {
          py::gil_scoped_release release;
          CertifyOptions certify;
          certify.max_depth = max_depth;
          const app::PartFit fit = app::fit_part(
              [&](const occt::PartOptions& options) { return occt::mesh_part_brep_string(text, name, options); },
              target_error, certify);
          doc = app::part_fit_json(fit);
          doc.erase("part");
        }
        return to_python(doc);
      },
      py::arg("brep_text"), py::arg("name"), py::arg("target_error"), py::arg("max_depth") = 8,
      "Fit a whole part (BREP text) to a certified target error, as `sagitta fit PART --json` (uniform segments "
      "and an edge tolerance; met, reason, segments, face_segments, face_graded_segments, edge_tolerance, "
      "face_edge_tolerance, triangles, "
      "certified_error, steps)");
  m.def(
      "certify_part",
      [](const occt::PartMesh& part, int max_depth) {
        if (max_depth < 0 || max_depth > 10) throw InputError("max_depth must be in 0..10");
        nlohmann::json doc;
        std::vector<double> triangle_upper;
        {
          py::gil_scoped_release release;
          CertifyOptions options;
          options.max_depth = max_depth;
          const app::PartCertificate cert = app::certify_part(part, options);
          doc = app::part_certificate_json(part, cert);
          triangle_upper = cert.triangle_upper;
        }
        py::dict out = to_python(doc).cast<py::dict>();
        out["triangle_error"] = array_of(triangle_upper);
        return out;
      },
      py::arg("part"), py::arg("max_depth") = 8,
      "The whole part's certificate, face by face (`sagitta validate PART --json`'s \"certificate\"), plus "
      "triangle_error (per triangle certified bound, inf on faces not certified)");
  m.def("check_solids", &check_solids_python, py::arg("mesh"), py::arg("triangle_solid"), py::arg("boundary_edges"),
        py::arg("cgal") = true, py::arg("self_intersections") = true,
        "Per-solid watertightness of a whole-part mesh: one dict per solid id (SolidCheck's fields), sorted by id");
}

// The run's budget (sagitta/budget.hpp), process-wide: what the FreeCAD commands use to cancel work
// running in another thread and to refuse, before allocating, work larger than the memory allowed.
void bind_budget(py::module_& m) {
  m.def("request_cancel", &budget::request_cancel,
        "Ask the running work (any thread) to stop at its next check: it raises Interrupted, no result");
  m.def("reset_budget", &budget::reset, "Clear the cancellation request, the time limit and the memory limit");
  m.def("set_max_seconds", &budget::set_max_seconds, py::arg("seconds"),
        "Work started from now raises Interrupted after `seconds` (<= 0: no limit)");
  m.def("set_max_memory", &budget::set_max_bytes, py::arg("bytes"),
        "Memory limit in bytes checked by up-front estimates and at allocation sites (<= 0: no limit); work that "
        "would exceed it raises MemoryLimitExceeded before allocating");
  m.def("max_memory", &budget::max_bytes, "The memory limit in bytes (0: none)");
  m.def("cancel_requested", &budget::exhausted, "True once cancellation was requested or the time limit passed");
}

}  // namespace

// Each class is bound before the functions that take or return it, so that their signatures name it.
PYBIND11_MODULE(_sagitta, m) {
  m.doc() = "Sagitta: tessellate Bézier surfaces and certify the distance to the exact surface";
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<BudgetExhausted>(m, "Interrupted", PyExc_RuntimeError);
  py::register_exception<MemoryLimitExceeded>(m, "MemoryLimitExceeded", PyExc_MemoryError);
  bind_budget(m);
  bind_model(m);
  bind_mesh(m);
  bind_tessellate(m);
  bind_validate(m);
  bind_fit(m);
  bind_cad(m);
  bind_part(m);
}
