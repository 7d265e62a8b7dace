// `sagitta peer occt`: OCCT's BRepMesh_IncrementalMesh on the same input, measured by our validator,
// so triangles, time and certified error compare with our schemes in one command (docs/CAD.md).
#include "commands.hpp"
#include "progress.hpp"

#include "sagitta/app/json.hpp"
#include "sagitta/app/part.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/occt/cad.hpp"

#include <iostream>
#include <memory>

namespace sagitta::cli {

namespace {

struct PeerCliOptions {
  std::string input;
  double deflection = 1e-3;
  double angle = 0.5;
  bool relative = false;
  int max_depth = 8;
  std::string out;
  std::string json;
};

nlohmann::json peer_interval_json(const DistanceInterval& d) {
  return {{"lower", d.lower}, {"upper", app::number_or_null(d.upper)}, {"upper_certified", d.certified}};
}

// Checks the outputs and --max-depth (InputError) and returns the options for OCCT's mesher and our validator.
occt::PeerOptions peer_options(const PeerCliOptions& o) {
  check_outputs({{"--out", o.out}, {"--json", o.json}}, {o.input});
  if (o.max_depth < 0 || o.max_depth > 10) throw InputError("--max-depth must be in 0..10");
  occt::PeerOptions options;
  options.deflection = o.deflection;
  options.angle = o.angle;
  options.relative = o.relative;
  options.certify.max_depth = o.max_depth;
  return options;
}

// The input's patch model and OCCT's mesh of it, already certified against the model by the OCCT adapter.
struct PeerMesh {
  Model model;
  occt::PeerResult result;
};

// Loads the patch file and meshes it with OCCT; `doc` receives the input's name.
PeerMesh mesh_with_occt(const PeerCliOptions& o, const occt::PeerOptions& options, nlohmann::json& doc) {
  doc["input"] = o.input.empty() ? "default" : o.input;
  PeerMesh peer;
  peer.model = load_model(o.input);
  peer.model.name = o.input.empty() ? "default" : o.input;
  peer.result = occt::peer_mesh_model(peer.model, options);
  return peer;
}

// OCCT's mesh checked against the model's patch topology (cracks, T-junctions, ...).
TopologyReport check_peer_topology(const PeerMesh& peer) {
  const Topology topology = build_topology(peer.model);
  return check_mesh_topology(peer.result.mesh, &peer.model, &topology);
}

// Adds the mesher, the mesh's counts, its certified distances and its topology to the report `doc`.
void add_peer_json(nlohmann::json& doc, const PeerCliOptions& o, const PeerMesh& peer, const TopologyReport& topo) {
  const occt::PeerResult& r = peer.result;
  doc["mesher"] = "BRepMesh_IncrementalMesh (OCCT " + occt::occt_version() + ")";
  doc["deflection"] = o.deflection;
  doc["angle"] = o.angle;
  doc["relative"] = o.relative;
  doc["patches"] = peer.model.patches.size();
  doc["triangles"] = r.triangles;
  doc["triangles_validated"] = r.triangles_validated;
  doc["vertices"] = r.mesh.positions.size();
  doc["faces_meshed"] = r.faces_meshed;
  doc["faces_without_mesh"] = r.faces_without_mesh;
  doc["mesh_seconds"] = r.mesh_seconds;
  doc["route"] = r.route;
  if (r.route == "bernstein") doc["max_node_offset"] = r.max_node_offset;
  doc["hausdorff"] = peer_interval_json(r.distance.hausdorff);
  doc["mesh_to_surface"] = peer_interval_json(r.distance.mesh_to_surface);
  doc["surface_to_mesh"] = peer_interval_json(r.distance.surface_to_mesh);
  doc["certified"] = r.distance.hausdorff.certified;
  doc["coverage_ok"] = r.distance.coverage_ok;
  if (!r.distance.coverage_note.empty()) doc["coverage_note"] = r.distance.coverage_note;
  if (!r.distance.not_certified_reason.empty()) doc["not_certified_reason"] = r.distance.not_certified_reason;
  doc["validate_seconds"] = r.validate_seconds;
  doc["topology"] = {{"open_edges", topo.open_edges},     {"model_boundary_edges", topo.model_boundary_edges},
                     {"crack_edges", topo.crack_edges},   {"t_junctions", topo.t_junctions},
                     {"non_manifold_edges", topo.non_manifold_edges},
                     {"inconsistent_orientation_edges", topo.inconsistent_orientation_edges},
                     {"degenerate_triangles", topo.degenerate_triangles}};
}

// The one-line summary on stdout.
void print_peer_summary(const PeerCliOptions& o, const occt::PeerResult& r, const TopologyReport& topo) {
  std::cout << "occt: deflection " << o.deflection << ", angle " << o.angle << ": " << r.triangles << " triangles in "
            << r.mesh_seconds << " s; hausdorff in [" << r.distance.hausdorff.lower << ", " << r.distance.hausdorff.upper << "]"
            << (r.distance.hausdorff.certified ? "" : " (upper not certified)") << " (" << r.route << " route"
            << "); cracks " << topo.crack_edges << ", T-junctions " << topo.t_junctions << "\n";
}

// A CAD file: BRepMesh's mesh of the whole part, in PartMesh form, certified face by face exactly as
// our own part meshes are (app::certify_part), with the part's solid checks (docs/CAD.md, "The peer
// on whole parts").
void run_peer_occt_part(const PeerCliOptions& o, const occt::PeerOptions& options) {
  const Stopwatch total;
  occt::BRepMeshOptions mesher;
  mesher.deflection = o.deflection;
  mesher.angle = o.angle;
  mesher.relative = o.relative;
  app::PartRun run;
  run.part = occt::brepmesh_part_file(o.input, mesher);
  {
    const ProgressTicker progress("sagitta peer occt:", "certifying " + std::to_string(run.part.mesh.triangles.size()) +
                                                            " triangles of " + std::to_string(run.part.faces.size()) + " faces");
    run.validation = app::validate_part(run.part);
    run.certificate = app::certify_part(run.part, options.certify);
  }
  nlohmann::json doc;
  doc["input"] = o.input;
  doc["mesher"] = "BRepMesh_IncrementalMesh (OCCT " + occt::occt_version() + ")";
  doc["deflection"] = o.deflection;
  doc["angle"] = o.angle;
  doc["relative"] = o.relative;
  doc["mesh_seconds"] = run.part.seconds;
  doc["validate_seconds"] = run.certificate.seconds;
  doc["route"] = "part";
  doc.update(app::part_run_json(run));
  const app::PartCertificate& c = run.certificate;
  doc["hausdorff"] = peer_interval_json(c.distance.hausdorff);
  doc["mesh_to_surface"] = peer_interval_json(c.distance.mesh_to_surface);
  doc["surface_to_mesh"] = peer_interval_json(c.distance.surface_to_mesh);
  if (!o.out.empty()) {
    io::write_mesh(run.part.mesh, o.out);
    doc["output"] = o.out;
  }
  doc["total_seconds"] = total.seconds();
  if (!o.json.empty()) write_json(o.json, doc);
  std::cout << "occt: deflection " << o.deflection << ", angle " << o.angle << ": " << run.part.mesh.triangles.size()
            << " triangles in " << run.part.seconds << " s; " << app::part_certificate_headline(run)
            << (c.all_certified ? "" : ", certified lower bound " + std::to_string(c.distance.hausdorff.lower))
            << " (certified in " << c.seconds << " s); cracks " << run.validation.crack_edges << ", T-junctions "
            << run.validation.t_junctions << "\n";
}

// Checks the options, meshes and certifies, checks the topology, then writes --out, --json and the summary.
void run_peer_occt(const PeerCliOptions& o) {
  const occt::PeerOptions options = peer_options(o);
  if (occt::is_cad_file(o.input)) return run_peer_occt_part(o, options);
  const Stopwatch total;
  nlohmann::json doc;
  const PeerMesh peer = mesh_with_occt(o, options, doc);
  const TopologyReport topo = check_peer_topology(peer);
  add_peer_json(doc, o, peer, topo);
  if (!o.out.empty()) {
    io::write_mesh(peer.result.mesh, o.out);
    doc["output"] = o.out;
  }
  doc["total_seconds"] = total.seconds();
  if (!o.json.empty()) write_json(o.json, doc);
  print_peer_summary(o, peer.result, topo);
}

}  // namespace

Command register_peer(CLI::App& app) {
  auto o = std::make_shared<PeerCliOptions>();
  CLI::App* peer = app.add_subcommand("peer", "Mesh the input with another tessellator and certify its distance to the exact surface");
  peer->require_subcommand(1);
  CLI::App* cmd = peer->add_subcommand(
      "occt", "OCCT's BRepMesh_IncrementalMesh: patches become Geom_BezierSurface faces (sewn); CAD files are meshed as they are");
  cmd->add_option("input", o->input, "Patch file (.bpt, .rib) or CAD file (.step, .stp, .iges, .igs, .brep, .brp)")->required();
  cmd->add_option("--deflection", o->deflection, "BRepMesh linear deflection (model units)")->capture_default_str();
  cmd->add_option("--angle", o->angle, "BRepMesh angular deflection (radians)")->capture_default_str();
  cmd->add_flag("--relative", o->relative, "Deflection relative to each edge's size");
  cmd->add_option("--max-depth", o->max_depth, "Validator subdivision budget per triangle (0..10)")->capture_default_str();
  cmd->add_option("--out", o->out, "OCCT's mesh (the validated faces): .obj, .ply or .stl, written atomically");
  cmd->add_option("--json", o->json, "Report: triangles, mesh_seconds, route, hausdorff {lower, upper}, topology, CAD face counts");
  return {peer, [o, cmd] {
            if (cmd->parsed()) run_peer_occt(*o);
          }};
}

}  // namespace sagitta::cli
