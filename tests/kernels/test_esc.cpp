// The ESC adaptive scheme: the seed's non-adaptive count, strips equal to the indexed triangles,
// monotone counts, crack-free closed output with no welding, valid parameter-domain tilings,
// positions against long-double de Casteljau.
#include "sagitta/esc.hpp"
#include "sagitta/evaluate.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/uniform.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <cstdio>
#include <cstdlib>
#include <set>

namespace sagitta {
namespace {

Tessellation run(const Model& model, int level, double rho, EscStats* stats = nullptr, bool per_edge = false) {
  EscParams params;
  params.level = level;
  params.threshold = rho;
  params.per_edge_levels = per_edge;
  return tessellate_esc(model, build_topology(model), params, stats);
}

// Thresholds from 0 to beyond the model's size, geometric in between.
std::vector<double> sweep(const Model& model, double step = 3.0) {
  const double d = model_box(model).diagonal();
  std::vector<double> rhos = {0.0};
  for (double f = 1e-5; f < 2.0; f *= step) rhos.push_back(f * d);
  rhos.push_back(2.0 * d);
  return rhos;
}

// Triangles of the strips by the usual rule (triangle i is (s_i, s_i+1, s_i+2), the first two
// swapped for odd i; triangles with a repeated index are skipped), as rotation-normalised triples.
std::multiset<std::array<uint32_t, 3>> normalise(const std::vector<Triangle>& tris) {
  std::multiset<std::array<uint32_t, 3>> out;
  for (const Triangle& t : tris) {
    const int k = static_cast<int>(std::min_element(t.begin(), t.end()) - t.begin());
    out.insert({t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)], t[static_cast<size_t>((k + 2) % 3)]});
  }
  return out;
}
std::vector<Triangle> expand_strips(const Tessellation& mesh) {
  std::vector<Triangle> out;
  for (const auto& s : mesh.strips) {
    for (size_t i = 0; i + 2 < s.size(); ++i) {
      Triangle t = (i % 2 == 0) ? Triangle{s[i], s[i + 1], s[i + 2]} : Triangle{s[i + 1], s[i], s[i + 2]};
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
      out.push_back(t);
    }
  }
  return out;
}

double cross2(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// Per patch, the triangles' (u, v) corners must tile the unit square: every triangle positively
// oriented, areas summing to 1, and no corner of the patch's triangles strictly inside another
// triangle's edge (no T-junction in the parameter domain). Returns the number of failures.
size_t check_parameter_tiling(const Tessellation& mesh, size_t patches) {
  std::vector<double> area(patches, 0.0);
  std::vector<std::vector<size_t>> by_patch(patches);
  size_t failures = 0;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& uv = mesh.triangle_uv[t];
    const double a = 0.5 * cross2(uv[0], uv[1], uv[2]);
    if (!(a > 0.0)) {
      ++failures;
      if (std::getenv("ESC_DEBUG")) std::printf("nonpositive %g: (%g %g) (%g %g) (%g %g)\n", a, uv[0].x, uv[0].y, uv[1].x, uv[1].y, uv[2].x, uv[2].y);
    }
    area[mesh.triangle_patch[t]] += a;
    by_patch[mesh.triangle_patch[t]].push_back(t);
  }
  for (size_t p = 0; p < patches; ++p) {
    if (std::abs(area[p] - 1.0) > 1e-9) ++failures;
    std::set<std::pair<double, double>> corners;
    for (size_t t : by_patch[p]) {
      for (const Vec2& c : mesh.triangle_uv[t]) corners.insert({c.x, c.y});
    }
    for (size_t t : by_patch[p]) {
      const auto& uv = mesh.triangle_uv[t];
      for (int k = 0; k < 3; ++k) {
        const Vec2 a = uv[static_cast<size_t>(k)], b = uv[static_cast<size_t>((k + 1) % 3)];
        const Vec2 ab = b - a;
        const double len2 = glm::dot(ab, ab);
        for (const auto& [x, y] : corners) {
          const Vec2 c(x, y);
          const double s = glm::dot(c - a, ab) / len2;
          if (s <= 1e-12 || s >= 1.0 - 1e-12) continue;
          if (std::abs(cross2(a, b, c)) <= 1e-12 * len2) {
            ++failures;
            if (std::getenv("ESC_DEBUG")) std::printf("T at (%g %g) on (%g %g)-(%g %g)\n", x, y, a.x, a.y, b.x, b.y);
          }
        }
      }
    }
  }
  return failures;
}

// Brute force in space: no vertex strictly inside another triangle's edge (catches T-junctions
// across patches as well).
size_t count_t_junctions(const Tessellation& mesh) {
  std::set<std::pair<uint32_t, uint32_t>> edges;
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[static_cast<size_t>(k)], b = t[static_cast<size_t>((k + 1) % 3)];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  }
  std::vector<char> used(mesh.positions.size(), 0);
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t v : t) used[v] = 1;
  }
  size_t count = 0;
  for (const auto& [a, b] : edges) {
    const Vec3 pa = mesh.positions[a], ab = mesh.positions[b] - pa;
    const double len2 = glm::dot(ab, ab);
    for (uint32_t v = 0; v < mesh.positions.size(); ++v) {
      if (!used[v] || v == a || v == b) continue;
      const Vec3 av = mesh.positions[v] - pa;
      const double s = glm::dot(av, ab) / len2;
      if (s <= 1e-9 || s >= 1.0 - 1e-9) continue;
      if (glm::length(av - s * ab) <= 1e-9 * std::sqrt(len2)) ++count;
    }
  }
  return count;
}

TEST(Esc, FullPatternCounts) {
  // Degree (n, m): 2 n m (L + 1)^2 triangles at threshold 0; the coarse 2 n m beyond the model.
  Model model;
  model.patches = {fixtures::random_patch(3, 3, 1), fixtures::random_patch(2, 5, 2), fixtures::random_patch(1, 4, 3)};
  for (size_t p = 0; p < model.patches.size(); ++p) model.patches[p].points[0].x += 10.0 * p;  // disjoint
  const uint64_t cells = 9 + 10 + 4;
  for (int level = 0; level <= 5; ++level) {
    const Tessellation full = run(model, level, 0.0);
    EXPECT_EQ(full.triangles.size(), 2 * cells * (level + 1) * (level + 1)) << "L=" << level;
    EXPECT_EQ(full.triangles.size(), esc_full_triangle_count(model, level));
    EXPECT_EQ(full.degenerate_triangles, 0u);
    const Tessellation coarse = run(model, level, 1e6);
    EXPECT_EQ(coarse.triangles.size(), 2 * cells) << "L=" << level;
  }
}

TEST(Esc, ThresholdZeroIsTheUniformGrid) {
  // At rho = 0 the pattern of a degree (n, n) patch is the uniform grid with n (L + 1) segments and
  // the same diagonals: compare the triangles as position triples (independent of vertex numbering).
  for (const Model& model : {fixtures::pillow_box(), fixtures::rational_torus()}) {
    const int n = model.patches[0].degree_u;
    UniformParams up;
    up.segments = n * 4;
    const Tessellation uni = tessellate_uniform(model, build_topology(model), up);
    const Tessellation esc = run(model, 3, 0.0);
    auto as_positions = [](const Tessellation& m) {
      std::multiset<std::array<std::array<double, 3>, 3>> out;
      for (const Triangle& t : m.triangles) {
        std::array<std::array<double, 3>, 3> p;
        for (int k = 0; k < 3; ++k) {
          const Vec3& x = m.positions[t[static_cast<size_t>(k)]];
          p[static_cast<size_t>(k)] = {x.x, x.y, x.z};
        }
        std::rotate(p.begin(), std::min_element(p.begin(), p.end()), p.end());
        out.insert(p);
      }
      return out;
    };
    EXPECT_EQ(as_positions(esc), as_positions(uni)) << model.name;
  }
}

TEST(Esc, TeacupsScene748800AtThresholdZero) {
  const std::string path = test::shared_data("teacup.bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model scene = replicate(io::read_bpt(path), 100);
  ASSERT_EQ(scene.patches.size(), 2600u);
  EscParams params;
  params.level = 3;
  params.threshold = 0.0;
  params.normals = params.surface_data = false;
  EscStats stats;
  const Tessellation full = tessellate_esc(scene, build_topology(scene), params, &stats);
  EXPECT_EQ(full.triangles.size(), 748800u);  // 2600 * 18 * 16, the paper's 731.25K (K = 1024)
  EXPECT_EQ(full.degenerate_triangles, 0u);
  EXPECT_EQ(stats.inserted_vertices, stats.candidates);
  params.threshold = 10.0 * model_box(scene).diagonal();
  const Tessellation coarse = tessellate_esc(scene, build_topology(scene), params, &stats);
  EXPECT_EQ(coarse.triangles.size(), 2600u * 18u);
  EXPECT_EQ(stats.inserted_vertices, 0u);
}

TEST(Esc, FindsThresholdsForThePapersHighAndMediumRows) {
  // Seed 000, Table 1, Teacups: adaptive High = 93.62 % and Medium = 51.96 % of the non-adaptive
  // count. The count is monotone in rho, so bisection finds the threshold; it runs on one cup (the
  // scene is 100 translated copies). The translation changes the rounding of |net - surface|, and
  // the cup's symmetric patches put many candidates at the same distance, so at the threshold itself
  // the scene's count can differ from 100 cups' by a few tenths of a percent; that rounding is also
  // what lets the bisection on the scene itself (sagitta_esc_measure, docs/ESC.md) hit 93.62 % and
  // 51.96 % exactly, which 100 exact copies of one cup could not.
  const std::string path = test::shared_data("teacup.bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model cup = io::read_bpt(path);
  const Topology cup_topology = build_topology(cup);
  auto count = [](const Model& model, const Topology& topology, double rho) {
    EscParams params;
    params.threshold = rho;
    params.normals = params.surface_data = false;
    return static_cast<double>(tessellate_esc(model, topology, params).triangles.size());
  };
  const double full = count(cup, cup_topology, 0.0), d = model_box(cup).diagonal();
  ASSERT_EQ(full, 26.0 * 288.0);
  const Model scene = replicate(cup, 100);
  const Topology scene_topology = build_topology(scene);
  for (double percent : {93.62, 51.96}) {
    const double target = percent / 100.0 * full;
    double lo = 1e-9 * d, hi = d;  // count(lo) > target >= count(hi)
    for (int it = 0; it < 60; ++it) {
      const double mid = std::sqrt(lo * hi);
      (count(cup, cup_topology, mid) <= target ? hi : lo) = mid;
    }
    const double c_lo = count(cup, cup_topology, lo), c_hi = count(cup, cup_topology, hi);
    const double rho = std::abs(c_lo - target) < std::abs(c_hi - target) ? lo : hi;
    // One cup has coarse steps (all 26 patches' candidates, several at equal distances): the
    // nearest attainable counts are 93.62 % (7010) and 52.00 % (3894 vs 3890.7 wanted).
    EXPECT_LE(c_hi, target);
    EXPECT_GT(c_lo, target);
    EXPECT_NEAR(100.0 * count(cup, cup_topology, rho) / full, percent, 0.05) << "rho " << rho;
    EXPECT_NEAR(100.0 * count(scene, scene_topology, rho) / 748800.0, percent, 0.2) << "rho " << rho;
  }
}

TEST(Esc, StripsDescribeTheTriangles) {
  std::vector<Model> models = {fixtures::pillow_box(), fixtures::rational_torus()};
  const std::string path = test::shared_data("teacup.bpt");
  if (std::filesystem::exists(path)) models.push_back(io::read_bpt(path));
  for (const Model& model : models) {
    for (int level : {1, 3, 4}) {
      for (double rho : sweep(model)) {
        const Tessellation mesh = run(model, level, rho);
        ASSERT_FALSE(mesh.strips.empty());
        EXPECT_EQ(normalise(expand_strips(mesh)), normalise(mesh.triangles)) << model.name << " L=" << level << " rho=" << rho;
      }
    }
  }
}

TEST(Esc, TriangleCountNeverIncreasesWithThreshold) {
  std::vector<Model> models = {fixtures::pillow_box(), fixtures::rational_torus()};
  const std::string path = test::shared_data("teacup.bpt");
  if (std::filesystem::exists(path)) models.push_back(io::read_bpt(path));
  for (const Model& model : models) {
   for (bool per_edge : {false, true}) {
    const double d = model_box(model).diagonal();
    size_t previous = SIZE_MAX;
    uint64_t previous_inserted = UINT64_MAX;
    for (int s = 0; s <= 60; ++s) {
      const double rho = s == 0 ? 0.0 : d * std::pow(10.0, -6.0 + 6.5 * s / 60.0);
      EscStats stats;
      const Tessellation mesh = run(model, 3, rho, &stats, per_edge);
      EXPECT_LE(mesh.triangles.size(), previous) << model.name << " rho=" << rho << " per_edge=" << per_edge;
      EXPECT_LE(stats.inserted_vertices, previous_inserted);
      previous = mesh.triangles.size();
      previous_inserted = stats.inserted_vertices;
    }
    EXPECT_EQ(previous, esc_full_triangle_count(model, 0));  // beyond the model: the coarse mesh
   }
  }
}

void expect_closed(const Model& model, long euler) {
  for (int level : {1, 2, 3, 5}) {
    for (double rho : sweep(model)) {
     for (bool per_edge : {false, true}) {
      const Tessellation mesh = run(model, level, rho, nullptr, per_edge);
      const test::MeshCounts c = test::count_topology(mesh);
      EXPECT_EQ(c.open_edges, 0u) << model.name << " L=" << level << " rho=" << rho;
      EXPECT_EQ(c.nonmanifold_edges, 0u);
      EXPECT_EQ(c.misoriented_edges, 0u);
      EXPECT_EQ(c.euler(), euler);
      EXPECT_EQ(c.used_vertices, mesh.positions.size());  // no unreferenced vertex
      EXPECT_EQ(check_parameter_tiling(mesh, model.patches.size()), 0u) << model.name << " L=" << level << " rho=" << rho;
      if (level <= 3) {
        EXPECT_EQ(count_t_junctions(mesh), 0u) << model.name << " L=" << level << " rho=" << rho;
      }
     }
    }
  }
}

TEST(Esc, PillowBoxClosedAtEveryThreshold) { expect_closed(fixtures::pillow_box(), 2); }
TEST(Esc, RationalTorusClosedAtEveryThreshold) { expect_closed(fixtures::rational_torus(), 0); }

TEST(Esc, MixedDegreePatchesTileTheirDomain) {
  // Single open patches of assorted degrees and weights at many thresholds exercise every
  // virtual-vertex case (missing ends, groups, empty rows); open edges only on the patch boundary.
  for (uint64_t seed = 1; seed <= 10; ++seed) {
    Model model;
    const int du = 1 + static_cast<int>(seed % 4), dv = 1 + static_cast<int>((seed * 7) % 5);
    model.patches = {fixtures::random_patch(du, dv, seed, 1.0, Vec3(0.0), seed % 3 == 0 ? 0.5 : 0.0, seed % 3 == 0 ? 2.0 : 0.0)};
    for (int level : {2, 3, 6}) {
      for (double rho : sweep(model, 1.6)) {
        const Tessellation mesh = run(model, level, rho, nullptr, seed % 2 == 0);
        EXPECT_EQ(check_parameter_tiling(mesh, 1), 0u) << "seed " << seed << " L=" << level << " rho=" << rho;
        std::map<std::pair<uint32_t, uint32_t>, int> count;
        std::map<std::pair<uint32_t, uint32_t>, std::pair<Vec2, Vec2>> uv;
        for (size_t t = 0; t < mesh.triangles.size(); ++t) {
          for (int k = 0; k < 3; ++k) {
            const uint32_t a = mesh.triangles[t][static_cast<size_t>(k)], b = mesh.triangles[t][static_cast<size_t>((k + 1) % 3)];
            ++count[{std::min(a, b), std::max(a, b)}];
            uv[{std::min(a, b), std::max(a, b)}] = {mesh.triangle_uv[t][static_cast<size_t>(k)],
                                                    mesh.triangle_uv[t][static_cast<size_t>((k + 1) % 3)]};
          }
        }
        for (const auto& [e, n] : count) {
          ASSERT_LE(n, 2);
          if (n == 1) {
            const auto [a, b] = uv[e];
            const bool on_side = (a.x == b.x && (a.x == 0.0 || a.x == 1.0)) || (a.y == b.y && (a.y == 0.0 || a.y == 1.0));
            EXPECT_TRUE(on_side) << "open edge inside the patch, seed " << seed;
          }
        }
        EXPECT_EQ(normalise(expand_strips(mesh)), normalise(mesh.triangles));
      }
    }
  }
}

TEST(Esc, TeaSetOpenEdgesOnlyOnTheFreeBoundary) {
  for (const char* name : {"teacup.bpt", "teapot.bpt", "teaspoon.bpt"}) {
    const std::string path = test::shared_data(name);
    SAGITTA_REQUIRE_DATA(path);
    const Model model = io::read_bpt(path);
    const Topology topology = build_topology(model);
    for (double rho : sweep(model)) {
      EscParams params;
      params.threshold = rho;
      const Tessellation mesh = tessellate_esc(model, topology, params);
      std::map<std::pair<uint32_t, uint32_t>, int> count;
      std::map<std::pair<uint32_t, uint32_t>, size_t> owner;
      for (size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
          const uint32_t a = mesh.triangles[t][static_cast<size_t>(k)], b = mesh.triangles[t][static_cast<size_t>((k + 1) % 3)];
          ++count[{std::min(a, b), std::max(a, b)}];
          owner[{std::min(a, b), std::max(a, b)}] = t * 3 + static_cast<size_t>(k);
        }
      }
      size_t open = 0, misplaced = 0;
      for (const auto& [e, n] : count) {
        EXPECT_LE(n, 2) << name;
        if (n != 1) continue;
        ++open;
        const size_t t = owner[e] / 3;
        const int k = static_cast<int>(owner[e] % 3);
        const Vec2 a = mesh.triangle_uv[t][static_cast<size_t>(k)], b = mesh.triangle_uv[t][static_cast<size_t>((k + 1) % 3)];
        Side side;
        if (a.x == b.x && a.x == 0.0) side = Side::kU0;
        else if (a.x == b.x && a.x == 1.0) side = Side::kU1;
        else if (a.y == b.y && a.y == 0.0) side = Side::kV0;
        else if (a.y == b.y && a.y == 1.0) side = Side::kV1;
        else {
          ++misplaced;
          continue;
        }
        const Topology::SideInfo& info = topology.side(mesh.triangle_patch[t], side);
        if (info.collapsed || topology.edges[static_cast<size_t>(info.edge)].uses.size() != 1) ++misplaced;
      }
      EXPECT_EQ(misplaced, 0u) << name << " rho=" << rho;
      if (topology.free_edges() > 0) {
        EXPECT_GT(open, 0u);
      }
    }
  }
}

TEST(Esc, PositionsMatchLongDoubleDeCasteljau) {
  std::vector<Model> models = {fixtures::pillow_box(), fixtures::rational_torus()};
  Model far;
  far.patches = {fixtures::random_patch(3, 3, 5, 1.0, Vec3(1e8, -1e8, 1e8)), fixtures::random_patch(4, 2, 6, 1.0, Vec3(0.0), 0.5, 2.0)};
  models.push_back(far);
  for (const Model& model : models) {
    const double scale = model_box(model).diagonal() + glm::length(model_box(model).center());
    for (double rho : {0.0, 1e-3 * model_box(model).diagonal()}) {
      const Tessellation mesh = run(model, 3, rho);
      ASSERT_EQ(mesh.surface_points.size(), mesh.positions.size());
      ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
      for (size_t v = 0; v < mesh.positions.size(); ++v) {
        const SurfacePoint& sp = mesh.surface_points[v];
        const auto ref = de_casteljau<long double>(model.patches[sp.patch], static_cast<long double>(sp.u),
                                                   static_cast<long double>(sp.v));
        const Vec3 r(static_cast<double>(ref[0]), static_cast<double>(ref[1]), static_cast<double>(ref[2]));
        EXPECT_LE(glm::length(mesh.positions[v] - r), 1e-13 * scale) << model.name << " vertex " << v;
        EXPECT_NEAR(glm::length(mesh.normals[v]), 1.0, 1e-12);
      }
      // Every triangle corner's (u, v) maps to its vertex (bit-identical where it is the vertex's own
      // patch, within rounding where a shared vertex records the neighbour).
      for (size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
          const Vec2 uv = mesh.triangle_uv[t][static_cast<size_t>(k)];
          const auto ref = de_casteljau<long double>(model.patches[mesh.triangle_patch[t]], static_cast<long double>(uv.x),
                                                     static_cast<long double>(uv.y));
          const Vec3 r(static_cast<double>(ref[0]), static_cast<double>(ref[1]), static_cast<double>(ref[2]));
          EXPECT_LE(glm::length(mesh.positions[mesh.triangles[t][static_cast<size_t>(k)]] - r), 1e-12 * scale);
        }
      }
    }
  }
}

TEST(Esc, NoZeroAreaTriangles) {
  std::vector<Model> models = {fixtures::pillow_box(), fixtures::rational_torus()};
  const std::string path = test::shared_data("teapot.bpt");
  if (std::filesystem::exists(path)) models.push_back(io::read_bpt(path));
  for (const Model& model : models) {
    const bool collapsed = build_topology(model).collapsed_sides() > 0;
    for (double rho : sweep(model)) {
      const Tessellation mesh = run(model, 3, rho);
      for (const Triangle& t : mesh.triangles) {
        const Vec3 n = glm::cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
        EXPECT_GT(glm::length(n), 0.0) << model.name;
      }
      if (!collapsed) {
        EXPECT_EQ(mesh.degenerate_triangles, 0u) << model.name;
      }
    }
  }
}

TEST(Esc, CollapsedSidesCountDegenerateTriangles) {
  // A patch whose side u = 0 collapses to a point: at threshold 0 the pattern's triangles there
  // collapse (counted, not emitted); emitted + degenerate is the full pattern count.
  Model model;
  BezierPatch patch = fixtures::random_patch(3, 3, 9);
  for (int j = 0; j <= 3; ++j) patch.at(0, j) = patch.at(0, 0);
  model.patches = {patch};
  const Topology topology = build_topology(model);
  ASSERT_EQ(topology.collapsed_sides(), 1u);
  for (double rho : sweep(model)) {
    const Tessellation mesh = run(model, 3, rho);
    if (rho == 0.0) {
      EXPECT_EQ(mesh.triangles.size() + mesh.degenerate_triangles, 288u);
      EXPECT_GT(mesh.degenerate_triangles, 0u);
    }
    EXPECT_EQ(normalise(expand_strips(mesh)), normalise(mesh.triangles));
    for (const Triangle& t : mesh.triangles) EXPECT_TRUE(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
  }
}

// Issue 20 item 9: next to a side collapsed to a point, a virtual vertex on the collapsed coarse
// edge is the collapse point, and two strips of one coarse triangle fanned the same triangle from it
// (seen on v = 0 and v = 1, never on u = 0 or u = 1). Two adjacent sides collapsed to their common
// corner closed the corner region into a bubble (a triangle twice, Euler characteristic 2) until the
// corner cell and its two neighbours took the full pattern. Random bicubic patches with each side,
// each opposite pair and each adjacent pair collapsed, several levels and thresholds: no triangle
// twice, none degenerate, and the mesh is a disc (consistently oriented, manifold, Euler
// characteristic 1, open edges only on the free sides).
TEST(Esc, CollapsedSideNeverDuplicatesATriangle) {
  // Each side alone, both opposite pairs (a spindle) and the four adjacent pairs (collapsed to
  // their common corner: every lattice point of both sides is one vertex).
  const std::vector<std::vector<Side>> cases = {{Side::kU0}, {Side::kU1}, {Side::kV0}, {Side::kV1},
                                                {Side::kU0, Side::kU1}, {Side::kV0, Side::kV1},
                                                {Side::kU0, Side::kV0}, {Side::kU0, Side::kV1},
                                                {Side::kU1, Side::kV0}, {Side::kU1, Side::kV1}};
  size_t meshes = 0;
  for (uint64_t seed = 1; seed <= 12; ++seed) {
    for (const std::vector<Side>& sides : cases) {
      BezierPatch patch = fixtures::random_patch(3, 3, seed);
      // A side collapses to its first control point; a U side and a V side to their common corner.
      int ci = -1, cj = -1;
      for (Side side : sides) {
        if (side == Side::kU0 || side == Side::kU1) ci = side == Side::kU1 ? 3 : 0;
        if (side == Side::kV0 || side == Side::kV1) cj = side == Side::kV1 ? 3 : 0;
      }
      const bool adjacent = ci >= 0 && cj >= 0;
      const Vec3 corner = adjacent ? patch.at(ci, cj) : Vec3(0.0);
      for (Side side : sides) {
        const int i0 = side == Side::kU1 ? 3 : 0, j0 = side == Side::kV1 ? 3 : 0;
        const Vec3 point = adjacent ? corner : patch.at(i0, j0);
        for (int k = 0; k <= 3; ++k) {
          const bool along_v = side == Side::kU0 || side == Side::kU1;
          patch.at(along_v ? i0 : k, along_v ? k : j0) = point;
        }
      }
      Model model;
      model.patches = {patch};
      const Topology topology = build_topology(model);
      ASSERT_EQ(topology.collapsed_sides(), sides.size());
      const double d = model_box(model).diagonal();
      for (int level : {1, 2, 3, 4, 5, 7}) {
        for (double f : {0.0, 0.003, 0.01, 0.03, 0.06, 0.1, 0.15, 0.2, 0.3}) {
          EscParams params;
          params.level = level;
          params.threshold = f * d;
          params.surface_data = true;
          const Tessellation mesh = tessellate_esc(model, topology, params);
          const std::string what = "seed " + std::to_string(seed) + " sides " + std::to_string(static_cast<int>(sides[0])) +
                                   (sides.size() > 1 ? "," + std::to_string(static_cast<int>(sides[1])) : "") +
                                    " L=" + std::to_string(level) + " rho=" + std::to_string(f) + "*diag";
          std::set<std::array<uint32_t, 3>> faces;
          for (size_t t = 0; t < mesh.triangles.size(); ++t) {
            std::array<uint32_t, 3> key = mesh.triangles[t];
            std::sort(key.begin(), key.end());
            EXPECT_TRUE(faces.insert(key).second) << what << ": triangle " << t << " repeats";
            const Triangle& tri = mesh.triangles[t];
            const Vec3 n = glm::cross(mesh.positions[tri[1]] - mesh.positions[tri[0]],
                                      mesh.positions[tri[2]] - mesh.positions[tri[0]]);
            EXPECT_GT(glm::length(n), 0.0) << what << ": triangle " << t << " degenerate";
            EXPECT_GT(cross2(mesh.triangle_uv[t][0], mesh.triangle_uv[t][1], mesh.triangle_uv[t][2]), 0.0) << what;
          }
          const test::MeshCounts c = test::count_topology(mesh);
          EXPECT_EQ(c.nonmanifold_edges, 0u) << what;
          EXPECT_EQ(c.misoriented_edges, 0u) << what;
          EXPECT_EQ(c.euler(), 1) << what;
          EXPECT_EQ(normalise(expand_strips(mesh)), normalise(mesh.triangles)) << what;
          const TopologyReport report = check_mesh_topology(mesh, &model, &topology);
          EXPECT_EQ(report.non_manifold_edges, 0u) << what;
          EXPECT_EQ(report.duplicated_faces, 0u) << what;
          EXPECT_EQ(report.degenerate_triangles, 0u) << what;
          EXPECT_EQ(report.crack_edges, 0u) << what;
          EXPECT_EQ(report.inconsistent_orientation_edges, 0u) << what;
          ++meshes;
        }
      }
    }
  }
  EXPECT_EQ(meshes, 12u * 10u * 6u * 9u);
}

TEST(Esc, SameOutputForAnyThreadCount) {
  const Model model = replicate(fixtures::pillow_box(), 8);
  const double rho = 1e-3 * model_box(model).diagonal();
  const Tessellation many = run(model, 3, rho);
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const Tessellation single = run(model, 3, rho);
  EXPECT_EQ(many.triangles, single.triangles);
  EXPECT_EQ(many.strips, single.strips);
  ASSERT_EQ(many.positions.size(), single.positions.size());
  for (size_t v = 0; v < many.positions.size(); ++v) EXPECT_EQ(many.positions[v], single.positions[v]);
}

TEST(Esc, PerEdgeLevelsRefineOnlyWhereThePaperTestDoes) {
  // Per-edge mode never inserts on an edge the paper's test leaves empty, inserts all at rho = 0,
  // and is the coarse mesh beyond the model.
  const Model model = fixtures::rational_torus();
  const double d = model_box(model).diagonal();
  EscStats paper, per_edge;
  for (double rho : sweep(model)) {
    run(model, 3, rho, &paper, false);
    const Tessellation mesh = run(model, 3, rho, &per_edge, true);
    if (rho == 0.0) {
      EXPECT_EQ(mesh.triangles.size(), esc_full_triangle_count(model, 3));
    }
    if (paper.inserted_vertices == 0) {
      EXPECT_EQ(per_edge.inserted_vertices, 0u);
    }
  }
  EXPECT_EQ(run(model, 3, 2.0 * d, nullptr, true).triangles.size(), esc_full_triangle_count(model, 0));
}

TEST(Esc, RejectsBadParameters) {
  const Model model = fixtures::pillow_box();
  const Topology topology = build_topology(model);
  EscParams p;
  p.level = -1;
  EXPECT_THROW(tessellate_esc(model, topology, p), InputError);
  p.level = kMaxEscLevel + 1;
  EXPECT_THROW(tessellate_esc(model, topology, p), InputError);
  p.level = 3;
  p.threshold = -1.0;
  EXPECT_THROW(tessellate_esc(model, topology, p), InputError);
  p.threshold = std::nan("");
  EXPECT_THROW(tessellate_esc(model, topology, p), InputError);
}

// tessellate_esc writes in place where it can predict the vertices its strips use and falls back
// to per-patch buffers copied into place elsewhere; both must give the same bits. Models with free
// boundaries, collapsed sides, mixed degrees and weights, every output option, per-patch thresholds.
TEST(Esc, InPlacePathGivesTheCopyPathsBits) {
  std::vector<std::pair<std::string, Model>> models = {{"pillow box", fixtures::pillow_box()},
                                                       {"rational torus", fixtures::rational_torus()},
                                                       {"default", fixtures::default_model()}};
  for (const char* name : {"teacup.bpt", "teapot.bpt", "teaspoon.bpt"}) {
    const std::string path = test::shared_data(name);
    SAGITTA_REQUIRE_DATA(path);
    models.emplace_back(name, io::read_bpt(path));
  }
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    Model model;
    const int du = 1 + static_cast<int>(seed % 4), dv = 1 + static_cast<int>((seed * 7) % 5);
    model.patches = {
        fixtures::random_patch(du, dv, seed, 1.0, Vec3(0.0), seed % 3 == 0 ? 0.5 : 0.0, seed % 3 == 0 ? 2.0 : 0.0)};
    BezierPatch collapsed = fixtures::random_patch(3, 3, seed + 100, 1.0, Vec3(2.0, 0.0, 0.0));
    for (int j = 0; j <= 3; ++j) collapsed.at(0, j) = collapsed.at(0, 0);
    if (seed % 2 == 0) {
      for (int i = 0; i <= 3; ++i) collapsed.at(i, 0) = collapsed.at(0, 0);  // two adjacent sides
    }
    model.patches.push_back(collapsed);
    models.emplace_back("random " + std::to_string(seed), model);
  }
  size_t in_place = 0, by_copy = 0;
  for (const auto& [name, model] : models) {
    const Topology topology = build_topology(model);
    const double d = model_box(model).diagonal();
    for (int level : {0, 1, 3, 7}) {
      for (double f : {0.0, 1e-4, 3e-3, 0.03, 0.3}) {
        for (int option = 0; option < 4; ++option) {
          EscParams params;
          params.level = level;
          params.threshold = f * d;
          params.normals = option & 1;
          params.surface_data = option & 2;
          params.per_edge_levels = option == 3;
          if (option == 2 && f > 0.0) {
            for (size_t p = 0; p < model.patches.size(); ++p) params.patch_thresholds.push_back(f * d * double(p % 3));
          }
          const std::string what = name + " L=" + std::to_string(level) + " rho=" + std::to_string(f) +
                                   "*diag option " + std::to_string(option);
          EscStats fast_stats, copy_stats;
          const Tessellation fast = tessellate_esc(model, topology, params, &fast_stats);
          const Tessellation copy = detail::tessellate_esc_by_copy(model, topology, params, &copy_stats);
          (detail::esc_direct_path_applies(model, topology, params) ? in_place : by_copy) += 1;
          ASSERT_EQ(fast.positions.size(), copy.positions.size()) << what;
          for (size_t v = 0; v < fast.positions.size(); ++v) ASSERT_EQ(fast.positions[v], copy.positions[v]) << what;
          ASSERT_EQ(fast.normals.size(), copy.normals.size()) << what;
          for (size_t v = 0; v < fast.normals.size(); ++v) ASSERT_EQ(fast.normals[v], copy.normals[v]) << what;
          ASSERT_EQ(fast.surface_points.size(), copy.surface_points.size()) << what;
          for (size_t v = 0; v < fast.surface_points.size(); ++v) {
            ASSERT_EQ(fast.surface_points[v].patch, copy.surface_points[v].patch) << what;
            ASSERT_EQ(fast.surface_points[v].u, copy.surface_points[v].u) << what;
            ASSERT_EQ(fast.surface_points[v].v, copy.surface_points[v].v) << what;
          }
          ASSERT_EQ(fast.triangles, copy.triangles) << what;
          ASSERT_EQ(fast.triangle_patch, copy.triangle_patch) << what;
          ASSERT_EQ(fast.triangle_uv, copy.triangle_uv) << what;
          ASSERT_EQ(fast.strips, copy.strips) << what;
          ASSERT_EQ(fast.degenerate_triangles, copy.degenerate_triangles) << what;
          EXPECT_EQ(fast_stats.candidates, copy_stats.candidates) << what;
          EXPECT_EQ(fast_stats.inserted_vertices, copy_stats.inserted_vertices) << what;
          EXPECT_EQ(fast_stats.strips, copy_stats.strips) << what;
          if (option == 0) {  // (u, v) per triangle takes another write path: the same triangles
            EscParams with_uv = params;
            with_uv.surface_data = true;
            const Tessellation uv = tessellate_esc(model, topology, with_uv);
            ASSERT_EQ(uv.triangles, fast.triangles) << what;
            ASSERT_EQ(uv.strips, fast.strips) << what;
          }
        }
      }
    }
  }
  // Every one of these, collapsed sides included, is predicted: the copy path is a safety net only,
  // and a change that made the in-place path give up would show here (as a slowdown otherwise).
  EXPECT_EQ(in_place, 960u);
  EXPECT_EQ(by_copy, 0u);
}

}  // namespace
}  // namespace sagitta
