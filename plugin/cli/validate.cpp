// `sagitta validate`: certified distance interval and topology verdict for a tessellation of a
// patch model, made here by a scheme or read from a mesh file; for a CAD part, the whole-part mesh
// checked solid by solid and certified on the faces today's certificate covers (app/part.hpp).
#include "commands.hpp"
#include "progress.hpp"
#include "schemes.hpp"

#include "sagitta/app/part.hpp"
#include "sagitta/app/validate.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/occt/cad.hpp"

#include <algorithm>
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
  double edge_tolerance = 0.0;
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

// --error-ply from per-triangle bounds (rounded up to float; +infinity stays infinite).
void write_error_ply(const std::string& path, const Tessellation& mesh, const std::vector<double>& upper) {
  std::vector<float> error(upper.size());
  for (size_t t = 0; t < error.size(); ++t) {
    const float f = static_cast<float>(upper[t]);
    error[t] = f < upper[t] ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
  }
  io::MeshWriteOptions w;
  w.face_error = &error;
  io::write_ply(mesh, path, w);
}

// --error-ply: the mesh as binary PLY with each face's certified upper bound (rounded up to float).
void write_error_ply(const ValidateOptions& o, const Tessellation& mesh, const DistanceReport& distance,
                     nlohmann::json& doc) {
  if (distance.triangle_upper.size() != mesh.triangles.size()) {
    throw InputError("--error-ply needs a mesh with (u, v): per-triangle bounds exist only for our schemes' meshes");
  }
  write_error_ply(o.error_ply, mesh, distance.triangle_upper);
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

// The part's watertight verdict (--require-watertight): no crack, T-junction or non-manifold edge,
// no skipped face, and a closed mesh for every closed, valid B-rep solid.
bool part_watertight(const occt::PartMesh& part, const app::PartValidation& check) {
  return check.watertight && part.faces_skipped == 0 && check.closed_solids_closed;
}

// The requirements a part mesh failed, each as one line; records them in `doc`.
nlohmann::json failed_part_requirements(const ValidateOptions& o, const occt::PartMesh& part,
                                        const app::PartValidation& check, const app::PartCertificate& cert,
                                        nlohmann::json& doc) {
  nlohmann::json failed = nlohmann::json::array();
  if (o.max_error >= 0.0) {
    doc["max_error"] = o.max_error;
    if (cert.distance.hausdorff.lower > o.max_error) {
      // A certified lower bound of some face is above E: proven, whether every face is certified or not.
      failed.push_back("max-error: the distance exceeds it (lower bound above)");
    } else if (!cert.all_certified) {
      failed.push_back("max-error: not certified (" + std::to_string(part.faces.size() - cert.faces_certified) +
                       " faces not certified)");
    } else if (!(cert.distance.hausdorff.upper <= o.max_error)) {
      failed.push_back("max-error: not certified (upper bound above)");
    }
  }
  if (o.require_watertight) {
    if (!check.watertight) failed.push_back("watertight: cracks, T-junctions or non-manifold edges found");
    if (part.faces_skipped > 0)
      failed.push_back("watertight: " + std::to_string(part.faces_skipped) + " faces skipped");
    if (!check.closed_solids_closed) failed.push_back("watertight: a closed, valid B-rep solid has an open mesh");
  }
  doc["requirements_failed"] = failed;
  return failed;
}

// Per-solid verdicts, the watertight verdict and the certificate's headline on stdout.
void print_part_validation(const occt::PartMesh& part, const app::PartValidation& check,
                           const app::PartCertificate& cert) {
  for (const SolidCheck& c : check.checks) {
    std::cout << (c.solid < 0 ? std::string("outside solids") : "solid " + std::to_string(c.solid)) << ": "
              << c.triangles << " triangles, " << (c.closed ? "closed" : "open") << "; open edges " << c.open_edges
              << " (model boundary " << c.model_boundary_edges << ", cracks " << c.crack_edges << "), non-manifold "
              << c.non_manifold_edges << ", T-junctions " << c.t_junctions << ", misoriented "
              << c.inconsistent_orientation_edges << ", components " << c.components << ", chi "
              << c.euler_characteristic;
    for (const app::SolidVolume& v : check.volumes) {
      if (v.solid != c.solid) continue;
      if (v.mesh_closed) {
        std::cout << "; volume " << v.mesh_volume << " vs OCCT " << v.occt_volume << " (relative error "
                  << v.relative_error << ")";
      } else {
        std::cout << "; volume: mesh open, OCCT " << v.occt_volume;
      }
    }
    std::cout << "\n";
  }
  std::cout << (part_watertight(part, check) ? "watertight" : "NOT watertight") << ": cracks " << check.crack_edges
            << ", T-junctions " << check.t_junctions << ", non-manifold " << check.non_manifold_edges
            << ", model boundary " << check.model_boundary_edges << ", faces skipped " << part.faces_skipped
            << ", closed solids with closed meshes "
            << std::count_if(check.volumes.begin(), check.volumes.end(),
                             [](const app::SolidVolume& v) { return v.mesh_closed; })
            << "/" << check.volumes.size() << "\n";
  std::cout << app::part_certificate_headline(part, cert) << (cert.all_certified ? "" : "; reasons in --json") << "\n";
}

// A CAD part: the whole-part mesh, its per-solid checks and the certificate where it applies.
int run_validate_part(const ValidateOptions& o) {
  const Stopwatch total;
  // Our own mesh of the part, or (--mesh) any mesh of it, found face by face on the B-rep.
  const occt::PartMesh part = o.mesh.empty()
                                  ? occt::mesh_part_file(o.input, app::part_options(scheme_spec(o.scheme), o.edge_tolerance))
                                  : occt::mesh_on_part_file(o.input, io::read_mesh(o.mesh), o.mesh);
  nlohmann::json doc = app::part_json(part);
  doc["input"] = o.input;
  if (o.mesh.empty()) {
    doc["scheme"] = o.scheme.scheme;
    doc["edge_tolerance"] = o.edge_tolerance;
  } else {
    doc["mesh"] = o.mesh;
    doc["unassigned_triangles"] = part.unassigned_triangles;
  }
  const app::PartValidation check = app::validate_part(part);
  CertifyOptions certify;
  certify.max_depth = o.max_depth;
  app::PartCertificate cert;
  {
    const ProgressTicker progress("sagitta validate:", "certifying every face of " + o.input);
    // With --max-error, the faces left once one is proven above it are skipped (the verdict is known).
    cert = app::certify_part(part, certify, o.max_error >= 0.0 ? o.max_error : std::numeric_limits<double>::infinity());
  }
  doc["validation"] = app::part_validation_json(check);
  doc["certificate"] = app::part_certificate_json(part, cert);
  doc["certified"] = cert.all_certified;
  doc["watertight"] = part_watertight(part, check);
  doc["max_depth"] = o.max_depth;
  const nlohmann::json failed = failed_part_requirements(o, part, check, cert, doc);
  if (!o.error_ply.empty()) {
    write_error_ply(o.error_ply, part.mesh, cert.triangle_upper);
    doc["error_ply"] = o.error_ply;
  }
  doc["total_seconds"] = total.seconds();
  if (!o.json.empty()) write_json(o.json, doc);
  std::cout << "part: " << part.faces_tessellated << "/" << part.faces.size() << " faces "
            << (o.mesh.empty() ? "tessellated, " : "found in the mesh, ") << part.mesh.triangles.size() << " triangles";
  if (part.unassigned_triangles > 0) std::cout << " (" << part.unassigned_triangles << " more on no single face)";
  std::cout << "\n";
  print_part_validation(part, check, cert);
  for (const auto& f : failed) std::cerr << "sagitta validate: requirement failed: " << f.get<std::string>() << "\n";
  return failed.empty() ? 0 : kExitRequirementFailed;
}

int run_validate(const ValidateOptions& o) {
  check_outputs({{"--json", o.json}, {"--error-ply", o.error_ply}}, {o.input, o.mesh});
  if (o.max_depth < 0 || o.max_depth > 10) throw InputError("--max-depth must be in 0..10");
  if (occt::is_cad_file(o.input) && occt::is_whole_part(occt::read_cad_file(o.input))) return run_validate_part(o);
  if (o.edge_tolerance != 0.0) throw InputError("--edge-tolerance applies to CAD parts only");
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
  cmd->add_option("input", o->input,
                  "Patch file (.bpt, .rib); omit or 'default' for the built-in model; or a CAD part (.step, .iges, "
                  ".brep: the whole-part mesh, checked per solid and certified on its untrimmed faces)");
  cmd->add_option("--edge-tolerance", o->edge_tolerance,
                  "CAD parts: chord tolerance of the B-rep edges (see tessellate)");
  cmd->add_option("--mesh", o->mesh, "Validate this mesh (.obj, .ply, .stl) instead of tessellating; no (u, v) needed");
  add_scheme_options(cmd, o->scheme);
  cmd->add_option("--json", o->json, "Report: hausdorff/mesh_to_surface/surface_to_mesh {lower, upper}, topology, seconds");
  cmd->add_option("--max-error", o->max_error, "Require the certified Hausdorff upper bound to be <= E (exit 3 otherwise)");
  cmd->add_flag(
      "--require-watertight", o->require_watertight,
      "Require no cracks, T-junctions or non-manifold edges (model boundary edges are allowed); on a CAD part also no "
      "skipped face and a closed mesh for every closed, valid B-rep solid (exit 3 otherwise)");
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
