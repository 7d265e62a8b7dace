// Brute-force geometry the certified bounds are checked against (header-only, no shared data).
#pragma once

#include "sagitta/patch.hpp"

#include <glm/geometric.hpp>

#include <algorithm>

namespace sagitta::test {

// Distance from p to triangle abc: closest point by region (Ericson, Real-Time Collision Detection
// 5.1.5), in double. The brute-force reference the certified bounds are checked against.
inline double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  if (glm::length(glm::cross(ab, ac)) == 0.0) {  // a segment or a point: the nearest of its sides
    const auto segment = [&](const Vec3& q, const Vec3& r) {
      const Vec3 d = r - q;
      const double dd = glm::dot(d, d);
      const double t = dd > 0.0 ? std::clamp(glm::dot(p - q, d) / dd, 0.0, 1.0) : 0.0;
      return glm::length(p - (q + t * d));
    };
    return std::min({segment(a, b), segment(b, c), segment(c, a)});
  }
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return glm::length(p - a);
  const Vec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return glm::length(p - b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + ab * (d1 / (d1 - d3))));
  const Vec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return glm::length(p - c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + ac * (d2 / (d2 - d6))));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return glm::length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
  const double denom = 1.0 / (va + vb + vc);
  return glm::length(p - (a + ab * (vb * denom) + ac * (vc * denom)));
}

}  // namespace sagitta::test
