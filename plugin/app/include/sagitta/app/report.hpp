// Speed/accuracy trade reports (`sagitta report`, and the main job `sagitta run`): every scheme swept
// over its parameter on each model, each mesh certified, error against triangles and time, Pareto
// front, fitted models, a verdict per scheme. The front end writes it out (report.json, report.html).
#pragma once

#include "sagitta/model.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace sagitta::app {

inline constexpr uint64_t kMaxSweepTriangles = 300'000;  // settings above this are left out of the sweep

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

// x with `digits` significant digits, as the report's labels and tables show numbers.
std::string format_number(double x, int digits = 3);

}  // namespace sagitta::app
