#include "sagitta/uniform_grid.hpp"

#include "sagitta/evaluate.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <string>

namespace sagitta {

namespace {

void check_segments(int segments) {
  if (segments < 1) throw InputError("--segments must be >= 1, got " + std::to_string(segments));
}

}  // namespace

UniformGridPlan::UniformGridPlan(const Model& model, int segments) : segments_(segments) {
  check_segments(segments);
  const size_t cols = static_cast<size_t>(segments) + 1;
  // v-basis values of every grid column for one (basis kind, degree), stored basis-major:
  // values[j * (N+1) + b] = basis j at v = b / N. They depend only on the degree and on whether the
  // evaluator uses the power basis, so all patches of that kind share one table.
  std::array<std::array<int, kMaxDegree + 1>, 2> table_of;
  for (auto& t : table_of) t.fill(-1);
  evals_.reserve(model.patches.size());
  for (const BezierPatch& patch : model.patches) {
    evals_.emplace_back(patch);
    const detail::PatchEvaluator& eval = evals_.back();
    const int m = patch.degree_v;
    int& index = table_of[eval.uses_power_basis() ? 1 : 0][static_cast<size_t>(m)];
    if (index < 0) {
      std::vector<double> values(static_cast<size_t>(m + 1) * cols);
      double b[kMaxDegree + 1], db[kMaxDegree + 1];
      for (int c = 0; c <= segments; ++c) {
        eval.basis_row(m, static_cast<double>(c) / segments, b, db);
        for (int j = 0; j <= m; ++j) values[static_cast<size_t>(j) * cols + static_cast<size_t>(c)] = b[j];
      }
      index = static_cast<int>(table_store_.size());
      table_store_.push_back(std::move(values));
    }
    // A polynomial patch in the power basis has homogeneous weight exactly 1 at every point
    // (weight coefficients 1, 0, ..., 0 and basis value 1 for the constant term), so the division
    // that PatchEvaluator::finish performs is the identity there and is skipped.
    unit_weight_.push_back(!patch.rational() && eval.uses_power_basis() ? 1 : 0);
  }
  // Pointers last: table_store_ no longer grows.
  table_store_.shrink_to_fit();
  size_t p = 0;
  tables_.resize(model.patches.size());
  for (const BezierPatch& patch : model.patches) {
    tables_[p] = table_store_[static_cast<size_t>(
                                  table_of[evals_[p].uses_power_basis() ? 1 : 0][static_cast<size_t>(patch.degree_v)])]
                     .data();
    ++p;
  }
}

uint64_t UniformGridPlan::vertices() const { return uniform_grid_patch_vertices(segments_) * evals_.size(); }

namespace {

// One grid row for any v-degree m: sums accumulated over the basis functions in scratch rows.
template <class Out>
inline __attribute__((always_inline)) void grid_row_any(const double* table, size_t cols, int m,
                                                        const std::array<double, 4>* row, bool unit_weight,
                                                        const Vec3& o, Out* out, double* x, double* y, double* z,
                                                        double* w) {
  for (size_t c = 0; c < cols; ++c) x[c] = y[c] = z[c] = w[c] = 0.0;
  for (int j = 0; j <= m; ++j) {
    const double* bj = table + static_cast<size_t>(j) * cols;
    const double rx = row[j][0], ry = row[j][1], rz = row[j][2], rw = row[j][3];
    for (size_t c = 0; c < cols; ++c) {
      x[c] += bj[c] * rx;
      y[c] += bj[c] * ry;
      z[c] += bj[c] * rz;
    }
    if (!unit_weight) {
      for (size_t c = 0; c < cols; ++c) w[c] += bj[c] * rw;
    }
  }
  if (unit_weight) {
    for (size_t c = 0; c < cols; ++c) {
      out[3 * c + 0] = static_cast<Out>(o.x + x[c]);
      out[3 * c + 1] = static_cast<Out>(o.y + y[c]);
      out[3 * c + 2] = static_cast<Out>(o.z + z[c]);
    }
  } else {
    for (size_t c = 0; c < cols; ++c) {
      out[3 * c + 0] = static_cast<Out>(o.x + x[c] / w[c]);
      out[3 * c + 1] = static_cast<Out>(o.y + y[c] / w[c]);
      out[3 * c + 2] = static_cast<Out>(o.z + z[c] / w[c]);
    }
  }
}

// One grid row for v-degree M: the same operations in the same order as grid_row_any (sums start
// at 0 and add basis j = 0..M), fused into one loop over the columns with the sums in registers.
template <int M, class Out>
inline __attribute__((always_inline)) void grid_row_fixed(const double* table, size_t cols,
                                                          const std::array<double, 4>* row, bool unit_weight,
                                                          const Vec3& o, Out* out) {
  if (unit_weight) {
    for (size_t c = 0; c < cols; ++c) {
      double x = 0.0, y = 0.0, z = 0.0;
      for (int j = 0; j <= M; ++j) {
        const double b = table[static_cast<size_t>(j) * cols + c];
        x += b * row[j][0];
        y += b * row[j][1];
        z += b * row[j][2];
      }
      out[3 * c + 0] = static_cast<Out>(o.x + x);
      out[3 * c + 1] = static_cast<Out>(o.y + y);
      out[3 * c + 2] = static_cast<Out>(o.z + z);
    }
  } else {
    for (size_t c = 0; c < cols; ++c) {
      double x = 0.0, y = 0.0, z = 0.0, w = 0.0;
      for (int j = 0; j <= M; ++j) {
        const double b = table[static_cast<size_t>(j) * cols + c];
        x += b * row[j][0];
        y += b * row[j][1];
        z += b * row[j][2];
        w += b * row[j][3];
      }
      out[3 * c + 0] = static_cast<Out>(o.x + x / w);
      out[3 * c + 1] = static_cast<Out>(o.y + y / w);
      out[3 * c + 2] = static_cast<Out>(o.z + z / w);
    }
  }
}

// One patch's (n+1)^2 grid positions, row by row, written interleaved (x, y, z) to `out`. `x`..`w`
// are scratch rows of n+1 doubles (used for v-degrees above 3). Every position is the same sequence of IEEE operations as
// PatchEvaluator::position (no fused multiply-add), so the output is bit-identical to it.
template <class Out>
inline __attribute__((always_inline)) void grid_patch_body(const detail::PatchEvaluator& eval, const double* table,
                                                           bool unit_weight, int n, Out* out, double* x, double* y,
                                                           double* z, double* w) {
  const size_t cols = static_cast<size_t>(n) + 1;
  const int m = eval.degree_v();
  const Vec3 o = eval.origin();
  double a_row[kMaxDegree + 1], da_row[kMaxDegree + 1];
  std::array<double, 4> row[kMaxDegree + 1], drow[kMaxDegree + 1];
  for (int a = 0; a <= n; ++a) {
    eval.basis_row(eval.degree_u(), static_cast<double>(a) / n, a_row, da_row);
    eval.contract_u(a_row, da_row, row, drow);
    switch (m) {  // the usual degrees get a fused loop with the sums in registers
      case 1: grid_row_fixed<1>(table, cols, row, unit_weight, o, out); break;
      case 2: grid_row_fixed<2>(table, cols, row, unit_weight, o, out); break;
      case 3: grid_row_fixed<3>(table, cols, row, unit_weight, o, out); break;
      default: grid_row_any(table, cols, m, row, unit_weight, o, out, x, y, z, w); break;
    }
    out += 3 * cols;
  }
}

// On x86-64 with GCC the kernel is also compiled for AVX2 (four doubles a lane instead of SSE2's
// two) and picked at load time by the CPU; "fma" is deliberately not enabled, so no multiply-add is
// fused and the results stay bit-identical to the scalar evaluator.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define SAGITTA_GRID_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define SAGITTA_GRID_CLONES
#endif

SAGITTA_GRID_CLONES void grid_patch(const detail::PatchEvaluator& eval, const double* table, bool unit_weight, int n,
                                    float* out, double* x, double* y, double* z, double* w) {
  grid_patch_body(eval, table, unit_weight, n, out, x, y, z, w);
}

SAGITTA_GRID_CLONES void grid_patch(const detail::PatchEvaluator& eval, const double* table, bool unit_weight, int n,
                                    double* out, double* x, double* y, double* z, double* w) {
  grid_patch_body(eval, table, unit_weight, n, out, x, y, z, w);
}

}  // namespace

template <class Out>
void UniformGridPlan::run_impl(Out* xyz) const {
  const int n = segments_;
  const size_t cols = static_cast<size_t>(n) + 1;
  const size_t per_patch = cols * cols;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, evals_.size()), [&](const tbb::blocked_range<size_t>& range) {
    // One row of homogeneous sums, structure of arrays so the column loops vectorise.
    std::vector<double> hx(cols), hy(cols), hz(cols), hw(cols);
    for (size_t p = range.begin(); p != range.end(); ++p) {
      grid_patch(evals_[p], tables_[p], unit_weight_[p] != 0, n, xyz + 3 * p * per_patch, hx.data(), hy.data(),
                 hz.data(), hw.data());
    }
  });
}

void UniformGridPlan::run(float* xyz) const { run_impl(xyz); }
void UniformGridPlan::run(double* xyz) const { run_impl(xyz); }

uint64_t uniform_grid_patch_vertices(int segments) {
  check_segments(segments);
  const uint64_t c = static_cast<uint64_t>(segments) + 1;
  return c * c;
}

uint64_t uniform_grid_vertices(const Model& model, int segments) {
  return uniform_grid_patch_vertices(segments) * model.patches.size();
}

std::vector<Triangle> uniform_grid_pattern(int segments) {
  check_segments(segments);
  const uint32_t c = static_cast<uint32_t>(segments) + 1;
  std::vector<Triangle> t;
  t.reserve(2 * static_cast<size_t>(segments) * static_cast<size_t>(segments));
  for (uint32_t a = 0; a + 1 < c; ++a) {
    for (uint32_t b = 0; b + 1 < c; ++b) {
      const uint32_t v00 = a * c + b, v10 = (a + 1) * c + b, v01 = a * c + b + 1, v11 = (a + 1) * c + b + 1;
      t.push_back({v00, v10, v11});
      t.push_back({v00, v11, v01});
    }
  }
  return t;
}

void tessellate_uniform_grid(const Model& model, int segments, float* xyz) { UniformGridPlan(model, segments).run(xyz); }
void tessellate_uniform_grid(const Model& model, int segments, double* xyz) { UniformGridPlan(model, segments).run(xyz); }

}  // namespace sagitta
