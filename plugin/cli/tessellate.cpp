#include "commands.hpp"
#include "progress.hpp"
#include "schemes.hpp"

#include "sagitta/app/part.hpp"
#include "sagitta/app/validate.hpp"
#include "sagitta/budget.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/occt/cad.hpp"

#include <algorithm>
#include <iostream>
#include <memory>

namespace sagitta::cli {

namespace {

struct TessellateOptions {
  std::string input;
  SchemeOptions scheme;
  int copies = 1;
  double edge_tolerance = 0.0;
  std::string out;
  std::string stats;
  bool certify = false;
};

// Why a patch model's mesh is not certified ("" when it is).
std::string not_certified_reason(const DistanceReport& distance) {
  if (distance.hausdorff.certified) return "";
  return distance.not_certified_reason.empty() ? distance.coverage_note : distance.not_certified_reason;
}

// The certificate's headline under the tessellation's line: the certified Hausdorff interval and
// its cost against the tessellation's, or why it is not certified.
void print_certificate(const DistanceReport& distance, double tessellation_seconds) {
  if (distance.hausdorff.certified) {
    std::cout << "certified: hausdorff in [" << distance.hausdorff.lower << ", " << distance.hausdorff.upper << "]";
  } else {
    std::cout << "not certified: hausdorff >= " << distance.hausdorff.lower << " (" << not_certified_reason(distance)
              << ")";
  }
  std::cout << " in " << distance.seconds << " s";
  if (tessellation_seconds > 0.0) std::cout << " (" << distance.seconds / tessellation_seconds << "x the tessellation)";
  std::cout << "\n";
}

// The certificate of a patch model's mesh in the --stats JSON.
nlohmann::json certificate_json(const DistanceReport& distance, double tessellation_seconds) {
  nlohmann::json j;
  j["certified"] = distance.hausdorff.certified;
  j["hausdorff"] = interval_json(distance.hausdorff);
  j["mesh_to_surface"] = interval_json(distance.mesh_to_surface);
  j["surface_to_mesh"] = interval_json(distance.surface_to_mesh);
  j["not_certified_reason"] = not_certified_reason(distance);
  j["seconds"] = distance.seconds;
  if (tessellation_seconds > 0.0) j["certificate_to_tessellation_ratio"] = distance.seconds / tessellation_seconds;
  return j;
}

// A mesh input (.obj, .ply, .stl): refined by the pn scheme, no patch model involved.
void run_tessellate_mesh(const TessellateOptions& o) {
  if (o.certify) {
    throw InputError(o.input +
                     ": --certify needs the exact surfaces (a patch model or a CAD part); a mesh input has none");
  }
  const Tessellation input = io::read_mesh(o.input);
  nlohmann::json stats;
  stats["input"] = o.input;
  stats["scheme"] = o.scheme.scheme;
  const SchemeSpec spec = scheme_spec(o.scheme);
  SchemeStats scheme_stats;
  const Stopwatch clock;
  const Tessellation mesh = tessellate_mesh(input, spec, &scheme_stats);
  stats["seconds"] = clock.seconds();
  stats.update(scheme_stats_json(scheme_stats));
  stats["vertices"] = mesh.positions.size();
  stats["triangles"] = mesh.triangles.size();
  stats["degenerate_triangles"] = mesh.degenerate_triangles;
  if (!o.out.empty()) {
    io::write_mesh(mesh, o.out);
    stats["output"] = o.out;
  }
  if (!o.stats.empty()) write_json(o.stats, stats);
  std::cout << "pn: " << input.triangles.size() << " input triangles -> " << mesh.triangles.size() << " triangles, "
            << mesh.positions.size() << " vertices, " << stats["open_edges"].get<size_t>() << " open edges ("
            << stats["crack_edges"].get<size_t>() << " on " << stats["crease_edges"].get<size_t>()
            << " crease edges, widest gap " << stats["max_crack_gap"].get<double>() << ") in " << stats["seconds"].get<double>()
            << " s\n";
}

// A CAD part (.step, .iges, .brep): every face through the whole-part mesher into one mesh; the
// stats are app::part_json's plus the per-solid closedness (topology only, no CGAL).
void run_tessellate_part(const TessellateOptions& o) {
  if (o.copies != 1) throw InputError(o.input + ": --copies applies to patch models, not to CAD parts");
  const occt::PartMesh part = occt::mesh_part_file(o.input, app::part_options(scheme_spec(o.scheme), o.edge_tolerance));
  SolidCheckOptions check_options;
  check_options.cgal = false;
  const app::PartValidation check = app::validate_part(part, check_options);
  nlohmann::json stats = app::part_json(part);
  stats["input"] = o.input;
  stats["scheme"] = o.scheme.scheme;
  stats["edge_tolerance"] = o.edge_tolerance;
  stats["degenerate_triangles"] = part.mesh.degenerate_triangles;
  stats["watertight"] = check.watertight;
  stats["crack_edges"] = check.crack_edges;
  stats["t_junctions"] = check.t_junctions;
  stats["non_manifold_edges"] = check.non_manifold_edges;
  size_t closed = 0;
  for (const app::SolidVolume& s : check.volumes) closed += s.mesh_closed ? 1 : 0;
  stats["closed_solids"] = check.volumes.size();
  stats["closed_solid_meshes"] = closed;
  app::PartCertificate cert;
  if (o.certify) {
    const ProgressTicker progress("sagitta tessellate:", "certifying every face of " + o.input);
    cert = app::certify_part(part, CertifyOptions{});
    stats["certificate"] = app::part_certificate_json(part, cert);
    stats["certified"] = cert.all_certified;
  }
  if (!o.out.empty()) {
    io::write_mesh(part.mesh, o.out);
    stats["output"] = o.out;
  }
  if (!o.stats.empty()) write_json(o.stats, stats);
  std::cout << o.scheme.scheme << ": " << part.faces_tessellated << "/" << part.faces.size() << " faces tessellated, "
            << part.faces_skipped << " skipped, " << part.mesh.triangles.size() << " triangles, "
            << part.mesh.positions.size() << " vertices, closed solids closed " << closed << "/" << check.volumes.size()
            << ", cracks " << check.crack_edges << ", in " << part.seconds << " s\n";
  if (!o.certify) return;
  std::cout << app::part_certificate_headline(part, cert) << (cert.all_certified ? "" : "; reasons in --stats")
            << " in " << cert.seconds << " s\n";
}

void run_tessellate(const TessellateOptions& o) {
  check_outputs({{"--out", o.out}, {"--stats", o.stats}}, {o.input});
  if (io::is_mesh_file(o.input)) {
    run_tessellate_mesh(o);
    return;
  }
  if (occt::is_cad_file(o.input) && occt::is_whole_part(occt::read_cad_file(o.input))) {
    run_tessellate_part(o);
    return;
  }
  if (o.edge_tolerance != 0.0) throw InputError("--edge-tolerance applies to CAD parts only");
  nlohmann::json cad;
  Model model = load_model(o.input, &cad);
  // Refuse before replicating a model that cannot fit: the mesh, the copies and their topology.
  int degree = 1;
  for (const BezierPatch& p : model.patches) degree = std::max({degree, p.degree_u, p.degree_v});
  const size_t patches = model.patches.size() * static_cast<size_t>(o.copies);
  SchemeSpec spec = scheme_spec(o.scheme);
  check_triangle_estimate(estimated_triangles(model, spec) * o.copies, spec,
                          o.copies > 1 ? model_bytes(patches, degree, degree, true) + topology_bytes(patches, degree)
                                       : topology_bytes(patches, degree));
  model = replicate(model, o.copies);
  const Topology topology = build_topology(model);
  nlohmann::json stats;
  if (!cad.is_null()) stats.update(cad);
  stats["input"] = o.input.empty() ? "default" : o.input;
  stats["copies"] = o.copies;
  stats["patches"] = model.patches.size();
  // The certificate needs each triangle's patch and (u, v); they are left out otherwise.
  spec.surface_data = o.certify;
  SchemeStats scheme_stats;
  const Stopwatch clock;
  const Tessellation mesh = tessellate(model, topology, spec, &scheme_stats);
  const double seconds = clock.seconds();
  stats["seconds"] = seconds;
  DistanceReport distance;
  if (o.certify) {
    budget::check_memory(app::validation_bytes(double(mesh.triangles.size())),
                         "certifying " + std::to_string(mesh.triangles.size()) + " triangles",
                         "lower --level or raise --max-memory");
    // Our schemes' meshes carry (patch, u, v); one that does not would be certified against a
    // reference tessellation, as `sagitta validate --mesh` does.
    const ProgressTicker progress("sagitta tessellate:",
                                  "certifying " + std::to_string(mesh.triangles.size()) + " triangles");
    distance = mesh.has_surface() ? certify_distance(model, mesh) : certify_external(model, mesh);
    stats["certificate"] = certificate_json(distance, seconds);
    stats["certificate"]["method"] = mesh.has_surface() ? "bernstein" : "reference";
  }
  stats.update(scheme_stats_json(scheme_stats));
  stats["vertices"] = mesh.positions.size();
  stats["triangles"] = mesh.triangles.size();
  stats["degenerate_triangles"] = mesh.degenerate_triangles;
  stats["topology"] = topology_json(model, topology);
  if (!o.out.empty()) {
    io::write_mesh(mesh, o.out);
    stats["output"] = o.out;
  }
  if (!o.stats.empty()) write_json(o.stats, stats);
  std::cout << stats["scheme"].get<std::string>() << ": " << model.patches.size() << " patches -> "
            << mesh.triangles.size() << " triangles (" << mesh.degenerate_triangles << " degenerate not emitted), "
            << mesh.positions.size() << " vertices in " << stats["seconds"].get<double>() << " s\n";
  if (o.certify) print_certificate(distance, seconds);
  if (!cad.is_null()) {
    std::cout << "faces: " << cad["faces"] << " (" << cad["faces_tessellated"] << " tessellated, " << cad["faces_trimmed"]
              << " trimmed, " << cad["faces_skipped"] << " skipped; listed in --stats)\n";
  }
}

}  // namespace

Command register_tessellate(CLI::App& app) {
  auto o = std::make_shared<TessellateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "tessellate", "Tessellate a patch model (.bpt, .rib) or a whole CAD part and write the mesh and statistics");
  cmd->add_option("input", o->input,
                  "Patch file (.bpt, .rib); omit or 'default' for the built-in model; a CAD part (.step, .stp, .iges, "
                  ".igs, .brep, .brp: every face, one mesh watertight across faces); or a mesh (.obj, .ply, .stl) for "
                  "--scheme pn");
  add_scheme_options(cmd, o->scheme);
  cmd->add_option("--copies", o->copies, "Place K translated instances of the model (the papers' scenes)")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd->add_option("--edge-tolerance", o->edge_tolerance,
                  "CAD parts: split every B-rep edge until each chord is within this distance of the curve (0: the "
                  "scheme's density only)");
  cmd->add_option("--out", o->out, "Mesh output: .obj, .ply (binary) or .stl (binary); written atomically");
  cmd->add_option("--stats", o->stats, "Statistics JSON: scheme, patches, vertices, triangles, degenerate_triangles, seconds");
  cmd->add_flag("--certify", o->certify,
                "Also certify the mesh: the Hausdorff interval to the exact surfaces (every face of a CAD part) on the "
                "console and under 'certificate' in --stats; the checks of 'sagitta validate' are not run");
  return {cmd, [o] { run_tessellate(*o); }};
}

}  // namespace sagitta::cli
