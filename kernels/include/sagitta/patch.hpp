// Bézier patches: degree 1..25 in u and v, optionally rational (all weights > 0).
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace sagitta {

using Vec2 = glm::dvec2;
using Vec3 = glm::dvec3;

inline constexpr int kMaxDegree = 25;

// Thrown for any input that violates a documented precondition; the message is one line a user can act on.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A tensor-product Bézier patch. Control point (i, j) is row i (the u index, 0..degree_u) and column
// j (the v index, 0..degree_v), stored row-major as in .bpt files: points[i * (degree_v + 1) + j].
// The surface is S(u, v) = sum_ij B_i^n(u) B_j^m(v) w_ij P_ij / sum_ij B_i^n(u) B_j^m(v) w_ij.
struct BezierPatch {
  int degree_u = 3;
  int degree_v = 3;
  std::vector<Vec3> points;
  std::vector<double> weights;  // empty: polynomial patch; else one weight > 0 per control point

  int rows() const { return degree_u + 1; }
  int cols() const { return degree_v + 1; }
  bool rational() const { return !weights.empty(); }
  const Vec3& at(int i, int j) const { return points[static_cast<size_t>(i * cols() + j)]; }
  Vec3& at(int i, int j) { return points[static_cast<size_t>(i * cols() + j)]; }
  double weight(int i, int j) const { return weights.empty() ? 1.0 : weights[static_cast<size_t>(i * cols() + j)]; }
};

// Largest coordinate magnitude a patch may have: beyond it the derivatives (up to 50 times the
// coordinates) and their cross products (the normals) overflow double.
inline constexpr double kMaxCoordinate = 1e150;

// Throws InputError naming `what` unless the patch is well formed: degrees in 1..25, the right number
// of points (and weights, if any), all coordinates finite and within +-kMaxCoordinate, all weights
// finite and > 0.
void validate_patch(const BezierPatch& patch, const std::string& what);

// Weights whose largest lies within 2^-kWeightExponentLimit .. 2^kWeightExponentLimit are left as
// they are by normalize_weights.
inline constexpr int kWeightExponentLimit = 100;

// Scales a rational patch's weights by a power of two so the largest lies in [1, 2) when it lies
// outside 2^+-kWeightExponentLimit (weights like 1e-300 or 1e300; others are not touched). The
// surface is exactly the same (a common factor of the weights cancels, and a power of two rounds
// nothing), and evaluation stays clear of under- and overflow. Every reader applies it (through
// normalize_weights(Model&)).
void normalize_weights(BezierPatch& patch);

// The four sides of a patch's parameter square. A side's boundary curve is read in increasing
// parameter order: kU0/kU1 are rows i = 0 / i = degree_u (parameter v runs along them),
// kV0/kV1 are columns j = 0 / j = degree_v (parameter u runs along them).
enum class Side : uint8_t { kU0 = 0, kU1 = 1, kV0 = 2, kV1 = 3 };
inline constexpr std::array<Side, 4> kAllSides = {Side::kU0, Side::kU1, Side::kV0, Side::kV1};

const char* side_name(Side side);

// Degree of the boundary curve on a side.
int side_degree(const BezierPatch& patch, Side side);

// Control point k (0..side_degree) of the boundary curve on a side, in increasing parameter order.
const Vec3& side_point(const BezierPatch& patch, Side side, int k);
double side_weight(const BezierPatch& patch, Side side, int k);

// (u, v) of parameter t in [0, 1] along a side, in the side's increasing parameter order.
Vec2 side_uv(Side side, double t);

// Axis-aligned bounding box of the control points (contains the surface: convex hull property).
struct Box {
  Vec3 lo{0.0};
  Vec3 hi{0.0};
  Vec3 center() const { return 0.5 * (lo + hi); }
  double diagonal() const;
};
Box control_box(const BezierPatch& patch);

}  // namespace sagitta
