// The JSON of every report field, so the CLI's files and the Python module's dicts read alike.
#pragma once

#include "sagitta/certify.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/model.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/solid_check.hpp"

#include <nlohmann/json.hpp>

namespace sagitta::app {

// A point as [x, y, z].
nlohmann::json vec_json(const Vec3& v);
// Infinity is not JSON: an uncertified upper bound is written as null.
nlohmann::json number_or_null(double x);
// A distance interval: lower, upper, width, ratio, which ends are certified, the witness.
nlohmann::json interval_json(const DistanceInterval& interval);
// A mesh topology verdict with its findings.
nlohmann::json topology_report_json(const TopologyReport& report);
// Per-solid verdicts of a whole-part mesh, one object per solid, keys named like SolidCheck's
// fields; signed_volume is null unless closed, cgal_volume unless CGAL found it closed.
nlohmann::json solid_checks_json(const std::vector<SolidCheck>& checks);
// Topology summary of a patch model for stats files.
nlohmann::json topology_json(const Model& model, const Topology& topology);

// The stats fields of a scheme run: the scheme's name, the parameters it used and its counts.
nlohmann::json scheme_stats_json(const SchemeStats& stats);

nlohmann::json fitted_model_json(const FittedModel& model);
// The fit's outcome: target_error, the chosen parameters, certified_error (upper bound), triangles,
// iterations, every measurement and the fitted models.
nlohmann::json fit_result_json(const FitResult& result);

}  // namespace sagitta::app
