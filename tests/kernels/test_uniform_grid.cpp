// The positions-only uniform grid (the throughput path of issue 10): every vertex equals the
// matrix-form evaluation of its patch (bit for bit in double, one rounding in float32), lies on the
// exact surface, the index pattern follows tessellate_uniform's emission order, and the output does
// not depend on the thread count.
#include "sagitta/evaluate.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/uniform.hpp"
#include "sagitta/uniform_grid.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <string>
#include <vector>

namespace sagitta {
namespace {

using detail::PatchEvaluator;

// Polynomial low degree (power basis), rational (division), high degree (Bernstein form).
std::vector<Model> grid_models() {
  Model high;
  high.name = "degree 9 x 8 and low degrees";
  high.patches.push_back(fixtures::random_patch(9, 8, 17, 1.0, Vec3(1e5, -3.0, 2.0), 0.25, 4.0));
  high.patches.push_back(fixtures::random_patch(2, 3, 5));
  // Every low v-degree the vector kernels specialise, polynomial and rational, far from the origin.
  high.patches.push_back(fixtures::random_patch(3, 1, 23));
  high.patches.push_back(fixtures::random_patch(1, 2, 29, 2.0, Vec3(-7.0, 3e3, 0.5)));
  high.patches.push_back(fixtures::random_patch(3, 3, 31, 1.0, Vec3(0.0), 0.5, 2.0));
  high.patches.push_back(fixtures::random_patch(2, 1, 37, 1.0, Vec3(4.0, 0.0, -1.0), 0.3, 3.0));
  high.patches.push_back(fixtures::random_patch(4, 2, 41, 1.0, Vec3(0.0), 0.7, 1.5));
  return {fixtures::default_model(), fixtures::rational_torus(), high};
}

// Every grid kernel this CPU runs (portable, AVX2, AVX-512), restored to the default afterwards.
std::vector<detail::GridKernel> runnable_kernels() {
  std::vector<detail::GridKernel> kernels;
  for (auto k : {detail::GridKernel::kGeneric, detail::GridKernel::kAvx2, detail::GridKernel::kAvx512}) {
    if (static_cast<int>(k) <= static_cast<int>(detail::best_grid_kernel())) kernels.push_back(k);
  }
  return kernels;
}

struct KernelReset {
  ~KernelReset() { detail::reset_grid_kernel(); }
};

TEST(UniformGrid, VerticesAreTheMatrixFormEvaluation) {
  KernelReset reset;
  for (const detail::GridKernel kernel : runnable_kernels()) {
    ASSERT_TRUE(detail::force_grid_kernel(kernel));
    SCOPED_TRACE("grid kernel " + std::to_string(static_cast<int>(kernel)));
    EXPECT_EQ(detail::grid_kernel(), kernel);
    for (const Model& model : grid_models()) {
      for (int n : {1, 3, 7, 8, 13, 16}) {
        const size_t count = uniform_grid_vertices(model, n);
        ASSERT_EQ(count, model.patches.size() * static_cast<size_t>((n + 1) * (n + 1)));
        std::vector<double> xyz(3 * count, -1.0);
        std::vector<float> xyzf(3 * count, -1.0f);
        tessellate_uniform_grid(model, n, xyz.data());
        tessellate_uniform_grid(model, n, xyzf.data());
        size_t k = 0;
        for (const BezierPatch& patch : model.patches) {
          const PatchEvaluator eval(patch);
          for (int a = 0; a <= n; ++a) {
            for (int b = 0; b <= n; ++b, ++k) {
              const double u = static_cast<double>(a) / n, v = static_cast<double>(b) / n;
              const Vec3 p = eval.position(u, v);
              const auto ref = de_casteljau<long double>(patch, u, v);
              for (int c = 0; c < 3; ++c) {
                ASSERT_EQ(xyz[3 * k + c], p[c]) << model.name << " n " << n << " vertex " << k;
                ASSERT_EQ(xyzf[3 * k + c], static_cast<float>(p[c])) << model.name;
                EXPECT_NEAR(xyz[3 * k + c], static_cast<double>(ref[static_cast<size_t>(c)]),
                            1e-9 * (1.0 + std::abs(p[c])));
              }
            }
          }
        }
        EXPECT_EQ(k, count);
      }
    }
  }
}

TEST(UniformGrid, PatternFollowsTheUniformSchemeOrder) {
  // A single patch with no collapsed side: tessellate_uniform emits 2 N^2 triangles per patch in
  // the pattern's order, so corresponding corners are the same surface points.
  Model model;
  model.patches.push_back(fixtures::random_patch(3, 3, 7));
  const int n = 6;
  UniformParams params;
  params.segments = n;
  const Tessellation t = tessellate_uniform(model, build_topology(model), params);
  const std::vector<Triangle> pattern = uniform_grid_pattern(n);
  ASSERT_EQ(pattern.size(), t.triangles.size());
  std::vector<double> xyz(3 * uniform_grid_vertices(model, n));
  tessellate_uniform_grid(model, n, xyz.data());
  for (size_t i = 0; i < pattern.size(); ++i) {
    for (int s = 0; s < 3; ++s) {
      const Vec3& p = t.positions[t.triangles[i][s]];
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(xyz[3 * pattern[i][s] + c], p[c], 1e-12) << "triangle " << i;
    }
  }
}

TEST(UniformGrid, OutputDoesNotDependOnThreadCount) {
  const Model model = replicate(fixtures::default_model(), 8);
  std::vector<float> one(3 * uniform_grid_vertices(model, 16)), many(one.size());
  {
    tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
    tessellate_uniform_grid(model, 16, one.data());
  }
  tessellate_uniform_grid(model, 16, many.data());
  EXPECT_EQ(one, many);
}

TEST(UniformGrid, PlanRepeatsTheSameOutput) {
  for (const Model& model : grid_models()) {
    const UniformGridPlan plan(model, 5);
    ASSERT_EQ(plan.vertices(), uniform_grid_vertices(model, 5));
    std::vector<double> direct(3 * plan.vertices()), first(direct.size(), 0.0), second(direct.size(), 1.0);
    tessellate_uniform_grid(model, 5, direct.data());
    plan.run(first.data());
    plan.run(second.data());
    EXPECT_EQ(first, direct) << model.name;
    EXPECT_EQ(second, direct) << model.name;
  }
  EXPECT_THROW(UniformGridPlan(fixtures::default_model(), 0), InputError);
}

TEST(UniformGrid, RejectsBadSegments) {
  const Model model = fixtures::default_model();
  std::vector<float> xyz(3);
  EXPECT_THROW(tessellate_uniform_grid(model, 0, xyz.data()), InputError);
  EXPECT_THROW(uniform_grid_pattern(-1), InputError);
}

}  // namespace
}  // namespace sagitta
