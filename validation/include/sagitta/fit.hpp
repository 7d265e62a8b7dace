// Fitting a scheme's parameter to a requested accuracy (a target for the certified Hausdorff error).
//
// A scheme's parameter (uniform segments, ESC threshold and level, PN segments per edge) is not an
// error. fit_to_error measures the certified error at a few parameter values, fits a smooth model
// of error against the parameter with Ceres (robust loss), inverts it for the target, tessellates,
// certifies, and refines until the certified upper bound is <= the target. See docs/FITTING.md.
#pragma once

#include "sagitta/certify.hpp"
#include "sagitta/model.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace sagitta {

// One measured point: a parameter setting, its triangle count and its certified error.
struct FitSample {
  int level = 0;           // uniform: segments per side; esc: pattern level L; pn: segments per edge K
  double threshold = 0.0;  // esc: rho; unused otherwise
  int base_level = -1;     // pn: level of the uniform base mesh (2^base_level segments)
  uint64_t triangles = 0;
  double certified_error = 0.0;  // certified Hausdorff upper bound
  double lower_bound = 0.0;      // certified Hausdorff lower bound
  double seconds = 0.0;          // tessellation + certification
};

// A fitted error model, e.g. "power_law": error = C * h^p.
struct FittedModel {
  std::string name;      // "power_law" | "floor_plus_power"
  std::string formula;   // human-readable, with the variable named
  std::string variable;  // "h = 1/segments", "rho", "1/K"
  int level = -1;        // esc: the pattern level this fit belongs to; pn: the base level
  std::vector<std::string> parameter_names;
  std::vector<double> parameters;
  std::vector<double> residuals;  // log(measured) - log(predicted), per sample used
  double cost = 0.0;              // Ceres' final cost (robust loss applied)
  // The model's prediction at a parameter value x (h, rho or 1/K); esc_floor_plus_power also takes
  // the level (default: `level`).
  double predict(double x, int at_level = -1) const;
};

struct FitProgress {
  std::string stage;  // "measure", "refine", ...
  int step = 0;
  int steps = 0;      // an estimate; 0 when unknown
};

// Certification settings for fitting: fewer lower-bound candidates and a smaller branch-and-bound
// budget than the default (the fit only uses the upper bound, which does not depend on them).
inline CertifyOptions fit_certify_defaults() {
  CertifyOptions o;
  o.lower_candidates = 4;
  o.lower_node_budget = 20000;
  return o;
}

struct FitOptions {
  bool per_patch = false;   // choose a parameter per patch (crack-free); see docs/FITTING.md
  int max_refinements = 12; // tessellate-certify steps after the first prediction
  // Stop tightening once the passing parameter is within this factor of a failing one (triangles).
  double tighten_ratio = 1.08;
  // Settings whose (estimated) triangle count exceeds this are not tried: an unreachable target
  // ends with met == false instead of exhausting memory.
  uint64_t max_triangles = 5'000'000;
  bool esc_per_edge_levels = false;  // ESC: EscParams::per_edge_levels
  std::vector<int> esc_levels;       // ESC levels to consider; empty: chosen from the target
  int pn_max_base_level = 5;         // PN: base meshes 2^b segments, b = 0..pn_max_base_level
  CertifyOptions certify = fit_certify_defaults();
  std::function<void(const FitProgress&)> progress;  // optional, called before each certification
};

// Per-patch result of a --per-patch fit.
struct PatchChoice {
  uint32_t patch = 0;
  int level = 0;           // as in FitSample
  double threshold = 0.0;  // esc
  double certified_error = 0.0;  // max certified per-triangle bound over the patch's triangles
};

struct FitResult {
  Scheme scheme = Scheme::kUniform;
  double target_error = 0.0;
  bool met = false;           // certified_error <= target_error
  int level = 0;              // the chosen parameter (see FitSample::level)
  double threshold = 0.0;     // esc
  int base_level = -1;        // pn
  double certified_error = 0.0;  // certified Hausdorff upper bound of `mesh`
  double lower_bound = 0.0;
  uint64_t triangles = 0;
  int iterations = 0;         // tessellate-certify steps after the model's prediction
  int certifications = 0;     // all certify_distance calls, measurements included
  double seconds = 0.0;
  std::vector<FitSample> samples;  // every measurement, in the order taken
  std::vector<FittedModel> models; // the fitted models (one per ESC level / PN base level)
  std::vector<PatchChoice> patches; // per-patch fits only
  Tessellation mesh;          // the final tessellation (with surface data)
};

// Guarantees: when result.met, result.mesh's certified Hausdorff upper bound (certify_distance with
// options.certify) is result.certified_error <= target_error. When the target cannot be met within
// the scheme's range or max_refinements, met == false and the best attempt is returned. Throws
// InputError for a target that is not positive and finite.
FitResult fit_to_error(const Model& model, const Topology& topology, Scheme scheme, double target_error,
                       const FitOptions& options = {});

// Fits error = C * x^p to (x, error) pairs with Ceres (Huber loss on log residuals). Needs two or
// more points with x > 0 and error > 0. Exposed for the report and tests.
FittedModel fit_power_law(const std::vector<double>& x, const std::vector<double>& error);

// Fits error = floor + C * x^p (floor >= 0, C >= 0, p > 0) likewise. Needs three or more points.
FittedModel fit_floor_plus_power(const std::vector<double>& x, const std::vector<double>& error);

// Smallest x > 0 with model.predict(x) <= target, searching x in [x_min, x_max] (the prediction is
// increasing in x); returns x_min when even x_min predicts too much and x_max when x_max is enough.
double invert_model(const FittedModel& model, double target, double x_min, double x_max);

}  // namespace sagitta
