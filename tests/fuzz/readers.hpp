// The readers the fuzzers and the regression test drive, by short name: every reader of untrusted
// bytes in plugin/io, and "validate" (a model and a mesh through the validator's cheap path). A
// reader may only return a result or throw sagitta::InputError.
#pragma once

#include "sagitta/certify.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/io/scene_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/model.hpp"

#include <stdexcept>
#include <string>
#include <vector>

namespace sagitta::fuzz {

// Names of the readers, which are also the corpus and regression folder names.
inline std::vector<std::string> reader_names() { return {"bpt", "rib", "obj", "ply", "stl", "scene", "validate"}; }

// The "validate" input: a .bpt model, a line "%%", then an OBJ mesh. Both are parsed; when they
// are small (at most 8 patches, 512 triangles: each run stays in milliseconds) the mesh's topology
// is checked against the model and its distance certified at a small depth, as `sagitta validate
// --mesh` does. A stated interval must have lower <= upper; anything else is a logic error.
inline void validate_model_and_mesh(const std::string& bytes, const std::string& name) {
  const size_t split = bytes.find("\n%%\n");
  if (split == std::string::npos) throw InputError(name + ": no line \"%%\" between the model and the mesh");
  const Model model = io::parse_bpt(bytes.substr(0, split + 1), name);
  const Tessellation mesh = io::detail::parse_mesh(bytes.substr(split + 4), name + " (mesh part)", ".obj");
  if (model.patches.size() > 8 || mesh.triangles.size() > 512) return;
  const Topology topology = build_topology(model);
  (void)check_mesh_topology(mesh, &model, &topology);
  ExternalOptions options;
  options.reference_segments = 4;
  options.surface_samples = 8;
  options.certify.max_depth = 2;
  options.certify.lower_candidates = 4;
  options.certify.lower_node_budget = 2000;
  options.hausdorff_min_reads = 100'000;  // a mesh in a planar model hit the default 20M in 36 s here
  options.hausdorff_reads_per_triangle = 200;
  const DistanceReport report = certify_external(model, mesh, options);
  for (const DistanceInterval* d : {&report.hausdorff, &report.mesh_to_surface, &report.surface_to_mesh}) {
    if (d->certified && !(d->lower <= d->upper)) {
      throw std::logic_error(name + ": the validator certified an interval with lower " + std::to_string(d->lower) +
                             " > upper " + std::to_string(d->upper));
    }
  }
}

// Parses `bytes` with the named reader; `name` is the file name put into error messages.
// Guarantees: returns normally or throws what the reader throws; an unknown reader is a logic error.
inline void parse_with(const std::string& reader, const std::string& bytes, const std::string& name) {
  if (reader == "bpt") {
    (void)io::parse_bpt(bytes, name);
  } else if (reader == "rib") {
    (void)io::detail::parse_rib(bytes, name);
  } else if (reader == "obj" || reader == "ply" || reader == "stl") {
    (void)io::detail::parse_mesh(bytes, name, "." + reader);
  } else if (reader == "scene") {
    (void)io::detail::parse_scene(bytes, name);
  } else if (reader == "validate") {
    validate_model_and_mesh(bytes, name);
  } else {
    throw std::logic_error("no reader called '" + reader + "'");
  }
}

}  // namespace sagitta::fuzz
