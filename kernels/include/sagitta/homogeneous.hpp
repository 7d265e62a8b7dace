// Homogeneous points (w x, w y, w z, w) for the de Casteljau evaluators, written once for two
// representations: HPoint (four doubles, one component at a time) and, on x86-64 with GCC or Clang,
// HVector (one 256-bit vector, for code compiled for AVX2 only: with plain SSE2, GCC's code for
// 32-byte vectors ran slower than the scalar loops). Both do the same operations per component, so
// they give the same values bit for bit (no FMA is enabled, so no multiply-add is fused).
// All functions are always inlined: no HVector crosses a call (GCC's note that AVX vectors change
// the ABI is moot).
#pragma once

#include <array>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
namespace sagitta::detail {

using HPoint = std::array<double, 4>;

template <class Point>
[[gnu::always_inline]] inline Point make_point(double x, double y, double z, double w) {
  return Point{x, y, z, w};
}
// s a + t b.
[[gnu::always_inline]] inline HPoint combine(const HPoint& a, const HPoint& b, double s, double t) {
  return {s * a[0] + t * b[0], s * a[1] + t * b[1], s * a[2] + t * b[2], s * a[3] + t * b[3]};
}
// d (b - a).
[[gnu::always_inline]] inline HPoint scaled_difference(const HPoint& a, const HPoint& b, double d) {
  return {d * (b[0] - a[0]), d * (b[1] - a[1]), d * (b[2] - a[2]), d * (b[3] - a[3])};
}
[[gnu::always_inline]] inline HPoint to_point(const HPoint& h) { return h; }

#if defined(__GNUC__) && defined(__x86_64__)
#define SAGITTA_HVECTOR 1
typedef double HVector __attribute__((vector_size(32)));

[[gnu::always_inline]] inline HVector combine(const HVector& a, const HVector& b, double s, double t) {
  const HVector sv = {s, s, s, s}, tv = {t, t, t, t};
  return sv * a + tv * b;
}
[[gnu::always_inline]] inline HVector scaled_difference(const HVector& a, const HVector& b, double d) {
  const HVector dv = {d, d, d, d};
  return dv * (b - a);
}
[[gnu::always_inline]] inline HPoint to_point(const HVector& h) { return {h[0], h[1], h[2], h[3]}; }
#endif

}  // namespace sagitta::detail
#pragma GCC diagnostic pop
