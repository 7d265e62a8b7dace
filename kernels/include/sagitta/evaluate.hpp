// Exact evaluation of Bézier patches: de Casteljau (the reference) and the paper's matrix form
// with per-patch precomputation (the fast path).
#pragma once

#include "sagitta/patch.hpp"

#include <array>
#include <type_traits>
#include <vector>

namespace sagitta {

// De Casteljau evaluation of a (possibly rational) patch in precision T (double or long double).
// Guarantees: every intermediate is a convex combination, so the result lies in the control hull.
template <class T>
std::array<T, 3> de_casteljau(const BezierPatch& patch, T u, T v);

// De Casteljau on one boundary curve given by its control polygon (and weights, empty if none).
Vec3 de_casteljau_curve(const std::vector<Vec3>& points, const std::vector<double>& weights, double t);

struct SurfacePointEval {
  Vec3 position{0.0};
  Vec3 du{0.0};  // dS/du
  Vec3 dv{0.0};  // dS/dv
};

// Position and first partial derivatives by de Casteljau in double.
SurfacePointEval evaluate_with_derivatives(const BezierPatch& patch, double u, double v);

// Used by the schemes; exported for their tests only.
namespace detail {

// Unit normal (dS/du x dS/dv). Where that cross product vanishes (collapsed edges, cusps) the limit
// along the direction to the patch centre is used, so the result is a finite unit vector wherever
// the patch is not collapsed to a point or a curve; there it is (0, 0, 1).
Vec3 surface_normal(const BezierPatch& patch, double u, double v);
// The same with the patch's control-box diagonal given (bit for bit the same result): for callers
// that take many normals of one patch.
Vec3 surface_normal(const BezierPatch& patch, double u, double v, double box_diagonal);

// The unit normal from an evaluation's partials at (u, v): du x dv normalised, or surface_normal's
// limit where that cross product vanishes or overflows.
Vec3 unit_normal(const SurfacePointEval& e, const BezierPatch& patch, double u, double v);

// The matrix form Q(u, v) = [U][N B M^T][V] with [N B M^T] precomputed once per patch relative to
// a patch-local origin (the control box centre), so coordinates far from the origin keep their
// digits. Above kMatrixFormMaxDegree the power basis loses too many digits; there the same
// precomputed layout holds the Bernstein form instead (basis rows from the stable recurrence).
inline constexpr int kMatrixFormMaxDegree = 7;

class PatchEvaluator {
 public:
  explicit PatchEvaluator(const BezierPatch& patch);

  int degree_u() const { return n_; }
  int degree_v() const { return m_; }
  bool uses_power_basis() const { return power_; }
  // The patch-local origin that contract_u's rows are relative to (finish adds it back).
  const Vec3& origin() const { return origin_; }

  // Basis row for parameter t along an axis of degree `degree` (value and derivative), in the
  // layout this evaluator expects. Callers tabulating a grid compute rows once per parameter.
  void basis_row(int degree, double t, double* values, double* derivatives) const;

  // Partial contraction over u: R_j = sum_i a_i K_ij (and with the u-derivative basis). `row`
  // and `drow` receive (m+1) homogeneous points. One call per grid row.
  void contract_u(const double* a, const double* da, std::array<double, 4>* row, std::array<double, 4>* drow) const;

  // Finishes a point from a contracted row: position (absolute) and partials.
  SurfacePointEval finish(const std::array<double, 4>* row, const std::array<double, 4>* drow, const double* b,
                          const double* db) const;

  // The same two steps for the position only (callers that need no partials): the same
  // operations as contract_u's `row` and finish's position, so the same bits, at a third of the cost.
  void contract_u_position(const double* a, std::array<double, 4>* row) const;
  Vec3 finish_position(const std::array<double, 4>* row, const double* b) const {
    std::array<double, 4> h{0.0, 0.0, 0.0, 0.0};
    for (int j = 0; j <= m_; ++j) {
      for (int q = 0; q < 4; ++q) h[q] += b[j] * row[j][q];
    }
    return origin_ + Vec3(h[0], h[1], h[2]) / h[3];
  }

  // The (n+1) x (m+1) homogeneous coefficients K_ij (row-major, i over u), in the basis of
  // uses_power_basis(): what contract_u multiplies the u-basis row with.
  const std::array<double, 4>* coefficients() const { return k_.data(); }

  // Convenience: full evaluation at one (u, v).
  SurfacePointEval evaluate(double u, double v) const;
  Vec3 position(double u, double v) const { return evaluate(u, v).position; }

 private:
  int n_, m_;
  bool power_;
  Vec3 origin_;
  std::vector<std::array<double, 4>> k_;  // (n+1) x (m+1) homogeneous coefficients (w*(P-o), w)
};

}  // namespace detail

// f(du, dv) with the degrees as std::integral_constant when both are 1 to 3 (so loops over them
// unroll), as int otherwise: the same function, the same operations.
template <class F>
decltype(auto) with_low_degrees(int n, int m, F&& f) {
  using One = std::integral_constant<int, 1>;
  using Two = std::integral_constant<int, 2>;
  using Three = std::integral_constant<int, 3>;
  const auto second = [&](auto du) -> decltype(f(One{}, One{})) {
    switch (m) {
      case 1:
        return f(du, One{});
      case 2:
        return f(du, Two{});
      case 3:
        return f(du, Three{});
      default:
        return f(n, m);
    }
  };
  switch (n) {
    case 1:
      return second(One{});
    case 2:
      return second(Two{});
    case 3:
      return second(Three{});
    default:
      return f(n, m);
  }
}

// Binomial coefficient C(n, k) as a double (exact for n <= 60).
double binomial(int n, int k);

}  // namespace sagitta
