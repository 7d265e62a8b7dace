// `sagitta report`'s writer: report.json, the plots and a self-contained report.html for a trade
// report built by the application layer (sagitta/app/report.hpp).
#pragma once

#include "sagitta/app/report.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace sagitta::cli {

using app::build_trade_report;
using app::format_number;
using app::kMaxSweepTriangles;
using app::NamedModel;
using app::ReportOptions;

// The uniform levels a whole CAD part is swept over (app::part_report_entry) by report and run.
inline const std::vector<int> kPartReportLevels = {1, 2, 3, 4};

// Writes DIR/report.json, the plots (DIR/*.png, by python3 + matplotlib running plot_report.py) and
// DIR/report.html with the plots embedded. When python3 or matplotlib is missing the page has the
// tables and a one-line notice instead of the plots. Returns the path of report.html.
std::string write_trade_report(const nlohmann::json& report, const std::string& out_dir);

}  // namespace sagitta::cli
