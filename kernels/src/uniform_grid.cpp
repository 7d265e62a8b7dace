#include "sagitta/uniform_grid.hpp"

#include "sagitta/evaluate.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <atomic>
#include <string>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#include <immintrin.h>
#endif

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
  std::array<std::array<int, kMaxDegree + 1>, 2> table_of, u_table_of;
  for (auto& t : table_of) t.fill(-1);
  for (auto& t : u_table_of) t.fill(-1);
  std::vector<int> u_index;
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
    // u-basis values of every grid row, row-major: values[a * (n+1) + i] = basis i at u = a / N
    // (basis_row's values, computed once per (basis kind, degree) instead of once per row).
    const int n = patch.degree_u;
    int& u_slot = u_table_of[eval.uses_power_basis() ? 1 : 0][static_cast<size_t>(n)];
    if (u_slot < 0) {
      std::vector<double> values(static_cast<size_t>(n + 1) * cols);
      double b[kMaxDegree + 1], db[kMaxDegree + 1];
      for (int a = 0; a <= segments; ++a) {
        eval.basis_row(n, static_cast<double>(a) / segments, b, db);
        for (int i = 0; i <= n; ++i)
          values[static_cast<size_t>(a) * static_cast<size_t>(n + 1) + static_cast<size_t>(i)] = b[i];
      }
      u_slot = static_cast<int>(table_store_.size());
      table_store_.push_back(std::move(values));
    }
    u_index.push_back(u_slot);
    // A polynomial patch in the power basis has homogeneous weight exactly 1 at every point
    // (weight coefficients 1, 0, ..., 0 and basis value 1 for the constant term), so the division
    // that PatchEvaluator::finish performs is the identity there and is skipped.
    unit_weight_.push_back(!patch.rational() && eval.uses_power_basis() ? 1 : 0);
  }
  // Pointers last: table_store_ no longer grows.
  table_store_.shrink_to_fit();
  size_t p = 0;
  tables_.resize(model.patches.size());
  u_tables_.resize(model.patches.size());
  for (const BezierPatch& patch : model.patches) {
    tables_[p] = table_store_[static_cast<size_t>(
                                  table_of[evals_[p].uses_power_basis() ? 1 : 0][static_cast<size_t>(patch.degree_v)])]
                     .data();
    u_tables_[p] = table_store_[static_cast<size_t>(u_index[p])].data();
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

// R_j = sum_i a_i K_ij for j = 0..m (sums from 0, i = 0..n): the same operations as
// PatchEvaluator::contract_u_position.
inline __attribute__((always_inline)) void contract_row(const std::array<double, 4>* k, int n, int m, const double* a,
                                                        std::array<double, 4>* row) {
  const size_t cols = static_cast<size_t>(m) + 1;
  for (size_t j = 0; j < cols; ++j) {
    std::array<double, 4> r{0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i <= n; ++i) {
      const std::array<double, 4>& kij = k[static_cast<size_t>(i) * cols + j];
      for (int q = 0; q < 4; ++q) r[q] += a[i] * kij[q];
    }
    row[j] = r;
  }
}

// One patch's (n+1)^2 grid positions, row by row, written interleaved (x, y, z) to `out`. `x`..`w`
// are scratch rows of n+1 doubles (used for v-degrees above 3). Every position is the same sequence of IEEE operations as
// PatchEvaluator::position (no fused multiply-add), so the output is bit-identical to it.
template <class Out>
inline __attribute__((always_inline)) void grid_patch_body(const detail::PatchEvaluator& eval, const double* table,
                                                           const double* u_table, bool unit_weight, int n, Out* out,
                                                           double* x, double* y, double* z, double* w) {
  const size_t cols = static_cast<size_t>(n) + 1;
  const int m = eval.degree_v(), du = eval.degree_u();
  const Vec3 o = eval.origin();
  std::array<double, 4> row[kMaxDegree + 1];
  for (int a = 0; a <= n; ++a) {
    contract_row(eval.coefficients(), du, m, u_table + static_cast<size_t>(a) * static_cast<size_t>(du + 1), row);
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
#define SAGITTA_GRID_AVX2 1
#else
#define SAGITTA_GRID_CLONES
#endif

SAGITTA_GRID_CLONES void grid_patch(const detail::PatchEvaluator& eval, const double* table, const double* u_table,
                                    bool unit_weight, int n, float* out, double* x, double* y, double* z, double* w) {
  grid_patch_body(eval, table, u_table, unit_weight, n, out, x, y, z, w);
}

SAGITTA_GRID_CLONES void grid_patch(const detail::PatchEvaluator& eval, const double* table, const double* u_table,
                                    bool unit_weight, int n, double* out, double* x, double* y, double* z, double* w) {
  grid_patch_body(eval, table, u_table, unit_weight, n, out, x, y, z, w);
}

#ifdef SAGITTA_GRID_AVX2
// The v-degrees 1 to 3 (power basis) written with AVX2 intrinsics: four grid columns per step, the homogeneous
// sums of each coordinate in one register, the result stored interleaved by shuffles (GCC's own
// vectorisation of grid_row_fixed stored the interleaved x, y, z one value at a time). Every value is
// the same IEEE operations in the same order as grid_row_fixed (sums from 0, basis j = 0..M, the
// origin added last; no FMA), so the output is the same bit for bit.

// Four positions (x, y, z each four lanes) stored interleaved as 12 values.
__attribute__((target("avx2"))) inline void store_interleaved(float* out, __m256d x, __m256d y, __m256d z) {
  const __m128 xs = _mm256_cvtpd_ps(x), ys = _mm256_cvtpd_ps(y), zs = _mm256_cvtpd_ps(z);
  const __m128 xy_lo = _mm_unpacklo_ps(xs, ys);                                   // x0 y0 x1 y1
  const __m128 zx_lo = _mm_unpacklo_ps(zs, xs);                                   // z0 x0 z1 x1
  const __m128 yz_lo = _mm_unpacklo_ps(ys, zs);                                   // y0 z0 y1 z1
  const __m128 xy_hi = _mm_unpackhi_ps(xs, ys);                                   // x2 y2 x3 y3
  const __m128 zx_hi = _mm_unpackhi_ps(zs, xs);                                   // z2 x2 z3 x3
  const __m128 yz_hi = _mm_unpackhi_ps(ys, zs);                                   // y2 z2 y3 z3
  _mm_storeu_ps(out, _mm_shuffle_ps(xy_lo, zx_lo, _MM_SHUFFLE(3, 0, 1, 0)));      // x0 y0 z0 x1
  _mm_storeu_ps(out + 4, _mm_shuffle_ps(yz_lo, xy_hi, _MM_SHUFFLE(1, 0, 3, 2)));  // y1 z1 x2 y2
  _mm_storeu_ps(out + 8, _mm_shuffle_ps(zx_hi, yz_hi, _MM_SHUFFLE(3, 2, 3, 0)));  // z2 x3 y3 z3
}

__attribute__((target("avx2"))) inline void store_interleaved(double* out, __m256d x, __m256d y, __m256d z) {
  const __m256d xy = _mm256_unpacklo_pd(x, y);                      // x0 y0 | x2 y2
  const __m256d zx = _mm256_shuffle_pd(z, x, 0b1010);               // z0 x1 | z2 x3
  const __m256d yz = _mm256_unpackhi_pd(y, z);                      // y1 z1 | y3 z3
  _mm256_storeu_pd(out, _mm256_permute2f128_pd(xy, zx, 0x20));      // x0 y0 z0 x1
  _mm256_storeu_pd(out + 4, _mm256_blend_pd(yz, xy, 0b1100));       // y1 z1 x2 y2
  _mm256_storeu_pd(out + 8, _mm256_permute2f128_pd(zx, yz, 0x31));  // z2 x3 y3 z3
}

template <int M, bool Unit, class Out>
__attribute__((target("avx2"))) inline void grid_patch_avx2_fixed(const detail::PatchEvaluator& eval,
                                                                  const double* table, const double* u_table, int n,
                                                                  Out* out) {
  const size_t cols = static_cast<size_t>(n) + 1, full = cols & ~size_t{3};
  const int du = eval.degree_u();
  const std::array<double, 4>* k = eval.coefficients();
  const Vec3 o = eval.origin();
  const __m256d ox = _mm256_set1_pd(o.x), oy = _mm256_set1_pd(o.y), oz = _mm256_set1_pd(o.z);
  for (int a = 0; a <= n; ++a) {
    const double* ua = u_table + static_cast<size_t>(a) * static_cast<size_t>(du + 1);
    std::array<double, 4> row[M + 1];
    __m256d rx[M + 1], ry[M + 1], rz[M + 1], rw[M + 1];
    for (int j = 0; j <= M; ++j) {
      __m256d r = _mm256_setzero_pd();
      for (int i = 0; i <= du; ++i) {
        r = _mm256_add_pd(
            r, _mm256_mul_pd(_mm256_set1_pd(ua[i]), _mm256_loadu_pd(k[static_cast<size_t>(i * (M + 1) + j)].data())));
      }
      _mm256_storeu_pd(row[j].data(), r);
      rx[j] = _mm256_permute4x64_pd(r, 0x00);
      ry[j] = _mm256_permute4x64_pd(r, 0x55);
      rz[j] = _mm256_permute4x64_pd(r, 0xAA);
      rw[j] = _mm256_permute4x64_pd(r, 0xFF);
    }
    // In the power basis the first v-basis value is 1 in every column, so the first step of each
    // sum, 0 + 1 * R_0, is the same number in every column: computed once per row.
    const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
    const __m256d x0 = _mm256_add_pd(zero, _mm256_mul_pd(one, rx[0]));
    const __m256d y0 = _mm256_add_pd(zero, _mm256_mul_pd(one, ry[0]));
    const __m256d z0 = _mm256_add_pd(zero, _mm256_mul_pd(one, rz[0]));
    const __m256d w0 = _mm256_add_pd(zero, _mm256_mul_pd(one, rw[0]));
    size_t c = 0;
    for (; c < full; c += 4) {
      __m256d x = x0, y = y0, z = z0, w = w0;
      for (int j = 1; j <= M; ++j) {
        const __m256d b = _mm256_loadu_pd(table + static_cast<size_t>(j) * cols + c);
        x = _mm256_add_pd(x, _mm256_mul_pd(b, rx[j]));
        y = _mm256_add_pd(y, _mm256_mul_pd(b, ry[j]));
        z = _mm256_add_pd(z, _mm256_mul_pd(b, rz[j]));
        if (!Unit) w = _mm256_add_pd(w, _mm256_mul_pd(b, rw[j]));
      }
      if (Unit) {
        store_interleaved(out + 3 * c, _mm256_add_pd(ox, x), _mm256_add_pd(oy, y), _mm256_add_pd(oz, z));
      } else {
        store_interleaved(out + 3 * c, _mm256_add_pd(ox, _mm256_div_pd(x, w)), _mm256_add_pd(oy, _mm256_div_pd(y, w)),
                          _mm256_add_pd(oz, _mm256_div_pd(z, w)));
      }
    }
    for (; c < cols; ++c) {  // the last n+1 mod 4 columns as grid_row_fixed computes them
      double x = 0.0, y = 0.0, z = 0.0, w = 0.0;
      for (int j = 0; j <= M; ++j) {
        const double b = table[static_cast<size_t>(j) * cols + c];
        x += b * row[j][0];
        y += b * row[j][1];
        z += b * row[j][2];
        if (!Unit) w += b * row[j][3];
      }
      if (!Unit) x /= w, y /= w, z /= w;
      out[3 * c + 0] = static_cast<Out>(o.x + x);
      out[3 * c + 1] = static_cast<Out>(o.y + y);
      out[3 * c + 2] = static_cast<Out>(o.z + z);
    }
    out += 3 * cols;
  }
}

template <class Out>
__attribute__((target("avx2"))) void grid_patch_avx2(const detail::PatchEvaluator& eval, const double* table,
                                                     const double* u_table, bool unit_weight, int n, Out* out) {
  switch (eval.degree_v() * 2 + (unit_weight ? 1 : 0)) {
    case 2:
      grid_patch_avx2_fixed<1, false>(eval, table, u_table, n, out);
      break;
    case 3:
      grid_patch_avx2_fixed<1, true>(eval, table, u_table, n, out);
      break;
    case 4:
      grid_patch_avx2_fixed<2, false>(eval, table, u_table, n, out);
      break;
    case 5:
      grid_patch_avx2_fixed<2, true>(eval, table, u_table, n, out);
      break;
    case 6:
      grid_patch_avx2_fixed<3, false>(eval, table, u_table, n, out);
      break;
    default:
      grid_patch_avx2_fixed<3, true>(eval, table, u_table, n, out);
      break;
  }
}

// The same with AVX-512 (F and VL): eight grid columns per step, the interleaving by two-source
// permutes. Same operations per value as grid_row_fixed again (no FMA is enabled), so the same bits.
#define SAGITTA_AVX512 __attribute__((target("avx512f,avx512vl")))
// GCC 12's _mm512_cvtpd_ps reads an undefined pass-through vector on purpose.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// Lane indices that interleave eight (x, y, z) into three vectors: from x and y (two-source permute,
// y's lanes numbered from 8), then z's lanes under a mask.
struct Interleave8 {
  int xy[3][8], z[3][8];
  unsigned mask[3];
};
constexpr Interleave8 kInterleave8 = {
    {{0, 8, 0, 1, 9, 0, 2, 10}, {0, 3, 11, 0, 4, 12, 0, 5}, {13, 0, 6, 14, 0, 7, 15, 0}},
    {{0, 0, 0, 0, 0, 1, 0, 0}, {2, 0, 0, 3, 0, 0, 4, 0}, {0, 5, 0, 0, 6, 0, 0, 7}},
    {0x24, 0x49, 0x92}};

SAGITTA_AVX512 inline void store_interleaved8(float* out, __m512d x, __m512d y, __m512d z) {
  const __m256 xs = _mm512_cvtpd_ps(x), ys = _mm512_cvtpd_ps(y), zs = _mm512_cvtpd_ps(z);
  for (int k = 0; k < 3; ++k) {
    const __m256i xy = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(kInterleave8.xy[k]));
    const __m256i zi = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(kInterleave8.z[k]));
    const __m256 v = _mm256_permutex2var_ps(xs, xy, ys);
    _mm256_storeu_ps(out + 8 * k, _mm256_mask_permutexvar_ps(v, static_cast<__mmask8>(kInterleave8.mask[k]), zi, zs));
  }
}

SAGITTA_AVX512 inline void store_interleaved8(double* out, __m512d x, __m512d y, __m512d z) {
  for (int k = 0; k < 3; ++k) {
    const __m512i xy = _mm512_cvtepi32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(kInterleave8.xy[k])));
    const __m512i zi = _mm512_cvtepi32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(kInterleave8.z[k])));
    const __m512d v = _mm512_permutex2var_pd(x, xy, y);
    _mm512_storeu_pd(out + 8 * k, _mm512_mask_permutexvar_pd(v, static_cast<__mmask8>(kInterleave8.mask[k]), zi, z));
  }
}

template <int M, bool Unit, class Out>
SAGITTA_AVX512 inline void grid_patch_avx512_fixed(const detail::PatchEvaluator& eval, const double* table,
                                                   const double* u_table, int n, Out* out) {
  const size_t cols = static_cast<size_t>(n) + 1, full = cols & ~size_t{7};
  const int du = eval.degree_u();
  const std::array<double, 4>* k = eval.coefficients();
  const Vec3 o = eval.origin();
  const __m512d ox = _mm512_set1_pd(o.x), oy = _mm512_set1_pd(o.y), oz = _mm512_set1_pd(o.z);
  for (int a = 0; a <= n; ++a) {
    const double* ua = u_table + static_cast<size_t>(a) * static_cast<size_t>(du + 1);
    std::array<double, 4> row[M + 1];
    for (int j = 0; j <= M; ++j) {  // contract_row's operations, one point per register
      __m256d r = _mm256_setzero_pd();
      for (int i = 0; i <= du; ++i) {
        r = _mm256_add_pd(
            r, _mm256_mul_pd(_mm256_set1_pd(ua[i]), _mm256_loadu_pd(k[static_cast<size_t>(i * (M + 1) + j)].data())));
      }
      _mm256_storeu_pd(row[j].data(), r);
    }
    __m512d rx[M + 1], ry[M + 1], rz[M + 1], rw[M + 1];
    for (int j = 0; j <= M; ++j) {
      rx[j] = _mm512_set1_pd(row[j][0]);
      ry[j] = _mm512_set1_pd(row[j][1]);
      rz[j] = _mm512_set1_pd(row[j][2]);
      rw[j] = _mm512_set1_pd(row[j][3]);
    }
    // Power basis: the first v-basis value is 1 in every column (see grid_patch_avx2_fixed).
    const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
    const __m512d x0 = _mm512_add_pd(zero, _mm512_mul_pd(one, rx[0]));
    const __m512d y0 = _mm512_add_pd(zero, _mm512_mul_pd(one, ry[0]));
    const __m512d z0 = _mm512_add_pd(zero, _mm512_mul_pd(one, rz[0]));
    const __m512d w0 = _mm512_add_pd(zero, _mm512_mul_pd(one, rw[0]));
    size_t c = 0;
    for (; c < full; c += 8) {
      __m512d x = x0, y = y0, z = z0, w = w0;
      for (int j = 1; j <= M; ++j) {
        const __m512d b = _mm512_loadu_pd(table + static_cast<size_t>(j) * cols + c);
        x = _mm512_add_pd(x, _mm512_mul_pd(b, rx[j]));
        y = _mm512_add_pd(y, _mm512_mul_pd(b, ry[j]));
        z = _mm512_add_pd(z, _mm512_mul_pd(b, rz[j]));
        if (!Unit) w = _mm512_add_pd(w, _mm512_mul_pd(b, rw[j]));
      }
      if (Unit) {
        store_interleaved8(out + 3 * c, _mm512_add_pd(ox, x), _mm512_add_pd(oy, y), _mm512_add_pd(oz, z));
      } else {
        store_interleaved8(out + 3 * c, _mm512_add_pd(ox, _mm512_div_pd(x, w)), _mm512_add_pd(oy, _mm512_div_pd(y, w)),
                           _mm512_add_pd(oz, _mm512_div_pd(z, w)));
      }
    }
    for (; c < cols; ++c) {  // the last n+1 mod 8 columns as grid_row_fixed computes them
      double x = 0.0, y = 0.0, z = 0.0, w = 0.0;
      for (int j = 0; j <= M; ++j) {
        const double b = table[static_cast<size_t>(j) * cols + c];
        x += b * row[j][0];
        y += b * row[j][1];
        z += b * row[j][2];
        if (!Unit) w += b * row[j][3];
      }
      if (!Unit) x /= w, y /= w, z /= w;
      out[3 * c + 0] = static_cast<Out>(o.x + x);
      out[3 * c + 1] = static_cast<Out>(o.y + y);
      out[3 * c + 2] = static_cast<Out>(o.z + z);
    }
    out += 3 * cols;
  }
}

template <class Out>
SAGITTA_AVX512 void grid_patch_avx512(const detail::PatchEvaluator& eval, const double* table, const double* u_table,
                                      bool unit_weight, int n, Out* out) {
  switch (eval.degree_v() * 2 + (unit_weight ? 1 : 0)) {
    case 2:
      grid_patch_avx512_fixed<1, false>(eval, table, u_table, n, out);
      break;
    case 3:
      grid_patch_avx512_fixed<1, true>(eval, table, u_table, n, out);
      break;
    case 4:
      grid_patch_avx512_fixed<2, false>(eval, table, u_table, n, out);
      break;
    case 5:
      grid_patch_avx512_fixed<2, true>(eval, table, u_table, n, out);
      break;
    case 6:
      grid_patch_avx512_fixed<3, false>(eval, table, u_table, n, out);
      break;
    default:
      grid_patch_avx512_fixed<3, true>(eval, table, u_table, n, out);
      break;
  }
}
#endif

}  // namespace

namespace detail {

namespace {
std::atomic<int> forced_grid_kernel{-1};
}

GridKernel best_grid_kernel() {
#ifdef SAGITTA_GRID_AVX2
  static const GridKernel best = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl")
                                     ? GridKernel::kAvx512
                                 : __builtin_cpu_supports("avx2") ? GridKernel::kAvx2
                                                                  : GridKernel::kGeneric;
  return best;
#else
  return GridKernel::kGeneric;
#endif
}

GridKernel grid_kernel() {
  const int forced = forced_grid_kernel.load(std::memory_order_relaxed);
  return forced < 0 ? best_grid_kernel() : static_cast<GridKernel>(forced);
}

bool force_grid_kernel(GridKernel kernel) {
  if (static_cast<int>(kernel) > static_cast<int>(best_grid_kernel())) return false;
  forced_grid_kernel.store(static_cast<int>(kernel), std::memory_order_relaxed);
  return true;
}

void reset_grid_kernel() { forced_grid_kernel.store(-1, std::memory_order_relaxed); }

}  // namespace detail

template <class Out>
void UniformGridPlan::run_impl(Out* xyz) const {
  const detail::GridKernel kernel = detail::grid_kernel();
  const int n = segments_;
  const size_t cols = static_cast<size_t>(n) + 1;
  const size_t per_patch = cols * cols;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, evals_.size()), [&](const tbb::blocked_range<size_t>& range) {
    // One row of homogeneous sums, structure of arrays so the column loops vectorise.
    std::vector<double> hx(cols), hy(cols), hz(cols), hw(cols);
    for (size_t p = range.begin(); p != range.end(); ++p) {
      const detail::PatchEvaluator& eval = evals_[p];
      Out* out = xyz + 3 * p * per_patch;
#ifdef SAGITTA_GRID_AVX2
      if (kernel != detail::GridKernel::kGeneric && eval.uses_power_basis() && eval.degree_v() >= 1 &&
          eval.degree_v() <= 3) {
        if (kernel == detail::GridKernel::kAvx512) {
          grid_patch_avx512(eval, tables_[p], u_tables_[p], unit_weight_[p] != 0, n, out);
        } else {
          grid_patch_avx2(eval, tables_[p], u_tables_[p], unit_weight_[p] != 0, n, out);
        }
        continue;
      }
#endif
      grid_patch(eval, tables_[p], u_tables_[p], unit_weight_[p] != 0, n, out, hx.data(), hy.data(), hz.data(),
                 hw.data());
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
