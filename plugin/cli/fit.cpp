// `sagitta fit`: choose a scheme's parameter for a requested certified accuracy (sagitta/fit.hpp).
#include "commands.hpp"
#include "progress.hpp"

#include "sagitta/app/part.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/occt/cad.hpp"
#include "sagitta/occt/part.hpp"

#include <glm/common.hpp>

#include <cmath>
#include <cstdio>
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
  bool relative = false;
  bool scheme_given = false;  // --scheme on the command line (whole parts default to uniform)
  bool fewest = false;        // whole parts: no tightness pass
};

// The largest distance between two vertices' bounding-box corners of a coarse mesh of the part
// (its vertices lie on the part): the diagonal `--relative` scales the target by.
double part_diagonal(const std::string& path) {
  SchemeSpec coarse;
  coarse.segments = 1;
  return points_box_diagonal(occt::mesh_part_file(path, app::part_options(coarse, 0.0)).mesh.positions);
}

// A whole CAD part: uniform segments and an edge tolerance of half the target (app::fit_part).
void run_fit_part(const FitCliOptions& o, double target) {
  if (o.scheme_given && o.scheme != "uniform") {
    throw InputError(o.input + ": a whole CAD part is fitted with --scheme uniform (segments per patch side and an "
                     "edge tolerance); " + o.scheme + " is not available for whole parts");
  }
  if (o.per_patch) throw InputError(o.input + ": --per-patch does not apply to a whole CAD part");
  CertifyOptions certify;
  ProgressLine progress("sagitta fit");
  const app::PartFit fit = app::fit_part(
      [&](const occt::PartOptions& options) { return occt::mesh_part_file(o.input, options); }, target, certify,
      [&](int step, int segments) { progress.update(step, 0, std::to_string(segments) + " segments (certifying)"); },
      !o.fewest);
  progress.clear();
  nlohmann::json doc = app::part_fit_json(fit);
  doc["input"] = o.input;
  doc["relative"] = o.relative;
  doc["tightness_pass"] = !o.fewest;
  if (o.relative) doc["target_fraction"] = o.target_error;
  if (!o.out.empty() && fit.met) {
    io::write_mesh(fit.run.part.mesh, o.out);
    doc["output"] = o.out;
  }
  if (!o.json.empty()) write_json(o.json, doc);
  std::cout << "sagitta fit: " << o.input << " (whole CAD part), uniform, target " << target << ": segments "
            << fit.segments << ", edge tolerance " << fit.edge_tolerance << ", "
            << fit.run.part.mesh.triangles.size() << " triangles, ";
  if (fit.run.certificate.all_certified) {
    std::cout << "certified error <= " << fit.run.certificate.distance.hausdorff.upper;
  } else {
    std::cout << "not certified";
  }
  std::cout << " (" << (fit.met ? "meets" : "MISSES") << " the target), " << fit.steps.size() << " steps, "
            << fit.seconds << " s\n";
  const nlohmann::json& over = doc["faces_over_ratio_limits_detail"];
  if (!over.empty()) {
    // The faces whose certified interval is wider than the fit aims for, worst first (the JSON has all).
    std::cout << "  faces over the ratio limits (upper > " << app::kFitRatioTrimmed << " x lower trimmed, > "
              << app::kFitRatioUntrimmed << " x untrimmed): " << over.size() << " of " << fit.run.part.faces.size()
              << ":";
    for (size_t k = 0; k < over.size() && k < 8; ++k) {
      const nlohmann::json& r = over[k];
      std::cout << (k ? ", " : " ") << r["face"].get<std::string>() << " (" << r["surface"].get<std::string>() << ", ";
      if (r["ratio"].is_number()) {
        char ratio[32];
        std::snprintf(ratio, sizeof ratio, "%.3g", r["ratio"].get<double>());
        std::cout << ratio << "x)";
      } else {
        std::cout << "no lower bound)";
      }
    }
    std::cout << (over.size() > 8 ? ", ..." : "") << "\n";
  }
  if (!o.json.empty()) std::cout << "  json: " << o.json << "\n";
  if (!o.out.empty() && fit.met) std::cout << "  mesh: " << o.out << "\n";
  if (!fit.met) throw InputError(o.input + ": the target " + std::to_string(target) + " was not met: " + fit.reason);
}

void run_fit(const FitCliOptions& o) {
  check_outputs({{"--json", o.json}, {"--out", o.out}}, {o.input});
  if (!(o.target_error > 0.0) || !std::isfinite(o.target_error)) {
    throw InputError("--target-error must be a positive number of model units, got " + std::to_string(o.target_error));
  }
  if (occt::is_cad_file(o.input) && occt::is_whole_part(occt::read_cad_file(o.input))) {
    run_fit_part(o, o.relative ? o.target_error * part_diagonal(o.input) : o.target_error);
    return;
  }
  if (o.fewest)
    throw InputError("--fewest applies to whole CAD parts only (a patch model's fit keeps the fewest triangles)");
  const Model model = load_model(o.input);
  const double target_error = o.relative ? o.target_error * model_box(model).diagonal() : o.target_error;
  const Topology topology = build_topology(model);
  FitOptions options;
  options.per_patch = o.per_patch;
  options.max_refinements = o.max_refinements;
  options.esc_per_edge_levels = o.per_edge_levels;
  ProgressLine progress("sagitta fit");
  options.progress = [&](const FitProgress& p) { progress.update(p.step, p.steps, p.stage + " (certifying)"); };
  const FitResult result = fit_to_error(model, topology, parse_scheme(o.scheme), target_error, options);
  progress.clear();
  nlohmann::json doc = fit_result_json(result);
  doc["input"] = o.input.empty() ? "default" : o.input;
  doc["model"] = model.name;
  doc["per_patch"] = o.per_patch;
  doc["relative"] = o.relative;
  if (result.scheme == Scheme::kEsc) doc["per_edge_levels"] = o.per_edge_levels;
  if (!o.out.empty()) {
    io::write_mesh(result.mesh, o.out);
    doc["output"] = o.out;
  }
  if (!o.json.empty()) write_json(o.json, doc);
  std::cout << "sagitta fit: " << model.name << ", " << o.scheme << (o.per_patch ? " per patch" : "") << ", target "
            << target_error << ": ";
  if (result.scheme == Scheme::kUniform) std::cout << "segments " << result.level;
  if (result.scheme == Scheme::kEsc) std::cout << "level " << result.level << ", threshold " << result.threshold;
  if (result.scheme == Scheme::kPn) std::cout << "base level " << result.base_level << ", level " << result.level;
  std::cout << ", " << result.triangles << " triangles, certified error <= " << result.certified_error << " ("
            << (result.met ? "meets" : "MISSES") << " the target), " << result.iterations << " verification steps, "
            << result.certifications << " certifications, " << result.seconds << " s\n";
  if (!o.json.empty()) std::cout << "  json: " << o.json << "\n";
  if (!o.out.empty()) std::cout << "  mesh: " << o.out << "\n";
  if (!result.met) throw InputError("the target " + std::to_string(target_error) + " was not met (best certified " +
                                    std::to_string(result.certified_error) + ")");
}

}  // namespace

Command register_fit(CLI::App& app) {
  auto o = std::make_shared<FitCliOptions>();
  CLI::App* cmd = app.add_subcommand("fit", "Choose a scheme's parameters so the certified error is at most a target");
  cmd->add_option("input", o->input,
                  "Patch file (.bpt, .rib); omit or 'default' for the built-in model; or a whole CAD part (.step, .stp, "
                  ".iges, .igs, .brep, .brp: --scheme uniform, segments and edge tolerance chosen together)");
  cmd->add_option("--scheme", o->scheme, "esc (level and threshold), uniform (segments) or pn (uniform base level and PN level)")
      ->check(CLI::IsMember({"esc", "uniform", "pn"}))
      ->capture_default_str();
  cmd->add_option("--target-error", o->target_error, "Largest certified Hausdorff distance allowed (model units)")->required();
  cmd->add_flag("--relative", o->relative, "--target-error is a fraction of the model's (or part's) bounding-box diagonal");
  cmd->add_flag("--fewest", o->fewest,
                "Whole CAD parts: keep the fewest triangles that meet the target, without the pass that refines faces "
                "whose certified interval is wider than 1.5x (trimmed) or 1.1x (untrimmed) its lower bound");
  cmd->add_flag("--per-patch", o->per_patch, "Choose the parameter per patch (uniform levels, esc thresholds); crack-free");
  cmd->add_option("--json", o->json, "Write the fit (parameters, certified error, models, samples) here");
  cmd->add_option("--out", o->out, "Write the fitted mesh here (.obj, .ply, .stl)");
  cmd->add_flag("--per-edge-levels", o->per_edge_levels,
                "esc: each refined coarse edge takes the smallest sufficient level (EscParams::per_edge_levels, docs/ESC.md)");
  cmd->add_option("--max-refinements", o->max_refinements, "Tessellate-certify steps after the prediction")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  return {cmd, [o, cmd] {
            o->scheme_given = cmd->count("--scheme") > 0;
            run_fit(*o);
          }};
}

}  // namespace sagitta::cli
