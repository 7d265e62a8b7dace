// Speed/accuracy trade reports (`sagitta report`, and the main job `sagitta run`): every scheme swept
// over its parameter on each model, each mesh certified, error against triangles and time, Pareto
// front, fitted models, a verdict per scheme; report.json and a self-contained report.html.
#pragma once

#include "sagitta/model.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <string>
#include <vector>

namespace sagitta::cli {

struct ReportOptions {
  bool occt = true;            // include OCCT BRepMesh deflections (the peer)
  double target_error = -1.0;  // > 0: also show how many triangles each scheme's fit needs for it
  // Called before each certified measurement: (done, total, what).
  std::function<void(int, int, const std::string&)> progress;
};

struct NamedModel {
  std::string name;  // shown in the report (the file name, or "default")
  Model model;
};

// Sweeps, certifies and summarises; the JSON written to report.json.
nlohmann::json build_trade_report(const std::vector<NamedModel>& models, const ReportOptions& options);

// Writes DIR/report.json, the plots (DIR/*.png, by python3 + matplotlib running plot_report.py) and
// DIR/report.html with the plots embedded. When python3 or matplotlib is missing the page has the
// tables and a one-line notice instead of the plots. Returns the path of report.html.
std::string write_trade_report(const nlohmann::json& report, const std::string& out_dir);

}  // namespace sagitta::cli
