// The uniform scheme: the seed's Table 1 counts, crack-free closed output with no welding,
// positions against long-double de Casteljau, and determinism under parallelism.
#include "sagitta/evaluate.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/uniform.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <set>

namespace sagitta {
namespace {

uint64_t total_triangles(const Tessellation& t) { return t.triangles.size() + t.degenerate_triangles; }

// Seed 001, Table 1: triangles (in K = 1024, two decimals) for scenes of 5..20 teacups (26 patches)
// or teapots (32 patches) at paper levels 1..5.
TEST(Uniform, ReproducesSeedTable1) {
  const std::string cup_path = test::shared_data("teacup.bpt"), pot_path = test::shared_data("teapot.bpt");
  SAGITTA_REQUIRE_DATA(cup_path);
  SAGITTA_REQUIRE_DATA(pot_path);
  struct Row {
    const char* scene;
    int copies;
    bool pots;
    double k[5];
  };
  const Row table[] = {
      {"S5cups", 5, false, {2.29, 12.44, 57.13, 244.00, 1007.75}},
      {"S5pots", 5, true, {2.81, 15.31, 70.31, 300.31, 1240.31}},
      {"S10cups", 10, false, {4.57, 24.88, 114.26, 488.01, 2015.51}},
      {"S10pots", 10, true, {5.63, 30.63, 140.63, 600.63, 2480.63}},
      {"S15cups", 15, false, {6.86, 37.32, 171.39, 732.01, 3023.26}},
      {"S15pots", 15, true, {8.44, 45.94, 210.94, 900.94, 3720.94}},
      {"S20cups", 20, false, {9.14, 49.77, 228.52, 976.02, 4031.02}},
      {"S20pots", 20, true, {11.25, 61.25, 281.25, 1201.25, 4961.25}},
  };
  const Model cup = io::read_bpt(cup_path), pot = io::read_bpt(pot_path);
  for (int level = 1; level <= 5; ++level) {
    UniformParams params;
    params.segments = detail::segments_for_paper_level(level);
    params.normals = params.surface_data = false;
    // One instance is tessellated for real; the scene is `copies` disjoint instances, which the
    // S5cups row checks by tessellating the replicated scene itself.
    const uint64_t per_cup = total_triangles(tessellate_uniform(cup, build_topology(cup), params));
    const uint64_t per_pot = total_triangles(tessellate_uniform(pot, build_topology(pot), params));
    for (const Row& row : table) {
      const uint64_t count = (row.pots ? per_pot : per_cup) * static_cast<uint64_t>(row.copies);
      const double k = std::round(count / 1024.0 * 100.0) / 100.0;
      EXPECT_DOUBLE_EQ(k, row.k[level - 1]) << row.scene << " level " << level << ": " << count << " triangles";
    }
    const Model scene = replicate(cup, 5);
    EXPECT_EQ(total_triangles(tessellate_uniform(scene, build_topology(scene), params)), 5 * per_cup);
  }
}

TEST(Uniform, TeapotLevel3CountsAndOpenEdgesOnlyOnFreeBoundary) {
  const std::string path = test::shared_data("teapot.bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model model = io::read_bpt(path);
  const Topology topo = build_topology(model);
  UniformParams params;
  params.segments = segments_for_level(3);
  const Tessellation t = tessellate_uniform(model, topo, params);
  EXPECT_EQ(total_triangles(t), 4096u);
  EXPECT_EQ(t.degenerate_triangles, 8u * 8u);  // 8 collapsed sides, one degenerate triangle per cell along each
  const test::MeshCounts c = test::count_topology(t);
  EXPECT_EQ(c.open_edges, topo.free_edges() * 8);
  EXPECT_EQ(c.nonmanifold_edges, 0u);
  EXPECT_EQ(c.misoriented_edges, 0u);
  // Every open edge joins two vertices on one free-boundary side.
  std::set<std::pair<uint32_t, int>> free_sides;
  for (const auto& e : topo.edges) {
    if (e.uses.size() == 1) free_sides.insert({e.uses[0].patch, static_cast<int>(e.uses[0].side)});
  }
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t k = 0; k < t.triangles.size(); ++k) {
    for (int s = 0; s < 3; ++s) {
      const uint32_t a = t.triangles[k][s], b = t.triangles[k][(s + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  }
  auto on_free_side = [&](uint32_t vertex, uint32_t patch) {
    // The vertex's parameters in `patch` are those of its triangles there; check against each side.
    for (size_t k = 0; k < t.triangles.size(); ++k) {
      if (t.triangle_patch[k] != patch) continue;
      for (int s = 0; s < 3; ++s) {
        if (t.triangles[k][s] != vertex) continue;
        const Vec2 uv = t.triangle_uv[k][s];
        if (uv.x == 0.0 && free_sides.count({patch, 0})) return true;
        if (uv.x == 1.0 && free_sides.count({patch, 1})) return true;
        if (uv.y == 0.0 && free_sides.count({patch, 2})) return true;
        if (uv.y == 1.0 && free_sides.count({patch, 3})) return true;
      }
    }
    return false;
  };
  size_t checked = 0;
  for (size_t k = 0; k < t.triangles.size(); ++k) {
    for (int s = 0; s < 3; ++s) {
      const uint32_t a = t.triangles[k][s], b = t.triangles[k][(s + 1) % 3];
      if (uses[{std::min(a, b), std::max(a, b)}] != 1) continue;
      EXPECT_TRUE(on_free_side(a, t.triangle_patch[k]) && on_free_side(b, t.triangle_patch[k]));
      ++checked;
    }
  }
  EXPECT_EQ(checked, c.open_edges);
}

class ClosedModel : public ::testing::TestWithParam<int> {};

TEST_P(ClosedModel, PillowBoxAndTorusAreClosedManifoldsWithoutWelding) {
  const int level = GetParam();
  UniformParams params;
  params.segments = segments_for_level(level);
  struct Case {
    Model model;
    long euler;
  };
  for (const Case& c : {Case{fixtures::pillow_box(), 2}, Case{fixtures::rational_torus(), 0}}) {
    const Tessellation t = tessellate_uniform(c.model, build_topology(c.model), params);
    const test::MeshCounts m = test::count_topology(t);
    EXPECT_EQ(m.open_edges, 0u) << c.model.name << " level " << level;
    EXPECT_EQ(m.nonmanifold_edges, 0u);
    EXPECT_EQ(m.misoriented_edges, 0u);
    EXPECT_EQ(m.euler(), c.euler) << c.model.name;
    EXPECT_EQ(m.used_vertices, t.positions.size());  // no duplicate or orphan vertices
    EXPECT_EQ(t.degenerate_triangles, 0u);
    // Outward orientation: positive signed volume.
    double volume = 0.0;
    for (const Triangle& tri : t.triangles) {
      volume += glm::dot(t.positions[tri[0]], glm::cross(t.positions[tri[1]], t.positions[tri[2]])) / 6.0;
    }
    EXPECT_GT(volume, 0.0) << c.model.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Levels0To6, ClosedModel, ::testing::Range(0, 7));

TEST(Uniform, VerticesLieOnTheExactSurface) {
  for (int d = 1; d <= 9; d += 2) {
    Model model;
    model.patches.push_back(fixtures::random_patch(d, 10 - d, 31 * d, 1.0, Vec3(1e6, 0.0, -1e6), 0.25, 4.0));
    UniformParams params;
    params.segments = 7;
    const Tessellation t = tessellate_uniform(model, build_topology(model), params);
    ASSERT_EQ(t.positions.size(), 64u);
    for (size_t k = 0; k < t.positions.size(); ++k) {
      const SurfacePoint& sp = t.surface_points[k];
      const auto ref = de_casteljau<long double>(model.patches[sp.patch], sp.u, sp.v);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(t.positions[k][c], static_cast<double>(ref[static_cast<size_t>(c)]), 1e-9) << "degree " << d;
      }
      EXPECT_NEAR(glm::length(t.normals[k]), 1.0, 1e-12);
    }
  }
}

TEST(Uniform, TriangleUvMatchesVertexPositions) {
  const Model model = fixtures::default_model();
  UniformParams params;
  params.segments = 5;
  const Tessellation t = tessellate_uniform(model, build_topology(model), params);
  ASSERT_EQ(t.triangle_uv.size(), t.triangles.size());
  for (size_t k = 0; k < t.triangles.size(); k += 7) {
    for (int s = 0; s < 3; ++s) {
      const Vec2 uv = t.triangle_uv[k][s];
      const auto ref = de_casteljau<long double>(model.patches[t.triangle_patch[k]], uv.x, uv.y);
      const Vec3& p = t.positions[t.triangles[k][s]];
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], static_cast<double>(ref[static_cast<size_t>(c)]), 1e-12);
    }
  }
}

TEST(Uniform, OutputDoesNotDependOnThreadCount) {
  const Model model = replicate(fixtures::default_model(), 4);
  const Topology topo = build_topology(model);
  UniformParams params;
  params.segments = 9;
  Tessellation one;
  {
    tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
    one = tessellate_uniform(model, topo, params);
  }
  const Tessellation many = tessellate_uniform(model, topo, params);
  EXPECT_EQ(one.positions, many.positions);
  EXPECT_EQ(one.triangles, many.triangles);
  EXPECT_EQ(one.normals, many.normals);
}

TEST(Uniform, LevelsNestAndLimitsAreExplained) {
  EXPECT_EQ(segments_for_level(0), 1);
  EXPECT_EQ(segments_for_level(6), 64);
  EXPECT_EQ(detail::segments_for_paper_level(3), 15);
  try {
    segments_for_level(13);
    FAIL() << "level 13 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("outside 0..12"), std::string::npos) << e.what();
  }
  // Level L's vertices are a subset of level L+1's (nesting): compare positions at shared parameters.
  const Model model = fixtures::pillow_box();
  const Topology topo = build_topology(model);
  UniformParams coarse, fine;
  coarse.segments = 4;
  fine.segments = 8;
  const Tessellation a = tessellate_uniform(model, topo, coarse), b = tessellate_uniform(model, topo, fine);
  std::set<std::tuple<uint32_t, double, double>> fine_params;
  std::map<std::tuple<uint32_t, double, double>, Vec3> fine_pos;
  for (size_t k = 0; k < b.positions.size(); ++k) {
    fine_pos[{b.surface_points[k].patch, b.surface_points[k].u, b.surface_points[k].v}] = b.positions[k];
  }
  size_t matched = 0;
  for (size_t k = 0; k < a.positions.size(); ++k) {
    auto it = fine_pos.find({a.surface_points[k].patch, a.surface_points[k].u, a.surface_points[k].v});
    ASSERT_NE(it, fine_pos.end());
    EXPECT_EQ(it->second, a.positions[k]);
    ++matched;
  }
  EXPECT_EQ(matched, a.positions.size());
}

// An anisotropic grid (segments along u, segments_v along v) on the closed rational torus, whose
// patches share u sides with u sides and v sides with v sides: closed, no welding, every vertex on
// the exact surface at its grid parameters, 2 nu nv triangles per patch.
TEST(Uniform, AnisotropicGridIsClosedAndOnTheSurface) {
  const Model model = fixtures::rational_torus();
  for (const auto& [nu, nv] : {std::pair{5, 2}, std::pair{1, 7}, std::pair{3, 3}}) {
    UniformParams params;
    params.segments = nu;
    params.segments_v = nv;
    const Tessellation t = tessellate_uniform(model, build_topology(model), params);
    EXPECT_EQ(t.triangles.size(), 2u * nu * nv * model.patches.size()) << nu << "x" << nv;
    EXPECT_EQ(uniform_triangle_count(model, nu, nv), t.triangles.size());
    const test::MeshCounts m = test::count_topology(t);
    EXPECT_EQ(m.open_edges, 0u) << nu << "x" << nv;
    EXPECT_EQ(m.nonmanifold_edges, 0u);
    EXPECT_EQ(m.misoriented_edges, 0u);
    EXPECT_EQ(m.euler(), 0);
    EXPECT_EQ(m.used_vertices, t.positions.size());
    for (size_t k = 0; k < t.triangles.size(); ++k) {
      for (int s = 0; s < 3; ++s) {
        const Vec2 uv = t.triangle_uv[k][s];
        // On the patch's own nu x nv grid.
        EXPECT_NEAR(uv.x * nu, std::round(uv.x * nu), 1e-12);
        EXPECT_NEAR(uv.y * nv, std::round(uv.y * nv), 1e-12);
        const auto ref = de_casteljau<long double>(model.patches[t.triangle_patch[k]], uv.x, uv.y);
        const Vec3& p = t.positions[t.triangles[k][s]];
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(p[c], static_cast<double>(ref[static_cast<size_t>(c)]), 1e-12);
      }
    }
  }
}

// A side shared by one patch's u side and another's v side cannot take two counts: refused.
TEST(Uniform, AnisotropicGridRefusesSidesSharedAcrossDirections) {
  BezierPatch a;
  a.degree_u = a.degree_v = 1;
  a.points = {Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(1, 0, 0), Vec3(1, 1, 0)};  // (i, j): u along x
  BezierPatch b;
  b.degree_u = b.degree_v = 1;
  // b's side V0 (j = 0, u runs along it) is a's side U1 (x = 1).
  b.points = {Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(1, 1, 0), Vec3(2, 1, 0)};
  Model model;
  model.patches = {a, b};
  const Topology topology = build_topology(model);
  UniformParams params;
  params.segments = 4;
  params.segments_v = 2;
  EXPECT_THROW(tessellate_uniform(model, topology, params), InputError);
  params.segments_v = 4;  // the same count both ways: fine
  const Tessellation t = tessellate_uniform(model, topology, params);
  EXPECT_EQ(t.triangles.size(), 64u);
  EXPECT_EQ(test::count_topology(t).open_edges, 24u);  // 6 free sides of 4 segments
  params.segments_v = -1;
  EXPECT_THROW(tessellate_uniform(model, topology, params), InputError);
}

TEST(Uniform, RejectsBadSegments) {
  const Model model = fixtures::pillow_box();
  UniformParams params;
  params.segments = 0;
  EXPECT_THROW(tessellate_uniform(model, build_topology(model), params), InputError);
}

}  // namespace
}  // namespace sagitta
