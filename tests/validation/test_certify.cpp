// Certified distance: closed-form cases, rational patches, and the tea set against a brute-force
// reference (dense samples projected by Newton in long double: tests/support/reference.hpp).
#include "sagitta/certify.hpp"
#include "sagitta/esc.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/uniform.hpp"
#include "reference.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numeric>
#include <vector>

namespace sagitta {
namespace {

// The long-double reference shared with the extreme-geometry suite (tests/support/reference.hpp):
// Bernstein by the stable recurrence, Newton from a seed clamped to the unit square.
using extreme::dot;
using extreme::LD;
using extreme::LVec;
using extreme::newton_distance;

// Newton from the three best points of a 5 x 5 parameter grid (a global search that is cheap
// next to running Newton from every grid point).
LD grid_newton_distance(const BezierPatch& p, LVec x) {
  std::array<std::pair<LD, int>, 25> seeds;
  for (int i = 0; i < 25; ++i) {
    LVec s, su, sv;
    extreme::evaluate(p, LVec{}, (i / 5) / LD(4), (i % 5) / LD(4), s, su, sv);
    seeds[i] = {std::sqrt(dot(x - s, x - s)), i};
  }
  std::partial_sort(seeds.begin(), seeds.begin() + 3, seeds.end());
  LD d = seeds[0].first;
  for (int k = 0; k < 3; ++k) d = std::min(d, newton_distance(p, x, (seeds[k].second / 5) / LD(4), (seeds[k].second % 5) / LD(4)));
  return d;
}

struct Brute {
  LD max_distance = 0;  // largest distance to the model over the samples
  LD gap = 0;           // largest sample spacing on the mesh (d(., S) is 1-Lipschitz)
};

// Dense samples (k per side) on every stride-th triangle, projected by Newton onto the triangle's
// patch (from its uv and a grid) and onto every other patch that could be nearer.
Brute brute_force(const Model& model, const Tessellation& mesh, int k, const std::vector<size_t>& triangles) {
  Brute br;
  for (size_t t : triangles) {
    const auto& tri = mesh.triangles[t];
    const auto& uv = mesh.triangle_uv[t];
    const BezierPatch& patch = model.patches[mesh.triangle_patch[t]];
    Vec3 P[3];
    for (int c = 0; c < 3; ++c) P[c] = mesh.positions[tri[c]];
    for (int c = 0; c < 3; ++c) br.gap = std::max<LD>(br.gap, glm::length(P[c] - P[(c + 1) % 3]) / k);
    for (int i = 0; i <= k; ++i) {
      for (int j = 0; i + j <= k; ++j) {
        const LD b0 = LD(i) / k, b1 = LD(j) / k, b2 = 1 - b0 - b1;
        const LVec x{b0 * P[0].x + b1 * P[1].x + b2 * P[2].x, b0 * P[0].y + b1 * P[1].y + b2 * P[2].y,
                     b0 * P[0].z + b1 * P[1].z + b2 * P[2].z};
        const LD u = b0 * uv[0].x + b1 * uv[1].x + b2 * uv[2].x, v = b0 * uv[0].y + b1 * uv[1].y + b2 * uv[2].y;
        // Newton from the triangle's own (u, v), and from the best seeds of a 5 x 5 grid when that
        // start lands on a poor local minimum (near-degenerate patches); the smallest is kept.
        LD d = std::min(newton_distance(patch, x, u, v), grid_newton_distance(patch, x));
        // The distance is to the whole model: every other patch whose control box (which holds the
        // patch) is nearer than d is searched from grid seeds too.
        for (size_t o = 0; o < model.patches.size(); ++o) {
          if (o == mesh.triangle_patch[t]) continue;
          const Box box = control_box(model.patches[o]);
          const LD gx = std::max({LD(box.lo.x) - x.x, x.x - LD(box.hi.x), LD(0)});
          const LD gy = std::max({LD(box.lo.y) - x.y, x.y - LD(box.hi.y), LD(0)});
          const LD gz = std::max({LD(box.lo.z) - x.z, x.z - LD(box.hi.z), LD(0)});
          if (std::sqrt(gx * gx + gy * gy + gz * gz) >= d) continue;
          d = std::min(d, grid_newton_distance(model.patches[o], x));
        }
        br.max_distance = std::max(br.max_distance, d);
      }
    }
  }
  return br;
}

// Every stride-th triangle.
std::vector<size_t> every(const Tessellation& mesh, size_t stride) {
  std::vector<size_t> list;
  for (size_t t = 0; t < mesh.triangles.size(); t += stride) list.push_back(t);
  return list;
}

// The `worst` triangles by certified bound (where the maximum must be) plus about `spread` more
// spread evenly over the mesh (so a bound that is too small elsewhere is caught too).
std::vector<size_t> worst_and_spread(const Tessellation& mesh, const DistanceReport& r, size_t worst, size_t spread) {
  std::vector<size_t> list(mesh.triangles.size());
  std::iota(list.begin(), list.end(), size_t(0));
  worst = std::min(worst, list.size());
  std::partial_sort(list.begin(), list.begin() + static_cast<long>(worst), list.end(),
                    [&](size_t a, size_t b) { return r.triangle_upper[a] > r.triangle_upper[b]; });
  list.resize(worst);
  const size_t stride = std::max<size_t>(1, mesh.triangles.size() / std::max<size_t>(spread, 1));
  for (size_t t = 0; t < mesh.triangles.size(); t += stride) list.push_back(t);
  return list;
}

Tessellation uniform(const Model& model, int segments) {
  UniformParams params;
  params.segments = segments;
  return tessellate_uniform(model, build_topology(model), params);
}

TEST(Certify, PlanarBilinearPatchIsExact) {
  Model model;
  BezierPatch p;
  p.degree_u = 1;
  p.degree_v = 1;
  p.points = {Vec3(0, 0, 0), Vec3(0, 2, 0.5), Vec3(3, 0, 0), Vec3(3, 2, 0.5)};  // a plane, skewed grid
  model.patches.push_back(p);
  for (int n : {1, 3, 8}) {
    const DistanceReport r = certify_distance(model, uniform(model, n));
    EXPECT_TRUE(r.coverage_ok) << r.coverage_note;
    EXPECT_EQ(r.hausdorff.lower, 0.0);
    EXPECT_LE(r.hausdorff.upper, 1e-13) << "n = " << n;
    EXPECT_TRUE(r.hausdorff.certified);
  }
}

// A flat trapezoid as a bilinear patch: the mesh lies in the surface (distance ~0), but the map is
// not affine over a triangle, so a leaf's bound is second order in its size and never reaches the
// refinement floor (1e-12 of the size). Nothing above the floor is seen, so the triangles keep the
// first pass's bounds: each was refined to the full depth before (4^8 leaves per triangle: the four
// lofted sides of a drafted pocket took 26-31 s each for 32 triangles).
TEST(Certify, FlatNonAffinePatchKeepsTheFirstPassBounds) {
  Model model;
  BezierPatch p;
  p.degree_u = 1;
  p.degree_v = 1;
  p.points = {Vec3(0, 0, 1), Vec3(0, 12, 1), Vec3(30, 4, 1), Vec3(30, 8, 1)};
  model.patches.push_back(p);
  for (int n : {2, 4}) {
    const Tessellation mesh = uniform(model, n);
    const DistanceReport r = certify_distance(model, mesh);
    std::cout << "[flat trapezoid N=" << n << "] [" << r.hausdorff.lower << ", " << r.hausdorff.upper << "], "
              << r.leaves << " leaves, " << mesh.triangles.size() << " triangles\n";
    ASSERT_TRUE(r.hausdorff.certified) << r.not_certified_reason << r.coverage_note;
    EXPECT_LE(r.hausdorff.lower, 1e-12);
    // Every vertex lies on the plane z = 1 and inside the trapezoid, so the true distance is 0; the
    // bound is the first pass's, small against the patch (diagonal 32).
    EXPECT_LT(r.hausdorff.upper, 1e-2);
    EXPECT_LT(r.leaves, 4096u * mesh.triangles.size());
  }
}

// A gentle bump over a square parametrised far from affinely (x = x(u), y = y(v), cubic and
// monotone): the triangles' (u, v) drift along the surface from their positions, so the surface
// over a leaf straddling a mesh edge is nearest to two triangles. Matched to one, the
// corner-matched surface->mesh bound fell only with the leaf's size (as on shell1's B-spline
// faces: [5.4e-5, 1.06e-3]; here 2.0x and 3.7x the lower bound); the tiling by projected leaves
// bounds it at second order.
TEST(Certify, SurfaceOverDriftingTrianglesIsBoundedByProjectedLeaves) {
  Model model;
  BezierPatch p;
  p.degree_u = 3;
  p.degree_v = 3;
  const double x[4] = {0.0, 0.05, 0.1, 1.0}, y[4] = {0.0, 0.6, 0.9, 1.0};
  for (int i = 0; i <= 3; ++i) {
    for (int j = 0; j <= 3; ++j) p.points.push_back(Vec3(x[i], y[j], (i % 3 && j % 3) ? 0.002 : 0.0));
  }
  model.patches.push_back(p);
  for (int n : {3, 6}) {
    const Tessellation mesh = uniform(model, n);
    const DistanceReport r = certify_distance(model, mesh);
    std::cout << "n = " << n << ": mesh->surface [" << r.mesh_to_surface.lower << ", " << r.mesh_to_surface.upper
              << "], surface->mesh [" << r.surface_to_mesh.lower << ", " << r.surface_to_mesh.upper << "]\n";
    EXPECT_TRUE(r.hausdorff.certified);
    EXPECT_LE(r.surface_to_mesh.upper, 1.1 * r.hausdorff.lower) << "n = " << n;
    EXPECT_LE(r.hausdorff.upper, 1.1 * r.hausdorff.lower) << "n = " << n;
    const Brute br = brute_force(model, mesh, 12, every(mesh, 1));
    EXPECT_LE(static_cast<double>(br.max_distance), r.mesh_to_surface.upper * (1 + 1e-9)) << "n = " << n;
  }
}

// A planar cubic x linear patch with one side collapsed to a point (a B-spline "face" of
// bearing.iges): the surface is a plane region bounded by a cubic arc, the mesh a fan of chords of
// that arc, so the distance is zero inside and the chords' sagitta at the arc. Leaves where the
// distance is ~0 must not refine to the depth budget to get below the estimate (2,097,144 leaves
// for the 20 triangles before the two-pass refinement); the interval must stay tight and hold the
// exact value, found here by sampling the arc densely against the mesh in long double.
TEST(Certify, PlanarFanOfChordsStopsRefiningWhereTheDistanceIsZero) {
  Model model;
  BezierPatch p;
  p.degree_u = 3;
  p.degree_v = 1;
  const Vec3 arc[4] = {Vec3(0, 3, 1), Vec3(1.7, 3, 1), Vec3(3.1, 1.7, 1), Vec3(3.1, 0, 1)};
  for (int i = 0; i <= 3; ++i) {
    p.points.push_back(Vec3(0, 0, 1));  // v = 0: collapsed
    p.points.push_back(arc[i]);
  }
  model.patches.push_back(p);
  for (int n : {2, 3, 5}) {
    const Tessellation mesh = uniform(model, n);
    const DistanceReport r = certify_distance(model, mesh);
    // Exact: the arc's largest distance to the mesh (chords of a convex arc lie inside the region).
    LD exact = 0;
    for (int k = 0; k <= 20000; ++k) {
      LVec s, su, sv;
      extreme::evaluate(p, LVec{}, LD(k) / 20000, 1, s, su, sv);
      LD best = INFINITY;
      for (const Triangle& t : mesh.triangles) {
        const Vec3 a = mesh.positions[t[0]], b = mesh.positions[t[1]], c = mesh.positions[t[2]];
        for (const auto& [e0, e1] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
          const LVec d = extreme::to_lvec(e1) - extreme::to_lvec(e0), w = s - extreme::to_lvec(e0);
          const LD len2 = dot(d, d);
          const LD x = len2 > 0 ? std::clamp(dot(w, d) / len2, LD(0), LD(1)) : LD(0);
          const LVec q{w.x - x * d.x, w.y - x * d.y, w.z - x * d.z};
          best = std::min(best, std::sqrt(dot(q, q)));
        }
      }
      exact = std::max(exact, best);
    }
    std::cout << "[planar fan N=" << n << "] exact " << static_cast<double>(exact) << " in [" << r.hausdorff.lower
              << ", " << r.hausdorff.upper << "], " << r.leaves << " leaves, " << mesh.triangles.size()
              << " triangles\n";
    ASSERT_TRUE(r.hausdorff.certified) << r.not_certified_reason << r.coverage_note;
    EXPECT_LE(r.hausdorff.lower, static_cast<double>(exact) * (1 + 1e-9));
    EXPECT_GE(r.hausdorff.upper, static_cast<double>(exact) * (1 - 1e-9));
    EXPECT_LE(r.hausdorff.ratio(), 1.1);
    EXPECT_EQ(r.budget_exhausted, 0u);
    EXPECT_LT(r.leaves, 1000u * mesh.triangles.size());
  }
}

// Exact Hausdorff distance between the parabola z = c x^2 on [-1, 1] and its chord polyline with N
// uniform segments, by nested 1-D searches in long double (independent of the validator).
LD parabola_hausdorff(LD c, int N) {
  auto dist_to_parabola = [&](LD px, LD pz) {
    LD x = px;  // Newton on f'(x) = (x - px) + 2 c x (c x^2 - pz) = 0, from the point's own x
    for (int it = 0; it < 60; ++it) {
      const LD g = (x - px) + 2 * c * x * (c * x * x - pz), dg = 1 + 6 * c * c * x * x - 2 * c * pz;
      x -= g / dg;
    }
    x = std::clamp(x, LD(-1), LD(1));
    return std::hypot(x - px, c * x * x - pz);
  };
  auto seg_point = [&](int k, LD t, LD& x, LD& z) {
    const LD x0 = -1 + LD(2) * k / N, x1 = -1 + LD(2) * (k + 1) / N;
    x = x0 + t * (x1 - x0);
    z = c * x0 * x0 + t * (c * x1 * x1 - c * x0 * x0);
  };
  auto dist_to_polyline = [&](LD px, LD pz) {
    LD best = INFINITY;
    for (int k = 0; k < N; ++k) {
      LD ax, az, bx, bz;
      seg_point(k, 0, ax, az);
      seg_point(k, 1, bx, bz);
      const LD t = std::clamp(((px - ax) * (bx - ax) + (pz - az) * (bz - az)) / ((bx - ax) * (bx - ax) + (bz - az) * (bz - az)),
                              LD(0), LD(1));
      best = std::min(best, std::hypot(ax + t * (bx - ax) - px, az + t * (bz - az) - pz));
    }
    return best;
  };
  auto golden_max = [](auto f, LD lo, LD hi) {
    const LD g = (std::sqrt(LD(5)) - 1) / 2;
    for (int it = 0; it < 200; ++it) {
      const LD a = hi - g * (hi - lo), b = lo + g * (hi - lo);
      if (f(a) < f(b)) lo = a; else hi = b;
    }
    return f((lo + hi) / 2);
  };
  LD h = 0;
  for (int k = 0; k < N; ++k) {
    h = std::max(h, golden_max([&](LD t) { LD x, z; seg_point(k, t, x, z); return dist_to_parabola(x, z); }, 0, 1));
    const LD x0 = -1 + LD(2) * k / N, x1 = -1 + LD(2) * (k + 1) / N;
    h = std::max(h, golden_max([&](LD x) { return dist_to_polyline(x, c * x * x); }, x0, x1));
  }
  return h;
}

TEST(Certify, ParabolicCylinderContainsExactHausdorff) {
  Model model;
  model.patches.push_back(fixtures::parabolic_cylinder(1.0));
  for (int n : {2, 4, 16, 64}) {
    const DistanceReport r = certify_distance(model, uniform(model, n));
    const double exact = static_cast<double>(parabola_hausdorff(1.0L, n));
    std::cout << "[parabolic cylinder N=" << n << "] exact " << exact << " in [" << r.hausdorff.lower << ", "
              << r.hausdorff.upper << "] width " << r.hausdorff.width() << " ratio " << r.hausdorff.ratio() << "\n";
    EXPECT_LE(r.hausdorff.lower, exact);
    EXPECT_GE(r.hausdorff.upper, exact);
    EXPECT_LE(r.hausdorff.ratio(), 1.1);
    EXPECT_LE(r.mesh_to_surface.upper, 1.0 / (n * n) * (1 + 1e-9));  // the vertical gap c / N^2 bounds it too
  }
}

TEST(Certify, AffineBoundIsTightForAQuadraticCurve) {
  // S(u, v) = (u, v, u^2) against the chord plane z = u over the whole square: max error 1/4.
  BezierPatch p;
  p.degree_u = 2;
  p.degree_v = 1;
  for (int i = 0; i <= 2; ++i) {
    for (int j = 0; j <= 1; ++j) p.points.emplace_back(i / 2.0, double(j), i == 2 ? 1.0 : 0.0);
  }
  const Vec2 q[3] = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)};
  const Vec3 X[3] = {Vec3(0, 0, 0), Vec3(1, 0, 1), Vec3(0, 1, 0)};
  const double bound = affine_error_bound(p, q, X);
  // e(b) = u^2 - u with u = b1: Bernstein coefficients of degree 3 are 0, -1/3, -1/3, 0 along that edge.
  EXPECT_GE(bound, 0.25);
  EXPECT_LE(bound, 1.0 / 3.0 + 1e-12);
}

TEST(Certify, RationalTorusAgainstBruteForce) {
  const Model model = fixtures::rational_torus();
  for (int n : {2, 4}) {
    const Tessellation mesh = uniform(model, n);
    const DistanceReport r = certify_distance(model, mesh);
    const Brute br = brute_force(model, mesh, 6, every(mesh, 1));
    std::cout << "[torus N=" << n << "] [" << r.hausdorff.lower << ", " << r.hausdorff.upper << "] ratio "
              << r.hausdorff.ratio() << " brute " << static_cast<double>(br.max_distance) << "  certify " << r.seconds << " s\n";
    EXPECT_TRUE(r.hausdorff.certified) << r.coverage_note;
    EXPECT_LE(static_cast<double>(br.max_distance), r.mesh_to_surface.upper);
    EXPECT_GE(static_cast<double>(br.max_distance + br.gap), r.mesh_to_surface.lower);
    EXPECT_LE(r.hausdorff.ratio(), 1.1);
  }
}

TEST(Certify, DistanceLowerBoundIsSound) {
  // Points on a sphere-like offset of the pillow box: the certified lower bound never exceeds a
  // brute-force distance, and comes close to it.
  const Model model = fixtures::pillow_box();
  for (const Vec3 x : {Vec3(0.3, 0.2, 1.6), Vec3(2.0, 2.0, 2.0), Vec3(0.1, -0.05, 0.2)}) {
    LD best = INFINITY;
    for (const BezierPatch& p : model.patches) {
      for (int i = 0; i <= 16; ++i) {
        for (int j = 0; j <= 16; ++j) best = std::min(best, newton_distance(p, {x.x, x.y, x.z}, i / 16.0L, j / 16.0L));
      }
    }
    const double low = detail::certified_distance_lower(model, x, static_cast<double>(best), 200000);
    EXPECT_LE(low, static_cast<double>(best) * (1 + 1e-12));
    EXPECT_GE(low, 0.98 * static_cast<double>(best));
  }
}

TEST(Certify, NoSurfaceDataIsAnInputError) {
  const Model model = fixtures::pillow_box();
  UniformParams params;
  params.segments = 2;
  params.surface_data = false;
  const Tessellation mesh = tessellate_uniform(model, build_topology(model), params);
  EXPECT_THROW(certify_distance(model, mesh), InputError);
}

class TeaSet : public ::testing::TestWithParam<const char*> {};

TEST_P(TeaSet, UniformLevelsAgainstBruteForce) {
  const std::string path = test::shared_data(std::string(GetParam()) + ".bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model model = io::read_bpt(path);
  for (int level = 1; level <= 4; ++level) {
    const Tessellation mesh = uniform(model, segments_for_level(level));
    const DistanceReport r = certify_distance(model, mesh);
    const Brute br = brute_force(model, mesh, 4, worst_and_spread(mesh, r, 80, 150));
    std::cout << "[" << GetParam() << " level " << level << "] " << mesh.triangles.size() << " triangles  H in ["
              << r.hausdorff.lower << ", " << r.hausdorff.upper << "] ratio " << r.hausdorff.ratio() << "  m2s ["
              << r.mesh_to_surface.lower << ", " << r.mesh_to_surface.upper << "]  brute "
              << static_cast<double>(br.max_distance) << "  s2m [" << r.surface_to_mesh.lower << ", "
              << r.surface_to_mesh.upper << "] exhausted " << r.budget_exhausted << " holes " << r.holes << "  "
              << r.seconds << " s\n";
    EXPECT_TRUE(r.hausdorff.certified) << r.coverage_note;
    EXPECT_LE(r.hausdorff.ratio(), 1.1) << "level " << level;
    EXPECT_LE(static_cast<double>(br.max_distance), r.mesh_to_surface.upper) << "level " << level;
    EXPECT_GE(static_cast<double>(br.max_distance + br.gap), r.mesh_to_surface.lower) << "level " << level;
  }
}

// ESC meshes (adaptive, strips, per-edge levels) carry (patch, u, v) like uniform ones, so the same
// certificate applies: at the paper's High and Medium thresholds and a finer one, the interval is
// tight and the brute-force reference falls inside it. The symmetric upper bound must be finite
// (the teapot's collapsed lid and bottom sides included).
TEST_P(TeaSet, EscThresholdsAgainstBruteForce) {
  const std::string path = test::shared_data(std::string(GetParam()) + ".bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model model = io::read_bpt(path);
  const Topology topology = build_topology(model);
  struct Case {
    double threshold;
    bool per_edge_levels;
  };
  for (const Case c : {Case{0.003, false}, Case{0.0117763, false}, Case{0.0658537, false}, Case{0.0117763, true}}) {
    EscParams params;
    params.level = 3;
    params.threshold = c.threshold;
    params.per_edge_levels = c.per_edge_levels;
    const Tessellation mesh = tessellate_esc(model, topology, params);
    const DistanceReport r = certify_distance(model, mesh);
    const Brute br = brute_force(model, mesh, 4, worst_and_spread(mesh, r, 80, 150));
    std::cout << "[" << GetParam() << " esc rho " << c.threshold << (c.per_edge_levels ? " per-edge" : "") << "] "
              << mesh.triangles.size() << " triangles  H in [" << r.hausdorff.lower << ", " << r.hausdorff.upper
              << "] ratio " << r.hausdorff.ratio() << "  brute " << static_cast<double>(br.max_distance) << "\n";
    EXPECT_TRUE(r.hausdorff.certified) << r.coverage_note;
    EXPECT_TRUE(std::isfinite(r.hausdorff.upper));
    EXPECT_LE(r.hausdorff.ratio(), 1.1) << "rho " << c.threshold;
    EXPECT_LE(static_cast<double>(br.max_distance), r.mesh_to_surface.upper) << "rho " << c.threshold;
    EXPECT_GE(static_cast<double>(br.max_distance + br.gap), r.mesh_to_surface.lower) << "rho " << c.threshold;
  }
}

// A deeper refinement budget never loosens a triangle's bound: the first pass (depth 4) gives the
// same bounds either way, and the second, against a target raised to what the first saw, may stop
// its leaves higher than the first did; each triangle keeps the smaller of the two (both proven).
TEST_P(TeaSet, DeeperBudgetNeverLoosensATriangle) {
  const std::string path = test::shared_data(std::string(GetParam()) + ".bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model model = io::read_bpt(path);
  int looser = 0, tighter = 0;
  for (int segments : {2, 3, 5, 9}) {
    const Tessellation mesh = uniform(model, segments);
    CertifyOptions shallow;
    shallow.max_depth = 4;
    const DistanceReport a = certify_distance(model, mesh, shallow), b = certify_distance(model, mesh);
    ASSERT_EQ(a.triangle_upper.size(), b.triangle_upper.size());
    for (size_t t = 0; t < a.triangle_upper.size(); ++t) {
      looser += b.triangle_upper[t] > a.triangle_upper[t] ? 1 : 0;
      tighter += b.triangle_upper[t] < a.triangle_upper[t] ? 1 : 0;
    }
    EXPECT_LE(b.hausdorff.upper, a.hausdorff.upper) << segments << " segments";
  }
  std::cout << "[" << GetParam() << "] depth 8 against depth 4: " << tighter << " triangles tighter, " << looser
            << " looser\n";
  EXPECT_EQ(looser, 0);
}

INSTANTIATE_TEST_SUITE_P(Models, TeaSet, ::testing::Values("teapot", "teacup", "teaspoon"));

}  // namespace
}  // namespace sagitta

namespace sagitta {
namespace {

TEST(CertifyExternal, MeshWithoutUvAgreesWithOwnCertificate) {
  // The same mesh certified with its (u, v) and as a bare mesh: the two intervals must overlap,
  // and the external interval is wider by about the reference's own error.
  const Model model = fixtures::pillow_box();
  const Tessellation mesh = uniform(model, 8);
  const DistanceReport own = certify_distance(model, mesh);
  Tessellation bare;
  bare.positions = mesh.positions;
  bare.triangles = mesh.triangles;
  ExternalOptions options;
  options.reference_segments = 32;
  const DistanceReport ext = certify_external(model, bare, options);
  std::cout << "[pillow box N=8] own [" << own.hausdorff.lower << ", " << own.hausdorff.upper << "] external ["
            << ext.hausdorff.lower << ", " << ext.hausdorff.upper << "] in " << ext.seconds << " s\n";
  EXPECT_TRUE(ext.hausdorff.certified);
  EXPECT_LE(ext.hausdorff.lower, own.hausdorff.upper);
  EXPECT_GE(ext.hausdorff.upper, own.hausdorff.lower);
  EXPECT_LE(ext.hausdorff.upper, 1.5 * own.hausdorff.upper);
  EXPECT_GE(ext.hausdorff.lower, 0.5 * own.hausdorff.lower);
  EXPECT_THROW(certify_external(model, Tessellation{}), InputError);
}

// A mesh lying in a planar model, its edges across the reference's: CGAL refines a face straddling
// two coplanar reference faces until its pieces are below the error bound, which at the fine bound
// (1e-9 of the diagonal) is more work than the limit; the coarse bound (1e-3) must then certify it.
// Lifted by 0.01, the interval must still contain 0.01 (the exact distance).
TEST(CertifyExternal, MeshInAPlanarModelAcrossTheReferenceEdgesIsCertified) {
  Model model;
  BezierPatch p;
  p.degree_u = 1;
  p.degree_v = 1;
  p.points = {Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(1, 0, 0), Vec3(1, 1, 0)};
  model.patches.push_back(p);
  const double diag = std::sqrt(2.0);
  for (const double lift : {0.0, 0.01}) {
    Tessellation fan;
    fan.positions = {Vec3(0, 0, lift), Vec3(1, 0, lift), Vec3(1, 1, lift), Vec3(0, 1, lift), Vec3(0.37, 0.61, lift)};
    fan.triangles = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
    ExternalOptions options;
    options.reference_segments = 4;
    const DistanceReport r = certify_external(model, fan, options);
    std::cout << "[flat square, lift " << lift << "] [" << r.hausdorff.lower << ", " << r.hausdorff.upper << "] in "
              << r.seconds << " s\n";
    EXPECT_TRUE(r.hausdorff.certified) << r.not_certified_reason;
    EXPECT_LE(r.hausdorff.lower, lift);
    EXPECT_GE(r.hausdorff.upper, lift);
    EXPECT_LE(r.hausdorff.upper, lift + 2.0 * 1e-3 * diag + 1e-12);
    if (lift > 0.0) {
      EXPECT_GE(r.hausdorff.lower, 0.99 * lift);
    }
  }
}

}  // namespace
}  // namespace sagitta
