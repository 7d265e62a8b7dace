#include "interpolation_bound.hpp"

#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sagitta::detail {

namespace {

constexpr double kUnit = std::numeric_limits<double>::epsilon() / 2;
constexpr double kInf = std::numeric_limits<double>::infinity();

using Vec4 = glm::dvec4;  // homogeneous control point (w (P - o), w)

Vec4 lerp(const Vec4& a, const Vec4& b, double t) { return (1.0 - t) * a + t * b; }

// The control points of the degree-d curve p restricted to [a, b'] with b' >= b (0 <= a < b <= 1,
// a and b multiples of a power of two), in place. Each result is at most 2d de Casteljau levels
// from the input, so it is within the rounding of 2d convex combinations of the exact restriction
// to [a, b'].
void restrict_curve(Vec4* p, int d, double a, double b) {
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

double length3(const Vec4& v) { return glm::length(Vec3(v)); }

}  // namespace

CurvatureGrid::CurvatureGrid(const BezierPatch& patch, int cells) {
  if (cells < 1 || cells > 64 || (cells & (cells - 1)) != 0) return;
  const int n = patch.degree_u, m = patch.degree_v;
  if (n < 0 || m < 0 || n > kMaxDegree || m > kMaxDegree) return;
  bool rational = false;
  for (double w : patch.weights) {
    if (!(w > 0.0) || !std::isfinite(w)) return;
    rational = rational || w != 1.0;
  }
  const Vec3 origin = control_box(patch).center();
  const size_t count = static_cast<size_t>((n + 1) * (m + 1));
  std::vector<Vec4> rel(count);
  double hmag = 0.0, rmax = 0.0, wmax = 0.0;
  for (size_t k = 0; k < count; ++k) {
    const double w = patch.weights.empty() ? 1.0 : patch.weights[k];
    const Vec3 d = patch.points[k] - origin;
    rel[k] = Vec4(w * d, w);
    hmag = std::max(hmag, w * glm::length(d));
    rmax = std::max(rmax, glm::length(d));
    wmax = std::max(wmax, w);
  }
  if (!std::isfinite(hmag) || !std::isfinite(rmax)) return;
  // Every sub-net coefficient is within 2 (n + m) lerps of the net, each erring by at most 3u of
  // the magnitudes (at most hmag, or wmax for the weight): e_sub is a margin of more than 2 over
  // that; a difference of up to four coefficients adds 4 e_sub of input error and its own rounding
  // (below another 2 e_sub).
  const double e_sub = 16.0 * (n + m + 2) * kUnit * std::max(hmag, wmax);
  const double slack = 6.0 * e_sub;
  const double width = 1.0 / cells;  // exact
  std::vector<Vec4> strip(count), sub(count);
  Vec4 work[kMaxDegree + 1];
  second_.assign(static_cast<size_t>(cells * cells), {0.0, 0.0, 0.0});
  auto at = [m](std::vector<Vec4>& net, int i, int j) -> Vec4& { return net[static_cast<size_t>(i * (m + 1) + j)]; };
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
      // Largest differences of the sub-net (numerator part and weight) in each direction.
      double nu = 0, nv = 0, nuu = 0, nuv = 0, nvv = 0, wu = 0, wv = 0, wuu = 0, wuv = 0, wvv = 0;
      double wlow = std::numeric_limits<double>::infinity();
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= m; ++j) {
          const Vec4 c = at(sub, i, j);
          wlow = std::min(wlow, c.w);
          if (i + 1 <= n) {
            const Vec4 d = at(sub, i + 1, j) - c;
            nu = std::max(nu, length3(d));
            wu = std::max(wu, std::abs(d.w));
          }
          if (j + 1 <= m) {
            const Vec4 d = at(sub, i, j + 1) - c;
            nv = std::max(nv, length3(d));
            wv = std::max(wv, std::abs(d.w));
          }
          if (i + 2 <= n) {
            const Vec4 d = at(sub, i + 2, j) - 2.0 * at(sub, i + 1, j) + c;
            nuu = std::max(nuu, length3(d));
            wuu = std::max(wuu, std::abs(d.w));
          }
          if (j + 2 <= m) {
            const Vec4 d = at(sub, i, j + 2) - 2.0 * at(sub, i, j + 1) + c;
            nvv = std::max(nvv, length3(d));
            wvv = std::max(wvv, std::abs(d.w));
          }
          if (i + 1 <= n && j + 1 <= m) {
            const Vec4 d = at(sub, i + 1, j + 1) - at(sub, i + 1, j) - at(sub, i, j + 1) + c;
            nuv = std::max(nuv, length3(d));
            wuv = std::max(wuv, std::abs(d.w));
          }
        }
      }
      // Derivatives over the box of the homogeneous numerator N and weight W (the sub-net covers at
      // least the box, so dividing by the box width over-estimates): N_u = n sum (u-differences) B
      // / width, N_uu = n (n - 1) sum (second u-differences) B / width^2, and so on.
      const double h = 1.0 / width;
      const double Nuu = n * (n - 1) * (nuu + slack) * h * h, Nuv = n * m * (nuv + slack) * h * h,
                   Nvv = m * (m - 1) * (nvv + slack) * h * h;
      std::array<double, 3>& box = second_[static_cast<size_t>(iu * cells + iv)];
      if (!rational) {  // W = 1: S - o = N
        box = {Nuu, Nuv, Nvv};
        continue;
      }
      // W S = N (S relative to o, |S| <= rmax by the convex hull): differentiating,
      // W S_u = N_u - W_u S, W S_uu = N_uu - 2 W_u S_u - W_uu S, W S_uv = N_uv - W_u S_v - W_v S_u - W_uv S.
      const double W = wlow - e_sub;  // the weight is at least the smallest sub-net weight
      if (!(W > 0.0)) return;         // no grid: the caller falls back to the exact bound
      const double Nu = n * (nu + slack) * h, Nv = m * (nv + slack) * h;
      const double Wu = n * (wu + slack) * h, Wv = m * (wv + slack) * h;
      const double Wuu = n * (n - 1) * (wuu + slack) * h * h, Wuv = n * m * (wuv + slack) * h * h,
                   Wvv = m * (m - 1) * (wvv + slack) * h * h;
      const double Su = (Nu + Wu * rmax) / W, Sv = (Nv + Wv * rmax) / W;
      box = {(Nuu + 2.0 * Wu * Su + Wuu * rmax) / W, (Nuv + Wu * Sv + Wv * Su + Wuv * rmax) / W,
             (Nvv + 2.0 * Wv * Sv + Wvv * rmax) / W};
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
