// `sagitta validate`: certified distance interval and topology verdict for a tessellation of a
// patch model, made here by a scheme or read from a mesh file.
#include "commands.hpp"
#include "progress.hpp"
#include "schemes.hpp"

#include "sagitta/app/validate.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/mesh_check.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <memory>

namespace sagitta::cli {

using app::validate_mesh;
using app::Validation;
using app::validation_json;
using app::ValidationOptions;

namespace {

// Exit codes (also in --help).
constexpr int kExitRequirementFailed = 3;

struct ValidateOptions {
  std::string input;
  std::string mesh;
  SchemeOptions scheme;
  std::string json;
  std::string error_ply;
  double max_error = -1.0;
  bool require_watertight = false;
  int max_depth = 8;
  int reference_segments = 32;
};

}  // namespace

namespace {

// The requirements (--max-error, --require-watertight) that failed, each as one line; records
// max_error and requirements_failed in `doc`.
nlohmann::json failed_requirements(const ValidateOptions& o, const Validation& validation, nlohmann::json& doc) {
  const DistanceReport& distance = validation.distance;
  nlohmann::json failed = nlohmann::json::array();
  if (o.max_error >= 0.0) {
    doc["max_error"] = o.max_error;
    if (!(distance.hausdorff.upper <= o.max_error)) {
      failed.push_back(distance.hausdorff.lower > o.max_error ? "max-error: the distance exceeds it (lower bound above)"
                                                              : "max-error: not certified (upper bound above)");
    }
  }
  if (o.require_watertight && !validation.topology.watertight())
    failed.push_back("watertight: cracks, T-junctions or non-manifold edges found");
  doc["requirements_failed"] = failed;
  return failed;
}

// --error-ply: the mesh as binary PLY with each face's certified upper bound (rounded up to float).
void write_error_ply(const ValidateOptions& o, const Tessellation& mesh, const DistanceReport& distance,
                     nlohmann::json& doc) {
  if (distance.triangle_upper.size() != mesh.triangles.size()) {
    throw InputError("--error-ply needs a mesh with (u, v): per-triangle bounds exist only for our schemes' meshes");
  }
  std::vector<float> error(distance.triangle_upper.size());
  for (size_t t = 0; t < error.size(); ++t) {
    const float f = static_cast<float>(distance.triangle_upper[t]);
    error[t] = f < distance.triangle_upper[t] ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
  }
  io::MeshWriteOptions w;
  w.face_error = &error;
  io::write_ply(mesh, o.error_ply, w);
  doc["error_ply"] = o.error_ply;
}

// The one-paragraph summary on stdout.
void print_validation(const Validation& validation, const Tessellation& mesh, const nlohmann::json& doc) {
  const DistanceReport& distance = validation.distance;
  const TopologyReport& topo = validation.topology;
  std::cout << "hausdorff in [" << distance.hausdorff.lower << ", " << distance.hausdorff.upper << "]"
            << (distance.hausdorff.certified ? "" : " (upper not certified)") << "; mesh->surface ["
            << distance.mesh_to_surface.lower << ", " << distance.mesh_to_surface.upper << "]; surface->mesh ["
            << distance.surface_to_mesh.lower << ", " << distance.surface_to_mesh.upper << "]; "
            << mesh.triangles.size() << " triangles; open edges " << topo.open_edges << " (model boundary "
            << topo.model_boundary_edges << ", cracks " << topo.crack_edges << "), T-junctions " << topo.t_junctions
            << ", non-manifold " << topo.non_manifold_edges << ", misoriented " << topo.inconsistent_orientation_edges
            << ", duplicated faces " << topo.duplicated_faces << "; components " << topo.components << " (closed "
            << topo.closed_components << ", inside-out " << topo.inside_out_components << "); "
            << doc["seconds"].get<double>() << " s\n";
  if (!distance.not_certified_reason.empty()) std::cout << "not certified: " << distance.not_certified_reason << "\n";
}

int run_validate(const ValidateOptions& o) {
  check_outputs({{"--json", o.json}, {"--error-ply", o.error_ply}}, {o.input, o.mesh});
  if (o.max_depth < 0 || o.max_depth > 10) throw InputError("--max-depth must be in 0..10");
  const Stopwatch total;
  nlohmann::json cad;
  const Model model = load_model(o.input, &cad);
  const Topology topology = build_topology(model);
  nlohmann::json doc;
  if (!cad.is_null()) doc.update(cad);
  doc["input"] = o.input.empty() ? "default" : o.input;
  doc["patches"] = model.patches.size();
  Tessellation mesh;
  double tessellation_seconds = 0.0;
  if (!o.mesh.empty()) {
    mesh = io::read_mesh(o.mesh);
    doc["mesh"] = o.mesh;
  } else {
    SchemeSpec spec = scheme_spec(o.scheme);
    spec.surface_data = true;
    SchemeStats stats;
    const Stopwatch clock;
    mesh = tessellate(model, topology, spec, &stats);
    tessellation_seconds = clock.seconds();
    doc["tessellation"] = scheme_stats_json(stats);
    doc["tessellation"]["seconds"] = tessellation_seconds;
  }
  doc["triangles"] = mesh.triangles.size();
  doc["vertices"] = mesh.positions.size();
  doc["dropped_degenerate_triangles"] = mesh.degenerate_triangles;

  ValidationOptions options;
  options.max_depth = o.max_depth;
  options.reference_segments = o.reference_segments;
  Validation validation;
  {
    // On a terminal, a line showing the validation running (it can take minutes).
    const ProgressTicker progress("sagitta validate:", "certifying " + std::to_string(mesh.triangles.size()) + " triangles");
    validation = validate_mesh(model, topology, mesh, options);
  }
  const DistanceReport& distance = validation.distance;
  doc.update(validation_json(model, topology, mesh, options, validation));
  if (tessellation_seconds > 0.0)
    doc["validation_to_tessellation_ratio"] = doc["seconds"].get<double>() / tessellation_seconds;

  const nlohmann::json failed = failed_requirements(o, validation, doc);
  if (!o.error_ply.empty()) write_error_ply(o, mesh, distance, doc);
  doc["total_seconds"] = total.seconds();
  if (!o.json.empty()) write_json(o.json, doc);

  print_validation(validation, mesh, doc);
  for (const auto& f : failed) std::cerr << "sagitta validate: requirement failed: " << f.get<std::string>() << "\n";
  return failed.empty() ? 0 : kExitRequirementFailed;
}

}  // namespace

Command register_validate(CLI::App& app) {
  auto o = std::make_shared<ValidateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "validate",
      "Certify the distance between a tessellation and the exact surfaces (an interval lower <= true <= upper) and check "
      "its topology. Exit codes: 0 all stated requirements hold; 2 input error; 3 a requirement (--max-error, "
      "--require-watertight) failed or could not be certified.");
  cmd->add_option("input", o->input, "Patch file (.bpt, .rib); omit or 'default' for the built-in model");
  cmd->add_option("--mesh", o->mesh, "Validate this mesh (.obj, .ply, .stl) instead of tessellating; no (u, v) needed");
  add_scheme_options(cmd, o->scheme);
  cmd->add_option("--json", o->json, "Report: hausdorff/mesh_to_surface/surface_to_mesh {lower, upper}, topology, seconds");
  cmd->add_option("--max-error", o->max_error, "Require the certified Hausdorff upper bound to be <= E (exit 3 otherwise)");
  cmd->add_flag("--require-watertight", o->require_watertight,
                "Require no cracks, T-junctions or non-manifold edges (model boundary edges are allowed; exit 3 otherwise)");
  cmd->add_option("--error-ply", o->error_ply, "Write the mesh as binary PLY with a per-face 'error' (certified upper bound)");
  cmd->add_option("--max-depth", o->max_depth, "Subdivision budget per triangle: at most 4^D sub-triangles (0..10)")
      ->capture_default_str();
  cmd->add_option("--reference-segments", o->reference_segments,
                  "--mesh only: uniform segments per patch side of the certified reference tessellation")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  return {cmd, [o] {
            const int code = run_validate(*o);
            if (code != 0) {
              std::cout.flush();
              std::cerr.flush();
              std::exit(code);
            }
          }};
}

}  // namespace sagitta::cli
