// Fitting a scheme's parameter to a certified target (validation/include/sagitta/fit.hpp): the Ceres
// models recover known parameters, every fit's mesh is re-certified independently, uniform fits are
// compared with a brute-force scan of segment counts, bad arguments are refused.
#include "sagitta/certify.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/uniform.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace sagitta {
namespace {

TEST(FitModels, PowerLawRecoversKnownParametersDespiteAnOutlier) {
  std::vector<double> x, e;
  for (int n = 2; n <= 64; n *= 2) {
    x.push_back(1.0 / n);
    e.push_back(0.7 * std::pow(1.0 / n, 2.0));
  }
  e[2] *= 3.0;  // one bad measurement; the Huber loss must keep it from dragging the fit
  const FittedModel m = fit_power_law(x, e);
  EXPECT_NEAR(m.parameters[0], 0.7, 0.07);
  EXPECT_NEAR(m.parameters[1], 2.0, 0.05);
  ASSERT_EQ(m.residuals.size(), x.size());
  EXPECT_GT(std::abs(m.residuals[2]), 0.9);  // the outlier keeps its residual (log 3 = 1.1)
}

TEST(FitModels, FloorPlusPowerRecoversKnownParameters) {
  std::vector<double> x, e;
  for (double k : {1.0, 2.0, 3.0, 4.0, 6.0, 8.0}) {
    x.push_back(1.0 / k);
    e.push_back(0.01 + 0.5 * std::pow(1.0 / k, 3.0));
  }
  const FittedModel m = fit_floor_plus_power(x, e);
  EXPECT_NEAR(m.parameters[0], 0.01, 1e-3);
  EXPECT_NEAR(m.parameters[1], 0.5, 0.05);
  EXPECT_NEAR(m.parameters[2], 3.0, 0.1);
  for (double r : m.residuals) EXPECT_LT(std::abs(r), 0.02);
}

TEST(FitModels, InversionFindsTheSmallestSufficientParameter) {
  FittedModel m;
  m.name = "power_law";
  m.parameters = {2.0, 2.0};
  const double x = invert_model(m, 1e-4, 1e-6, 1.0);
  EXPECT_NEAR(2.0 * x * x, 1e-4, 1e-9);  // closed form: x = sqrt(E / C)
  EXPECT_EQ(invert_model(m, 10.0, 1e-6, 1.0), 1.0);   // the largest x is enough
  EXPECT_EQ(invert_model(m, 1e-20, 1e-6, 1.0), 1e-6);  // even the smallest is not
}

TEST(FitModels, RefusesTooFewOrBadPoints) {
  EXPECT_THROW(fit_power_law({0.5}, {1.0}), InputError);
  EXPECT_THROW(fit_power_law({0.5, 0.25}, {1.0, -1.0}), InputError);
  EXPECT_THROW(fit_floor_plus_power({0.5, 0.25}, {1.0, 0.5}), InputError);
}

TEST(FitToError, RefusesBadArguments) {
  const Model model = fixtures::default_model();
  const Topology topology = build_topology(model);
  EXPECT_THROW(fit_to_error(model, topology, Scheme::kEsc, 0.0), InputError);
  EXPECT_THROW(fit_to_error(model, topology, Scheme::kEsc, -1e-3), InputError);
  EXPECT_THROW(fit_to_error(model, topology, Scheme::kEsc, std::nan("")), InputError);
  FitOptions per_patch;
  per_patch.per_patch = true;
  EXPECT_THROW(fit_to_error(model, topology, Scheme::kPn, 0.05, per_patch), InputError);
  EXPECT_THROW(parse_scheme("bogus"), InputError);
}

TEST(FitToError, UnreachableTargetEndsUnmetWithinTheTriangleLimit) {
  const Model model = fixtures::default_model();
  const Topology topology = build_topology(model);
  FitOptions options;
  options.max_triangles = 20000;
  for (Scheme scheme : {Scheme::kUniform, Scheme::kEsc}) {
    const FitResult r = fit_to_error(model, topology, scheme, 1e-9, options);
    EXPECT_FALSE(r.met) << scheme_name(r.scheme);
    EXPECT_GT(r.certified_error, 1e-9);
    for (const FitSample& s : r.samples) EXPECT_LE(s.triangles, options.max_triangles);
  }
  options.per_patch = true;
  const FitResult r = fit_to_error(model, topology, Scheme::kUniform, 1e-9, options);
  EXPECT_FALSE(r.met);
  for (const FitSample& s : r.samples) EXPECT_LE(s.triangles, options.max_triangles);
}

// The returned mesh, certified again with the validator's default (more thorough) options, must meet
// the target; its triangle count must match the result.
void expect_certified(const Model& model, const FitResult& r) {
  ASSERT_TRUE(r.met) << scheme_name(r.scheme);
  EXPECT_LE(r.certified_error, r.target_error);
  EXPECT_EQ(r.mesh.triangles.size(), r.triangles);
  const DistanceReport check = certify_distance(model, r.mesh);
  ASSERT_TRUE(check.hausdorff.certified);
  EXPECT_LE(check.hausdorff.upper, r.target_error) << scheme_name(r.scheme);
  EXPECT_GE(r.iterations, 1);
  EXPECT_FALSE(r.models.empty());
}

TEST(FitToError, EverySchemeMeetsItsTargetOnTheDefaultModel) {
  const Model model = fixtures::default_model();
  const Topology topology = build_topology(model);
  const double target = 2e-3 * model_box(model).diagonal();
  for (Scheme scheme : {Scheme::kUniform, Scheme::kEsc}) {
    expect_certified(model, fit_to_error(model, topology, scheme, target));
  }
  // PN converges to the PN surface of its base mesh: a looser target it can reach at a low base level.
  expect_certified(model, fit_to_error(model, topology, Scheme::kPn, 2e-2 * model_box(model).diagonal()));
}

// Brute force: the smallest segment count whose certified error meets the target, scanning every N.
TEST(FitToError, UniformFitIsWithinAQuarterOfTheBruteForceOptimum) {
  const Model model = fixtures::default_model();
  const Topology topology = build_topology(model);
  const double target = 2e-3 * model_box(model).diagonal();
  const FitResult fit = fit_to_error(model, topology, Scheme::kUniform, target);
  ASSERT_TRUE(fit.met);
  int best = 0;
  for (int n = 1; n <= fit.level && best == 0; ++n) {
    UniformParams params;
    params.segments = n;
    const Tessellation mesh = tessellate_uniform(model, topology, params);
    if (certify_distance(model, mesh, fit_certify_defaults()).hausdorff.upper <= target) best = n;
  }
  ASSERT_GT(best, 0);
  EXPECT_LE(double(fit.triangles), 1.25 * double(uniform_triangle_count(model, best)))
      << "fit N = " << fit.level << ", brute force N = " << best;
}

TEST(FitToError, PerPatchUniformLevelsMeetTheTargetWithoutCracks) {
  const Model model = fixtures::default_model();
  const Topology topology = build_topology(model);
  const double target = 2e-3 * model_box(model).diagonal();
  FitOptions options;
  options.per_patch = true;
  const FitResult r = fit_to_error(model, topology, Scheme::kUniform, target, options);
  expect_certified(model, r);
  ASSERT_EQ(r.patches.size(), model.patches.size());
  for (const PatchChoice& p : r.patches) EXPECT_LE(p.certified_error, target) << "patch " << p.patch;
  const TopologyReport topo = check_mesh_topology(r.mesh, &model, &topology);
  EXPECT_TRUE(topo.watertight()) << topo.crack_edges << " crack edges, " << topo.t_junctions << " T-junctions";
}

}  // namespace
}  // namespace sagitta
