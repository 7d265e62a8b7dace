// Per-patch parameters in the kernels: uniform levels and ESC thresholds that differ between
// neighbours must stay crack-free and T-junction-free (checked by the validator's mesh check), tile
// every patch's parameter square, share boundary vertices by index, and the certified per-patch
// error must bound the error measured by dense sampling.
#include "sagitta/certify.hpp"
#include "sagitta/esc.hpp"
#include "sagitta/evaluate.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/uniform.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <tuple>

namespace sagitta {
namespace {

Model named_model(const std::string& name) {
  if (name == "pillow_box") return fixtures::pillow_box();
  if (name == "rational_torus") return fixtures::rational_torus();
  return io::read_bpt(test::shared_data(name + ".bpt"));
}

// Surface point by long-double de Casteljau (the reference evaluation).
Vec3 evaluate(const BezierPatch& patch, double u, double v) {
  const auto x = de_casteljau<long double>(patch, u, v);
  return Vec3(static_cast<double>(x[0]), static_cast<double>(x[1]), static_cast<double>(x[2]));
}

double cross2(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// Every triangle positively oriented in (u, v) and, per patch, the areas sum to 1 (patches without
// collapsed sides; with collapsed sides only the dropped degenerate triangles may be missing).
void expect_parameter_tiling(const Tessellation& mesh, const Model& model, const Topology& topology) {
  std::vector<double> area(model.patches.size(), 0.0);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& uv = mesh.triangle_uv[t];
    const double a = 0.5 * cross2(uv[0], uv[1], uv[2]);
    ASSERT_GT(a, 0.0) << "triangle " << t << " of patch " << mesh.triangle_patch[t];
    area[mesh.triangle_patch[t]] += a;
  }
  for (size_t p = 0; p < area.size(); ++p) {
    bool collapsed = false;
    for (Side s : kAllSides) collapsed = collapsed || topology.side(static_cast<uint32_t>(p), s).collapsed;
    if (collapsed) {
      EXPECT_LE(area[p], 1.0 + 1e-12) << "patch " << p;
    } else {
      EXPECT_NEAR(area[p], 1.0, 1e-12) << "patch " << p;
    }
  }
}

// No two vertices share a bit-identical position (neighbours index one vertex instead of welding),
// and every vertex lies on the surface at its recorded (patch, u, v).
void expect_shared_vertices(const Tessellation& mesh, const Model& model, const Topology& topology) {
  std::map<std::tuple<double, double, double>, uint32_t> seen;
  std::vector<bool> used(mesh.positions.size(), false);
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t id : t) used[id] = true;
  }
  const double tolerance = 1e-12 * model_box(model).diagonal();
  for (uint32_t id = 0; id < mesh.positions.size(); ++id) {
    if (!used[id]) continue;
    const Vec3& x = mesh.positions[id];
    const auto key = std::make_tuple(x.x, x.y, x.z);
    const auto [it, fresh] = seen.emplace(key, id);
    // Collapsed sides are one corner class, so even they produce a single vertex. Only patch corners
    // may coincide without being shared (the teapot has corners where unmatched sides meet).
    const SurfacePoint& sp = mesh.surface_points[id];
    const SurfacePoint& other = mesh.surface_points[it->second];
    auto is_corner = [](const SurfacePoint& s) { return (s.u == 0.0 || s.u == 1.0) && (s.v == 0.0 || s.v == 1.0); };
    EXPECT_TRUE(fresh || (is_corner(sp) && is_corner(other))) << "vertices " << it->second << " and " << id << " coincide";
    EXPECT_LE(glm::length(evaluate(model.patches[sp.patch], sp.u, sp.v) - x), tolerance) << "vertex " << id;
  }
  (void)topology;
}

// Distance from x to the patch (an upper estimate of the true distance that converges to it): the
// best point of a 10 x 10 parameter grid, refined by clamped Gauss-Newton steps.
double distance_to_patch(const BezierPatch& patch, const Vec3& x) {
  double best = std::numeric_limits<double>::infinity();
  Vec2 q(0.0);
  for (int i = 0; i <= 10; ++i) {
    for (int j = 0; j <= 10; ++j) {
      const double d = glm::length(evaluate(patch, i / 10.0, j / 10.0) - x);
      if (d < best) {
        best = d;
        q = Vec2(i / 10.0, j / 10.0);
      }
    }
  }
  for (int step = 0; step < 20; ++step) {
    const SurfacePointEval e = evaluate_with_derivatives(patch, q.x, q.y);
    const Vec3 r = e.position - x;
    const double a = glm::dot(e.du, e.du), b = glm::dot(e.du, e.dv), c = glm::dot(e.dv, e.dv);
    const double g0 = glm::dot(e.du, r), g1 = glm::dot(e.dv, r);
    const double det = a * c - b * b;
    if (!(std::abs(det) > 1e-300)) break;
    q = glm::clamp(q - Vec2((c * g0 - b * g1) / det, (a * g1 - b * g0) / det), Vec2(0.0), Vec2(1.0));
    best = std::min(best, glm::length(evaluate(patch, q.x, q.y) - x));
  }
  return best;
}

// Per patch, the largest distance from a sample of its triangles (edge midpoints, centroid) to the
// whole surface, patches pruned by their control boxes.
std::vector<double> sampled_patch_distance(const Model& model, const Tessellation& mesh) {
  std::vector<Box> boxes;
  for (const BezierPatch& patch : model.patches) boxes.push_back(control_box(patch));
  std::vector<double> error(model.patches.size(), 0.0);
  const double weights[4][3] = {{.5, .5, 0}, {0, .5, .5}, {.5, 0, .5}, {1. / 3, 1. / 3, 1. / 3}};
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Triangle& tri = mesh.triangles[t];
    for (const auto& w : weights) {
      const Vec3 x = w[0] * mesh.positions[tri[0]] + w[1] * mesh.positions[tri[1]] + w[2] * mesh.positions[tri[2]];
      double best = distance_to_patch(model.patches[mesh.triangle_patch[t]], x);
      for (size_t p = 0; p < model.patches.size(); ++p) {
        const Vec3 gap = glm::max(glm::max(boxes[p].lo - x, x - boxes[p].hi), Vec3(0.0));
        if (glm::length(gap) < best) best = std::min(best, distance_to_patch(model.patches[p], x));
      }
      error[mesh.triangle_patch[t]] = std::max(error[mesh.triangle_patch[t]], best);
    }
  }
  return error;
}

struct Case {
  std::string model;
  int max_level;
};

class PerPatch : public ::testing::TestWithParam<Case> {};

TEST_P(PerPatch, RandomUniformLevelsAreCrackFree) {
  const Case c = GetParam();
  if (c.model == "teapot") SAGITTA_REQUIRE_DATA(test::shared_data("teapot.bpt"));
  const Model model = named_model(c.model);
  const Topology topology = build_topology(model);
  std::mt19937 rng(20261122);
  std::uniform_int_distribution<int> level(0, c.max_level);
  for (int round = 0; round < 3; ++round) {
    UniformParams params;
    for (size_t p = 0; p < model.patches.size(); ++p) params.patch_levels.push_back(level(rng));
    const Tessellation mesh = tessellate_uniform(model, topology, params);
    const TopologyReport report = check_mesh_topology(mesh, &model, &topology);
    EXPECT_EQ(report.crack_edges, 0u) << c.model << " round " << round;
    EXPECT_EQ(report.t_junctions, 0u) << c.model << " round " << round;
    EXPECT_EQ(report.non_manifold_edges, 0u);
    EXPECT_EQ(report.inconsistent_orientation_edges, 0u);
    // (The teapot has zero-area triangles at corners that coincide without being shared, at any level.)
    if (c.model != "teapot") {
      EXPECT_EQ(report.degenerate_triangles, 0u);
    }
    expect_parameter_tiling(mesh, model, topology);
    expect_shared_vertices(mesh, model, topology);
    // Closed fixtures stay closed: no open edge at all, Euler characteristic of the surface.
    if (c.model != "teapot") {
      const test::MeshCounts counts = test::count_topology(mesh);
      EXPECT_EQ(counts.open_edges, 0u);
      EXPECT_EQ(counts.euler(), c.model == "pillow_box" ? 2 : 0);
    }
  }
}

TEST_P(PerPatch, EqualLevelsReproduceTheGlobalGrid) {
  const Case c = GetParam();
  if (c.model == "teapot") SAGITTA_REQUIRE_DATA(test::shared_data("teapot.bpt"));
  const Model model = named_model(c.model);
  const Topology topology = build_topology(model);
  UniformParams global;
  global.segments = 4;
  UniformParams per_patch;
  per_patch.patch_levels.assign(model.patches.size(), 2);
  const Tessellation a = tessellate_uniform(model, topology, global);
  const Tessellation b = tessellate_uniform(model, topology, per_patch);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.triangle_patch, b.triangle_patch);
  EXPECT_EQ(a.degenerate_triangles, b.degenerate_triangles);
}

TEST_P(PerPatch, CertifiedPatchErrorBoundsTheSampledError) {
  const Case c = GetParam();
  if (c.model == "teapot") SAGITTA_REQUIRE_DATA(test::shared_data("teapot.bpt"));
  const Model model = named_model(c.model);
  const Topology topology = build_topology(model);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> level(0, 2);
  UniformParams params;
  for (size_t p = 0; p < model.patches.size(); ++p) params.patch_levels.push_back(level(rng));
  const Tessellation mesh = tessellate_uniform(model, topology, params);
  const DistanceReport report = certify_distance(model, mesh);
  ASSERT_TRUE(report.coverage_ok) << report.coverage_note;
  std::vector<double> certified(model.patches.size(), 0.0);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    certified[mesh.triangle_patch[t]] = std::max(certified[mesh.triangle_patch[t]], report.triangle_upper[t]);
  }
  // The certified bound is a Hausdorff-type bound (distance to the nearest surface point), so the
  // reference is the distance of mesh samples to the surface found by projection.
  const std::vector<double> sampled = sampled_patch_distance(model, mesh);
  const double diagonal = model_box(model).diagonal();
  for (size_t p = 0; p < model.patches.size(); ++p) {
    EXPECT_GT(sampled[p], 0.0);
    EXPECT_LE(sampled[p], certified[p] + 1e-12 * diagonal) << "patch " << p << " level " << params.patch_levels[p];
  }
}

TEST_P(PerPatch, RandomEscThresholdsAreCrackFree) {
  const Case c = GetParam();
  if (c.model == "teapot") SAGITTA_REQUIRE_DATA(test::shared_data("teapot.bpt"));
  const Model model = named_model(c.model);
  const Topology topology = build_topology(model);
  const double diagonal = model_box(model).diagonal();
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> exponent(-5.0, -1.0);
  for (int round = 0; round < 3; ++round) {
    EscParams params;
    params.level = 4;
    params.per_edge_levels = round == 2;
    for (size_t p = 0; p < model.patches.size(); ++p) {
      params.patch_thresholds.push_back(p % 5 == 0 ? 0.0 : diagonal * std::pow(10.0, exponent(rng)));
    }
    const Tessellation mesh = tessellate_esc(model, topology, params);
    const TopologyReport report = check_mesh_topology(mesh, &model, &topology);
    EXPECT_EQ(report.crack_edges, 0u) << c.model << " round " << round;
    EXPECT_EQ(report.t_junctions, 0u) << c.model << " round " << round;
    EXPECT_EQ(report.non_manifold_edges, 0u);
    expect_parameter_tiling(mesh, model, topology);
    expect_shared_vertices(mesh, model, topology);
  }
}

TEST_P(PerPatch, EqualEscThresholdsReproduceTheGlobalThreshold) {
  const Case c = GetParam();
  if (c.model == "teapot") SAGITTA_REQUIRE_DATA(test::shared_data("teapot.bpt"));
  const Model model = named_model(c.model);
  const Topology topology = build_topology(model);
  EscParams global;
  global.level = 4;
  global.threshold = 1e-3 * model_box(model).diagonal();
  EscParams per_patch = global;
  per_patch.threshold = 1.0;  // ignored once per-patch thresholds are given
  per_patch.patch_thresholds.assign(model.patches.size(), global.threshold);
  const Tessellation a = tessellate_esc(model, topology, global);
  const Tessellation b = tessellate_esc(model, topology, per_patch);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.positions, b.positions);
}

// A patch's refinement never drops below what its own threshold alone gives: raising a neighbour's
// threshold can only keep or remove vertices on the neighbour's own interior.
TEST(PerPatchEsc, SharedSidesUseTheSmallerThreshold) {
  const Model model = fixtures::pillow_box();
  const Topology topology = build_topology(model);
  const double diagonal = model_box(model).diagonal();
  EscParams fine;
  fine.level = 6;
  fine.threshold = 1e-4 * diagonal;
  EscParams mixed = fine;
  mixed.patch_thresholds.assign(model.patches.size(), 0.3 * diagonal);
  mixed.patch_thresholds[0] = fine.threshold;
  const Tessellation a = tessellate_esc(model, topology, fine);
  const Tessellation b = tessellate_esc(model, topology, mixed);
  // Patch 0's triangles are the same in both: its sides are decided with its own (smaller) threshold.
  auto patch_triangles = [](const Tessellation& mesh, uint32_t p) {
    std::vector<std::array<Vec3, 3>> out;
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (mesh.triangle_patch[t] != p) continue;
      const Triangle& tri = mesh.triangles[t];
      out.push_back({mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]});
    }
    return out;
  };
  EXPECT_EQ(patch_triangles(a, 0), patch_triangles(b, 0));
  EXPECT_LT(b.triangles.size(), a.triangles.size());
}

TEST(PerPatchParams, RejectWrongSizesAndLevels) {
  const Model model = fixtures::pillow_box();
  const Topology topology = build_topology(model);
  UniformParams uniform;
  uniform.patch_levels = {1, 2};
  EXPECT_THROW(tessellate_uniform(model, topology, uniform), InputError);
  uniform.patch_levels.assign(model.patches.size(), kMaxUniformLevel + 1);
  EXPECT_THROW(tessellate_uniform(model, topology, uniform), InputError);
  EscParams esc;
  esc.patch_thresholds = {0.1};
  EXPECT_THROW(tessellate_esc(model, topology, esc), InputError);
  esc.patch_thresholds.assign(model.patches.size(), -1.0);
  EXPECT_THROW(tessellate_esc(model, topology, esc), InputError);
  esc.patch_thresholds.assign(model.patches.size(), std::nan(""));
  EXPECT_THROW(tessellate_esc(model, topology, esc), InputError);
}

INSTANTIATE_TEST_SUITE_P(Models, PerPatch,
                         ::testing::Values(Case{"teapot", 3}, Case{"pillow_box", 4}, Case{"rational_torus", 4}),
                         [](const ::testing::TestParamInfo<Case>& info) { return info.param.model; });

}  // namespace
}  // namespace sagitta
