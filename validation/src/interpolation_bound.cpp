#include "interpolation_bound.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sagitta::detail {

namespace {

constexpr double kUnit = std::numeric_limits<double>::epsilon() / 2;
constexpr double kInf = std::numeric_limits<double>::infinity();

Vec3 lerp(const Vec3& a, const Vec3& b, double t) { return (1.0 - t) * a + t * b; }

// The control points of the degree-d curve p restricted to [a, b'] with b' >= b (0 <= a < b <= 1,
// a and b multiples of a power of two), in place. Each result is at most 2d de Casteljau levels
// from the input, so it is within the rounding of 2d convex combinations of the exact restriction
// to [a, b'].
void restrict_curve(Vec3* p, int d, double a, double b) {
  if (a > 0.0) {  // the right part at a: p[k] = P^(d-k)_k
    for (int r = 1; r <= d; ++r) {
      for (int k = 0; k <= d - r; ++k) p[k] = lerp(p[k], p[k + 1], a);
    }
  }
  if (b >= 1.0) return;
  // (b - a) and (1 - a) are exact, their quotient is correctly rounded; the next double up makes
  // the covered interval end at or past b.
  double t = a > 0.0 ? std::nextafter((b - a) / (1.0 - a), 2.0) : b;
  if (t >= 1.0) return;
  for (int r = 1; r <= d; ++r) {  // the left part at t: p[k] = P^k_0
    for (int k = d; k >= r; --k) p[k] = lerp(p[k - 1], p[k], t);
  }
}

}  // namespace

CurvatureGrid::CurvatureGrid(const BezierPatch& patch, int cells) {
  for (double w : patch.weights) {
    if (w != 1.0) return;
  }
  if (cells < 1 || cells > 64 || (cells & (cells - 1)) != 0) return;
  const int n = patch.degree_u, m = patch.degree_v;
  if (n < 0 || m < 0 || n > kMaxDegree || m > kMaxDegree) return;
  const Vec3 origin = control_box(patch).center();
  const size_t count = static_cast<size_t>((n + 1) * (m + 1));
  std::vector<Vec3> rel(count);
  double hmag = 0.0;
  for (size_t k = 0; k < count; ++k) {
    rel[k] = patch.points[k] - origin;
    hmag = std::max(hmag, glm::length(rel[k]));
  }
  if (!std::isfinite(hmag)) return;
  // Every sub-net coefficient is within 2 (n + m) lerps of the net, each erring by at most 3u of
  // the magnitudes (at most hmag): e_sub is a margin of more than 2 over that; a second difference
  // adds 4 e_sub of input error and its own rounding (below another 2 e_sub).
  const double e_sub = 16.0 * (n + m + 2) * kUnit * hmag;
  const double width = 1.0 / cells;  // exact
  const double cu2 = n * (n - 1) / (width * width), cuv = n * m / (width * width), cv2 = m * (m - 1) / (width * width);
  std::vector<Vec3> strip(count), sub(count);
  Vec3 work[kMaxDegree + 1];
  second_.assign(static_cast<size_t>(cells * cells), {0.0, 0.0, 0.0});
  auto at = [m](std::vector<Vec3>& net, int i, int j) -> Vec3& { return net[static_cast<size_t>(i * (m + 1) + j)]; };
  for (int iu = 0; iu < cells; ++iu) {
    for (int j = 0; j <= m; ++j) {
      for (int i = 0; i <= n; ++i) work[i] = at(rel, i, j);
      restrict_curve(work, n, iu * width, (iu + 1) * width);
      for (int i = 0; i <= n; ++i) at(strip, i, j) = work[i];
    }
    for (int iv = 0; iv < cells; ++iv) {
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= m; ++j) work[j] = at(strip, i, j);
        restrict_curve(work, m, iv * width, (iv + 1) * width);
        for (int j = 0; j <= m; ++j) at(sub, i, j) = work[j];
      }
      double duu = 0.0, duv = 0.0, dvv = 0.0;
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= m; ++j) {
          if (i + 2 <= n) duu = std::max(duu, glm::length(at(sub, i + 2, j) - 2.0 * at(sub, i + 1, j) + at(sub, i, j)));
          if (j + 2 <= m) dvv = std::max(dvv, glm::length(at(sub, i, j + 2) - 2.0 * at(sub, i, j + 1) + at(sub, i, j)));
          if (i + 1 <= n && j + 1 <= m) {
            duv = std::max(duv,
                           glm::length(at(sub, i + 1, j + 1) - at(sub, i + 1, j) - at(sub, i, j + 1) + at(sub, i, j)));
          }
        }
      }
      // S_uu = n (n - 1) sum (second u-differences) B / width^2 over the box (the sub-net covers at
      // least the box, so dividing by the box width over-estimates); likewise for the others.
      second_[static_cast<size_t>(iu * cells + iv)] = {cu2 * (duu + 6.0 * e_sub), cuv * (duv + 6.0 * e_sub),
                                                       cv2 * (dvv + 6.0 * e_sub)};
    }
  }
  cells_ = cells;
}

// For (u, v) = sum b_i q_i in the triangle and d_i = q_i - (u, v): S(q_i) = S + DS d_i + R_i with
// |R_i| <= (1/2) (|S_uu| d_iu^2 + 2 |S_uv| |d_iu d_iv| + |S_vv| d_iv^2) along the segment, and
// sum b_i d_i = 0, so |sum b_i S(q_i) - S| <= (1/2) sum b_i (...). sum b_i d_iu^2 is the variance of
// the u_i under the weights b, at most ru^2 / 4 (ru the u-range of the corners); the mixed sum is
// at most ru rv / 4 by Cauchy-Schwarz. Hence the bound (A ru^2 + 2 C ru rv + B rv^2) / 8 with A, C, B
// the second-derivative bounds of the boxes the triangle's (u, v) box meets.
double CurvatureGrid::interpolation_bound(const Vec2 q[3]) const {
  if (cells_ == 0) return kInf;
  const double umin = std::min({q[0].x, q[1].x, q[2].x}), umax = std::max({q[0].x, q[1].x, q[2].x});
  const double vmin = std::min({q[0].y, q[1].y, q[2].y}), vmax = std::max({q[0].y, q[1].y, q[2].y});
  if (!(umin >= 0.0 && umax <= 1.0 && vmin >= 0.0 && vmax <= 1.0)) return kInf;  // also NaN
  const double g = cells_;  // a power of two: the products below are exact
  const auto range = [&](double lo, double hi, int& first, int& last) {
    first = std::clamp(static_cast<int>(std::floor(lo * g)), 0, cells_ - 1);
    last = std::clamp(static_cast<int>(std::ceil(hi * g)) - 1, first, cells_ - 1);
  };
  int iu0, iu1, iv0, iv1;
  range(umin, umax, iu0, iu1);
  range(vmin, vmax, iv0, iv1);
  double a = 0.0, c = 0.0, b = 0.0;
  for (int iu = iu0; iu <= iu1; ++iu) {
    for (int iv = iv0; iv <= iv1; ++iv) {
      const auto& s = second_[static_cast<size_t>(iu * cells_ + iv)];
      a = std::max(a, s[0]);
      c = std::max(c, s[1]);
      b = std::max(b, s[2]);
    }
  }
  const double ru = umax - umin, rv = vmax - vmin;
  const double bound = (a * ru * ru + 2.0 * c * ru * rv + b * rv * rv) * 0.125 * (1.0 + 1e-9);
  return bound >= 0.0 ? bound : kInf;
}

}  // namespace sagitta::detail
