// The main job: tessellate a model (the built-in default when none is given) with every scheme,
// certify each mesh, fit ESC to a target error, and write the trade report into an output folder,
// printing where each file is. A whole CAD part gets the part mesher's uniform and esc meshes, checked
// per solid and certified where the certificate applies, the whole-part fit and its level sweep.
#include "commands.hpp"
#include "progress.hpp"
#include "report.hpp"
#include "schemes.hpp"

#include "sagitta/app/part.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/occt/cad.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

namespace sagitta::cli {

namespace {

struct RunOptions {
  std::string input;
  std::string out_dir = "sagitta-out";
  int level = 4;
  double target_error = -1.0;  // <= 0: 1e-3 of the model's box diagonal
  bool report = true;
};

// One scheme's mesh: tessellated, certified, topology-checked and written as OUT_DIR/<name>.ply.
nlohmann::json run_one_scheme(const Model& model, const Topology& topology, const SchemeSpec& scheme,
                              const std::string& out_dir, const std::string& name) {
  SchemeStats scheme_stats;
  const Stopwatch clock;
  const Tessellation mesh = tessellate(model, topology, scheme, &scheme_stats);
  const double seconds = clock.seconds();
  nlohmann::json stats = scheme_stats_json(scheme_stats);
  stats["seconds"] = seconds;
  stats["vertices"] = mesh.positions.size();
  stats["triangles"] = mesh.triangles.size();
  stats["degenerate_triangles"] = mesh.degenerate_triangles;
  const DistanceReport distance = certify_distance(model, mesh);
  stats["hausdorff"] = interval_json(distance.hausdorff);
  stats["certify_seconds"] = distance.seconds;
  const TopologyReport topo = check_mesh_topology(mesh, &model, &topology);
  stats["crack_edges"] = topo.crack_edges;
  stats["t_junctions"] = topo.t_junctions;
  stats["watertight"] = topo.watertight();
  const std::string path = (std::filesystem::path(out_dir) / (name + ".ply")).string();
  io::write_mesh(mesh, path);
  stats["output"] = path;
  std::cout << "  " << name << ": " << mesh.triangles.size() << " triangles in " << stats["seconds"].get<double>()
            << " s, certified Hausdorff [" << distance.hausdorff.lower << ", " << distance.hausdorff.upper << "], "
            << (topo.watertight() ? "no cracks or T-junctions" : "CRACKS or T-junctions") << " -> " << path << "\n"
            << std::flush;
  return stats;
}

// One scheme's part mesh: meshed, checked per solid (CGAL verdicts included), certified where the
// certificate applies, written as OUT_DIR/<name>.ply; one summary line, with a certified number only
// when every face is certified.
nlohmann::json run_one_part_scheme(const std::string& input, const SchemeSpec& scheme, const std::string& out_dir,
                                   const std::string& name, const std::string& setting) {
  const app::PartRun run = app::run_part(input, scheme, true);
  nlohmann::json stats = app::part_run_json(run);
  stats["scheme"] = name;
  stats["setting"] = setting;
  stats["degenerate_triangles"] = run.part.mesh.degenerate_triangles;
  stats["box_diagonal"] = points_box_diagonal(run.part.mesh.positions);
  const std::string path = (std::filesystem::path(out_dir) / (name + ".ply")).string();
  io::write_mesh(run.part.mesh, path);
  stats["output"] = path;
  std::cout << "  " << name << ": " << run.part.faces_tessellated << "/" << run.part.faces.size()
            << " faces tessellated, " << run.part.mesh.triangles.size() << " triangles in " << run.part.seconds
            << " s, closed solids closed " << run.closed_solid_meshes() << "/" << run.validation.volumes.size() << ", "
            << app::part_certificate_headline(run) << " -> " << path << "\n"
            << std::flush;
  return stats;
}

// `sagitta run` on a whole CAD part: uniform at --level and ESC, each checked and certified where it
// applies; the whole-part fit (fit.ply, fit.json); the report is the part's level sweep plus both
// meshes' tables.
void run_part_job(const RunOptions& o) {
  std::filesystem::create_directories(o.out_dir);
  const std::filesystem::path dir(o.out_dir);
  nlohmann::json summary;
  summary["input"] = o.input;
  summary["model"] = std::filesystem::path(o.input).filename().string();
  std::cout << "sagitta run: " << o.input << " (whole CAD part)\n[1/3] uniform and esc, checked per solid, with "
            << "the distance certificate where it applies:\n"
            << std::flush;
  SchemeSpec uniform;
  uniform.level = o.level;
  summary["runs"].push_back(
      run_one_part_scheme(o.input, uniform, o.out_dir, "uniform", "level " + std::to_string(o.level)));
  // ESC's threshold: 1e-3 of the part's box diagonal, the box of the uniform mesh's vertices (points on the part).
  const double diagonal = summary["runs"][0]["box_diagonal"].get<double>();
  SchemeSpec esc;
  esc.scheme = Scheme::kEsc;
  esc.level = 3;
  esc.threshold = 1e-3 * diagonal;
  summary["box_diagonal"] = diagonal;
  summary["runs"].push_back(
      run_one_part_scheme(o.input, esc, o.out_dir, "esc", "L 3, rho " + app::format_number(esc.threshold)));
  // The fit as `sagitta fit PART --target-error E` (docs/FITTING.md): E = --target-error, else 1e-3 of
  // the diagonal.
  const double target = o.target_error > 0.0 ? o.target_error : 1e-3 * diagonal;
  std::cout << "[2/3] fit the whole part to certified error <= " << target << " (uniform, each face its own "
            << "density):\n"
            << std::flush;
  {
    ProgressLine progress("sagitta run: fit");
    const app::PartFit fit = app::fit_part(
        [&](const occt::PartOptions& options) { return occt::mesh_part_file(o.input, options); }, target,
        CertifyOptions{},
        [&](int step, int segments) { progress.update(step, 0, std::to_string(segments) + " segments (certifying)"); });
    progress.clear();
    nlohmann::json fit_doc = app::part_fit_json(fit);
    fit_doc["input"] = o.input;
    const std::string fit_mesh = (dir / "fit.ply").string();
    if (fit.met) {
      io::write_mesh(fit.run.part.mesh, fit_mesh);
      fit_doc["output"] = fit_mesh;
    } else {
      std::error_code ignored;  // an earlier run's fit.ply must not pass for this one's
      std::filesystem::remove(fit_mesh, ignored);
    }
    const std::string fit_json = (dir / "fit.json").string();
    write_json(fit_json, fit_doc);
    summary["fit"] = app::part_fit_summary(fit);  // fit.json has every face
    std::cout << "  " << fit.run.part.mesh.triangles.size() << " triangles (segments up to " << fit.segments
              << ", edge tolerance " << app::format_number(fit.edge_tolerance) << "), ";
    if (fit.run.certificate.all_certified) {
      std::cout << "certified error <= " << fit.run.certificate.distance.hausdorff.upper;
    } else {
      std::cout << "not certified";
    }
    std::cout << (fit.met ? " (meets the target)" : " (MISSES the target: " + fit.reason + ")") << " -> "
              << (fit.met ? fit_mesh + ", " : std::string()) << fit_json << "\n"
              << std::flush;
  }
  if (o.report) {
    std::cout << "[3/3] report (the part swept over uniform levels " << kPartReportLevels.front() << "-"
              << kPartReportLevels.back() << "):\n"
              << std::flush;
    ProgressLine progress("sagitta run: report");
    nlohmann::json entry = app::part_report_entry(
        o.input, summary["model"].get<std::string>(), kPartReportLevels,
        [&](int done, int total, const std::string& what) { progress.update(done, total, what); });
    progress.clear();
    entry["meshes"] = summary["runs"];
    entry["fit"] = summary["fit"];
    nlohmann::json report = {{"tool", "sagitta run"}, {"models", {entry}}, {"occt_version", occt::occt_version()}};
    report["error"] = "certified Hausdorff upper bound between mesh and exact surface (model units)";
    report["time"] = "tessellation wall time (seconds), certification excluded";
    const std::string html = write_trade_report(report, o.out_dir);
    summary["report"] = html;
    std::cout << "  -> " << html << ", " << (dir / "report.json").string() << "\n";
  }
  const std::string summary_path = (dir / "run.json").string();
  write_json(summary_path, summary);
  std::cout << "  summary: " << summary_path << "\n";
}

void run_main_job(const RunOptions& o) {
  std::vector<NamedPath> outputs;
  for (const char* file : {"uniform.ply", "esc.ply", "pn.ply", "fit.ply", "fit.json", "report.json", "report.html",
                           "plot.log", "model_0_triangles.png", "model_0_time.png", "run.json"}) {
    outputs.push_back({file, (std::filesystem::path(o.out_dir) / file).string()});
  }
  check_outputs(outputs, {o.input});
  if (occt::is_cad_file(o.input) && occt::is_whole_part(occt::read_cad_file(o.input))) {
    run_part_job(o);
    return;
  }
  const Model model = load_model(o.input);
  const Topology topology = build_topology(model);
  std::filesystem::create_directories(o.out_dir);
  const std::filesystem::path dir(o.out_dir);
  const double diagonal = model_box(model).diagonal();
  const double target = o.target_error > 0.0 ? o.target_error : 1e-3 * diagonal;
  nlohmann::json summary;
  summary["input"] = o.input.empty() ? "default" : o.input;
  summary["model"] = model.name;
  summary["patches"] = model.patches.size();
  summary["topology"] = topology_json(model, topology);
  std::cout << "sagitta run: " << model.name << ", " << model.patches.size() << " patches (" << topology.shared_edges()
            << " shared edges, " << topology.free_edges() << " free, " << topology.collapsed_sides() << " collapsed sides)\n"
            << "[1/3] every scheme, certified:\n"
            << std::flush;

  SchemeSpec uniform;
  uniform.level = o.level;
  summary["runs"].push_back(run_one_scheme(model, topology, uniform, o.out_dir, "uniform"));
  SchemeSpec esc;
  esc.scheme = Scheme::kEsc;
  esc.level = 3;
  esc.threshold = 1e-3 * diagonal;
  summary["runs"].push_back(run_one_scheme(model, topology, esc, o.out_dir, "esc"));
  SchemeSpec pn;
  pn.scheme = Scheme::kPn;
  pn.base_level = 2;
  pn.level = 3;
  summary["runs"].push_back(run_one_scheme(model, topology, pn, o.out_dir, "pn"));

  std::cout << "[2/3] fit ESC to certified error <= " << target << ":\n" << std::flush;
  FitOptions fit_options;
  {
    ProgressLine progress("sagitta run: fit");
    fit_options.progress = [&](const FitProgress& p) { progress.update(p.step, p.steps, p.stage + " (certifying)"); };
    const FitResult fit = fit_to_error(model, topology, Scheme::kEsc, target, fit_options);
    progress.clear();
    nlohmann::json fit_doc = fit_result_json(fit);
    const std::string fit_mesh = (dir / "fit.ply").string();
    io::write_mesh(fit.mesh, fit_mesh);
    fit_doc["output"] = fit_mesh;
    const std::string fit_json = (dir / "fit.json").string();
    write_json(fit_json, fit_doc);
    summary["fit"] = fit_doc;
    std::cout << "  level " << fit.level << ", threshold " << fit.threshold << ": " << fit.triangles
              << " triangles, certified error <= " << fit.certified_error << (fit.met ? " (meets the target)" : " (MISSES the target)")
              << " -> " << fit_mesh << ", " << fit_json << "\n"
              << std::flush;
  }

  if (o.report) {
    std::cout << "[3/3] trade report (every scheme swept and certified):\n" << std::flush;
    ReportOptions report_options;
    report_options.target_error = target;
    ProgressLine progress("sagitta run: report");
    report_options.progress = [&](int done, int total, const std::string& what) { progress.update(done, total, what); };
    const nlohmann::json report = build_trade_report({{o.input.empty() ? "default" : o.input, model}}, report_options);
    progress.clear();
    const std::string html = write_trade_report(report, o.out_dir);
    summary["report"] = html;
    std::cout << "  -> " << html << ", " << (dir / "report.json").string() << "\n";
    for (const auto& [scheme, s] : report["models"][0]["schemes"].items()) {
      std::cout << "     " << scheme << ": " << s["verdict"].get<std::string>() << "\n";
    }
  }
  const std::string summary_path = (dir / "run.json").string();
  write_json(summary_path, summary);
  std::cout << "  summary: " << summary_path << "\n";
}

}  // namespace

Command register_run(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run", "The main job: every scheme tessellated and certified, an ESC fit to a target error, and the trade report");
  cmd->add_option("input", o->input,
                  "Patch file (.bpt, .rib); omit for the built-in default model; or a whole CAD part (.step, .iges, "
                  ".brep: uniform and esc part meshes checked per solid, the whole-part fit, the level sweep)");
  cmd->add_option("--out-dir", o->out_dir, "Folder for the meshes, fit and report")->capture_default_str();
  cmd->add_option("--level", o->level, "Uniform level of uniform.ply")->capture_default_str();
  cmd->add_option("--target-error", o->target_error, "Fit target (default: 1e-3 of the model's box diagonal)");
  cmd->add_flag("!--no-report", o->report, "Skip the trade report");
  return {cmd, [o] { run_main_job(*o); }};
}

}  // namespace sagitta::cli
