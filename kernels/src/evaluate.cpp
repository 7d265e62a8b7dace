#include "sagitta/evaluate.hpp"

#include "sagitta/homogeneous.hpp"

#include <glm/geometric.hpp>

#include <array>
#include <cmath>
#include <type_traits>

// HVector values pass only between always-inlined functions (sagitta/homogeneous.hpp): GCC's note
// that AVX vectors change the ABI, issued where the templates are instantiated, is moot.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace sagitta {

namespace {

double binomial_computed(int n, int k) {
  double r = 1.0;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
  return std::round(r);
}

}  // namespace

double binomial(int n, int k) {
  if (k < 0 || k > n) return 0.0;
  // The degrees a patch can have, tabulated once (every matrix-form evaluator asks for them).
  static const auto table = [] {
    std::array<std::array<double, kMaxDegree + 1>, kMaxDegree + 1> t{};
    for (int a = 0; a <= kMaxDegree; ++a) {
      for (int b = 0; b <= a; ++b) t[static_cast<size_t>(a)][static_cast<size_t>(b)] = binomial_computed(a, b);
    }
    return t;
  }();
  if (n <= kMaxDegree) return table[static_cast<size_t>(n)][static_cast<size_t>(k)];
  return binomial_computed(n, k);
}

template <class T>
std::array<T, 3> de_casteljau(const BezierPatch& patch, T u, T v) {
  const int n = patch.degree_u, m = patch.degree_v;
  // Homogeneous rows: collapse each row i over v, then the column over u.
  std::vector<std::array<T, 4>> rowpts(static_cast<size_t>(n + 1));
  std::vector<std::array<T, 4>> work(static_cast<size_t>(std::max(n, m) + 1));
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= m; ++j) {
      const T w = static_cast<T>(patch.weight(i, j));
      const Vec3& p = patch.at(i, j);
      work[static_cast<size_t>(j)] = {w * static_cast<T>(p.x), w * static_cast<T>(p.y), w * static_cast<T>(p.z), w};
    }
    for (int r = 1; r <= m; ++r) {
      for (int j = 0; j <= m - r; ++j) {
        for (int c = 0; c < 4; ++c) work[j][c] = (T(1) - v) * work[j][c] + v * work[j + 1][c];
      }
    }
    rowpts[static_cast<size_t>(i)] = work[0];
  }
  for (int r = 1; r <= n; ++r) {
    for (int i = 0; i <= n - r; ++i) {
      for (int c = 0; c < 4; ++c) rowpts[i][c] = (T(1) - u) * rowpts[i][c] + u * rowpts[i + 1][c];
    }
  }
  const auto& h = rowpts[0];
  return {h[0] / h[3], h[1] / h[3], h[2] / h[3]};
}

template std::array<double, 3> de_casteljau<double>(const BezierPatch&, double, double);
template std::array<long double, 3> de_casteljau<long double>(const BezierPatch&, long double, long double);

namespace {

using H = detail::HPoint;

// De Casteljau on d + 1 homogeneous points (overwritten); returns value and derivative d/dt.
// `Degree` is int, or std::integral_constant for the low degrees (the same operations, unrolled);
// `Point` one of sagitta/homogeneous.hpp's representations (the same values).
template <class Point, class Degree>
[[gnu::always_inline]] inline void curve_with_derivative(Point* pts, Degree d, double t, Point& value,
                                                         Point& derivative) {
  const double s = 1.0 - t;
  for (int r = 1; r < d; ++r) {
    for (int k = 0; k <= d - r; ++k) pts[k] = detail::combine(pts[k], pts[k + 1], s, t);
  }
  value = detail::combine(pts[0], pts[1], s, t);
  derivative = detail::scaled_difference(pts[0], pts[1], d);
}

Vec3 project(const H& h) { return Vec3(h[0], h[1], h[2]) / h[3]; }

Vec3 project_derivative(const H& h, const H& dh) {
  const Vec3 s = project(h);
  return (Vec3(dh[0], dh[1], dh[2]) - s * dh[3]) / h[3];
}

}  // namespace

namespace {

// De Casteljau on the homogeneous control points, `count` of them (an int, or a
// std::integral_constant: the same operations, unrolled), in the scratch `pts`.
template <class Count>
[[gnu::always_inline]] inline Vec3 de_casteljau_homogeneous(const std::vector<Vec3>& points,
                                                            const std::vector<double>& weights, double t, Count count,
                                                            H* pts) {
  for (size_t k = 0; k < count; ++k) {
    const double w = weights.empty() ? 1.0 : weights[k];
    pts[k] = {w * points[k].x, w * points[k].y, w * points[k].z, w};
  }
  for (size_t r = 1; r < count; ++r) {
    for (size_t k = 0; k + r < count; ++k) {
      for (int c = 0; c < 4; ++c) pts[k][c] = (1.0 - t) * pts[k][c] + t * pts[k + 1][c];
    }
  }
  return project(pts[0]);
}

// de_casteljau_curve for N control points: the same operations in the same order, with the loops'
// bounds known (unrolled; the usual degrees 1 to 3).
template <size_t N>
Vec3 de_casteljau_fixed(const std::vector<Vec3>& points, const std::vector<double>& weights, double t) {
  if (weights.empty() && t >= 0.0 && t <= 1.0) {
    // Unit weights stay exactly 1 at every step for t in [0, 1]: fl(1 - t) + t rounds to 1 (1 - t
    // is exact for t >= 1/2; below, its error is at most 2^-54, which the sum rounds away). So the
    // weight channel and the division by it are left out: the same bits.
    Vec3 pts[N];
    for (size_t k = 0; k < N; ++k) pts[k] = points[k];
    for (size_t r = 1; r < N; ++r) {
      for (size_t k = 0; k + r < N; ++k) {
        for (int c = 0; c < 3; ++c) pts[k][c] = (1.0 - t) * pts[k][c] + t * pts[k + 1][c];
      }
    }
    return pts[0];
  }
  H pts[N];
  return de_casteljau_homogeneous(points, weights, t, std::integral_constant<size_t, N>(), pts);
}

}  // namespace

Vec3 de_casteljau_curve(const std::vector<Vec3>& points, const std::vector<double>& weights, double t) {
  switch (points.size()) {
    case 2:
      return de_casteljau_fixed<2>(points, weights, t);
    case 3:
      return de_casteljau_fixed<3>(points, weights, t);
    case 4:
      return de_casteljau_fixed<4>(points, weights, t);
    default:
      break;
  }
  // On the stack up to the largest degree (the boundary samples of every scheme come here).
  H local[kMaxDegree + 1];
  std::vector<H> heap;
  H* pts = local;
  if (points.size() > kMaxDegree + 1) {
    heap.resize(points.size());
    pts = heap.data();
  }
  const size_t count = points.size();
  if (count == 0) return Vec3(std::nan(""));
  return de_casteljau_homogeneous(points, weights, t, count, pts);
}

namespace {

// evaluate_with_derivatives for degrees n x m (int, or std::integral_constant: the same operations)
// on homogeneous points of type Point.
template <class Point, class DegreeU, class DegreeV>
[[gnu::always_inline]] inline SurfacePointEval evaluate_with_derivatives_on(const BezierPatch& patch, DegreeU n,
                                                                            DegreeV m, double u, double v) {
  // On the stack: the certifier evaluates this in its innermost loops.
  Point along_v[kMaxDegree + 1], rows[kMaxDegree + 1], drows[kMaxDegree + 1];
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= m; ++j) {
      const double w = patch.weight(i, j);
      const Vec3& p = patch.at(i, j);
      along_v[j] = detail::make_point<Point>(w * p.x, w * p.y, w * p.z, w);
    }
    curve_with_derivative(along_v, m, v, rows[i], drows[i]);
  }
  Point h, hu, hv, unused;
  curve_with_derivative(rows, n, u, h, hu);
  curve_with_derivative(drows, n, u, hv, unused);
  SurfacePointEval e;
  e.position = project(detail::to_point(h));
  e.du = project_derivative(detail::to_point(h), detail::to_point(hu));
  e.dv = project_derivative(detail::to_point(h), detail::to_point(hv));
  return e;
}

template <class DegreeU, class DegreeV>
SurfacePointEval evaluate_with_derivatives_impl(const BezierPatch& patch, DegreeU n, DegreeV m, double u, double v) {
  return evaluate_with_derivatives_on<H>(patch, n, m, u, v);
}

#ifdef SAGITTA_HVECTOR
// The same on CPUs with AVX2 (one vector register per point; the same values bit for bit).
template <class DegreeU, class DegreeV>
__attribute__((target("avx2"))) SurfacePointEval evaluate_with_derivatives_avx2(const BezierPatch& patch, DegreeU n,
                                                                                DegreeV m, double u, double v) {
  return evaluate_with_derivatives_on<detail::HVector>(patch, n, m, u, v);
}
#endif

}  // namespace

SurfacePointEval evaluate_with_derivatives(const BezierPatch& patch, double u, double v) {
  const int n = patch.degree_u, m = patch.degree_v;
  if (n > kMaxDegree || m > kMaxDegree) throw InputError("degree above 25");
#ifdef SAGITTA_HVECTOR
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2)
    return with_low_degrees(n, m,
                            [&](auto du, auto dv) { return evaluate_with_derivatives_avx2(patch, du, dv, u, v); });
#endif
  return with_low_degrees(n, m, [&](auto du, auto dv) { return evaluate_with_derivatives_impl(patch, du, dv, u, v); });
}

namespace detail {

Vec3 surface_normal(const BezierPatch& patch, double u, double v) {
  return surface_normal(patch, u, v, control_box(patch).diagonal());
}

Vec3 unit_normal(const SurfacePointEval& e, const BezierPatch& patch, double u, double v) {
  const Vec3 cr = glm::cross(e.du, e.dv);
  const double len = glm::length(cr);
  return (len > 0.0 && std::isfinite(len)) ? cr / len : surface_normal(patch, u, v);
}

Vec3 surface_normal(const BezierPatch& patch, double u, double v, double scale) {
  const double tiny = 1e-24 * scale * scale;
  // Step towards the patch centre until the tangent plane is defined; the first step is so small
  // that the result is the limit normal to within the step size.
  double step = 0.0;
  for (int attempt = 0; attempt < 8; ++attempt) {
    const double uu = u + step * (0.5 - u), vv = v + step * (0.5 - v);
    const SurfacePointEval e = evaluate_with_derivatives(patch, uu, vv);
    const Vec3 n = glm::cross(e.du, e.dv);
    const double len2 = glm::dot(n, n);
    if (len2 > tiny && std::isfinite(len2)) return n / std::sqrt(len2);
    step = step == 0.0 ? 1e-9 : step * 10.0;
  }
  return Vec3(0.0, 0.0, 1.0);
}

PatchEvaluator::PatchEvaluator(const BezierPatch& patch)
    : n_(patch.degree_u),
      m_(patch.degree_v),
      power_(patch.degree_u <= kMatrixFormMaxDegree && patch.degree_v <= kMatrixFormMaxDegree),
      origin_(control_box(patch).center()),
      k_(static_cast<size_t>((n_ + 1) * (m_ + 1)), H{0.0, 0.0, 0.0, 0.0}) {
  const int cols = m_ + 1;
  std::vector<H> b(k_.size());
  for (int i = 0; i <= n_; ++i) {
    for (int j = 0; j <= m_; ++j) {
      const double w = patch.weight(i, j);
      const Vec3 p = patch.at(i, j) - origin_;
      b[static_cast<size_t>(i * cols + j)] = {w * p.x, w * p.y, w * p.z, w};
    }
  }
  if (!power_) {
    k_ = b;
    return;
  }
  // K = N B M^T with N_ki = C(n,k) C(k,i) (-1)^(k-i): the power-basis coefficient of u^k in B_i^n.
  auto coeff = [](int deg, int i, int k) {
    if (k < i) return 0.0;
    const double s = ((k - i) % 2) ? -1.0 : 1.0;
    return s * binomial(deg, k) * binomial(k, i);
  };
  std::vector<H> nb(k_.size(), H{0.0, 0.0, 0.0, 0.0});
  for (int k = 0; k <= n_; ++k) {
    for (int i = 0; i <= k; ++i) {
      const double c = coeff(n_, i, k);
      for (int j = 0; j <= m_; ++j) {
        for (int q = 0; q < 4; ++q) nb[k * cols + j][q] += c * b[i * cols + j][q];
      }
    }
  }
  for (int k = 0; k <= n_; ++k) {
    for (int l = 0; l <= m_; ++l) {
      for (int j = 0; j <= l; ++j) {
        const double c = coeff(m_, j, l);
        for (int q = 0; q < 4; ++q) k_[k * cols + l][q] += c * nb[k * cols + j][q];
      }
    }
  }
}

void PatchEvaluator::basis_row(int degree, double t, double* values, double* derivatives) const {
  if (power_) {
    double p = 1.0;
    for (int k = 0; k <= degree; ++k) {
      values[k] = p;
      derivatives[k] = k == 0 ? 0.0 : k * values[k - 1];
      p *= t;
    }
    return;
  }
  // Bernstein values by the stable triangle; derivatives from the degree - 1 values.
  for (int k = 0; k <= degree; ++k) values[k] = 0.0;
  values[0] = 1.0;
  for (int r = 1; r <= degree; ++r) {
    if (r == degree) {
      derivatives[0] = -degree * values[0];
      for (int k = 1; k < degree; ++k) derivatives[k] = degree * (values[k - 1] - values[k]);
      derivatives[degree] = degree * values[degree - 1];
    }
    for (int k = r; k >= 1; --k) values[k] = t * values[k - 1] + (1.0 - t) * values[k];
    values[0] *= (1.0 - t);
  }
}

void PatchEvaluator::contract_u(const double* a, const double* da, H* row, H* drow) const {
  const int cols = m_ + 1;
  for (int j = 0; j <= m_; ++j) {
    H r{0.0, 0.0, 0.0, 0.0}, dr{0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i <= n_; ++i) {
      const H& kij = k_[static_cast<size_t>(i * cols + j)];
      for (int q = 0; q < 4; ++q) {
        r[q] += a[i] * kij[q];
        dr[q] += da[i] * kij[q];
      }
    }
    row[j] = r;
    drow[j] = dr;
  }
}

namespace {

// contract_u_position's loops with the u-degree n an int or a std::integral_constant (the same
// operations, unrolled for the usual degrees).
template <class Degree>
[[gnu::always_inline]] inline void contract_u_position_on(const H* k, Degree n, int m, const double* a, H* row) {
  const int cols = m + 1;
  for (int j = 0; j <= m; ++j) {
    H r{0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i <= n; ++i) {
      const H& kij = k[static_cast<size_t>(i * cols + j)];
      for (int q = 0; q < 4; ++q) r[q] += a[i] * kij[q];
    }
    row[j] = r;
  }
}

}  // namespace

void PatchEvaluator::contract_u_position(const double* a, H* row) const {
  switch (n_) {
    case 1:
      return contract_u_position_on(k_.data(), std::integral_constant<int, 1>(), m_, a, row);
    case 2:
      return contract_u_position_on(k_.data(), std::integral_constant<int, 2>(), m_, a, row);
    case 3:
      return contract_u_position_on(k_.data(), std::integral_constant<int, 3>(), m_, a, row);
    default:
      return contract_u_position_on(k_.data(), n_, m_, a, row);
  }
}

SurfacePointEval PatchEvaluator::finish(const H* row, const H* drow, const double* b, const double* db) const {
  H h{0.0, 0.0, 0.0, 0.0}, hu{0.0, 0.0, 0.0, 0.0}, hv{0.0, 0.0, 0.0, 0.0};
  for (int j = 0; j <= m_; ++j) {
    for (int q = 0; q < 4; ++q) {
      h[q] += b[j] * row[j][q];
      hu[q] += b[j] * drow[j][q];
      hv[q] += db[j] * row[j][q];
    }
  }
  SurfacePointEval e;
  const Vec3 rel = project(h);
  e.position = origin_ + rel;
  e.du = project_derivative(h, hu);
  e.dv = project_derivative(h, hv);
  return e;
}

SurfacePointEval PatchEvaluator::evaluate(double u, double v) const {
  double a[kMaxDegree + 1], da[kMaxDegree + 1], b[kMaxDegree + 1], db[kMaxDegree + 1];
  H row[kMaxDegree + 1], drow[kMaxDegree + 1];
  basis_row(n_, u, a, da);
  basis_row(m_, v, b, db);
  contract_u(a, da, row, drow);
  return finish(row, drow, b, db);
}

}  // namespace detail

}  // namespace sagitta
