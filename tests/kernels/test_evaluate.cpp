// Evaluation against independent references: long-double de Casteljau for positions, long-double
// central differences for derivatives, and geometric limits for normals at degenerate points.
#include "sagitta/evaluate.hpp"
#include "sagitta/fixtures.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace sagitta {
namespace {

using detail::PatchEvaluator;
using detail::surface_normal;

double ulp(double x) { return std::nextafter(std::fabs(x), INFINITY) - std::fabs(x); }

// Long-double de Casteljau computed relative to the first control point, so the reference keeps its
// digits far from the origin (translation commutes with affine combinations; the shift is exact
// because the control points lie within a factor of two of each other).
std::array<long double, 3> reference(const BezierPatch& patch, double u, double v) {
  BezierPatch local = patch;
  const Vec3 o = patch.points.front();
  for (Vec3& p : local.points) p -= o;
  auto r = de_casteljau<long double>(local, u, v);
  for (int c = 0; c < 3; ++c) r[static_cast<size_t>(c)] += static_cast<long double>(o[c]);
  return r;
}

// Largest |fast - reference| over random parameters, minus the unavoidable rounding of the output
// coordinate (half an ulp of each coordinate), relative to the patch size.
double relative_error(const BezierPatch& patch, int samples, uint64_t seed) {
  const PatchEvaluator eval(patch);
  const double size = control_box(patch).diagonal();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> t(0.0, 1.0);
  double worst = 0.0;
  for (int s = 0; s < samples; ++s) {
    const double u = t(rng), v = t(rng);
    const auto ref = reference(patch, u, v);
    const Vec3 p = eval.position(u, v);
    for (int c = 0; c < 3; ++c) {
      const long double err = std::fabs(static_cast<long double>(p[c]) - ref[static_cast<size_t>(c)]);
      const double beyond_rounding = std::max(0.0, static_cast<double>(err) - 0.5 * ulp(p[c]));
      worst = std::max(worst, beyond_rounding / size);
    }
  }
  return worst;
}

TEST(Evaluate, DeCasteljauDoubleMatchesLongDouble) {
  for (int d = 1; d <= 25; d += 3) {
    const BezierPatch patch = fixtures::random_patch(d, 26 - d, 100 + d);
    const auto a = de_casteljau<double>(patch, 0.3, 0.7);
    const auto b = de_casteljau<long double>(patch, 0.3L, 0.7L);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], static_cast<double>(b[c]), 1e-13);
  }
}

TEST(Evaluate, CornersAreControlPoints) {
  const BezierPatch plain = fixtures::random_patch(5, 3, 7);
  EXPECT_EQ(evaluate_with_derivatives(plain, 0.0, 0.0).position, plain.at(0, 0));
  const BezierPatch patch = fixtures::random_patch(5, 3, 7, 1.0, Vec3(0.0), 0.5, 2.0);
  const PatchEvaluator eval(patch);
  EXPECT_NEAR(evaluate_with_derivatives(patch, 0.0, 0.0).position.x, patch.at(0, 0).x, 1e-15);
  const auto p = de_casteljau<long double>(patch, 1.0L, 1.0L);
  EXPECT_NEAR(static_cast<double>(p[0]), patch.at(5, 3).x, 1e-15);
  EXPECT_NEAR(eval.position(1.0, 0.0).y, patch.at(5, 0).y, 1e-12);
}

// The acceptance figure: fast path vs long double on random patches of every degree 1..25 at
// offsets up to 1e8. The bound 1e-12 of the patch size holds for degree <= 7; higher degrees are
// measured, printed and held to the looser bounds stated in docs/ACCURACY.md.
TEST(Evaluate, FastPathMatchesLongDoubleReference) {
  double worst_low = 0.0, worst_high = 0.0;
  for (int d = 1; d <= kMaxDegree; ++d) {
    double worst_degree = 0.0;
    for (const double offset : {0.0, 1e4, 1e8}) {
      for (const bool rational : {false, true}) {
        const BezierPatch patch = fixtures::random_patch(d, std::max(1, (d * 7) % 26), 1000 * d + (rational ? 1 : 0),
                                                         1.0, Vec3(offset, -0.5 * offset, 0.25 * offset),
                                                         rational ? 0.5 : 0.0, rational ? 2.0 : 0.0);
        const int max_deg = std::max(patch.degree_u, patch.degree_v);
        const double e = relative_error(patch, 200, static_cast<uint64_t>(d));
        worst_degree = std::max(worst_degree, e);
        (max_deg <= 7 ? worst_low : worst_high) = std::max(max_deg <= 7 ? worst_low : worst_high, e);
      }
    }
    std::printf("degree %2d (with partner degree %2d): fast-path error / patch size = %.3g\n", d, std::max(1, (d * 7) % 26),
                worst_degree);
  }
  RecordProperty("worst_relative_error_degree_le_7", std::to_string(worst_low));
  RecordProperty("worst_relative_error_degree_gt_7", std::to_string(worst_high));
  EXPECT_LE(worst_low, 1e-12);
  EXPECT_LE(worst_high, 1e-12);
}

// evaluate_with_derivatives (its AVX2 variant on CPUs that have it, the scalar loops otherwise)
// does de Casteljau's operations in de_casteljau<double>'s order: its position is that one bit for
// bit, for the unrolled low degrees and the generic ones, rational or not.
TEST(Evaluate, WithDerivativesPositionIsDeCasteljauBitForBit) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> t(0.0, 1.0);
  for (int d = 1; d <= kMaxDegree; ++d) {
    for (const int e : {1, 2, 3, d}) {
      for (const bool rational : {false, true}) {
        const BezierPatch patch = fixtures::random_patch(d, e, 31 * d + e, 1.0, Vec3(1e3, -2.0, 0.5),
                                                         rational ? 0.5 : 0.0, rational ? 2.0 : 0.0);
        for (int s = 0; s < 20; ++s) {
          const double u = t(rng), v = t(rng);
          const auto ref = de_casteljau<double>(patch, u, v);
          const Vec3 p = evaluate_with_derivatives(patch, u, v).position;
          ASSERT_EQ(p.x, ref[0]) << "degrees " << d << " x " << e << (rational ? " rational" : "");
          ASSERT_EQ(p.y, ref[1]) << "degrees " << d << " x " << e << (rational ? " rational" : "");
          ASSERT_EQ(p.z, ref[2]) << "degrees " << d << " x " << e << (rational ? " rational" : "");
        }
      }
    }
  }
}

TEST(Evaluate, DerivativesMatchLongDoubleDifferences) {
  for (int d = 1; d <= 12; ++d) {
    const BezierPatch patch = fixtures::random_patch(d, 13 - d, 77 + d, 2.0, Vec3(3.0), 0.3, 3.0);
    const PatchEvaluator eval(patch);
    const long double h = 1e-6L;
    const double u = 0.37, v = 0.61;
    const auto up = de_casteljau<long double>(patch, u + h, v), um = de_casteljau<long double>(patch, u - h, v);
    const auto vp = de_casteljau<long double>(patch, u, v + h), vm = de_casteljau<long double>(patch, u, v - h);
    const SurfacePointEval slow = evaluate_with_derivatives(patch, u, v);
    const SurfacePointEval fast = eval.evaluate(u, v);
    for (int c = 0; c < 3; ++c) {
      const double du = static_cast<double>((up[c] - um[c]) / (2 * h)), dv = static_cast<double>((vp[c] - vm[c]) / (2 * h));
      const double tol = 1e-6 * (1.0 + std::fabs(du) + std::fabs(dv));
      EXPECT_NEAR(slow.du[c], du, tol) << "degree " << d;
      EXPECT_NEAR(slow.dv[c], dv, tol) << "degree " << d;
      EXPECT_NEAR(fast.du[c], du, tol) << "degree " << d;
      EXPECT_NEAR(fast.dv[c], dv, tol) << "degree " << d;
    }
  }
}

TEST(Evaluate, NormalDefinedAtCollapsedEdge) {
  // A cone-like patch: row u = 0 collapses to the apex; the normal there is the limit of the
  // normals along u -> 0 at the same v.
  BezierPatch patch;
  patch.degree_u = 3;
  patch.degree_v = 3;
  for (int i = 0; i <= 3; ++i) {
    for (int j = 0; j <= 3; ++j) {
      const double r = i / 3.0, a = j * 0.5;
      patch.points.emplace_back(r * std::cos(a), r * std::sin(a), 1.0 - r * r);
    }
  }
  for (const double v : {0.0, 0.3, 1.0}) {
    const Vec3 n = surface_normal(patch, 0.0, v);
    EXPECT_NEAR(glm::length(n), 1.0, 1e-12);
    const Vec3 near = surface_normal(patch, 1e-5, v);
    EXPECT_GT(glm::dot(n, near), 0.999) << "v = " << v;
  }
  // A patch collapsed to a point still yields a finite unit vector.
  BezierPatch dot = patch;
  for (Vec3& p : dot.points) p = Vec3(1.0, 2.0, 3.0);
  const Vec3 n = surface_normal(dot, 0.5, 0.5);
  EXPECT_NEAR(glm::length(n), 1.0, 1e-12);
}

TEST(Evaluate, PlanarPatchNormalIsThePlaneNormal) {
  BezierPatch patch = fixtures::random_patch(4, 2, 5);
  for (Vec3& p : patch.points) p.z = 0.0;
  for (const double u : {0.0, 0.5, 1.0}) {
    const Vec3 n = surface_normal(patch, u, 0.25);
    EXPECT_NEAR(std::fabs(n.z), 1.0, 1e-12);
  }
}

TEST(Evaluate, BinomialIsExact) {
  EXPECT_EQ(binomial(25, 12), 5200300.0);
  EXPECT_EQ(binomial(10, 0), 1.0);
  EXPECT_EQ(binomial(3, 4), 0.0);
}

// de_casteljau_curve leaves the weight channel out for polynomial curves at t in [0, 1] (unit weights
// stay exactly 1 there); the result must be bit for bit the homogeneous computation with explicit
// unit weights, at every degree, at the ends and at random and adversarial parameters (just below
// 1/2, tiny, just below 1), on coordinates of mixed magnitude.
TEST(Evaluate, PolynomialCurveEqualsUnitWeightHomogeneousCurve) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> unit(0.0, 1.0), coord(-1e3, 1e3);
  std::vector<double> ts = {0.0,       1.0, 0.5, std::nextafter(0.5, 0.0), 1e-300, 5e-324, std::nextafter(1.0, 0.0),
                            1.0 / 3.0, 0.1, 0.7};
  for (int k = 0; k < 2000; ++k) ts.push_back(unit(rng));
  size_t compared = 0;
  for (int degree = 1; degree <= 7; ++degree) {
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<Vec3> points;
      for (int k = 0; k <= degree; ++k) {
        const double scale = std::pow(10.0, static_cast<double>(k % 5) - 2.0);
        points.emplace_back(coord(rng) * scale, coord(rng), coord(rng) / scale);
      }
      const std::vector<double> ones(points.size(), 1.0);
      for (double t : ts) {
        const Vec3 fast = de_casteljau_curve(points, {}, t);
        const Vec3 homogeneous = de_casteljau_curve(points, ones, t);
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(fast[c], homogeneous[c]) << "degree " << degree << " t " << t << " coordinate " << c;
        }
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 7u * 20u * 2010u);
}

}  // namespace
}  // namespace sagitta
