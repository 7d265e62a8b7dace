// The main job: tessellate a model (the built-in default when none is given), write the mesh and a
// statistics file into an output folder, and print a summary.
#include "commands.hpp"
#include "schemes.hpp"

#include "sagitta/io/mesh_io.hpp"

#include <filesystem>
#include <iostream>
#include <memory>

namespace sagitta::cli {

namespace {

struct RunOptions {
  std::string input;
  std::string out_dir = "sagitta-out";
  int level = 4;
};

void run_main_job(const RunOptions& o) {
  const Model model = load_model(o.input);
  const Topology topology = build_topology(model);
  std::filesystem::create_directories(o.out_dir);
  nlohmann::json report;
  report["input"] = o.input.empty() ? "default" : o.input;
  report["model"] = model.name;
  report["patches"] = model.patches.size();
  report["topology"] = topology_json(model, topology);
  SchemeOptions scheme;
  scheme.level = o.level;
  nlohmann::json stats;
  const Stopwatch clock;
  const Tessellation mesh = run_scheme(model, topology, scheme, stats);
  stats["seconds"] = clock.seconds();
  stats["vertices"] = mesh.positions.size();
  stats["triangles"] = mesh.triangles.size();
  stats["degenerate_triangles"] = mesh.degenerate_triangles;
  const std::string mesh_path = (std::filesystem::path(o.out_dir) / "uniform.ply").string();
  io::write_mesh(mesh, mesh_path);
  stats["output"] = mesh_path;
  report["runs"].push_back(stats);
  const std::string json_path = (std::filesystem::path(o.out_dir) / "report.json").string();
  write_json(json_path, report);
  std::cout << "sagitta run: " << model.name << ", " << model.patches.size() << " patches ("
            << topology.shared_edges() << " shared edges, " << topology.free_edges() << " free, "
            << topology.collapsed_sides() << " collapsed sides)\n"
            << "  uniform level " << o.level << ": " << mesh.triangles.size() << " triangles, "
            << mesh.positions.size() << " vertices, " << stats["seconds"].get<double>() << " s -> " << mesh_path << "\n"
            << "  report: " << json_path << "\n";
}

}  // namespace

Command register_run(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "The main job: tessellate (and, as they land, validate and report) a model");
  cmd->add_option("input", o->input, "Patch file (.bpt, .rib); omit for the built-in default model");
  cmd->add_option("--out-dir", o->out_dir, "Folder for the mesh and report")->capture_default_str();
  cmd->add_option("--level", o->level, "Uniform level")->capture_default_str();
  return {cmd, [o] { run_main_job(*o); }};
}

}  // namespace sagitta::cli
