// Certified distance between a tessellation and its Bézier surfaces (see docs/VALIDATION.md).
#include "sagitta/certify.hpp"

#include "conditioning.hpp"
#include "interpolation_bound.hpp"
#include "mesh_distance.hpp"
#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"
#include "sagitta/homogeneous.hpp"

#include <CGAL/box_intersection_d.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <tuple>
#include <type_traits>
#include <unordered_map>
#include <vector>

// V4 and HVector values pass only between always-inlined functions (see V4 below).
#pragma GCC diagnostic ignored "-Wpsabi"

namespace sagitta {

namespace {

using H = std::array<double, 4>;
constexpr double kUnit = std::numeric_limits<double>::epsilon() / 2;  // unit roundoff u = 2^-53
constexpr double kInf = std::numeric_limits<double>::infinity();

// |(x, y, z)| without spurious underflow or overflow in the squares: a vector far from unit size is
// scaled by a power of two (exact) first, so the result is within a few units of rounding at any
// magnitude (a plain sqrt of squares returns 0 for components below 1e-154, which would turn a
// bound into a false certificate).
double norm(double x, double y, double z) {
  const double m = std::max({std::abs(x), std::abs(y), std::abs(z)});
  if (m > 0x1p-500 && m < 0x1p500) return std::sqrt(x * x + y * y + z * z);
  if (!(m > 0.0) || !std::isfinite(m)) return std::isnan(x + y + z) ? std::numeric_limits<double>::quiet_NaN() : m;
  const int e = std::ilogb(m);
  x = std::ldexp(x, -e);
  y = std::ldexp(y, -e);
  z = std::ldexp(z, -e);
  return std::ldexp(std::sqrt(x * x + y * y + z * z), e);
}
double norm(const Vec3& v) { return norm(v.x, v.y, v.z); }

// The largest norm() of the vectors added, with one square root for those in norm()'s plain range
// (sqrt is monotone, so the largest root is the root of the largest sum): the same value.
struct MaxNorm {
  double squares = 0.0, other = 0.0;
  void add(const Vec3& v) {
    const double m = std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
    if (m > 0x1p-500 && m < 0x1p500) {
      squares = std::max(squares, v.x * v.x + v.y * v.y + v.z * v.z);
    } else {
      other = std::max(other, norm(v));
    }
  }
  double value() const { return std::max(other, std::sqrt(squares)); }
};
double norm(const Vec2& v) { return glm::length(v); }

// A homogeneous point in one vector (GCC/Clang vector extension) for composed_bound's blossoms:
// one register in its AVX2 clone, two in the default one. Its operations are per component, the
// same as on H (no multiply-add is fused: the targets used do not enable FMA), so the values are
// bit for bit those of the scalar code. Only there: in code compiled for SSE2 alone, the
// evaluations with V4 ran slower than the scalar loops (GCC's lowering of 32-byte vectors).
// (Always inlined, so no V4 crosses a call: GCC's note that AVX vectors change the ABI, ignored
// for this file at its top, is moot; so for sagitta/homogeneous.hpp's HVector.)
typedef double V4 __attribute__((vector_size(32)));
[[gnu::always_inline]] inline V4 load(const H& h) {
  V4 v;
  std::memcpy(&v, h.data(), sizeof v);
  return v;
}
[[gnu::always_inline]] inline H store(const V4& v) {
  H h;
  std::memcpy(h.data(), &v, sizeof v);
  return h;
}

[[gnu::always_inline]] inline H lerp(const H& a, const H& b, double t) {
  const double s = 1.0 - t;
  return {s * a[0] + t * b[0], s * a[1] + t * b[1], s * a[2] + t * b[2], s * a[3] + t * b[3]};
}

double norm3(const H& h) { return norm(h[0], h[1], h[2]); }

// A patch moved so its first control point is the origin (for project_shifted).
BezierPatch shifted_patch(const BezierPatch& patch) {
  BezierPatch shifted = patch;
  for (Vec3& p : shifted.points) p -= patch.points[0];
  return shifted;
}

// Per patch data: homogeneous control points relative to a local origin and the magnitudes the
// rounding bound needs.
struct PatchData {
  const BezierPatch* patch = nullptr;
  int n = 0, m = 0;
  Vec3 origin{0.0};
  std::vector<H> h;  // (w (P - o), w), row-major like the patch
  double hmag = 0.0;  // max |w (P - o)|
  double wmin = 1.0, wmax = 1.0;
  double lipschitz = 0.0;  // >= max |dS/du| + |dS/dv| over the domain
  BezierPatch shifted;     // the patch moved so its first control point is the origin (project_shifted)
  // Projection of x onto the patch seeded at q: project() without copying the patch.
  Vec2 project(const Vec3& x, Vec2 q) const;
  // Projection of x onto the patch's curve over the (u, v) segment from a to b, seeded at a + t (b - a).
  Vec2 project_on_segment(const Vec3& x, Vec2 a, Vec2 b, double t) const;
  // A bound on |eval(*patch, q) - S(q)|, the rounding of the de Casteljau evaluation below.
  double eval_rounding() const { return 4.0 * (n + m + 2) * kUnit * (hmag / wmin + norm(origin)) * wmax / wmin; }
};

PatchData make_patch_data(const BezierPatch& patch) {
  PatchData d;
  d.patch = &patch;
  d.n = patch.degree_u;
  d.m = patch.degree_v;
  d.origin = control_box(patch).center();
  d.wmin = kInf;
  d.wmax = 0.0;
  for (int i = 0; i <= d.n; ++i) {
    for (int j = 0; j <= d.m; ++j) {
      const double w = patch.weight(i, j);
      const Vec3 p = patch.at(i, j) - d.origin;
      d.h.push_back({w * p.x, w * p.y, w * p.z, w});
      d.hmag = std::max(d.hmag, w * norm(p));
      d.wmin = std::min(d.wmin, w);
      d.wmax = std::max(d.wmax, w);
    }
  }
  // dS/du = (N_u - (S - o) W_u) / W with N = sum w (P - o) B: |N_u| <= n max |Δ_u (w (P - o))|,
  // |W_u| <= n max |Δ_u w|, |S - o| <= max |P - o|.
  double rmax = 0.0;
  for (const Vec3& p : patch.points) rmax = std::max(rmax, norm(p - d.origin));
  auto at = [&](int i, int j) { return d.h[static_cast<size_t>(i * (d.m + 1) + j)]; };
  double du = 0.0, dv = 0.0;
  for (int i = 0; i <= d.n; ++i) {
    for (int j = 0; j <= d.m; ++j) {
      if (i < d.n) {
        const H a = at(i, j), b = at(i + 1, j);
        const H diff{b[0] - a[0], b[1] - a[1], b[2] - a[2], b[3] - a[3]};
        du = std::max(du, d.n * (norm3(diff) + rmax * std::abs(diff[3])) / d.wmin);
      }
      if (j < d.m) {
        const H a = at(i, j), b = at(i, j + 1);
        const H diff{b[0] - a[0], b[1] - a[1], b[2] - a[2], b[3] - a[3]};
        dv = std::max(dv, d.m * (norm3(diff) + rmax * std::abs(diff[3])) / d.wmin);
      }
    }
  }
  d.lipschitz = (du + dv) * (1.0 + 1e-12);
  d.shifted = shifted_patch(patch);
  return d;
}

// Triples (a0, a1, a2) with a0 + a1 + a2 = s, in a fixed order; index(a0, a1) finds one.
struct Triples {
  int s = 0;
  std::vector<std::array<int, 3>> list;
  std::vector<int> index;  // (a0 * (s + 1) + a1) -> position
  explicit Triples(int total = 0) : s(total), index(static_cast<size_t>((total + 1) * (total + 1)), -1) {
    for (int a0 = 0; a0 <= s; ++a0) {
      for (int a1 = 0; a0 + a1 <= s; ++a1) {
        index[static_cast<size_t>(a0 * (s + 1) + a1)] = static_cast<int>(list.size());
        list.push_back({a0, a1, s - a0 - a1});
      }
    }
  }
  int at(int a0, int a1) const { return index[static_cast<size_t>(a0 * (s + 1) + a1)]; }
};

// Binomial coefficients C(a, b) for a <= 2 kMaxDegree + 1, the values of binomial() (exact integers).
struct BinomialTable {
  static constexpr int kSize = 2 * kMaxDegree + 2;
  std::array<double, kSize * kSize> c{};
  BinomialTable() {
    for (int a = 0; a < kSize; ++a) {
      for (int b = 0; b < kSize; ++b) c[static_cast<size_t>(a * kSize + b)] = binomial(a, b);
    }
  }
  double operator()(int a, int b) const { return c[static_cast<size_t>(a * kSize + b)]; }
};
const BinomialTable& binomials() {
  static const BinomialTable table;
  return table;
}

// The index tables of the composition for patch degrees (n, m): built once per degree pair for
// the whole process (read-only afterwards, shared by all threads).
struct DegreeTables {
  Triples tu, tv, tn, tn1;  // degrees n, m, n + m, n + m + 1
  // Per degree-(n + m) triple: the blossom values (indices into Scratch::r) and Vandermonde weights
  // it sums.
  std::vector<std::vector<std::pair<size_t, double>>> terms;
  DegreeTables(int n, int m) : tu(n), tv(m), tn(n + m), tn1(n + m + 1) {
    const BinomialTable& binomial = binomials();
    const double inv_total = 1.0 / binomial(n + m, n);
    terms.assign(tn.list.size(), {});
    for (size_t g = 0; g < tn.list.size(); ++g) {
      const auto& al = tn.list[g];
      for (int a0 = 0; a0 <= std::min(al[0], n); ++a0) {
        for (int a1 = 0; a1 <= std::min(al[1], n - a0); ++a1) {
          const int a2 = n - a0 - a1;
          if (a2 > al[2]) continue;
          const double wgt = binomial(al[0], a0) * binomial(al[1], a1) * binomial(al[2], a2) * inv_total;
          const size_t index = static_cast<size_t>(tu.at(a0, a1)) * tv.list.size() + static_cast<size_t>(tv.at(al[0] - a0, al[1] - a1));
          terms[g].emplace_back(index, wgt);
        }
      }
    }
  }
};

const DegreeTables& degree_tables(int n, int m) {
  static std::mutex mutex;
  static std::array<std::unique_ptr<DegreeTables>, (kMaxDegree + 1) * (kMaxDegree + 1)> tables;
  const std::lock_guard<std::mutex> lock(mutex);
  auto& t = tables[static_cast<size_t>(n * (kMaxDegree + 1) + m)];
  if (!t) t = std::make_unique<DegreeTables>(n, m);
  return *t;
}

// Scratch space reused across triangles by one thread.
struct Scratch {
  int n = -1, m = -1;
  const DegreeTables* t = nullptr;  // of degrees (n, m)
  std::vector<H> qa;                // per u-triple: m + 1 points
  std::vector<H> r;                 // per (u-triple, v-triple): the blossom value
  std::vector<H> coef;              // per degree-(n + m) triple
  // coef holds the composition of `coef_patch` with the (u, v) triangle coef_q (wmin_poly its
  // smallest weight coefficient): a repeated composed_bound over the same (u, v) reuses it.
  const PatchData* coef_patch = nullptr;
  Vec2 coef_q[3];
  double coef_wmin = 0.0;
  void prepare(int n_, int m_) {
    if (n == n_ && m == m_) return;
    n = n_;
    m = m_;
    t = &degree_tables(n, m);
    qa.assign(t->tu.list.size() * static_cast<size_t>(m + 1), H{});
    r.assign(t->tu.list.size() * t->tv.list.size(), H{});
    coef.assign(t->tn.list.size(), H{});
    coef_patch = nullptr;
  }
};

// One de Casteljau level with argument t from points src[0 .. count] into dst[0 .. count - 1]
// (dst may be src): lerp's operations on V4 registers.
[[gnu::always_inline]] inline void casteljau_level(const V4* src, V4* dst, int count, double t) {
  const double s = 1.0 - t;
  const V4 sv = {s, s, s, s}, tv = {t, t, t, t};
  for (int i = 0; i < count; ++i) dst[i] = sv * src[i] + tv * src[i + 1];
}

// The blossom of the degree-d points `pts` at every argument list x0^a0 x1^a1 x2^(d - a0 - a1), in
// the order of Triples(d), into out[stride * k] (k the triple's position). Each value is the
// de Casteljau evaluation with the arguments in that order; the levels of a shared prefix (x0^a0,
// then x0^a0 x1^a1) are computed once, so every value is bit for bit the plain evaluation's.
[[gnu::always_inline]] inline void blossom_all_any(const H* pts, int d, const double x[3], H* out, size_t stride) {
  V4 p[kMaxDegree + 1], w0[kMaxDegree + 1], w1[kMaxDegree + 1], w2[kMaxDegree + 1];
  for (int i = 0; i <= d; ++i) p[i] = load(pts[i]);
  size_t k = 0;
  const V4* prefix0 = p;  // after x0^a0
  for (int a0 = 0; a0 <= d; ++a0) {
    if (a0 > 0) casteljau_level(prefix0, w0, d + 1 - a0, x[0]), prefix0 = w0;
    const V4* prefix1 = prefix0;  // after x0^a0 x1^a1
    for (int a1 = 0; a0 + a1 <= d; ++a1) {
      if (a1 > 0) casteljau_level(prefix1, w1, d + 1 - a0 - a1, x[1]), prefix1 = w1;
      const V4* tail = prefix1;
      for (int level = a0 + a1 + 1; level <= d; ++level) casteljau_level(tail, w2, d + 1 - level, x[2]), tail = w2;
      out[stride * k++] = store(tail[0]);
    }
  }
}

// blossom_all_any for a degree D known at compile time: the same operations in the same order, on
// local arrays that the compiler unrolls and keeps in registers.
template <int D>
[[gnu::always_inline]] inline void blossom_all_fixed(const H* pts, const double x[3], H* out, size_t stride) {
  const double s0 = 1.0 - x[0], s1 = 1.0 - x[1], s2 = 1.0 - x[2], t0 = x[0], t1 = x[1], t2 = x[2];
  const V4 sv[3] = {{s0, s0, s0, s0}, {s1, s1, s1, s1}, {s2, s2, s2, s2}};
  const V4 tv[3] = {{t0, t0, t0, t0}, {t1, t1, t1, t1}, {t2, t2, t2, t2}};
  V4 p0[D + 1];
#pragma GCC unroll 8
  for (int i = 0; i <= D; ++i) p0[i] = load(pts[i]);
  size_t k = 0;
#pragma GCC unroll 8
  for (int a0 = 0; a0 <= D; ++a0) {
    if (a0 > 0) {
#pragma GCC unroll 8
      for (int i = 0; i < D + 1 - a0; ++i) p0[i] = sv[0] * p0[i] + tv[0] * p0[i + 1];
    }
    V4 p1[D + 1];
#pragma GCC unroll 8
    for (int i = 0; i <= D; ++i) p1[i] = p0[i];
#pragma GCC unroll 8
    for (int a1 = 0; a0 + a1 <= D; ++a1) {
      if (a1 > 0) {
#pragma GCC unroll 8
        for (int i = 0; i < D + 1 - a0 - a1; ++i) p1[i] = sv[1] * p1[i] + tv[1] * p1[i + 1];
      }
      V4 p2[D + 1];
#pragma GCC unroll 8
      for (int i = 0; i <= D; ++i) p2[i] = p1[i];
#pragma GCC unroll 8
      for (int level = a0 + a1 + 1; level <= D; ++level) {
#pragma GCC unroll 8
        for (int i = 0; i < D + 1 - level; ++i) p2[i] = sv[2] * p2[i] + tv[2] * p2[i + 1];
      }
      out[stride * k++] = store(p2[0]);
    }
  }
}

[[gnu::always_inline]] inline void blossom_all(const H* pts, int d, const double x[3], H* out, size_t stride) {
  switch (d) {
    case 1:
      return blossom_all_fixed<1>(pts, x, out, stride);
    case 2:
      return blossom_all_fixed<2>(pts, x, out, stride);
    case 3:
      return blossom_all_fixed<3>(pts, x, out, stride);
    default:
      return blossom_all_any(pts, d, x, out, stride);
  }
}

// u-blossom of every column for each u-triple, then the v-blossom of those for each (u-triple,
// v-triple), into s.r.
[[gnu::always_inline]] inline void blossom(const PatchData& P, const Vec2 q[3], Scratch& s) {
  const int n = P.n, m = P.m;
  const size_t nu = s.t->tu.list.size(), nv = s.t->tv.list.size();
  const double xu[3] = {q[0].x, q[1].x, q[2].x}, xv[3] = {q[0].y, q[1].y, q[2].y};
  H column[kMaxDegree + 1];
  for (int j = 0; j <= m; ++j) {
    for (int i = 0; i <= n; ++i) column[i] = P.h[static_cast<size_t>(i * (m + 1) + j)];
    blossom_all(column, n, xu, &s.qa[static_cast<size_t>(j)], static_cast<size_t>(m + 1));
  }
  for (size_t a = 0; a < nu; ++a) blossom_all(&s.qa[a * (m + 1)], m, xv, &s.r[a * nv], 1);
}

// Triangular coefficients of degree n + m from the blossom values (into s.coef); returns the
// smallest weight coefficient.
[[gnu::always_inline]] inline double triangular_coefficients(Scratch& s) {
  double wmin_poly = kInf;
  for (size_t g = 0; g < s.t->tn.list.size(); ++g) {
    V4 acc = {0, 0, 0, 0};
    for (const auto& [index, wgt] : s.t->terms[g]) {
      const V4 w = {wgt, wgt, wgt, wgt};
      acc += w * load(s.r[index]);
    }
    s.coef[g] = store(acc);
    wmin_poly = std::min(wmin_poly, acc[3]);
  }
  return wmin_poly;
}

// The core bound: Bernstein coefficients of S(sum b_i q_i) - sum b_i X_i over the triangle by
// blossoming. The tensor-product blossom with i copies of corner 0, j of corner 1 and k of corner 2
// split into n u-arguments and m v-arguments (averaged over all splits, Vandermonde weights) gives
// the triangular Bernstein coefficient c_ijk of the composition, exactly in exact arithmetic.
//
// On x86-64 with GCC it is also compiled for AVX2 (a homogeneous point in one register instead of
// two), with blossom() inlined, and picked at load time by the CPU; "fma" is not enabled, so no
// multiply-add is fused and the bound is bit for bit the same on every CPU.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define SAGITTA_BOUND_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define SAGITTA_BOUND_CLONES
#endif
SAGITTA_BOUND_CLONES double composed_bound(const PatchData& P, const Vec2 q[3], const Vec3 X[3], Scratch& s) {
  const int n = P.n, m = P.m, N = n + m;
  s.prepare(n, m);
  if (s.coef_patch != &P || s.coef_q[0] != q[0] || s.coef_q[1] != q[1] || s.coef_q[2] != q[2]) {
    blossom(P, q, s);
    s.coef_wmin = triangular_coefficients(s);
    s.coef_patch = &P;
    std::copy(q, q + 3, s.coef_q);
  }
  double wmin_poly = s.coef_wmin;
  Vec3 Xl[3];
  double xmag = 0.0;
  for (int l = 0; l < 3; ++l) {
    Xl[l] = X[l] - P.origin;
    xmag = std::max(xmag, norm(Xl[l]));
  }
  MaxNorm largest;
  double emax = 0.0;
  if (!P.patch->rational()) {
    // e_ijk = c_ijk - (i X0 + j X1 + k X2) / N  (the affine part degree-elevated to N, exactly).
    for (size_t g = 0; g < s.t->tn.list.size(); ++g) {
      const auto& al = s.t->tn.list[g];
      const Vec3 lin = (double(al[0]) * Xl[0] + double(al[1]) * Xl[1] + double(al[2]) * Xl[2]) / double(N);
      const Vec3 e(s.coef[g][0] - lin.x, s.coef[g][1] - lin.y, s.coef[g][2] - lin.z);
      largest.add(e);
    }
    emax = largest.value();
    wmin_poly = 1.0;
  } else {
    // N(b) - W(b) X(b) has degree N + 1: E_g = sum_l g_l / (N + 1) (Nc_{g - e_l} - Wc_{g - e_l} X_l).
    const Triples& t1 = s.t->tn;  // degree N indices
    const Triples& up = s.t->tn1;
    for (const auto& g : up.list) {
      Vec3 e(0.0);
      for (int l = 0; l < 3; ++l) {
        if (g[l] == 0) continue;
        std::array<int, 3> h = g;
        --h[l];
        const H& c = s.coef[static_cast<size_t>(t1.at(h[0], h[1]))];
        e += (double(g[l]) / double(N + 1)) * (Vec3(c[0], c[1], c[2]) - c[3] * Xl[l]);
      }
      largest.add(e);
    }
    emax = largest.value();
    if (!(wmin_poly > 0.0)) return kInf;
    emax /= wmin_poly;
  }
  // Rounding: every coefficient is a chain of at most N lerps (convex combinations, args in [0, 1])
  // and one weighted sum; each step errs by at most 3u times the magnitudes involved. The constant
  // 8 (N + 4) is a margin of more than 2 over that count; see docs/VALIDATION.md.
  const double rounding = 8.0 * (N + 4) * kUnit * (P.hmag + P.wmax * xmag) / std::min(wmin_poly, P.wmin) +
                          4.0 * kUnit * P.lipschitz;
  const double bound = emax * (1.0 + 4.0 * kUnit) + rounding;
  return bound >= 0.0 ? bound : kInf;  // NaN (an overflow on the way) proves nothing
}

// The first of the points candidate(1), candidate(1/2), ... candidate(2^-19) that is closer to x
// than `best`: best, q and e take its distance, parameters and evaluation, and its scale is
// returned; 0 when none is closer (they keep theirs).
template <class Candidate>
double closer_by_halving(const BezierPatch& patch, const Vec3& x, Candidate candidate, double& best, Vec2& q,
                         SurfacePointEval& e) {
  for (int half = 0; half < 20; ++half) {
    const double scale = std::ldexp(1.0, -half);
    const Vec2 next = candidate(scale);
    const SurfacePointEval ne = evaluate_with_derivatives(patch, next.x, next.y);
    const double d = norm(x - ne.position);
    if (d < best) {
      best = d;
      q = next;
      e = ne;
      return scale;
    }
  }
  return 0.0;
}

// Damped Gauss-Newton projection of x onto the patch, seeded at q, clamped to the domain; a step is
// accepted only when it brings the point closer (halved otherwise), so the result is never worse
// than the seed (beyond rounding, in the final steps below). Any result is acceptable to the
// callers (they only need some surface point).
//
// Iterates on the patch moved so its first control point is the origin (`patch`, with x moved
// alike): in absolute coordinates far from the origin (1e8) the evaluation noise (~ulp(|x|)) stalls
// the descent test well before the projection, and the bounds built on the result then change with
// a translation of the model. Any parameters are sound; this makes them (nearly) translation
// invariant.
Vec2 project_shifted(const BezierPatch& patch, const Vec3& x, Vec2 q) {
  SurfacePointEval e = evaluate_with_derivatives(patch, q.x, q.y);
  double best = norm(x - e.position);
  for (int it = 0; it < 12; ++it) {
    const Vec3 r = x - e.position;
    const double a = glm::dot(e.du, e.du), b = glm::dot(e.du, e.dv), c = glm::dot(e.dv, e.dv);
    const double det = a * c - b * b;
    if (!(det > 1e-300)) break;
    const double ru = glm::dot(e.du, r), rv = glm::dot(e.dv, r);
    Vec2 step((c * ru - b * rv) / det, (a * rv - b * ru) / det);
    // A parameter on a side of the domain where the distance decreases outwards (the gradient
    // (r . du, r . dv) points out) is held there (active set): the step is then the 1D
    // Gauss-Newton step in the other parameter, so a point beyond a side slides along it to its
    // nearest point instead of stalling where the clamped 2D step fails.
    const auto held = [](double t, double g) { return (t <= 0.0 && g < 0.0) || (t >= 1.0 && g > 0.0); };
    const bool hold_u = held(q.x, ru), hold_v = held(q.y, rv);
    if (hold_u && hold_v) break;
    if (hold_u) step = Vec2(0.0, c > 0.0 ? rv / c : 0.0);
    if (hold_v) step = Vec2(a > 0.0 ? ru / a : 0.0, 0.0);
    // The gradient in the parameters that are free.
    const Vec2 gradient(hold_u ? 0.0 : ru, hold_v ? 0.0 : rv);
    if (norm(step) < 1e-6) {
      // Near the solution the distance changes by O(|step|^2), below its own rounding, so the
      // descent test stalls at ~sqrt(u) in (u, v) and the result would depend on rounding (a
      // scaled model gave bounds 1e-9 apart). Here a plain Gauss-Newton step is kept while it
      // shrinks the gradient (r . du, r . dv), which converges to full precision.
      const Vec2 next = glm::clamp(q + step, Vec2(0.0), Vec2(1.0));
      const SurfacePointEval ne = evaluate_with_derivatives(patch, next.x, next.y);
      const Vec3 nr = x - ne.position;
      const Vec2 next_gradient(hold_u ? 0.0 : glm::dot(ne.du, nr), hold_v ? 0.0 : glm::dot(ne.dv, nr));
      if (norm(next_gradient) >= norm(gradient)) break;
      q = next;
      e = ne;
      continue;
    }
    const Vec2 from = q;
    const double scale = closer_by_halving(
        patch, x, [&](double s) { return glm::clamp(from + s * step, Vec2(0.0), Vec2(1.0)); }, best, q, e);
    if (scale == 0.0 || norm(0.5 * scale * step) < 1e-15) break;
  }
  return q;
}

Vec2 project(const BezierPatch& patch, const Vec3& x, Vec2 q) {
  return project_shifted(shifted_patch(patch), x - patch.points[0], q);
}

Vec2 PatchData::project(const Vec3& x, Vec2 q) const { return project_shifted(shifted, x - patch->points[0], q); }

Vec2 PatchData::project_on_segment(const Vec3& x, Vec2 a, Vec2 b, double t) const {
  // Damped Gauss-Newton in t on [0, 1], as project_shifted; any t is acceptable to the callers.
  const Vec3 y = x - patch->points[0];
  const Vec2 d = b - a;
  const auto at = [&](double s) { return glm::clamp(a + s * d, Vec2(0.0), Vec2(1.0)); };
  Vec2 q = at(t);
  SurfacePointEval e = evaluate_with_derivatives(shifted, q.x, q.y);
  double best = norm(y - e.position);
  for (int it = 0; it < 12; ++it) {
    const Vec3 tangent = d.x * e.du + d.y * e.dv;
    const double tt = glm::dot(tangent, tangent);
    if (!(tt > 1e-300)) break;
    const double g = glm::dot(tangent, y - e.position);
    const double step = g / tt;
    const double scale = closer_by_halving(
        shifted, y, [&](double s) { return at(std::clamp(t + s * step, 0.0, 1.0)); }, best, q, e);
    if (scale == 0.0) break;
    t = std::clamp(t + scale * step, 0.0, 1.0);
    if (std::abs(0.5 * scale * step) < 1e-15) break;
  }
  return q;
}

// S(q): de_casteljau<double> (kernels/src/evaluate.cpp) on the stack, the same operations (the
// degrees int, or std::integral_constant for degrees 1 to 3: unrolled), on homogeneous points of
// type Point (sagitta/homogeneous.hpp: the same values).
template <class Point, class DegreeU, class DegreeV>
[[gnu::always_inline]] inline Vec3 eval_on(const BezierPatch& patch, DegreeU n, DegreeV m, Vec2 q) {
  const double u = q.x, v = q.y, su = 1.0 - u, sv = 1.0 - v;
  Point rowpts[kMaxDegree + 1], work[kMaxDegree + 1];
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= m; ++j) {
      const double w = patch.weight(i, j);
      const Vec3& p = patch.at(i, j);
      work[j] = detail::make_point<Point>(w * p.x, w * p.y, w * p.z, w);
    }
    for (int r = 1; r <= m; ++r) {
      for (int j = 0; j <= m - r; ++j) work[j] = detail::combine(work[j], work[j + 1], sv, v);
    }
    rowpts[i] = work[0];
  }
  for (int r = 1; r <= n; ++r) {
    for (int i = 0; i <= n - r; ++i) rowpts[i] = detail::combine(rowpts[i], rowpts[i + 1], su, u);
  }
  const H h = detail::to_point(rowpts[0]);
  return Vec3(h[0] / h[3], h[1] / h[3], h[2] / h[3]);
}

template <class DegreeU, class DegreeV>
Vec3 eval_impl(const BezierPatch& patch, DegreeU n, DegreeV m, Vec2 q) {
  return eval_on<H>(patch, n, m, q);
}

#ifdef SAGITTA_HVECTOR
// The same on CPUs with AVX2 (one vector register per point; the same values bit for bit).
template <class DegreeU, class DegreeV>
__attribute__((target("avx2"))) Vec3 eval_impl_avx2(const BezierPatch& patch, DegreeU n, DegreeV m, Vec2 q) {
  return eval_on<detail::HVector>(patch, n, m, q);
}
#endif

Vec3 eval(const BezierPatch& patch, Vec2 q) {
  const int n = patch.degree_u, m = patch.degree_v;
#ifdef SAGITTA_HVECTOR
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2) return with_low_degrees(n, m, [&](auto du, auto dv) { return eval_impl_avx2(patch, du, dv, q); });
#endif
  return with_low_degrees(n, m, [&](auto du, auto dv) { return eval_impl(patch, du, dv, q); });
}

// Distance from x to an axis-aligned box (0 inside).
double box_distance(const Box& box, const Vec3& x) {
  const Vec3 d = glm::max(glm::max(box.lo - x, x - box.hi), Vec3(0.0));
  return norm(d);
}

// Distance between two axis-aligned boxes (0 when they overlap).
double box_distance(const Box& a, const Box& b) {
  const Vec3 d = glm::max(glm::max(a.lo - b.hi, b.lo - a.hi), Vec3(0.0));
  return norm(d);
}

// Projection of x onto a patch without a seed: the best point of a 5 x 5 parameter grid, then
// Newton. Like project(), any result is acceptable (callers only need some surface point).
Vec2 project_unseeded(const BezierPatch& patch, const Vec3& x) {
  Vec2 best(0.5);
  double best_d = kInf;
  for (int i = 0; i <= 4; ++i) {
    for (int j = 0; j <= 4; ++j) {
      const Vec2 q(i / 4.0, j / 4.0);
      const double d = norm(x - eval(patch, q));
      if (d < best_d) {
        best_d = d;
        best = q;
      }
    }
  }
  return project(patch, x, best);
}

// Other patches that may be closer to a mesh triangle than its own patch: the mesh->surface
// distance is to the whole model, so a triangle cutting across a fold or a seam may be matched
// to a neighbouring patch instead. `near` lists them (never the own patch); any list is sound.
struct OtherPatches {
  const std::vector<PatchData>* data = nullptr;
  const std::vector<Box>* boxes = nullptr;
  const std::vector<uint32_t>* near = nullptr;
  bool empty() const { return near == nullptr || near->empty(); }
};

// Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5); the
// result is a convex combination of the corners.
Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  if (!(len2 > 0.0)) return a;
  return a + std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) * ab;
}

Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const Vec3 n = glm::cross(ab, ac);
  if (!(glm::dot(n, n) > 1e-24 * glm::dot(ab, ab) * glm::dot(ac, ac))) {
    // (Nearly) degenerate: the closest of the three edges' closest points.
    Vec3 best = closest_on_segment(p, a, b);
    for (const Vec3& q : {closest_on_segment(p, b, c), closest_on_segment(p, c, a)}) {
      if (norm(q - p) < norm(best - p)) best = q;
    }
    return best;
  }
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return (1.0 - v - w) * a + v * b + w * c;
}

// Where the estimates sample a triangle (barycentric): its centroid and edge midpoints.
const Vec3 kEstimatePoints[4] = {Vec3(1, 1, 1) / 3.0, Vec3(0.5, 0.5, 0), Vec3(0, 0.5, 0.5), Vec3(0.5, 0, 0.5)};

// The projections of a triangle's edge midpoints (kEstimatePoints[1..3]) made by pass 1: the same
// values that pass 2 computes at those corners of the triangle's leaves, handed over.
struct MidpointProjections {
  Vec2 qp[3];
  double residual[3];
};

struct TriangleResult {
  double m2s = 0.0, s2m = 0.0;
  double m2s_est = 0.0;  // largest residual |x - S(proj x)| seen (a candidate, not a bound)
  Vec3 m2s_point{0.0};
  Vec2 m2s_seed{0.0};
  double s2m_est = 0.0;
  Vec2 s2m_uv{0.0};
  uint64_t leaves = 0;
  bool exhausted = false;
  // The leaves kept, by barycentric corners, when the triangle was subdivided (empty: the whole
  // triangle is its one leaf); surface_over_projected_leaves tiles the surface with them.
  std::vector<std::array<Vec3, 3>> kept_leaves;
};

// The results of every triangle: stored for the triangles that are refined; a settled triangle
// (cheap bound at most `settled`: no refinement could raise the overall bound through it) keeps
// its cheap bound over one leaf, and its pass-1 estimate as its candidate, read from those arrays.
// Storing only the refined ones spares the memory of a result per triangle (teapot level 6: 13,512
// refined of 261,632).
class TriangleResults {
 public:
  void init(const std::vector<double>& cheap, double settled, const std::vector<double>& est_value,
            const std::vector<Vec3>& est_point, const std::vector<Vec2>& est_uv) {
    cheap_ = &cheap;
    value_ = &est_value;
    point_ = &est_point;
    uv_ = &est_uv;
    slot_.assign(cheap.size(), kSettled);
    refined_.clear();
    for (size_t t = 0; t < cheap.size(); ++t) {
      if (cheap[t] <= settled) continue;
      slot_[t] = static_cast<uint32_t>(refined_.size());
      refined_.push_back(static_cast<uint32_t>(t));
    }
    stored_.assign(refined_.size(), TriangleResult{});
  }
  size_t size() const { return slot_.size(); }
  const std::vector<uint32_t>& refined() const { return refined_; }  // the refined triangles, in order
  TriangleResult& stored(size_t k) { return stored_[k]; }            // of refined()[k]
  bool is_refined(size_t t) const { return slot_[t] != kSettled; }
  const TriangleResult& at(size_t t) const { return stored_[slot_[t]]; }  // a refined triangle's
  double m2s(size_t t) const { return is_refined(t) ? at(t).m2s : (*cheap_)[t]; }
  double s2m(size_t t) const { return is_refined(t) ? at(t).s2m : (*cheap_)[t]; }
  uint64_t leaves(size_t t) const { return is_refined(t) ? at(t).leaves : 1; }
  bool exhausted(size_t t) const { return is_refined(t) && at(t).exhausted; }
  double m2s_est(size_t t) const { return is_refined(t) ? at(t).m2s_est : (*value_)[t]; }
  double s2m_est(size_t t) const { return is_refined(t) ? at(t).s2m_est : (*value_)[t]; }
  Vec3 m2s_point(size_t t) const {
    return is_refined(t) ? at(t).m2s_point : ((*value_)[t] > 0.0 ? (*point_)[t] : Vec3(0.0));
  }
  Vec2 s2m_uv(size_t t) const { return is_refined(t) ? at(t).s2m_uv : ((*value_)[t] > 0.0 ? (*uv_)[t] : Vec2(0.0)); }
  const std::vector<std::array<Vec3, 3>>* kept_leaves(size_t t) const {
    static const std::vector<std::array<Vec3, 3>> kWhole;
    return is_refined(t) ? &at(t).kept_leaves : &kWhole;
  }

 private:
  static constexpr uint32_t kSettled = ~uint32_t(0);
  const std::vector<double>* cheap_ = nullptr;
  const std::vector<double>* value_ = nullptr;
  const std::vector<Vec3>* point_ = nullptr;
  const std::vector<Vec2>* uv_ = nullptr;
  std::vector<uint32_t> slot_;  // by triangle: its index in refined_ / stored_, or kSettled
  std::vector<uint32_t> refined_;
  std::vector<TriangleResult> stored_;
};

struct Leaf {
  std::array<Vec3, 3> b;  // barycentric corners
  int depth = 0;
};

// What the bounds compute at one corner of a leaf, kept for the other leaves sharing the corner
// (a pure function of the corner: reusing it changes no result).
struct CornerData {
  bool projected = false;  // qp: the projection onto the own patch seeded at q; residual |X - S(qp)|
  Vec2 qp{0.0};
  double residual = 0.0;
  bool surfaced = false;  // sp = S(q)
  Vec3 sp{0.0};
  bool near_searched = false;  // near_found / near: the mesh triangle nearest to sp
  bool near_found = false;
  std::array<Vec3, 3> near{};
  double near_distance = 0.0;  // |sp - its closest point on near|
};

// The corners of one triangle's leaves by barycentric coordinates (exact: dyadic midpoints).
class CornerCache {
 public:
  CornerData& at(const Vec3& b) { return map_[Key{b.x, b.y, b.z}]; }
  bool contains(const Vec3& b) const { return map_.count(Key{b.x, b.y, b.z}) != 0; }
  void clear() { map_.clear(); }

 private:
  struct Key {
    double x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct Hash {
    size_t operator()(const Key& k) const {
      const std::hash<double> h;
      return h(k.x) ^ (h(k.y) * 0x9e3779b97f4a7c15ull) ^ (h(k.z) * 0xc2b2ae3d27d4eb4full);
    }
  };
  std::unordered_map<Key, CornerData, Hash> map_;
};

// A leaf's corners in (u, v) and on the mesh triangle, and their shared data.
struct LeafCorners {
  Vec2 q[3];
  Vec3 X[3];
  CornerData* data[3];
};

// A leaf's bounds and the distances actually seen at its corners.
struct LeafBounds {
  double m2s = 0.0, s2m = 0.0;
  double m2s_seen = 0.0, s2m_seen = 0.0;
  bool projected = false;  // qp holds the corners' projections onto the own patch
  Vec2 qp[3];
};

// A restricted domain's test for a box of the own patch's (u, v) (CertifyOptions::box_in_domain,
// bound to the patch): null or empty when there is none.
using BoxInDomain = std::function<double(const Vec2& lo, const Vec2& hi, const Vec2& inside)>;

// Mesh->surface: the leaf's corners matched to their projections on the surface; `lin` is the
// leaf's bound in its own (u, v). Lowers b.m2s, sets b.m2s_seen and the candidate in res. With
// own_uv_only (a restricted domain) the projections are used only where box_in_domain vouches for
// the box of the leaf's own (u, v) and its corners' projections: the projections' triangle then
// lies in the domain, so its surface points belong to the face (or lie within the margin it
// returns of the face's, which is added).
void bound_mesh_to_surface(const PatchData& P, const LeafCorners& c, double lin, double tau, const OtherPatches& others,
                           bool own_uv_only, const BoxInDomain* box_in_domain, Scratch& s, LeafBounds& b,
                           TriangleResult& res) {
  const Vec2* q = c.q;
  const Vec3* X = c.X;
  Vec2 qp[3];
  double residual[3];
  for (int i = 0; i < 3; ++i) {
    CornerData& d = *c.data[i];
    if (!d.projected) {
      d.qp = P.project(X[i], q[i]);
      d.residual = norm(X[i] - eval(*P.patch, d.qp));
      d.projected = true;
    }
    qp[i] = d.qp;
    residual[i] = d.residual;
  }
  b.projected = true;
  std::copy(qp, qp + 3, b.qp);
  if (!own_uv_only) {
    b.m2s = std::min(lin, composed_bound(P, qp, X, s));
  } else if (box_in_domain && *box_in_domain) {
    Vec2 lo = q[0], hi = q[0];
    for (int i = 0; i < 3; ++i) lo = glm::min(lo, glm::min(q[i], qp[i])), hi = glm::max(hi, glm::max(q[i], qp[i]));
    const double margin = (*box_in_domain)(lo, hi, (q[0] + q[1] + q[2]) / 3.0);
    if (margin == 0.0) {
      b.m2s = std::min(lin, composed_bound(P, qp, X, s));
    } else if (margin < kInf) {  // the surface over the box within `margin` of the domain's
      b.m2s = std::min(lin, (composed_bound(P, qp, X, s) + margin) * (1.0 + 2.0 * kUnit));
    }
  }
  if (b.m2s > tau && !others.empty()) {
    // The leaf matched to another patch: sound for the distance to the model, and the only
    // tight match where the triangle leaves its own patch for a neighbour (folds, seams).
    Box leaf_box{glm::min(glm::min(X[0], X[1]), X[2]), glm::max(glm::max(X[0], X[1]), X[2])};
    for (uint32_t o : *others.near) {
      if (box_distance((*others.boxes)[o], leaf_box) >= b.m2s) continue;  // cannot do better
      const PatchData& O = (*others.data)[o];
      Vec2 qo[3];
      for (int i = 0; i < 3; ++i) {
        qo[i] = i == 0 ? project_unseeded(*O.patch, X[i]) : O.project(X[i], qo[i - 1]);
        residual[i] = std::min(residual[i], norm(X[i] - eval(*O.patch, qo[i])));
      }
      b.m2s = std::min(b.m2s, composed_bound(O, qo, X, s));
    }
  }
  for (int i = 0; i < 3; ++i) {
    b.m2s_seen = std::max(b.m2s_seen, residual[i]);
    if (residual[i] > res.m2s_est) {
      res.m2s_est = residual[i];
      res.m2s_point = X[i];
      res.m2s_seed = qp[i];
    }
  }
}

// Surface->mesh: the leaf's surface corners matched to their closest points on the triangle T (or
// on each of the given mesh triangles; all three corners on the same one, so the affine
// interpolation stays on the mesh). Where that leaves the bound above tau, the mesh triangles
// nearest to the corners (`nearest`) are tried too. Lowers b.s2m, sets b.s2m_seen and (unless
// s2m_only) the candidate in res.
void bound_surface_to_mesh(const PatchData& P, const LeafCorners& c, const std::array<Vec3, 3>& T, double tau,
                           bool s2m_only, const std::vector<std::array<Vec3, 3>>* s2m_targets,
                           const std::function<bool(const Vec3&, std::array<Vec3, 3>&)>& nearest, Scratch& s,
                           LeafBounds& b, TriangleResult& res) {
  const Vec2* q = c.q;
  Vec3 sp[3];
  for (int i = 0; i < 3; ++i) {
    CornerData& d = *c.data[i];
    if (!d.surfaced) {
      d.sp = eval(*P.patch, q[i]);
      d.surfaced = true;
    }
    sp[i] = d.sp;
  }
  std::vector<std::array<Vec3, 3>> targets = s2m_targets ? *s2m_targets : std::vector<std::array<Vec3, 3>>{T};
  double corner_distance[3] = {kInf, kInf, kInf};
  const auto bound_against = [&](const std::array<Vec3, 3>& target) {
    Vec3 Y[3];
    for (int i = 0; i < 3; ++i) {
      Y[i] = closest_on_triangle(sp[i], target[0], target[1], target[2]);
      corner_distance[i] = std::min(corner_distance[i], norm(sp[i] - Y[i]));
    }
    b.s2m = std::min(b.s2m, composed_bound(P, q, Y, s));
  };
  for (const auto& target : targets) bound_against(target);
  // The mesh triangle nearest to a corner (found by the caller's search, kept per corner) is a
  // candidate too where it is closer to that corner than the given targets (a tie, as at a mesh
  // vertex, gains nothing). Only asked where the given targets leave the leaf above tau: below it
  // the leaf is done either way.
  const auto search_nearest = [&](CornerData& d) {
    if (d.near_searched) return;
    d.near_found = nearest(d.sp, d.near);
    if (d.near_found) d.near_distance = norm(d.sp - closest_on_triangle(d.sp, d.near[0], d.near[1], d.near[2]));
    d.near_searched = true;
  };
  if (b.s2m > tau && nearest) {
    const size_t given = targets.size();
    for (int i = 0; i < 3; ++i) {
      CornerData& d = *c.data[i];
      search_nearest(d);
      if (!d.near_found || std::find(targets.begin(), targets.end(), d.near) != targets.end()) continue;
      if (d.near_distance < corner_distance[i]) targets.push_back(d.near);
    }
    for (size_t k = given; k < targets.size(); ++k) bound_against(targets[k]);
  }
  for (int i = 0; i < 3; ++i) {
    CornerData& d = *c.data[i];
    // A candidate for the lower bound at its distance to the nearest mesh triangle (the given
    // targets alone may overstate it): searched where it would beat the candidate so far.
    if (!s2m_only && nearest && corner_distance[i] > res.s2m_est) search_nearest(d);
    if (d.near_found) corner_distance[i] = std::min(corner_distance[i], d.near_distance);
    if (std::isfinite(corner_distance[i])) b.s2m_seen = std::max(b.s2m_seen, corner_distance[i]);
    if (!s2m_only && corner_distance[i] > res.s2m_est) {
      res.s2m_est = corner_distance[i];
      res.s2m_uv = q[i];
    }
  }
}

// Refines one triangle; `tau` is the level below which a leaf is accepted; `root_bound`, when
// finite, is a proven bound on both directions over the whole triangle (the cheap bound).
//
// Leaves are refined largest bound first. A leaf that is not done is still kept as it is (not
// refined) when refining it could change neither result:
//  - each of its bounds is at most the triangle's bound so far in that direction (from leaves kept
//    before it). Every kept leaf is a final leaf of the full refinement too, so the triangle's bounds
//    are the maxima over a subset of the full refinement's final leaves: tighter or equal;
//  - its bounds are below the lower-bound candidates found so far: a point of the leaf lies within
//    `lin` of its own-(u, v) surface point (projections start there and never end farther), and a
//    surface point over it within b.s2m of the mesh, so its sub-leaves' corners cannot beat them.
TriangleResult refine_triangle(const PatchData& P, const std::array<Vec2, 3>& uv, const std::array<Vec3, 3>& T,
                               double tau, double target_ratio, int max_depth, Scratch& s, bool s2m_only = false,
                               const std::vector<std::array<Vec3, 3>>* s2m_targets = nullptr,
                               const std::function<bool(const Vec3&, std::array<Vec3, 3>&)>& nearest = {},
                               const OtherPatches& others = {}, bool own_uv_only = false, double root_bound = kInf,
                               const BoxInDomain* box_in_domain = nullptr,
                               const MidpointProjections* midpoints = nullptr) {
  TriangleResult res;
  CornerCache corners;
  if (midpoints) {  // the edge midpoints' projections, as bound_mesh_to_surface would compute them
    for (int k = 0; k < 3; ++k) {
      CornerData& d = corners.at(kEstimatePoints[k + 1]);
      d.projected = true;
      d.qp = midpoints->qp[k];
      d.residual = midpoints->residual[k];
    }
  }
  struct Evaluated {
    Leaf leaf;
    LeafBounds b;
    double lin = 0.0;
    double key() const { return std::max(b.m2s, b.s2m); }
    bool operator<(const Evaluated& o) const { return key() < o.key(); }
  };
  const auto evaluate = [&](const Leaf& leaf) {
    budget::check("validation");
    ++res.leaves;
    if (leaf.depth == 0 && root_bound > tau && root_bound < kInf && max_depth > 0) {
      // root_bound is proven for both directions over the whole triangle and is above tau, so the
      // triangle is split; the corner-matched bounds are not computed for it (at the root, whose
      // corners are mesh vertices, they come out about the same). Its children compute them.
      Evaluated e{leaf, {}, root_bound};
      e.b.m2s = s2m_only ? 0.0 : root_bound;
      e.b.s2m = root_bound;
      return e;
    }
    LeafCorners c;
    for (int i = 0; i < 3; ++i) {
      const Vec3& b = leaf.b[i];
      c.q[i] = b.x * uv[0] + b.y * uv[1] + b.z * uv[2];
      c.X[i] = b.x * T[0] + b.y * T[1] + b.z * T[2];
      c.data[i] = &corners.at(b);
    }
    Evaluated e{leaf, {}, composed_bound(P, c.q, c.X, s)};
    LeafBounds& b = e.b;
    b.m2s = s2m_only ? 0.0 : e.lin;
    b.s2m = e.lin;
    // Surface->mesh first: its bounds compose S over the same (u, v) triangle as `lin`, whose
    // composition the scratch space still holds (the two directions share no data).
    if (e.lin > tau) bound_surface_to_mesh(P, c, T, tau, s2m_only, s2m_targets, nearest, s, b, res);
    if (e.lin > tau && !s2m_only)
      bound_mesh_to_surface(P, c, e.lin, tau, others, own_uv_only, box_in_domain, s, b, res);
    return e;
  };
  std::vector<Evaluated> heap{evaluate({{Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}, 0})};
  bool kept = false;  // res.m2s / res.s2m hold some kept leaf's bounds
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end());
    const Evaluated e = heap.back();
    heap.pop_back();
    const Leaf& leaf = e.leaf;
    const LeafBounds& b = e.b;
    // A leaf is done when each bound is below the global target or within the target ratio of a
    // distance actually seen at its corners (then refining cannot tighten the overall interval
    // by more than that ratio, and a direction whose distance exceeds the other's estimate does
    // not refine to the depth budget for nothing).
    const bool done =
        b.m2s <= std::max(tau, target_ratio * b.m2s_seen) && b.s2m <= std::max(tau, target_ratio * b.s2m_seen);
    const bool refinable = !done && leaf.depth < max_depth;
    bool settled = refinable && kept && b.m2s <= res.m2s && b.s2m <= res.s2m && b.s2m < res.s2m_est;
    if (settled && !s2m_only && !(e.lin < res.m2s_est)) {
      // The own-(u, v) bound does not rule out a better mesh->surface candidate: the bound with
      // the corners' projections bounds their residuals too (where the projections converge).
      double geometric = b.m2s;
      if (own_uv_only && b.projected) {
        Vec3 X[3];
        for (int i = 0; i < 3; ++i) X[i] = leaf.b[i].x * T[0] + leaf.b[i].y * T[1] + leaf.b[i].z * T[2];
        geometric = composed_bound(P, b.qp, X, s);
      }
      settled = geometric < res.m2s_est;
    }
    if (refinable && !settled) {
      const Vec3 m01 = 0.5 * (leaf.b[0] + leaf.b[1]), m12 = 0.5 * (leaf.b[1] + leaf.b[2]),
                 m20 = 0.5 * (leaf.b[2] + leaf.b[0]);
      const int d = leaf.depth + 1;
      for (const Leaf& child : {Leaf{{leaf.b[0], m01, m20}, d}, Leaf{{m01, leaf.b[1], m12}, d},
                                Leaf{{m20, m12, leaf.b[2]}, d}, Leaf{{m12, m20, m01}, d}}) {
        heap.push_back(evaluate(child));
        std::push_heap(heap.begin(), heap.end());
      }
      continue;
    }
    if (!done && !settled) res.exhausted = true;
    res.m2s = std::max(res.m2s, b.m2s);
    res.s2m = std::max(res.s2m, b.s2m);
    if (leaf.depth > 0 || !res.kept_leaves.empty()) res.kept_leaves.push_back(leaf.b);
    kept = true;
  }
  return res;
}

// A (u, v) triangle the mesh does not list because its corners collapse to a segment in space
// (next to a side of the patch that collapses to a point); X are the mesh points at its corners.
struct Hole {
  uint32_t patch = 0;
  std::array<Vec2, 3> uv;
  std::array<Vec3, 3> X;
  // The emitted triangles whose edges bound it: both contain its image (the mesh edge), so surface
  // points over the hole may be matched to any point of either.
  std::vector<std::array<Vec3, 3>> neighbours;
};

bool on_side(const Vec2& q, Side side) {
  switch (side) {
    case Side::kU0: return q.x == 0.0;
    case Side::kU1: return q.x == 1.0;
    case Side::kV0: return q.y == 0.0;
    case Side::kV1: return q.y == 1.0;
  }
  return false;
}

bool side_collapsed(const BezierPatch& patch, Side side) {
  for (int k = 1; k <= side_degree(patch, side); ++k) {
    if (side_point(patch, side, k) != side_point(patch, side, 0)) return false;
  }
  return true;
}

// Reconstructs the degenerate triangles a scheme dropped next to collapsed sides: two (u, v)-open
// edges of a patch's triangles that meet at an interior point b and end on the same collapsed side
// at a and a' bound the missing triangle (b, a, a'); its image in space is the mesh edge from b to
// the collapse point, so every surface point over it is certified against that edge.
std::vector<Hole> collapsed_side_holes(const Model& model, const Tessellation& mesh) {
  struct Key {
    double a[4];
    bool operator<(const Key& o) const { return std::lexicographical_compare(a, a + 4, o.a, o.a + 4); }
  };
  std::vector<Hole> holes;
  std::vector<std::vector<size_t>> by_patch(model.patches.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) by_patch[mesh.triangle_patch[t]].push_back(t);
  for (uint32_t p = 0; p < model.patches.size(); ++p) {
    const BezierPatch& patch = model.patches[p];
    std::vector<Side> collapsed;
    for (Side sd : kAllSides) {
      if (side_collapsed(patch, sd)) collapsed.push_back(sd);
    }
    if (collapsed.empty()) continue;
    std::map<Key, int> uses;
    auto key = [](Vec2 a, Vec2 b) {
      if (std::tie(b.x, b.y) < std::tie(a.x, a.y)) std::swap(a, b);
      return Key{{a.x, a.y, b.x, b.y}};
    };
    // Only edges touching a collapsed side matter below.
    const auto touches = [&](const Vec2& a, const Vec2& b) {
      for (Side sd : collapsed) {
        if (on_side(a, sd) || on_side(b, sd)) return true;
      }
      return false;
    };
    for (size_t t : by_patch[p]) {
      for (int k = 0; k < 3; ++k) {
        const Vec2 a = mesh.triangle_uv[t][k], b = mesh.triangle_uv[t][(k + 1) % 3];
        if (touches(a, b)) ++uses[key(a, b)];
      }
    }
    // Interior end point -> (side point uv, mesh position of each end) of open edges touching a side.
    struct Spoke {
      Vec2 side_uv;
      Vec3 side_pos, inner_pos;
      int side;
      int64_t triangle;  // the emitted triangle owning the edge, -1 for a domain-boundary segment
    };
    std::map<std::pair<double, double>, std::vector<Spoke>> spokes;
    for (size_t t : by_patch[p]) {
      for (int k = 0; k < 3; ++k) {
        const Vec2 a = mesh.triangle_uv[t][k], b = mesh.triangle_uv[t][(k + 1) % 3];
        if (!touches(a, b) || uses[key(a, b)] != 1) continue;
        const Vec3 pa = mesh.positions[mesh.triangles[t][k]], pb = mesh.positions[mesh.triangles[t][(k + 1) % 3]];
        for (Side sd : collapsed) {
          if (on_side(a, sd) && !on_side(b, sd)) spokes[{b.x, b.y}].push_back({a, pa, pb, int(sd), int64_t(t)});
          if (on_side(b, sd) && !on_side(a, sd)) spokes[{a.x, a.y}].push_back({b, pb, pa, int(sd), int64_t(t)});
        }
      }
    }
    for (auto& [inner, list] : spokes) {
      if (list.size() == 1) {
        // The missing triangle's third edge runs along the domain boundary to a corner of the side.
        const Vec2 b(inner.first, inner.second);
        const Side sd = static_cast<Side>(list[0].side);
        const bool u_side = sd == Side::kU0 || sd == Side::kU1;
        const bool b_on_boundary = u_side ? (b.y == 0.0 || b.y == 1.0) : (b.x == 0.0 || b.x == 1.0);
        if (!b_on_boundary) continue;
        Vec2 c = b;
        if (sd == Side::kU0) c.x = 0.0;
        if (sd == Side::kU1) c.x = 1.0;
        if (sd == Side::kV0) c.y = 0.0;
        if (sd == Side::kV1) c.y = 1.0;
        list.push_back({c, list[0].side_pos, list[0].inner_pos, list[0].side, -1});
      }
      if (list.size() != 2 || list[0].side != list[1].side) continue;
      Hole h;
      h.patch = p;
      h.uv = {Vec2(inner.first, inner.second), list[0].side_uv, list[1].side_uv};
      h.X = {list[0].inner_pos, list[0].side_pos, list[1].side_pos};
      for (const Spoke& sp : list) {
        if (sp.triangle < 0) continue;
        const Triangle& tri = mesh.triangles[static_cast<size_t>(sp.triangle)];
        h.neighbours.push_back({mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]});
      }
      const double area = (h.uv[1].x - h.uv[0].x) * (h.uv[2].y - h.uv[0].y) - (h.uv[2].x - h.uv[0].x) * (h.uv[1].y - h.uv[0].y);
      if (area == 0.0) continue;
      if (area < 0.0) {
        std::swap(h.uv[1], h.uv[2]);
        std::swap(h.X[1], h.X[2]);
      }
      holes.push_back(h);
    }
  }
  return holes;
}

// Coverage of every patch domain by the triangles' (u, v): all corners inside [0, 1]^2, every uv
// triangle positively oriented, and the areas summing to 1 per patch (relative tolerance 1e-9).
bool check_coverage(const Model& model, const Tessellation& mesh, const std::vector<Hole>& holes, std::string& note) {
  std::vector<long double> area(model.patches.size(), 0.0L);
  for (const Hole& h : holes) {
    const auto& q = h.uv;
    area[h.patch] += 0.5L * ((static_cast<long double>(q[1].x) - q[0].x) * (static_cast<long double>(q[2].y) - q[0].y) -
                             (static_cast<long double>(q[2].x) - q[0].x) * (static_cast<long double>(q[1].y) - q[0].y));
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& q = mesh.triangle_uv[t];
    for (const Vec2& p : q) {
      if (!(p.x >= 0.0 && p.x <= 1.0 && p.y >= 0.0 && p.y <= 1.0)) {
        note = "triangle " + std::to_string(t) + " has (u, v) outside [0, 1]^2";
        return false;
      }
    }
    const long double a = 0.5L * ((static_cast<long double>(q[1].x) - q[0].x) * (static_cast<long double>(q[2].y) - q[0].y) -
                                  (static_cast<long double>(q[2].x) - q[0].x) * (static_cast<long double>(q[1].y) - q[0].y));
    if (a < 0.0L) {
      note = "triangle " + std::to_string(t) + " is reversed in (u, v)";
      return false;
    }
    area[mesh.triangle_patch[t]] += a;
  }
  for (size_t p = 0; p < area.size(); ++p) {
    if (std::abs(area[p] - 1.0L) > 1e-9L) {
      note = "the triangles cover " + std::to_string(static_cast<double>(area[p])) + " of patch " + std::to_string(p) +
             "'s (u, v) domain instead of 1";
      return false;
    }
  }
  return true;
}

// One subdivision of a patch for the branch-and-bound: homogeneous control points relative to x.
struct Node {
  std::vector<H> h;
  int n = 0, m = 0, depth = 0;
  double lb = 0.0;
};

// Lower bound of the distance from the origin to the convex hull of the node's control points:
// the larger of the box distance and a slab distance along the node's approximate normal, minus
// the node's rounding allowance.
double node_lower(const Node& node, double scale) {
  Vec3 lo(kInf), hi(-kInf);
  thread_local std::vector<Vec3> pts;  // reused across calls (no allocation per node)
  pts.resize(node.h.size());
  for (size_t k = 0; k < node.h.size(); ++k) {
    pts[k] = Vec3(node.h[k][0], node.h[k][1], node.h[k][2]) / node.h[k][3];
    lo = glm::min(lo, pts[k]);
    hi = glm::max(hi, pts[k]);
  }
  const Vec3 gap = glm::max(glm::max(lo, -hi), Vec3(0.0));
  double lb = norm(gap);
  const int n = node.n, m = node.m;
  const Vec3 p00 = pts[0], p0m = pts[static_cast<size_t>(m)], pn0 = pts[static_cast<size_t>(n * (m + 1))],
             pnm = pts.back();
  Vec3 normal = glm::cross(pnm - p00, pn0 - p0m);
  const double len = norm(normal);
  if (len > 0.0) {
    normal /= len;
    double smin = kInf, smax = -kInf;
    for (const Vec3& p : pts) {
      const double sdot = glm::dot(normal, p);
      smin = std::min(smin, sdot);
      smax = std::max(smax, sdot);
    }
    const double slab = smin > 0.0 ? smin : (smax < 0.0 ? -smax : 0.0);
    lb = std::max(lb, slab);
  }
  // Each de Casteljau split level adds at most 3u |coordinates| of error; the normal need not be
  // exact (any unit vector gives a valid slab), but its rounding is absorbed here too.
  const double err = (3.0 * node.depth + 16.0) * kUnit * scale * 4.0;
  return std::max(0.0, lb - err);
}

void split(const Node& node, bool along_u, Node& left, Node& right) {
  const int n = node.n, m = node.m;
  left = right = node;
  ++left.depth;
  ++right.depth;
  const int count = along_u ? n : m;
  const int lines = along_u ? m + 1 : n + 1;
  H w[kMaxDegree + 1];
  for (int line = 0; line < lines; ++line) {
    auto idx = [&](int k) { return static_cast<size_t>(along_u ? k * (m + 1) + line : line * (m + 1) + k); };
    for (int k = 0; k <= count; ++k) w[k] = node.h[idx(k)];
    left.h[idx(0)] = w[0];
    right.h[idx(count)] = w[count];
    for (int level = 1; level <= count; ++level) {
      for (int k = 0; k <= count - level; ++k) w[k] = lerp(w[k], w[k + 1], 0.5);
      left.h[idx(level)] = w[0];
      right.h[idx(count - level)] = w[count - level];
    }
  }
}

}  // namespace

double affine_error_bound(const BezierPatch& patch, const Vec2 q[3], const Vec3 X[3]) {
  const PatchData P = make_patch_data(patch);
  Scratch s;
  return composed_bound(P, q, X, s);
}

namespace {

double certified_distance_lower_conditioned(const Model& model, const Vec3& x, double target, int node_budget) {
  std::vector<Node> stack;
  double scale = std::max({std::abs(x.x), std::abs(x.y), std::abs(x.z)});
  for (const BezierPatch& patch : model.patches) {
    Node node;
    node.n = patch.degree_u;
    node.m = patch.degree_v;
    for (int i = 0; i <= node.n; ++i) {
      for (int j = 0; j <= node.m; ++j) {
        const double w = patch.weight(i, j);
        const Vec3 p = patch.at(i, j) - x;
        node.h.push_back({w * p.x, w * p.y, w * p.z, w});
        scale = std::max({scale, std::abs(patch.at(i, j).x), std::abs(patch.at(i, j).y), std::abs(patch.at(i, j).z)});
      }
    }
    stack.push_back(std::move(node));
  }
  double result = target;
  int spent = 0;
  while (!stack.empty()) {
    if ((spent & 255) == 0) budget::check("validation");
    Node node = std::move(stack.back());
    stack.pop_back();
    node.lb = node_lower(node, scale);
    if (node.lb >= target) continue;
    // A corner of the node is a surface point: the distance is at most its length.
    for (const size_t k : {size_t(0), size_t(node.m), node.h.size() - 1 - size_t(node.m), node.h.size() - 1}) {
      const H& c = node.h[k];
      const double r = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) / c[3];
      if (r * (1.0 - 1e-3) < target) target = r * (1.0 - 1e-3);  // aim just below a known distance
    }
    result = std::min(result, target);
    if (node.lb >= target) continue;
    if (++spent > node_budget || node.depth > 80) {
      result = std::min(result, node.lb);
      for (Node& rest : stack) result = std::min(result, node_lower(rest, scale));
      return result;
    }
    // Split along the parameter direction whose control polygon is longer.
    double lu = 0.0, lv = 0.0;
    for (int i = 0; i <= node.n; ++i) {
      for (int j = 0; j <= node.m; ++j) {
        const H& a = node.h[static_cast<size_t>(i * (node.m + 1) + j)];
        const Vec3 pa = Vec3(a[0], a[1], a[2]) / a[3];
        if (i < node.n) {
          const H& b = node.h[static_cast<size_t>((i + 1) * (node.m + 1) + j)];
          lu = std::max(lu, norm(Vec3(b[0], b[1], b[2]) / b[3] - pa));
        }
        if (j < node.m) {
          const H& b = node.h[static_cast<size_t>(i * (node.m + 1) + j + 1)];
          lv = std::max(lv, norm(Vec3(b[0], b[1], b[2]) / b[3] - pa));
        }
      }
    }
    Node left, right;
    split(node, lu * node.n >= lv * node.m, left, right);
    stack.push_back(std::move(left));
    stack.push_back(std::move(right));
  }
  return std::min(result, target);
}

}  // namespace

double detail::certified_distance_lower(const Model& model, const Vec3& x, double target, int node_budget) {
  if (!(target > 0.0)) return 0.0;
  return detail::lower_with_safe_arithmetic(model, x, [&](const Model& m, const Vec3& y, double distance_scale) {
    return certified_distance_lower_conditioned(m, y, target * distance_scale, node_budget);
  });
}

namespace {

// Lower bounds from the worst candidates of each direction.
void certify_lowers(const Model& model, const std::vector<PatchData>& pd, const Tessellation& mesh,
                    const TriangleResults& results, const CertifyOptions& options, const detail::MeshDistance& dist,
                    DistanceReport& report) {
  const size_t k = std::min<size_t>(static_cast<size_t>(std::max(options.lower_candidates, 1)), results.size());
  std::vector<size_t> order(results.size());
  std::iota(order.begin(), order.end(), size_t(0));
  // Mesh->surface.
  std::partial_sort(order.begin(), order.begin() + static_cast<long>(k), order.end(),
                    [&](size_t a, size_t b) { return results.m2s_est(a) > results.m2s_est(b); });
  std::vector<double> low(k, 0.0);
  // Each candidate's bound is at most its target (0.995 of its estimate), and the targets decrease:
  // candidates are taken a few at a time (one per thread), and once a proven lower bound reaches the
  // next targets, those candidates cannot raise it and are not computed (the same result).
  const size_t batch = static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  for (size_t first = 0; first < k; first += batch) {
    const size_t last = std::min(k, first + batch);
    tbb::parallel_for(first, last, [&](size_t i) {
      const size_t t = order[i];
      const double target = results.m2s_est(t) * 0.995;
      if (target > report.mesh_to_surface.lower)
        low[i] = detail::certified_distance_lower(model, results.m2s_point(t), target, options.lower_node_budget);
    });
    for (size_t i = first; i < last; ++i) {
      if (low[i] > report.mesh_to_surface.lower) {
        report.mesh_to_surface.lower = low[i];
        report.mesh_to_surface.witness = results.m2s_point(order[i]);
        report.mesh_to_surface.witness_patch = mesh.triangle_patch.empty() ? -1 : mesh.triangle_patch[order[i]];
      }
    }
  }
  // Surface->mesh: exact surface points (evaluation error bounded below) against the whole mesh.
  std::partial_sort(order.begin(), order.begin() + static_cast<long>(k), order.end(),
                    [&](size_t a, size_t b) { return results.s2m_est(a) > results.s2m_est(b); });
  std::vector<Vec3> points(k);
  tbb::parallel_for(size_t(0), k, [&](size_t i) {
    const size_t t = order[i];
    const BezierPatch& patch = model.patches[mesh.triangle_patch[t]];
    const Vec3 p = eval(patch, results.s2m_uv(t));
    points[i] = p;
    // No candidate was recorded (an exact triangle: every corner distance 0): s2m_uv is not a point
    // of the triangle, and on a restricted domain not even of the surface.
    if (!(results.s2m_est(t) > 0.0) ||
        (options.in_domain && !options.in_domain(mesh.triangle_patch[t], results.s2m_uv(t)))) {
      low[i] = 0.0;  // not a point of the restricted surface: no witness
      return;
    }
    low[i] = std::max(0.0, dist.distance(p) - dist.rounding_bound(p) - pd[mesh.triangle_patch[t]].eval_rounding());
  });
  for (size_t i = 0; i < k; ++i) {
    if (low[i] > report.surface_to_mesh.lower) {
      report.surface_to_mesh.lower = low[i];
      report.surface_to_mesh.witness = points[i];
      report.surface_to_mesh.witness_patch = mesh.triangle_patch[order[i]];
    }
  }
}

}  // namespace

namespace {

std::array<Vec3, 3> triangle_corners(const Tessellation& mesh, size_t t) {
  const Triangle& tri = mesh.triangles[t];
  return std::array<Vec3, 3>{mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]};
}

// Per triangle: the largest projection residual seen, where (in space and in (u, v)) it was seen.

struct Estimates {
  std::vector<double> value;
  std::vector<Vec3> point;
  std::vector<Vec2> uv;
  // By triangle: its index in `midpoints`, or kNoMidpoints where pass 1 did not project it.
  static constexpr uint32_t kNoMidpoints = ~uint32_t(0);
  std::vector<uint32_t> midpoint_slot;
  std::vector<MidpointProjections> midpoints;
  const MidpointProjections* midpoints_of(size_t t) const {
    return midpoint_slot[t] == kNoMidpoints ? nullptr : &midpoints[midpoint_slot[t]];
  }
};

// |S(q) - X| for a mesh point X meant to be S(q), plus the evaluation's rounding (as for the lower
// bounds' witnesses): a bound on the exact distance.
double corner_offset(const PatchData& P, Vec2 q, const Vec3& X) {
  return norm(eval(*P.patch, q) - X) + P.eval_rounding();
}

// The cheap bounds of pass 0: per patch a curvature grid, per triangle the bound.
struct CheapBounds {
  std::vector<detail::CurvatureGrid> grids;
  std::vector<double> triangle;
  // A bound on both directions for the mesh triangle X over the (u, v) triangle q of patch P whose
  // corners are `offsets` from their exact surface points: the interpolation bound plus the largest
  // offset, or (no grid) the exact composed bound.
  double bound(const PatchData& P, size_t patch, const Vec2 q[3], const Vec3 X[3], const double offsets[3],
               Scratch& s) const {
    double b = grids[patch].interpolation_bound(q);
    if (std::isfinite(b)) b = (b + std::max({offsets[0], offsets[1], offsets[2]})) * (1.0 + 1e-9);
    if (!(b < kInf)) b = composed_bound(P, q, X, s);
    return b >= 0.0 ? b : kInf;  // NaN proves nothing
  }
};

// Pass 0: per triangle, a cheap proven bound on both directions over it (the mesh triangle against
// the surface over its own (u, v)): the curvature grid's interpolation bound plus the corners'
// distances to their exact surface points; where no grid applies ((u, v) outside [0, 1]^2, a weight
// bound that is not positive) the exact composed bound. Most triangles are settled by it (docs/VALIDATION.md).
CheapBounds cheap_triangle_bounds(const Tessellation& mesh, const std::vector<PatchData>& pd) {
  const size_t count = mesh.triangles.size();
  std::vector<size_t> per_patch(pd.size(), 0);
  for (uint32_t p : mesh.triangle_patch) ++per_patch[p];
  // A grid of up to 16 x 16 boxes, about 8 triangles or more per box.
  CheapBounds cb;
  cb.grids.resize(pd.size());
  tbb::parallel_for(size_t(0), pd.size(), [&](size_t p) {
    int cells = 1;
    while (cells < 16 && size_t(4 * cells * cells * 8) <= per_patch[p]) cells *= 2;
    if (per_patch[p] > 0) cb.grids[p] = detail::CurvatureGrid(*pd[p].patch, cells);
  });
  // One evaluation per vertex: the first corner listing it (on a patch with a grid) sets its
  // (patch, (u, v)); corners that agree bit for bit reuse it, others evaluate their own.
  constexpr uint64_t kNone = ~uint64_t(0);
  std::vector<uint64_t> owner(mesh.positions.size(), kNone);
  for (size_t t = 0; t < count; ++t) {
    if ((t & 0xffffu) == 0) budget::check("validation");
    if (cb.grids[mesh.triangle_patch[t]].empty()) continue;
    for (int c = 0; c < 3; ++c) {
      uint64_t& o = owner[mesh.triangles[t][c]];
      if (o == kNone) o = 3 * t + c;
    }
  }
  std::vector<double> offset(mesh.positions.size(), 0.0);
  tbb::parallel_for(size_t(0), owner.size(), [&](size_t v) {
    if (owner[v] == kNone) return;
    const size_t t = owner[v] / 3, c = owner[v] % 3;
    offset[v] = corner_offset(pd[mesh.triangle_patch[t]], mesh.triangle_uv[t][c], mesh.positions[v]);
  });
  cb.triangle.assign(count, kInf);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& range) {
    Scratch s;
    budget::check("validation");
    for (size_t t = range.begin(); t != range.end(); ++t) {
      const uint32_t patch = mesh.triangle_patch[t];
      const PatchData& P = pd[patch];
      const Vec2 q[3] = {mesh.triangle_uv[t][0], mesh.triangle_uv[t][1], mesh.triangle_uv[t][2]};
      const auto T = triangle_corners(mesh, t);
      const Vec3 X[3] = {T[0], T[1], T[2]};
      double offsets[3] = {0.0, 0.0, 0.0};
      if (!cb.grids[patch].empty()) {
        for (int c = 0; c < 3; ++c) {
          const uint32_t v = mesh.triangles[t][c];
          const uint64_t o = owner[v];
          const bool shared =
              o != kNone && mesh.triangle_patch[o / 3] == patch && mesh.triangle_uv[o / 3][o % 3] == q[c];
          offsets[c] = shared ? offset[v] : corner_offset(P, q[c], X[c]);
        }
      }
      cb.triangle[t] = cb.bound(P, patch, q, X, offsets, s);
    }
  });
  return cb;
}

// The same bound for each hole (its corners are mesh points too).
std::vector<double> cheap_hole_bounds(const std::vector<Hole>& holes, const std::vector<PatchData>& pd,
                                      const CheapBounds& cb) {
  std::vector<double> bound(holes.size(), kInf);
  tbb::parallel_for(size_t(0), holes.size(), [&](size_t i) {
    Scratch s;
    const Hole& h = holes[i];
    const PatchData& P = pd[h.patch];
    const Vec2 q[3] = {h.uv[0], h.uv[1], h.uv[2]};
    const Vec3 X[3] = {h.X[0], h.X[1], h.X[2]};
    double offsets[3];
    for (int c = 0; c < 3; ++c) offsets[c] = corner_offset(P, q[c], X[c]);
    bound[i] = cb.bound(P, h.patch, q, X, offsets, s);
  });
  return bound;
}

// Pass 1: an estimate of the distance (projection residuals at centroids and edge midpoints), which
// sets the refinement target. Only the largest estimates matter, and a triangle's residuals are at
// most its cheap bound (each point x = sum b_i X_i is within the bound of S(sum b_i q_i), where its
// projection starts): triangles are visited by decreasing bound until the next bound is below the
// largest residual seen. A visited triangle's bound is first tightened to the exact composed one
// (in `cheap`, for pass 2 too); its points are projected only if that still exceeds the largest
// residual so far. `visited` marks the triangles projected; the others keep the estimate 0.
Estimates own_patch_estimates(const Tessellation& mesh, const std::vector<PatchData>& pd, std::vector<double>& cheap,
                              std::vector<char>& visited) {
  const size_t count = mesh.triangles.size();
  Estimates est;
  est.value.assign(count, 0.0);
  est.point.resize(count);
  est.uv.resize(count);
  est.midpoint_slot.assign(count, Estimates::kNoMidpoints);
  visited.assign(count, 0);
  std::vector<size_t> order(count);
  std::iota(order.begin(), order.end(), size_t(0));
  const auto larger = [&](size_t a, size_t b) { return cheap[a] > cheap[b]; };
  // Usually only the first few thousand are visited: the largest 4,096 are sorted first (linear
  // selection, then a small sort), blocks four times larger only when the walk gets there.
  size_t sorted = std::min<size_t>(count, 4096);
  std::nth_element(order.begin(), order.begin() + static_cast<long>(sorted) - 1, order.end(), larger);
  std::sort(order.begin(), order.begin() + static_cast<long>(sorted), larger);
  double largest = 0.0;
  size_t next = 0;
  // Batches grow from 32 to 1024 triangles: the first ones (the largest bounds) set `largest`, so
  // that the rest are mostly settled by their composed bound without a projection.
  size_t batch = 32;
  while (next < count && cheap[order[next]] > largest) {
    if (next >= sorted) {  // the next block, four times the size of those before, selected and sorted
      budget::check("validation");
      const size_t more = std::min(count, 4 * sorted);
      std::nth_element(order.begin() + static_cast<long>(sorted), order.begin() + static_cast<long>(more) - 1,
                       order.end(), larger);
      std::sort(order.begin() + static_cast<long>(sorted), order.begin() + static_cast<long>(more), larger);
      sorted = more;
    }
    size_t end = next;
    while (end < sorted && end - next < batch && cheap[order[end]] > largest) ++end;
    batch = std::min<size_t>(2 * batch, 1024);
    // The triangle at walk position i keeps its midpoints' projections in slot i.
    est.midpoints.resize(end);
    tbb::parallel_for(tbb::blocked_range<size_t>(next, end, 16), [&](const tbb::blocked_range<size_t>& range) {
      Scratch s;
      budget::check("validation");
      for (size_t i = range.begin(); i != range.end(); ++i) {
        const size_t t = order[i];
        const auto T = triangle_corners(mesh, t);
        const auto& uv = mesh.triangle_uv[t];
        const PatchData& P = pd[mesh.triangle_patch[t]];
        const Vec2 q[3] = {uv[0], uv[1], uv[2]};
        const Vec3 X[3] = {T[0], T[1], T[2]};
        cheap[t] = std::min(cheap[t], composed_bound(P, q, X, s));
        if (!(cheap[t] > largest)) continue;
        MidpointProjections& mid = est.midpoints[i];
        for (int k = 0; k < 4; ++k) {
          const Vec3& b = kEstimatePoints[k];
          const Vec3 x = b.x * T[0] + b.y * T[1] + b.z * T[2];
          const Vec2 qp = P.project(x, b.x * uv[0] + b.y * uv[1] + b.z * uv[2]);
          const double e = norm(x - eval(*P.patch, qp));
          if (k > 0) mid.qp[k - 1] = qp, mid.residual[k - 1] = e;
          if (e >= est.value[t]) {
            est.value[t] = e;
            est.point[t] = x;
            est.uv[t] = b.x * uv[0] + b.y * uv[1] + b.z * uv[2];
          }
        }
        visited[t] = 1;
        est.midpoint_slot[t] = static_cast<uint32_t>(i);
      }
    });
    for (size_t i = next; i < end; ++i) largest = std::max(largest, est.value[order[i]]);
    next = end;
  }
  return est;
}

// The patches other than its own near each triangle, listed only for the triangles that have any.
struct NearPatches {
  static constexpr uint32_t kNone = ~uint32_t(0);
  std::vector<uint32_t> slot;  // by triangle: its list in `lists`, or kNone
  std::vector<std::vector<uint32_t>> lists;
  // The list of triangle t, or null when it has none.
  const std::vector<uint32_t>* of(size_t t) const {
    return slot.empty() || slot[t] == kNone ? nullptr : &lists[slot[t]];
  }
};

// Patches near each triangle other than its own (control boxes within 1.5 times the triangle's
// own-patch estimate: a patch farther away than that cannot be the closer one), found by CGAL's
// box intersection; each list sorted.
NearPatches near_patches(const Model& model, const Tessellation& mesh, const Estimates& est,
                         const std::vector<Box>& patch_boxes) {
  const size_t count = mesh.triangles.size();
  NearPatches near;
  near.slot.assign(count, NearPatches::kNone);
  using IdBox = CGAL::Box_intersection_d::Box_with_info_d<double, 3, size_t>;
  const double floor = 1e-12 * model_box(model).diagonal();
  std::vector<IdBox> tri_boxes, surface_boxes;
  for (size_t t = 0; t < count; ++t) {
    if (!(est.value[t] > floor)) continue;
    const auto T = triangle_corners(mesh, t);
    const double r = 1.5 * est.value[t];
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min({T[0][k], T[1][k], T[2][k]}) - r;
      hi[k] = std::max({T[0][k], T[1][k], T[2][k]}) + r;
    }
    tri_boxes.emplace_back(lo, hi, t);
  }
  for (size_t p = 0; p < model.patches.size(); ++p) {
    double lo[3] = {patch_boxes[p].lo.x, patch_boxes[p].lo.y, patch_boxes[p].lo.z};
    double hi[3] = {patch_boxes[p].hi.x, patch_boxes[p].hi.y, patch_boxes[p].hi.z};
    surface_boxes.emplace_back(lo, hi, p);
  }
  CGAL::box_intersection_d(tri_boxes.begin(), tri_boxes.end(), surface_boxes.begin(), surface_boxes.end(),
                           [&](const IdBox& a, const IdBox& b) {
                             if (b.info() == mesh.triangle_patch[a.info()]) return;
                             uint32_t& slot = near.slot[a.info()];
                             if (slot == NearPatches::kNone) {
                               slot = static_cast<uint32_t>(near.lists.size());
                               near.lists.emplace_back();
                             }
                             near.lists[slot].push_back(static_cast<uint32_t>(b.info()));
                           });
  for (auto& list : near.lists) std::sort(list.begin(), list.end());
  return near;
}

// The estimates become distances to the model, not just the own patch. Only the largest estimates
// matter (they set the refinement target): visit triangles by decreasing own-patch estimate and
// stop once the next cannot exceed the running maximum, since matching to more patches only lowers
// an estimate.
void match_estimates_to_model(const Model& model, const Tessellation& mesh, const std::vector<Box>& patch_boxes,
                              const NearPatches& near, Estimates& est) {
  const size_t count = mesh.triangles.size();
  // Only triangles with a positive estimate can be visited (the walk stops at the first estimate
  // at most the running maximum, which is never negative).
  std::vector<size_t> by_estimate;
  for (size_t t = 0; t < count; ++t) {
    if (est.value[t] > 0.0) by_estimate.push_back(t);
  }
  std::sort(by_estimate.begin(), by_estimate.end(), [&](size_t a, size_t b) { return est.value[a] > est.value[b]; });
  double running_max = 0.0;
  size_t visited = 0;
  for (size_t t : by_estimate) {
    if ((visited++ & 255u) == 0) budget::check("validation");
    if (est.value[t] <= running_max) break;
    const std::vector<uint32_t>* others = near.of(t);
    if (!others) {
      running_max = est.value[t];
      continue;
    }
    const auto T = triangle_corners(mesh, t);
    const auto& uv = mesh.triangle_uv[t];
    double worst = 0.0;
    for (const Vec3& b : kEstimatePoints) {
      const Vec3 x = b.x * T[0] + b.y * T[1] + b.z * T[2];
      const BezierPatch& own = model.patches[mesh.triangle_patch[t]];
      const Vec2 q0 = b.x * uv[0] + b.y * uv[1] + b.z * uv[2];
      double e = norm(x - eval(own, project(own, x, q0)));
      for (uint32_t c : *others) {
        if (box_distance(patch_boxes[c], x) >= e) continue;
        const BezierPatch& other = model.patches[c];
        e = std::min(e, norm(x - eval(other, project_unseeded(other, x))));
      }
      if (e >= worst) {
        worst = e;
        est.point[t] = x;
      }
    }
    est.value[t] = worst;
    running_max = std::max(running_max, worst);
  }
}

// What pass 2 refines against: the patches' data and boxes, the other patches near each triangle,
// the mesh's AABB tree, the refinement target tau.
struct Refinement {
  const Model& model;
  const Tessellation& mesh;
  const CertifyOptions& options;
  const std::vector<PatchData>& pd;
  const std::vector<Box>& patch_boxes;
  const NearPatches& near;
  const detail::MeshDistance& mesh_distance;
  double tau;
  int max_depth;  // of the subdivision per triangle (the options' or a shallower first pass's)
  // Triangles whose cheap bound is at most `settled` keep it: no refinement could raise the
  // overall bound above the largest estimate through them.
  const std::vector<double>& cheap;
  double settled;
  // Triangles around each vertex (offsets into ring_triangles, by vertex).
  const std::vector<uint32_t>& ring_start;
  const std::vector<uint32_t>& ring_triangles;
  // The mesh triangle nearest to p (false for an empty mesh).
  bool nearest(const Vec3& p, std::array<Vec3, 3>& tri) const {
    const int64_t t = mesh_distance.closest_triangle(p);
    if (t < 0) return false;
    tri = triangle_corners(mesh, static_cast<size_t>(t));
    return true;
  }
  // Of the triangles sharing a vertex with triangle t, one nearest to p: where the mesh follows the
  // surface within a fraction of its triangles' size (the triangles refined here), a surface point
  // over t is nearest to one of them. Only a candidate for the bounds (any triangle is sound).
  bool nearest_around(size_t t, const Vec3& p, std::array<Vec3, 3>& tri) const {
    double best = kInf;
    for (uint32_t v : mesh.triangles[t]) {
      for (uint32_t k = ring_start[v]; k < ring_start[v + 1]; ++k) {
        const auto T = triangle_corners(mesh, ring_triangles[k]);
        const Vec3 d = p - closest_on_triangle(p, T[0], T[1], T[2]);
        const double d2 = glm::dot(d, d);
        if (d2 < best) {
          best = d2;
          tri = T;
        }
      }
    }
    return best < kInf;
  }
};

// The triangles around each vertex (compressed rows: start has one entry per vertex plus one).
void vertex_rings(const Tessellation& mesh, std::vector<uint32_t>& start, std::vector<uint32_t>& triangles) {
  start.assign(mesh.positions.size() + 1, 0);
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t v : t) ++start[v + 1];
  }
  for (size_t v = 0; v + 1 < start.size(); ++v) start[v + 1] += start[v];
  triangles.resize(start.back());
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    if ((i & 0xffffu) == 0) budget::check("validation");
    for (uint32_t v : mesh.triangles[i]) triangles[fill[v]++] = static_cast<uint32_t>(i);
  }
}

// Depth of the first refinement pass (see certify_conditioned).
constexpr int kFirstPassDepth = 4;
// Depth of the look taken before it where the estimates saw nothing (see certify_conditioned).
constexpr int kProbeDepth = 2;

// Pass 2: the triangles whose cheap bound is above rf.settled refined (only those with redo[t] set
// when redo is given, the others keep their results; without redo `results` is set up first, the
// others settled); each keeps the larger of its pass-1 estimate and the refinement's as the candidate
// for the lower bounds.
void refine_triangles(const Refinement& rf, const Estimates& est, TriangleResults& results,
                      const std::vector<char>* redo = nullptr) {
  const Tessellation& mesh = rf.mesh;
  const CertifyOptions& options = rf.options;
  if (!redo) results.init(rf.cheap, rf.settled, est.value, est.point, est.uv);
  const std::vector<uint32_t>& refined = results.refined();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, refined.size(), 4), [&](const tbb::blocked_range<size_t>& range) {
    Scratch s;
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const size_t t = refined[k];
      if (redo && !(*redo)[t]) continue;
      TriangleResult& result = results.stored(k);
      // With a restricted domain (a face of a part, cut along its patch grid) the triangles are
      // few and large, and a surface point over t may lie nearest to a triangle beyond t's ring
      // (an analytic face's re-parametrised circle over a coarse triangle): the mesh's tree is
      // asked too, and the nearer candidate kept.
      const bool search_tree = static_cast<bool>(options.in_domain);
      const auto nearest = [&rf, t, search_tree](const Vec3& p, std::array<Vec3, 3>& tri) {
        if (!search_tree) return rf.nearest_around(t, p, tri);
        std::array<Vec3, 3> ring{}, any{};
        const bool r = rf.nearest_around(t, p, ring), a = rf.nearest(p, any);
        if (!r && !a) return false;
        const auto distance = [&p](const std::array<Vec3, 3>& T) {
          return norm(p - closest_on_triangle(p, T[0], T[1], T[2]));
        };
        tri = !a || (r && distance(ring) <= distance(any)) ? ring : any;
        return true;
      };
      const uint32_t patch = mesh.triangle_patch[t];
      BoxInDomain box_in_domain;
      if (options.box_in_domain) {
        box_in_domain = [&options, patch](const Vec2& lo, const Vec2& hi, const Vec2& inside) {
          return options.box_in_domain(patch, lo, hi, inside);
        };
      }
      result = refine_triangle(
          rf.pd[patch], mesh.triangle_uv[t], triangle_corners(mesh, t), rf.tau, options.target_ratio, rf.max_depth, s,
          false, nullptr, nearest, OtherPatches{&rf.pd, &rf.patch_boxes, rf.near.of(t)},
          options.in_domain && !options.domain_contains_patches, rf.cheap[t], &box_in_domain, est.midpoints_of(t));
      if (result.m2s_est < est.value[t]) {
        result.m2s_est = est.value[t];
        result.m2s_point = est.point[t];
      }
      if (result.s2m_est < est.value[t]) {
        result.s2m_uv = est.uv[t];
        result.s2m_est = est.value[t];
      }
    }
  });
}

// Dropped degenerate triangles next to collapsed sides: surface->mesh only (only those with redo[i]
// set when redo is given).
void refine_holes(const Refinement& rf, const std::vector<Hole>& holes, const std::vector<double>& cheap,
                  std::vector<TriangleResult>& hole_results, const std::vector<char>* redo = nullptr) {
  const CertifyOptions& options = rf.options;
  const auto nearest = [&](const Vec3& p, std::array<Vec3, 3>& tri) { return rf.nearest(p, tri); };
  hole_results.resize(holes.size());
  tbb::parallel_for(size_t(0), holes.size(), [&](size_t i) {
    if (redo && !(*redo)[i]) return;
    if (cheap[i] <= rf.settled) {  // the surface over the hole is within cheap[i] of its mesh edge
      hole_results[i].s2m = cheap[i];
      hole_results[i].leaves = 1;
      return;
    }
    Scratch s;
    hole_results[i] = refine_triangle(rf.pd[holes[i].patch], holes[i].uv, holes[i].X, rf.tau, options.target_ratio,
                                      rf.max_depth, s, true, &holes[i].neighbours, nearest);
  });
}

// The upper bounds of both directions over the triangles (and holes); fills the report's
// per-triangle bounds, leaves and exhausted count.
struct Uppers {
  double m2s = 0.0, s2m = 0.0;
};
Uppers collect_uppers(const TriangleResults& results, const std::vector<TriangleResult>& hole_results,
                      DistanceReport& report) {
  Uppers u;
  for (const TriangleResult& r : hole_results) {
    u.s2m = std::max(u.s2m, r.s2m);
    report.leaves += r.leaves;
    report.budget_exhausted += r.exhausted ? 1 : 0;
  }
  for (size_t t = 0; t < results.size(); ++t) {
    const double m2s = results.m2s(t), s2m = results.s2m(t);
    u.m2s = std::max(u.m2s, m2s);
    u.s2m = std::max(u.s2m, s2m);
    report.triangle_upper[t] = std::max(m2s, s2m);
    report.leaves += results.leaves(t);
    report.budget_exhausted += results.exhausted(t) ? 1 : 0;
  }
  return u;
}

// The rounding term at the worst triangle's scale, for the report.
double worst_triangle_rounding(const Tessellation& mesh, const std::vector<PatchData>& pd,
                               const std::vector<double>& triangle_upper) {
  const size_t worst =
      static_cast<size_t>(std::max_element(triangle_upper.begin(), triangle_upper.end()) - triangle_upper.begin());
  const auto T = triangle_corners(mesh, worst);
  const PatchData& P = pd[mesh.triangle_patch[worst]];
  const Vec3 X[3] = {T[0], T[1], T[2]};
  double xmag = 0.0;
  for (const Vec3& x : X) xmag = std::max(xmag, norm(x - P.origin));
  return 8.0 * (P.n + P.m + 1 + 4) * kUnit * (P.hmag + P.wmax * xmag) / P.wmin + 4.0 * kUnit * P.lipschitz;
}

// The mesh triangles that can be nearest to a query point of pass 2 or of the lower bounds: every
// such point is a surface point over a triangle that is refined (cheap bound above `settled`) or was
// estimated, or over a hole, within that triangle's bound r of the triangle itself; so its nearest
// mesh triangle is within r too, and its box meets the triangle's box grown by 2 r. Empty when that
// is most of the mesh (the caller then indexes all of it) or a bound is infinite.
double largest_component(const Vec3& v) { return std::max({v.x, v.y, v.z}); }

std::vector<uint32_t> triangles_near_queries(const Tessellation& mesh, const std::vector<double>& cheap, double settled,
                                             const std::vector<char>& visited, const std::vector<Hole>& holes,
                                             const std::vector<double>& hole_cheap) {
  const size_t count = mesh.triangles.size();
  std::vector<Box> queries;
  const auto add_query = [&](const std::array<Vec3, 3>& T, double r) {
    if (!(r < kInf)) return false;
    Box box{glm::min(glm::min(T[0], T[1]), T[2]), glm::max(glm::max(T[0], T[1]), T[2])};
    // 2 r, plus a margin for the rounding of the query points and of the boxes (1e-9 relative).
    const Vec3 grow = Vec3(2.0 * r) + 1e-9 * (glm::abs(box.lo) + glm::abs(box.hi) + Vec3(r));
    queries.push_back({box.lo - grow, box.hi + grow});
    return true;
  };
  for (size_t t = 0; t < count; ++t) {
    if ((t & 0xffffu) == 0) budget::check("validation");
    if (visited[t] || !(cheap[t] <= settled)) {
      if (!add_query(triangle_corners(mesh, t), cheap[t])) return {};
    }
  }
  for (size_t i = 0; i < holes.size(); ++i) {
    if (!(hole_cheap[i] <= settled) && !add_query(holes[i].X, hole_cheap[i])) return {};
  }
  if (queries.empty() || 2 * queries.size() > count) return {};
  // Voxels of about the mean query size over the mesh's box: those a query box meets are marked,
  // and a triangle is chosen when its box meets a marked voxel (a superset of the boxes meeting a
  // query box).
  Box world{Vec3(kInf), Vec3(-kInf)};
  for (const Vec3& p : mesh.positions) {
    world.lo = glm::min(world.lo, p);
    world.hi = glm::max(world.hi, p);
  }
  const Vec3 extent = world.hi - world.lo;
  double mean = 0.0;
  for (const Box& q : queries) mean += largest_component(q.hi - q.lo) / static_cast<double>(queries.size());
  const double cell = std::max({mean, largest_component(extent) / 256.0, std::numeric_limits<double>::min()});
  if (!std::isfinite(cell) || !std::isfinite(largest_component(extent))) return {};
  int dims[3];
  for (int k = 0; k < 3; ++k) dims[k] = std::clamp(static_cast<int>(extent[k] / cell) + 1, 1, 256);
  const auto voxel = [&](double x, int k) {
    return std::clamp(static_cast<int>((x - world.lo[k]) / extent[k] * dims[k]), 0, dims[k] - 1);
  };
  const auto range = [&](const Box& b, int lo[3], int hi[3]) {
    for (int k = 0; k < 3; ++k) {
      if (!(extent[k] > 0.0)) {
        lo[k] = hi[k] = 0;
        continue;
      }
      lo[k] = voxel(b.lo[k], k);
      hi[k] = voxel(b.hi[k], k);
    }
  };
  std::vector<char> marked(static_cast<size_t>(dims[0]) * dims[1] * dims[2], 0);
  const auto index = [&](int x, int y, int z) { return (static_cast<size_t>(x) * dims[1] + y) * dims[2] + z; };
  for (const Box& q : queries) {
    int lo[3], hi[3];
    range(q, lo, hi);
    for (int x = lo[0]; x <= hi[0]; ++x)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int z = lo[2]; z <= hi[2]; ++z) marked[index(x, y, z)] = 1;
  }
  // Blocks of triangles in parallel, each chosen list in triangle order, joined in block order.
  constexpr size_t kBlock = 16384;
  std::vector<std::vector<uint32_t>> chosen_in((count + kBlock - 1) / kBlock);
  tbb::parallel_for(size_t(0), chosen_in.size(), [&](size_t k) {
    budget::check("validation");
    for (size_t t = k * kBlock; t < std::min(count, (k + 1) * kBlock); ++t) {
      const auto T = triangle_corners(mesh, t);
      const Box b{glm::min(glm::min(T[0], T[1]), T[2]), glm::max(glm::max(T[0], T[1]), T[2])};
      int lo[3], hi[3];
      range(b, lo, hi);
      bool chosen = false;
      for (int x = lo[0]; x <= hi[0] && !chosen; ++x)
        for (int y = lo[1]; y <= hi[1] && !chosen; ++y)
          for (int z = lo[2]; z <= hi[2] && !chosen; ++z) chosen = marked[index(x, y, z)] != 0;
      if (chosen) chosen_in[k].push_back(static_cast<uint32_t>(t));
    }
  });
  std::vector<uint32_t> subset;
  for (const std::vector<uint32_t>& block : chosen_in) subset.insert(subset.end(), block.begin(), block.end());
  if (2 * subset.size() > count) return {};
  return subset;
}

// ---------------------------------------------------------------------------------------------
// Surface->mesh over the projected leaves.
//
// The corner-matched surface->mesh bound of a leaf pairs its surface corners with their closest
// points on one mesh triangle; where the surface over a leaf is nearest to two triangles (along a
// mesh edge, when the triangles' (u, v) drift from their positions along the surface) it falls
// only with the leaf's size. Here the surface is tiled instead by the leaves mapped through the
// projections of their points: for a leaf with points X_k (its corners and the other leaves'
// corners on its sides, in order around it) and their projections p_k onto the patch, each fan
// triangle (p_0, p_k, p_k+1) carries the composed bound of S over it against the flat triangle
// (X_0, X_k, X_k+1), which lies on the mesh. A point shared by several leaves (or two mesh
// triangles) is computed from canonical data, so it projects to the same p in all; the fans' edges
// then cancel in pairs except along the edges of one triangle (the union's boundary), whose ends
// keep their (u, v) and whose inner points move along the edge only. So the fans' boundaries add
// up to the union's boundary moved along itself: every point of the (u, v) triangles' union (off
// that boundary) has a nonzero winding number around them, lies in some fan triangle, and its
// surface point is within that triangle's bound of the mesh. The bound is the largest over the fans.

// A point of a triangle at exact barycentric b, with (u, v) and position computed from canonical
// data: a mesh vertex's own, a point of a mesh edge from the edge's endpoints in a fixed order.
struct ChainPoint {
  Vec2 q;
  Vec3 X;
};

bool lexicographic_less(const Vec2& qa, const Vec3& xa, const Vec2& qb, const Vec3& xb) {
  const std::array<double, 5> a{qa.x, qa.y, xa.x, xa.y, xa.z}, b{qb.x, qb.y, xb.x, xb.y, xb.z};
  return a < b;
}

ChainPoint chain_point(const std::array<Vec2, 3>& uv, const std::array<Vec3, 3>& T, const Vec3& b) {
  const double w[3] = {b.x, b.y, b.z};
  int zeros = 0, zero = -1;
  for (int i = 0; i < 3; ++i) {
    if (w[i] == 0.0) ++zeros, zero = i;
  }
  if (zeros == 2) {
    for (int i = 0; i < 3; ++i) {
      if (w[i] != 0.0) return {uv[static_cast<size_t>(i)], T[static_cast<size_t>(i)]};
    }
  }
  if (zeros == 1) {
    size_t i = static_cast<size_t>((zero + 1) % 3), j = static_cast<size_t>((zero + 2) % 3);
    if (lexicographic_less(uv[j], T[j], uv[i], T[i])) std::swap(i, j);
    const double t = w[j];  // exact (dyadic); 1 - t is exact too
    return {(1.0 - t) * uv[i] + t * uv[j], (1.0 - t) * T[i] + t * T[j]};
  }
  return {b.x * uv[0] + b.y * uv[1] + b.z * uv[2], b.x * T[0] + b.y * T[1] + b.z * T[2]};
}

// The canonical key of a mesh edge of one patch: its endpoints' (u, v) and positions, ordered.
struct EdgeKey {
  uint32_t patch;
  std::array<double, 10> ends;
  bool operator==(const EdgeKey& o) const { return patch == o.patch && ends == o.ends; }
};
struct EdgeKeyHash {
  size_t operator()(const EdgeKey& k) const {
    size_t h = std::hash<uint32_t>()(k.patch);
    for (double d : k.ends) h = h * 0x9e3779b97f4a7c15ull ^ std::hash<double>()(d);
    return h;
  }
};

EdgeKey edge_key(uint32_t patch, const Vec2& qa, const Vec3& xa, const Vec2& qb, const Vec3& xb) {
  const bool swap = lexicographic_less(qb, xb, qa, xa);
  const Vec2& q0 = swap ? qb : qa;
  const Vec2& q1 = swap ? qa : qb;
  const Vec3& x0 = swap ? xb : xa;
  const Vec3& x1 = swap ? xa : xb;
  return {patch, {q0.x, q0.y, x0.x, x0.y, x0.z, q1.x, q1.y, x1.x, x1.y, x1.z}};
}

// A triangle of the tiling (a mesh triangle) with its kept leaves.
struct Tile {
  uint32_t patch = 0;
  std::array<Vec2, 3> uv;
  std::array<Vec3, 3> X;
  const std::vector<std::array<Vec3, 3>>* leaves = nullptr;
};

// The surface->mesh bound over the projected leaves (see above), per tile: the fans of a tile's
// leaves cover (with those of the others) the union of the tiles' (u, v) triangles, and those along
// an edge with one tile cover that edge's (u, v) segment. Empty when an edge is shared by more than
// two tiles or a tile is reversed in (u, v).
std::vector<double> surface_over_projected_leaves(const std::vector<Tile>& tiles, const std::vector<PatchData>& pd) {
  const size_t count = tiles.size();
  for (const Tile& tile : tiles) {
    const auto& q = tile.uv;
    if ((q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y) < 0.0) return {};
  }
  // The mesh's edges: how many triangles have them, and the sum of their directions (+1 from the
  // key's first end to its second, -1 the other way). An edge of two triangles must be crossed in
  // opposite directions (the triangles lie on its two sides), so that the two chains cancel.
  std::unordered_map<EdgeKey, std::pair<int, int>, EdgeKeyHash> edges;
  for (size_t t = 0; t < count; ++t) {
    const auto& T = tiles[t].X;
    const auto& uv = tiles[t].uv;
    for (size_t i = 0; i < 3; ++i) {
      const size_t j = (i + 1) % 3;
      auto& [n, direction] = edges[edge_key(tiles[t].patch, uv[i], T[i], uv[j], T[j])];
      ++n;
      direction += lexicographic_less(uv[i], T[i], uv[j], T[j]) ? 1 : -1;
    }
  }
  // The ends of the boundary edges (one triangle): they keep their own (u, v), and the edges' inner
  // points move along the edge only, so the fans' outer boundary is the triangles' own.
  std::unordered_map<EdgeKey, int, EdgeKeyHash> boundary_ends;  // keyed as the edge (end, end)
  for (const auto& [key, edge] : edges) {
    if (edge.first > 2 || (edge.first == 2 && edge.second != 0)) return {};
    if (edge.first != 1) continue;
    for (int e = 0; e < 2; ++e) {
      const double* c = key.ends.data() + 5 * e;
      const Vec2 q(c[0], c[1]);
      const Vec3 X(c[2], c[3], c[4]);
      boundary_ends[edge_key(key.patch, q, X, q, X)] = 1;
    }
  }
  // Which mesh edge a barycentric point with one zero lies on: its key and parameter from the
  // edge's first end (as chain_point computes it).
  const auto on_edge = [&](size_t t, const Vec3& b, EdgeKey& key, double& param) {
    const double w[3] = {b.x, b.y, b.z};
    int zeros = 0, zero = -1;
    for (int i = 0; i < 3; ++i) {
      if (w[i] == 0.0) ++zeros, zero = i;
    }
    if (zeros != 1) return false;
    const auto& T = tiles[t].X;
    const auto& uv = tiles[t].uv;
    size_t i = static_cast<size_t>((zero + 1) % 3), j = static_cast<size_t>((zero + 2) % 3);
    if (lexicographic_less(uv[j], T[j], uv[i], T[i])) std::swap(i, j);
    key = edge_key(tiles[t].patch, uv[i], T[i], uv[j], T[j]);
    param = w[j];
    return true;
  };
  // The leaves' corners on each mesh edge, by parameter.
  std::unordered_map<EdgeKey, std::vector<double>, EdgeKeyHash> edge_points;
  for (size_t t = 0; t < count; ++t) {
    for (const auto& leaf : *tiles[t].leaves) {
      for (const Vec3& b : leaf) {
        EdgeKey key;
        double param = 0.0;
        if (on_edge(t, b, key, param)) edge_points[key].push_back(param);
      }
    }
  }
  for (auto& [key, params] : edge_points) {
    std::sort(params.begin(), params.end());
    params.erase(std::unique(params.begin(), params.end()), params.end());
  }
  std::vector<double> bound(count, 0.0);
  tbb::parallel_for(size_t(0), count, [&](size_t t) {
    budget::check("validation");
    Scratch s;
    const auto& T = tiles[t].X;
    const auto& uv = tiles[t].uv;
    const uint32_t patch = tiles[t].patch;
    const PatchData& P = pd[patch];
    const std::vector<std::array<Vec3, 3>> leaves =
        tiles[t].leaves->empty() ? std::vector<std::array<Vec3, 3>>{{Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}}
                                 : *tiles[t].leaves;
    CornerCache inside;  // the leaves' corners (membership only)
    for (const auto& leaf : leaves) {
      for (const Vec3& b : leaf) inside.at(b);
    }
    const auto present = [&](const Vec3& b) {
      EdgeKey key;
      double param = 0.0;
      if (on_edge(t, b, key, param)) {
        const auto it = edge_points.find(key);
        return it != edge_points.end() && std::binary_search(it->second.begin(), it->second.end(), param);
      }
      return inside.contains(b);
    };
    // A point's projection: a boundary edge's end keeps its (u, v), a boundary edge's inner point
    // moves along the edge, any other point is projected onto the patch.
    const auto project = [&](const Vec3& b, const ChainPoint& c) {
      EdgeKey key;
      double param = 0.0;
      if (on_edge(t, b, key, param)) {
        if (edges.at(key).first != 1) return P.project(c.X, c.q);
        return P.project_on_segment(c.X, Vec2(key.ends[0], key.ends[1]), Vec2(key.ends[5], key.ends[6]), param);
      }
      if (b.x == 1.0 || b.y == 1.0 || b.z == 1.0) {  // a vertex
        return boundary_ends.count(edge_key(patch, c.q, c.X, c.q, c.X)) ? c.q : P.project(c.X, c.q);
      }
      return P.project(c.X, c.q);
    };
    std::map<std::array<double, 3>, std::pair<ChainPoint, Vec2>> projected;
    const auto point = [&](const Vec3& b) -> const std::pair<ChainPoint, Vec2>& {
      auto [it, added] = projected.try_emplace({b.x, b.y, b.z});
      if (added) {
        it->second.first = chain_point(uv, T, b);
        it->second.second = project(b, it->second.first);
      }
      return it->second;
    };
    std::vector<Vec3> chain;
    // The points of the leaf edge (a, b], b last: a midpoint where some leaf has a corner first.
    const std::function<void(const Vec3&, const Vec3&, int)> walk = [&](const Vec3& a, const Vec3& b, int depth) {
      const Vec3 m = 0.5 * (a + b);
      if (depth < 64 && present(m)) {
        walk(a, m, depth + 1);
        walk(m, b, depth + 1);
      } else {
        chain.push_back(b);
      }
    };
    double worst = 0.0;
    for (const auto& leaf : leaves) {
      chain.clear();
      walk(leaf[0], leaf[1], 0);
      walk(leaf[1], leaf[2], 0);
      walk(leaf[2], leaf[0], 0);  // ends with leaf[0]
      const auto& first = point(chain.back());
      for (size_t k = 0; k + 2 < chain.size(); ++k) {
        const auto& c1 = point(chain[k]);
        const auto& c2 = point(chain[k + 1]);
        const Vec2 q[3] = {first.second, c1.second, c2.second};
        const Vec3 X[3] = {first.first.X, c1.first.X, c2.first.X};
        worst = std::max(worst, composed_bound(P, q, X, s));
      }
    }
    bound[t] = worst;
  });
  return bound;
}

// The Hausdorff interval from the two one-sided ones; the witness of the larger lower bound.
void set_hausdorff(DistanceReport& report) {
  report.hausdorff.lower = std::max(report.mesh_to_surface.lower, report.surface_to_mesh.lower);
  report.hausdorff.upper = std::max(report.mesh_to_surface.upper, report.surface_to_mesh.upper);
  report.hausdorff.certified = report.mesh_to_surface.certified && report.surface_to_mesh.certified;
  const bool m2s_wins = report.mesh_to_surface.lower >= report.surface_to_mesh.lower;
  report.hausdorff.witness = m2s_wins ? report.mesh_to_surface.witness : report.surface_to_mesh.witness;
  report.hausdorff.witness_patch =
      m2s_wins ? report.mesh_to_surface.witness_patch : report.surface_to_mesh.witness_patch;
}

// certify_distance on a model and mesh in the safe range (certify_distance runs it through
// detail::with_safe_arithmetic, conditioning.hpp).
DistanceReport certify_conditioned(const Model& model, const Tessellation& mesh, const CertifyOptions& options) {
  const auto start = std::chrono::steady_clock::now();

  DistanceReport report;
  report.triangle_upper.assign(mesh.triangles.size(), 0.0);
  if (mesh.triangles.empty()) {
    report.coverage_note = "the mesh has no triangles";
    report.seconds = 0.0;
    return report;
  }
  std::vector<PatchData> pd;
  pd.reserve(model.patches.size());
  for (const BezierPatch& p : model.patches) pd.push_back(make_patch_data(p));
  CheapBounds cheap_bounds = cheap_triangle_bounds(mesh, pd);
  std::vector<double>& cheap = cheap_bounds.triangle;
  std::vector<char> visited;
  Estimates est = own_patch_estimates(mesh, pd, cheap, visited);
  std::vector<Box> patch_boxes(model.patches.size());
  for (size_t p = 0; p < model.patches.size(); ++p) patch_boxes[p] = control_box(model.patches[p]);
  NearPatches near;
  // Leaves may be matched to a neighbouring patch where every patch is the surface's (no domain, or
  // one that contains its patches whole: an untrimmed face's seams and patch sides).
  if (model.patches.size() > 1 && (!options.in_domain || options.domain_contains_patches)) {
    near = near_patches(model, mesh, est, patch_boxes);
    match_estimates_to_model(model, mesh, patch_boxes, near, est);
  }
  const double estimate = *std::max_element(est.value.begin(), est.value.end());
  // Refinement target; the floor (1e-12 of the model's size, near the rounding term) stops exact
  // meshes (planar patches) from refining to the depth budget for nothing.
  const double floor = std::max(1e-12, options.refine_floor) * model_box(model).diagonal();
  const double tau = std::max(options.target_ratio * estimate, floor);
  // A triangle whose cheap bound is at most the largest estimate (or the floor) keeps that bound.
  const double settled = std::max(estimate, floor);
  // Dropped degenerate triangles next to collapsed sides: surface->mesh only.
  // (Not with a restricted domain: there coverage is the caller's to prove.)
  const std::vector<Hole> holes = options.in_domain ? std::vector<Hole>{} : collapsed_side_holes(model, mesh);
  // Pass 2: refinement. The mesh's AABB tree answers nearest-triangle queries from the triangles
  // refined or estimated and from the holes only, so it holds only the triangles near those.
  const std::vector<double> hole_cheap = cheap_hole_bounds(holes, pd, cheap_bounds);
  const std::vector<uint32_t> near_queries = triangles_near_queries(mesh, cheap, settled, visited, holes, hole_cheap);
  const detail::MeshDistance mesh_distance(mesh, near_queries.empty() ? nullptr : &near_queries);
  std::vector<uint32_t> ring_start, ring_triangles;
  vertex_rings(mesh, ring_start, ring_triangles);
  // First to a shallow depth: a triangle done there has its final result (the depth budget did
  // not bind). The others are refined again to the full depth, against tau raised to target_ratio
  // times the largest distance the first pass saw: where the estimates miss the worst error (a
  // planar face whose error is a chord's sagitta at its curved side, zero inside), a leaf whose
  // distance is ~0 would otherwise refine to the depth budget to get below the estimate.
  Refinement rf{model,
                mesh,
                options,
                pd,
                patch_boxes,
                near,
                mesh_distance,
                tau,
                std::min(options.max_depth, kFirstPassDepth),
                cheap,
                settled,
                ring_start,
                ring_triangles};
  TriangleResults results;
  std::vector<TriangleResult> hole_results;
  uint64_t earlier_leaves = 0;  // evaluated by the passes whose results a later pass replaces
  // Neither the estimates nor the look below saw a distance above the floor: an exact mesh (a flat
  // face whose parametrisation is not affine over its triangles, such as a lofted B-spline side,
  // has leaf bounds of second order in their size that never reach the floor). The first pass's
  // bounds are kept: refining to the full depth only polishes a bound on distances that are all
  // below the floor (drafted_pocket's four loft sides: 26-31 s each at depth 8 for 1.7e-6).
  bool nothing_seen = false;
  if (estimate < floor && rf.max_depth > kProbeDepth) {
    // The estimates saw nothing above the rounding floor, but the cheap bounds leave room: a
    // surface that leaves the mesh between the estimates' points (bearing.iges's small B-spline
    // faces with a collapsed side: the estimates ~1e-17, the face's distance 1.7e-5, every triangle
    // refined to the first pass's depth against the floor). A shallow look first; the largest
    // distance it sees (measured at its leaves' corners, so a distance the mesh really has) raises
    // the target, as the second pass does. Only the target changes: every bound stays proven.
    Refinement look = rf;
    look.max_depth = kProbeDepth;
    TriangleResults seen_results;
    std::vector<TriangleResult> seen_holes;
    refine_triangles(look, est, seen_results);
    refine_holes(look, holes, hole_cheap, seen_holes);
    double seen = 0.0;
    for (size_t t = 0; t < seen_results.size(); ++t)
      seen = std::max({seen, seen_results.s2m_est(t), seen_results.m2s_est(t)});
    for (size_t k = 0; k < seen_results.refined().size(); ++k) earlier_leaves += seen_results.stored(k).leaves;
    for (const TriangleResult& r : seen_holes) seen = std::max(seen, r.s2m_est), earlier_leaves += r.leaves;
    rf.tau = std::max(rf.tau, options.target_ratio * seen);
    nothing_seen = seen <= floor;
  }
  refine_triangles(rf, est, results);
  refine_holes(rf, holes, hole_cheap, hole_results);
  if (rf.max_depth < options.max_depth && !nothing_seen) {
    double seen = 0.0;
    std::vector<char> redo(results.size(), 0), redo_holes(hole_results.size(), 0);
    bool any = false;
    for (size_t t = 0; t < results.size(); ++t) {
      seen = std::max({seen, results.s2m_est(t), results.m2s_est(t)});
      redo[t] = results.exhausted(t) ? 1 : 0;
      any = any || results.exhausted(t);
    }
    for (size_t i = 0; i < hole_results.size(); ++i) {
      seen = std::max(seen, hole_results[i].s2m_est);
      redo_holes[i] = hole_results[i].exhausted ? 1 : 0;
      any = any || hole_results[i].exhausted;
    }
    if (any) {
      // Both passes' bounds are proven over the whole triangle: each keeps the smaller (the second
      // pass refines against a raised target, so it may stop above what the first reached).
      const auto bounds = [](auto&& result, size_t count) {
        std::vector<std::pair<double, double>> out(count);
        for (size_t k = 0; k < count; ++k) out[k] = {result(k).m2s, result(k).s2m};
        return out;
      };
      const auto keep_smaller = [](auto&& result, const std::vector<std::pair<double, double>>& first) {
        for (size_t k = 0; k < first.size(); ++k) {
          result(k).m2s = std::min(result(k).m2s, first[k].first);
          result(k).s2m = std::min(result(k).s2m, first[k].second);
        }
      };
      const auto refined = [&results](size_t k) -> TriangleResult& { return results.stored(k); };
      const auto hole = [&hole_results](size_t k) -> TriangleResult& { return hole_results[k]; };
      const auto first = bounds(refined, results.refined().size()), first_holes = bounds(hole, hole_results.size());
      for (size_t k = 0; k < results.refined().size(); ++k)
        earlier_leaves += redo[results.refined()[k]] ? results.stored(k).leaves : 0;
      for (size_t i = 0; i < hole_results.size(); ++i) earlier_leaves += redo_holes[i] ? hole_results[i].leaves : 0;
      rf.max_depth = options.max_depth;
      rf.tau = std::max(tau, options.target_ratio * seen);
      refine_triangles(rf, est, results, &redo);
      refine_holes(rf, holes, hole_cheap, hole_results, &redo_holes);
      keep_smaller(refined, first);
      keep_smaller(hole, first_holes);
    }
  }
  Uppers upper = collect_uppers(results, hole_results, report);
  report.leaves += earlier_leaves;
  report.rounding = worst_triangle_rounding(mesh, pd, report.triangle_upper);
  if (options.in_domain) {
    report.coverage_note = "restricted domain: the caller checks that the triangles cover it";
  } else {
    report.coverage_ok = check_coverage(model, mesh, holes, report.coverage_note);
  }
  report.holes = holes.size();
  // The tiling by projected leaves covers what the (u, v) triangles cover: each patch whole (the
  // coverage check), or the triangles' union on an untrimmed face cut along its patch grid (the
  // caller proves that it covers the face). Not next to a collapsed side (holes): projections are
  // ill-conditioned along it (shell1's Faces 31 and 41: 21x and 25x looser than the corner-matched
  // bound, with the holes' own bounds kept). Tried where the corner-matched bound sets the upper end,
  // and (without a restricted domain, whose candidates may lie outside it) not where it is within
  // the target ratio of the largest distance seen anyway (the teaspoon at 4 segments: 1.012 -> 1.008
  // for 1.7x the certificate's time).
  double seen = 0.0;
  if (!options.in_domain) {
    for (size_t t = 0; t < results.size(); ++t) seen = std::max({seen, results.s2m_est(t), results.m2s_est(t)});
  }
  if (holes.empty() && (options.in_domain ? options.domain_contains_patches : report.coverage_ok) &&
      upper.s2m > options.target_ratio * std::max(upper.m2s, seen)) {
    std::vector<Tile> tiles;
    for (size_t t = 0; t < mesh.triangles.size(); ++t)
      tiles.push_back({mesh.triangle_patch[t], mesh.triangle_uv[t], triangle_corners(mesh, t), results.kept_leaves(t)});
    const std::vector<double> over = surface_over_projected_leaves(tiles, pd);
    if (!over.empty()) {
      const double s2m = *std::max_element(over.begin(), over.end());
      if (s2m < upper.s2m) {
        upper.s2m = s2m;
        for (size_t t = 0; t < results.size(); ++t) report.triangle_upper[t] = std::max(results.m2s(t), over[t]);
      }
    }
  }
  if (options.in_domain) report.surface_to_mesh_over_triangles = upper.s2m;
  report.mesh_to_surface.upper = upper.m2s;
  report.mesh_to_surface.certified = true;
  report.surface_to_mesh.upper = report.coverage_ok ? upper.s2m : kInf;
  report.surface_to_mesh.certified = report.coverage_ok;
  certify_lowers(model, pd, mesh, results, options, mesh_distance, report);
  set_hausdorff(report);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace

DistanceReport certify_distance(const Model& model, const Tessellation& mesh, const CertifyOptions& options) {
  if (!mesh.has_surface() || mesh.triangle_patch.size() != mesh.triangles.size() ||
      mesh.triangle_uv.size() != mesh.triangles.size()) {
    throw InputError("certify_distance: the mesh carries no per-triangle (patch, u, v); use certify_external");
  }
  for (uint32_t p : mesh.triangle_patch) {
    if (p >= model.patches.size()) throw InputError("certify_distance: a triangle refers to patch " + std::to_string(p) +
                                                    " but the model has " + std::to_string(model.patches.size()));
  }
  return detail::with_safe_arithmetic(model, mesh, [&](const Model& m, const Tessellation& t) {
    return certify_conditioned(m, t, options);
  });
}

}  // namespace sagitta
