// The curvature grid's interpolation bound (validation/src/interpolation_bound.hpp), which settles
// most triangles of a certificate: never below the distance between the patch and the affine
// interpolation of its points, measured in long double on dense barycentric samples, on random
// patches and triangles of every size; and not vacuous (within a small factor of that distance on
// the small triangles of a fine tessellation).
#include "interpolation_bound.hpp"
#include "reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace sagitta {
namespace {

using extreme::LD;
using extreme::LVec;

LVec surface(const BezierPatch& patch, LD u, LD v) {
  LVec s, su, sv;
  extreme::evaluate(patch, LVec{0, 0, 0}, u, v, s, su, sv);
  return s;
}

// max over barycentric samples (k per side) of |S(sum b_i q_i) - sum b_i S(q_i)|, in long double.
LD sampled_interpolation_error(const BezierPatch& patch, const Vec2 q[3], int k) {
  LVec corner[3];
  for (int c = 0; c < 3; ++c) corner[c] = surface(patch, q[c].x, q[c].y);
  LD worst = 0;
  for (int i = 0; i <= k; ++i) {
    for (int j = 0; i + j <= k; ++j) {
      const LD b0 = LD(i) / k, b1 = LD(j) / k, b2 = 1 - b0 - b1;
      const LD u = b0 * q[0].x + b1 * q[1].x + b2 * q[2].x, v = b0 * q[0].y + b1 * q[1].y + b2 * q[2].y;
      const LVec s = surface(patch, u, v);
      const LVec l{b0 * corner[0].x + b1 * corner[1].x + b2 * corner[2].x,
                   b0 * corner[0].y + b1 * corner[1].y + b2 * corner[2].y,
                   b0 * corner[0].z + b1 * corner[1].z + b2 * corner[2].z};
      const LVec d = s - l;
      worst = std::max(worst, std::sqrt(extreme::dot(d, d)));
    }
  }
  return worst;
}

BezierPatch random_patch(std::mt19937& rng, int n, int m, double scale, Vec3 offset) {
  std::uniform_real_distribution<double> coord(-1.0, 1.0);
  BezierPatch p;
  p.degree_u = n;
  p.degree_v = m;
  for (int k = 0; k < (n + 1) * (m + 1); ++k) {
    p.points.push_back(offset + scale * Vec3(coord(rng), coord(rng), coord(rng)));
  }
  return p;
}

// `trials` random triangles of sizes 2^-halvings to 1 anywhere in [0, 1]^2: each bound finite and
// not below the sampled error. Returns the number checked.
int check_random_triangles(const BezierPatch& patch, const detail::CurvatureGrid& grid, std::mt19937& rng, int trials,
                           double halvings) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const double size = std::pow(2.0, -halvings * unit(rng));
    const Vec2 base(unit(rng) * (1.0 - size), unit(rng) * (1.0 - size));
    Vec2 q[3];
    for (auto& c : q) c = base + size * Vec2(unit(rng), unit(rng));
    const double bound = grid.interpolation_bound(q);
    EXPECT_TRUE(std::isfinite(bound));
    EXPECT_GE(static_cast<LD>(bound), sampled_interpolation_error(patch, q, 12))
        << "degrees " << patch.degree_u << "," << patch.degree_v << (patch.rational() ? " rational" : "");
    ++checked;
  }
  return checked;
}

TEST(InterpolationBound, NeverBelowTheSampledErrorOnRandomPatchesAndTriangles) {
  std::mt19937 rng(20261202);
  const int degrees[][2] = {{1, 1}, {2, 1}, {3, 3}, {2, 5}, {6, 4}, {9, 9}, {25, 3}};
  int checked = 0;
  for (const auto& d : degrees) {
    for (const int cells : {1, 2, 4, 16}) {
      const BezierPatch patch = random_patch(rng, d[0], d[1], 1.0, Vec3(0.0));
      const detail::CurvatureGrid grid(patch, cells);
      ASSERT_FALSE(grid.empty());
      // Sizes from the whole domain down to 1/256 of it.
      checked += check_random_triangles(patch, grid, rng, 40, 8.0);
    }
  }
  EXPECT_EQ(checked, 7 * 4 * 40);
}

// Rational patches: weights from 1/4 to 4 (a quarter circle has 1 and 1/sqrt(2)); the bound goes
// through the quotient rule on the homogeneous net, so it is looser, but still never below.
TEST(InterpolationBound, RationalPatchesToo) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked = 0;
  for (const auto& d :
       {std::array<int, 2>{1, 2}, std::array<int, 2>{2, 2}, std::array<int, 2>{3, 4}, std::array<int, 2>{7, 2}}) {
    for (const int cells : {1, 4, 16}) {
      BezierPatch patch = random_patch(rng, d[0], d[1], 1.0, Vec3(0.0));
      for (size_t k = 0; k < patch.points.size(); ++k) patch.weights.push_back(std::pow(4.0, 2.0 * unit(rng) - 1.0));
      const detail::CurvatureGrid grid(patch, cells);
      ASSERT_FALSE(grid.empty());
      checked += check_random_triangles(patch, grid, rng, 30, 7.0);
    }
  }
  EXPECT_EQ(checked, 4 * 3 * 30);
  // A quarter of a unit circle swept along z (the rational quadratic of a cylinder): on a fine grid
  // the bound stays within a small factor of the true chord error.
  BezierPatch cylinder;
  cylinder.degree_u = 2;
  cylinder.degree_v = 1;
  const double r = std::sqrt(0.5);
  cylinder.points = {Vec3(1, 0, 0), Vec3(1, 0, 1), Vec3(1, 1, 0), Vec3(1, 1, 1), Vec3(0, 1, 0), Vec3(0, 1, 1)};
  cylinder.weights = {1, 1, r, r, 1, 1};
  const detail::CurvatureGrid grid(cylinder, 16);
  const Vec2 q[3] = {Vec2(0.5, 0.25), Vec2(0.5 + 1.0 / 64, 0.25), Vec2(0.5 + 1.0 / 64, 0.25 + 1.0 / 64)};
  const double bound = grid.interpolation_bound(q);
  const LD sampled = sampled_interpolation_error(cylinder, q, 16);
  EXPECT_GE(static_cast<LD>(bound), sampled);
  EXPECT_LT(static_cast<LD>(bound), 12 * sampled);
}

// Triangles of a uniform grid (corners on multiples of 1/64, so on the boxes' sides): every box
// they touch counts, and the bound stays within a small factor of the true error.
TEST(InterpolationBound, TightOnTheTrianglesOfAFineUniformGrid) {
  std::mt19937 rng(7);
  const BezierPatch patch = random_patch(rng, 3, 3, 1.0, Vec3(0.0));
  const detail::CurvatureGrid grid(patch, 16);
  const int level = 64;
  LD worst_ratio = 0;
  for (int i = 0; i < level; i += 5) {
    for (int j = 0; j < level; j += 3) {
      const Vec2 a(double(i) / level, double(j) / level), b(double(i + 1) / level, double(j) / level),
          c(double(i + 1) / level, double(j + 1) / level), e(double(i) / level, double(j + 1) / level);
      for (const auto& tri : {std::array<Vec2, 3>{a, b, c}, std::array<Vec2, 3>{a, c, e}}) {
        const double bound = grid.interpolation_bound(tri.data());
        const LD sampled = sampled_interpolation_error(patch, tri.data(), 16);
        ASSERT_GE(static_cast<LD>(bound), sampled);
        if (sampled > 0) worst_ratio = std::max(worst_ratio, bound / sampled);
      }
    }
  }
  // Norms of second derivatives added where they point different ways, and their largest value over
  // a box of 4 x 4 cells: a few times the error, never orders of magnitude.
  EXPECT_LT(worst_ratio, 12.0L);
  EXPECT_GT(worst_ratio, 1.0L);
}

TEST(InterpolationBound, PlanesAndFarOffsetsAndWhatItRefuses) {
  // A bilinear patch whose four points are coplanar and form a parallelogram is an affine map:
  // no interpolation error at all (only the rounding margin).
  BezierPatch plane;
  plane.degree_u = plane.degree_v = 1;
  plane.points = {Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(1, 0, 0), Vec3(1, 1, 0)};
  const Vec2 q[3] = {Vec2(0.1, 0.2), Vec2(0.9, 0.3), Vec2(0.4, 0.8)};
  EXPECT_LT(detail::CurvatureGrid(plane, 4).interpolation_bound(q), 1e-13);

  // Far from the origin: the bound follows the shape, not the offset (the grid works relative to the
  // patch's centre).
  std::mt19937 rng(11);
  const BezierPatch near = random_patch(rng, 3, 3, 1.0, Vec3(0.0));
  BezierPatch far = near;
  for (Vec3& p : far.points) p += Vec3(1e8, -1e8, 1e8);
  const Vec2 t[3] = {Vec2(0.25, 0.25), Vec2(0.5, 0.25), Vec2(0.5, 0.5)};
  const double b_near = detail::CurvatureGrid(near, 8).interpolation_bound(t);
  const double b_far = detail::CurvatureGrid(far, 8).interpolation_bound(t);
  EXPECT_GE(static_cast<LD>(b_far), sampled_interpolation_error(near, t, 12));
  EXPECT_LT(std::abs(b_far - b_near), 1e-6 * b_near + 1e-6);

  // Weights that are not positive finite numbers give no grid (and no bound); corners outside the
  // unit square get no bound.
  BezierPatch rational = near;
  rational.weights.assign(16, 1.0);
  rational.weights[5] = 0.0;
  EXPECT_TRUE(detail::CurvatureGrid(rational, 4).empty());
  EXPECT_TRUE(std::isinf(detail::CurvatureGrid(rational, 4).interpolation_bound(t)));
  rational.weights[5] = std::nan("");
  EXPECT_TRUE(detail::CurvatureGrid(rational, 4).empty());
  const Vec2 outside[3] = {Vec2(-0.01, 0.0), Vec2(0.5, 0.0), Vec2(0.5, 0.5)};
  EXPECT_TRUE(std::isinf(detail::CurvatureGrid(near, 4).interpolation_bound(outside)));
  const Vec2 nan[3] = {Vec2(std::nan(""), 0.0), Vec2(0.5, 0.0), Vec2(0.5, 0.5)};
  EXPECT_TRUE(std::isinf(detail::CurvatureGrid(near, 4).interpolation_bound(nan)));
  // All weights 1 is a polynomial patch.
  rational.weights.assign(16, 1.0);
  EXPECT_FALSE(detail::CurvatureGrid(rational, 4).empty());
}

}  // namespace
}  // namespace sagitta
