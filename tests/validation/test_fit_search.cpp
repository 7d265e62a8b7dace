// Issue 8, acceptance 1: the ESC fit for a certified error of 1e-3 on the tea set uses at most 1.25x
// the triangles of the best (level, threshold) on an exhaustive grid that also meets 1e-3.
//
// Grid: every level L = 1..15 and thresholds rho in {0, E/8, E/4, E/2, E, 2E, 4E, 8E} (E = 1e-3):
// 120 settings. The search is exhaustive but ordered: all settings are tessellated (cheap) and
// visited by increasing triangle count; the first one whose certified upper bound is <= E is the
// grid's optimum, since every cheaper setting was shown to fail. Failures are shown by certified
// lower bounds > E: first from a few mesh points (branch-and-bound distance to the model), then from
// a quick certification (depth budget 2); the rest get the full certification.
//
// Registered only without sanitizers (tests/validation/CMakeLists.txt): the teapot at 1e-3 needs
// certifications of ~110,000-triangle meshes, about a minute in all in Release.
#include "sagitta/certify.hpp"
#include "sagitta/esc.hpp"
#include "sagitta/evaluate.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/io/model_io.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numeric>

namespace sagitta {
namespace {

constexpr double kTarget = 1e-3;

// True when a certified lower bound on the Hausdorff distance exceeds `target`, found cheaply: the
// distance to the whole model from the mesh points with the largest parametric deviation
// |x - S(u, v)| (triangle centroids and edge midpoints), certified from below by branch-and-bound.
bool certainly_fails(const Model& model, const Tessellation& mesh, double target) {
  static const Vec3 kBary[4] = {Vec3(1.0, 1.0, 1.0) / 3.0, Vec3(0.5, 0.5, 0.0), Vec3(0.0, 0.5, 0.5), Vec3(0.5, 0.0, 0.5)};
  const size_t n = mesh.triangles.size();
  std::vector<double> estimate(n, 0.0);
  std::vector<Vec3> worst_point(n);
  tbb::parallel_for(size_t(0), n, [&](size_t t) {
    const Triangle& tri = mesh.triangles[t];
    const auto& uv = mesh.triangle_uv[t];
    for (const Vec3& b : kBary) {
      const Vec3 x = b.x * mesh.positions[tri[0]] + b.y * mesh.positions[tri[1]] + b.z * mesh.positions[tri[2]];
      const Vec2 q = b.x * uv[0] + b.y * uv[1] + b.z * uv[2];
      const auto s = de_casteljau<double>(model.patches[mesh.triangle_patch[t]], q.x, q.y);
      const double e = glm::length(x - Vec3(s[0], s[1], s[2]));
      if (e > estimate[t]) {
        estimate[t] = e;
        worst_point[t] = x;
      }
    }
  });
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t(0));
  const size_t k = std::min<size_t>(8, n);
  std::partial_sort(order.begin(), order.begin() + k, order.end(), [&](size_t a, size_t b) { return estimate[a] > estimate[b]; });
  for (size_t i = 0; i < k; ++i) {
    const double e = estimate[order[i]];
    if (e <= target) break;
    // Ask only for what the estimate promises, so the branch-and-bound can stop early.
    if (detail::certified_distance_lower(model, worst_point[order[i]], 0.995 * e, 20000) > target) return true;
  }
  return false;
}

// A quick certification: depth budget 2 (a looser but still certified upper bound) and the
// validator's certified lower bound from 8 candidate points.
DistanceReport quick_certify(const Model& model, const Tessellation& mesh) {
  CertifyOptions options;
  options.max_depth = 2;
  options.lower_candidates = 8;
  options.lower_node_budget = 100000;
  return certify_distance(model, mesh, options);
}

struct GridPoint {
  int level;
  double rho;
  uint64_t triangles;
};

void compare_with_grid(const std::string& name) {
  const std::string path = test::shared_data(name + ".bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model model = io::read_bpt(path);
  const Topology topology = build_topology(model);

  const FitResult fit = fit_to_error(model, topology, Scheme::kEsc, kTarget);
  ASSERT_TRUE(fit.met) << name;
  ASSERT_LE(fit.certified_error, kTarget);

  std::vector<GridPoint> grid;
  for (int level = 1; level <= kMaxEscLevel; ++level) {
    for (double f : {0.0, 0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0}) {
      EscParams params;
      params.level = level;
      params.threshold = f * kTarget;
      params.normals = false;
      params.surface_data = false;
      grid.push_back({level, f * kTarget, tessellate_esc(model, topology, params).triangles.size()});
    }
  }
  std::stable_sort(grid.begin(), grid.end(), [](const GridPoint& a, const GridPoint& b) { return a.triangles < b.triangles; });
  const GridPoint* best = nullptr;
  int certified = 0, rejected = 0;
  for (const GridPoint& g : grid) {
    EscParams params;
    params.level = g.level;
    params.threshold = g.rho;
    params.normals = false;
    const Tessellation mesh = tessellate_esc(model, topology, params);
    if (certainly_fails(model, mesh, kTarget)) {
      ++rejected;
      continue;
    }
    const DistanceReport quick = quick_certify(model, mesh);
    if (quick.hausdorff.lower > kTarget) {
      ++rejected;
      continue;
    }
    ++certified;
    if ((quick.hausdorff.certified && quick.hausdorff.upper <= kTarget) ||
        certify_distance(model, mesh, fit_certify_defaults()).hausdorff.upper <= kTarget) {
      best = &g;
      break;
    }
  }
  ASSERT_NE(best, nullptr) << name << ": no grid setting meets " << kTarget;
  std::cout << name << ": fit L " << fit.level << ", rho " << fit.threshold << ", " << fit.triangles
            << " triangles (certified " << fit.certified_error << "); grid best L " << best->level << ", rho " << best->rho
            << ", " << best->triangles << " triangles (" << rejected << " settings rejected by certified lower bounds, " << certified
            << " certified)\n";
  EXPECT_LE(double(fit.triangles), 1.25 * double(best->triangles)) << name;
}

TEST(FitSearch, TeapotEscFitWithinAQuarterOfTheGridOptimum) { compare_with_grid("teapot"); }
TEST(FitSearch, TeacupEscFitWithinAQuarterOfTheGridOptimum) { compare_with_grid("teacup"); }
TEST(FitSearch, TeaspoonEscFitWithinAQuarterOfTheGridOptimum) { compare_with_grid("teaspoon"); }

}  // namespace
}  // namespace sagitta
