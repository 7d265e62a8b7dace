// JSON for fit results, shared by `sagitta fit`, `sagitta report` and `sagitta run`.
#pragma once

#include "sagitta/fit.hpp"

#include <nlohmann/json.hpp>

namespace sagitta::cli {

nlohmann::json fitted_model_json(const FittedModel& model);

// The fit's outcome: target_error, the chosen parameters, certified_error (upper bound), triangles,
// iterations, every measurement and the fitted models.
nlohmann::json fit_result_json(const FitResult& result);

}  // namespace sagitta::cli
