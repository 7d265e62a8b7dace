// `sagitta fit`: choose a scheme's parameter for a requested certified accuracy (sagitta/fit.hpp).
#include "commands.hpp"
#include "progress.hpp"

#include "sagitta/app/part.hpp"
#include "sagitta/io/mesh_io.hpp"

#include <cmath>
#include <iostream>
#include <memory>

namespace sagitta::cli {

namespace {

struct FitCliOptions {
  std::string input;
  std::string scheme = "esc";
  double target_error = 0.0;
  bool per_patch = false;
  std::string json;
  std::string out;
  int max_refinements = 12;
  bool per_edge_levels = false;
};

void run_fit(const FitCliOptions& o) {
  check_outputs({{"--json", o.json}, {"--out", o.out}}, {o.input});
  if (!(o.target_error > 0.0) || !std::isfinite(o.target_error)) {
    throw InputError("--target-error must be a positive number of model units, got " + std::to_string(o.target_error));
  }
  app::refuse_cad_part(o.input, "fit");
  const Model model = load_model(o.input);
  const Topology topology = build_topology(model);
  FitOptions options;
  options.per_patch = o.per_patch;
  options.max_refinements = o.max_refinements;
  options.esc_per_edge_levels = o.per_edge_levels;
  ProgressLine progress("sagitta fit");
  options.progress = [&](const FitProgress& p) { progress.update(p.step, p.steps, p.stage + " (certifying)"); };
  const FitResult result = fit_to_error(model, topology, parse_scheme(o.scheme), o.target_error, options);
  progress.clear();
  nlohmann::json doc = fit_result_json(result);
  doc["input"] = o.input.empty() ? "default" : o.input;
  doc["model"] = model.name;
  doc["per_patch"] = o.per_patch;
  if (result.scheme == Scheme::kEsc) doc["per_edge_levels"] = o.per_edge_levels;
  if (!o.out.empty()) {
    io::write_mesh(result.mesh, o.out);
    doc["output"] = o.out;
  }
  if (!o.json.empty()) write_json(o.json, doc);
  std::cout << "sagitta fit: " << model.name << ", " << o.scheme << (o.per_patch ? " per patch" : "") << ", target "
            << o.target_error << ": ";
  if (result.scheme == Scheme::kUniform) std::cout << "segments " << result.level;
  if (result.scheme == Scheme::kEsc) std::cout << "level " << result.level << ", threshold " << result.threshold;
  if (result.scheme == Scheme::kPn) std::cout << "base level " << result.base_level << ", level " << result.level;
  std::cout << ", " << result.triangles << " triangles, certified error <= " << result.certified_error << " ("
            << (result.met ? "meets" : "MISSES") << " the target), " << result.iterations << " verification steps, "
            << result.certifications << " certifications, " << result.seconds << " s\n";
  if (!o.json.empty()) std::cout << "  json: " << o.json << "\n";
  if (!o.out.empty()) std::cout << "  mesh: " << o.out << "\n";
  if (!result.met) throw InputError("the target " + std::to_string(o.target_error) + " was not met (best certified " +
                                    std::to_string(result.certified_error) + ")");
}

}  // namespace

Command register_fit(CLI::App& app) {
  auto o = std::make_shared<FitCliOptions>();
  CLI::App* cmd = app.add_subcommand("fit", "Choose a scheme's parameters so the certified error is at most a target");
  cmd->add_option("input", o->input, "Patch file (.bpt, .rib); omit or 'default' for the built-in model");
  cmd->add_option("--scheme", o->scheme, "esc (level and threshold), uniform (segments) or pn (uniform base level and PN level)")
      ->check(CLI::IsMember({"esc", "uniform", "pn"}))
      ->capture_default_str();
  cmd->add_option("--target-error", o->target_error, "Largest certified Hausdorff distance allowed (model units)")->required();
  cmd->add_flag("--per-patch", o->per_patch, "Choose the parameter per patch (uniform levels, esc thresholds); crack-free");
  cmd->add_option("--json", o->json, "Write the fit (parameters, certified error, models, samples) here");
  cmd->add_option("--out", o->out, "Write the fitted mesh here (.obj, .ply, .stl)");
  cmd->add_flag("--per-edge-levels", o->per_edge_levels,
                "esc: each refined coarse edge takes the smallest sufficient level (EscParams::per_edge_levels, docs/ESC.md)");
  cmd->add_option("--max-refinements", o->max_refinements, "Tessellate-certify steps after the prediction")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  return {cmd, [o] { run_fit(*o); }};
}

}  // namespace sagitta::cli
