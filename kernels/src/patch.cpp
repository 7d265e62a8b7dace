#include "sagitta/patch.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace sagitta {

void validate_patch(const BezierPatch& patch, const std::string& what) {
  auto fail = [&](const std::string& problem) { throw InputError(what + ": " + problem); };
  if (patch.degree_u < 1 || patch.degree_u > kMaxDegree || patch.degree_v < 1 || patch.degree_v > kMaxDegree) {
    std::ostringstream s;
    s << "degree " << patch.degree_u << "x" << patch.degree_v << " is outside 1.." << kMaxDegree;
    fail(s.str());
  }
  const size_t expected = static_cast<size_t>(patch.rows()) * static_cast<size_t>(patch.cols());
  if (patch.points.size() != expected) {
    fail("has " + std::to_string(patch.points.size()) + " control points, expected " + std::to_string(expected));
  }
  if (!patch.weights.empty() && patch.weights.size() != expected) {
    fail("has " + std::to_string(patch.weights.size()) + " weights, expected " + std::to_string(expected));
  }
  for (size_t k = 0; k < patch.points.size(); ++k) {
    const Vec3& p = patch.points[k];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      fail("control point " + std::to_string(k) + " is not finite");
    }
    const double magnitude = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    if (magnitude > kMaxCoordinate) {
      std::ostringstream s;
      s << "control point " << k << " has a coordinate of magnitude " << magnitude << ", beyond the " << kMaxCoordinate
        << " where derivatives and squared lengths overflow; scale the model";
      fail(s.str());
    }
  }
  for (size_t k = 0; k < patch.weights.size(); ++k) {
    const double w = patch.weights[k];
    if (!std::isfinite(w) || !(w > 0.0)) fail("weight " + std::to_string(k) + " is not a finite number > 0");
  }
}

void normalize_weights(BezierPatch& patch) {
  if (!patch.rational()) return;
  const double largest = *std::max_element(patch.weights.begin(), patch.weights.end());
  if (!(largest > 0.0) || !std::isfinite(largest)) return;  // validate_patch reports such weights
  const int e = std::ilogb(largest);
  if (std::abs(e) <= kWeightExponentLimit) return;  // ordinary weights stay exactly as given
  for (double& w : patch.weights) w = std::ldexp(w, -e);
}

const char* side_name(Side side) {
  switch (side) {
    case Side::kU0: return "u0";
    case Side::kU1: return "u1";
    case Side::kV0: return "v0";
    case Side::kV1: return "v1";
  }
  return "?";
}

int side_degree(const BezierPatch& patch, Side side) {
  return (side == Side::kU0 || side == Side::kU1) ? patch.degree_v : patch.degree_u;
}

static std::pair<int, int> side_index(const BezierPatch& patch, Side side, int k) {
  switch (side) {
    case Side::kU0: return {0, k};
    case Side::kU1: return {patch.degree_u, k};
    case Side::kV0: return {k, 0};
    case Side::kV1: return {k, patch.degree_v};
  }
  return {0, 0};
}

const Vec3& side_point(const BezierPatch& patch, Side side, int k) {
  const auto [i, j] = side_index(patch, side, k);
  return patch.at(i, j);
}

double side_weight(const BezierPatch& patch, Side side, int k) {
  const auto [i, j] = side_index(patch, side, k);
  return patch.weight(i, j);
}

Vec2 side_uv(Side side, double t) {
  switch (side) {
    case Side::kU0: return {0.0, t};
    case Side::kU1: return {1.0, t};
    case Side::kV0: return {t, 0.0};
    case Side::kV1: return {t, 1.0};
  }
  return {0.0, 0.0};
}

double Box::diagonal() const { return glm::length(hi - lo); }

Box control_box(const BezierPatch& patch) {
  Box b{patch.points.front(), patch.points.front()};
  for (const Vec3& p : patch.points) {
    b.lo = glm::min(b.lo, p);
    b.hi = glm::max(b.hi, p);
  }
  return b;
}

}  // namespace sagitta
