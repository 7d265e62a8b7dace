#include "sagitta/mesh_normals.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <map>

namespace sagitta {

std::vector<Vec3> angle_weighted_normals(const std::vector<Vec3>& positions, const std::vector<Triangle>& triangles) {
  // Group vertices by exact position (+0.0 and -0.0 are one position).
  auto key = [](const Vec3& p) { return std::array<double, 3>{p.x + 0.0, p.y + 0.0, p.z + 0.0}; };
  std::map<std::array<double, 3>, uint32_t> group_of_position;
  std::vector<uint32_t> group(positions.size());
  for (size_t v = 0; v < positions.size(); ++v) {
    group[v] = group_of_position.emplace(key(positions[v]), static_cast<uint32_t>(group_of_position.size())).first->second;
  }
  std::vector<Vec3> sum(group_of_position.size(), Vec3(0.0));
  for (const Triangle& t : triangles) {
    const Vec3 face = glm::cross(positions[t[1]] - positions[t[0]], positions[t[2]] - positions[t[0]]);
    const double area2 = glm::length(face);
    if (!(area2 > 0.0) || !std::isfinite(area2)) continue;
    const Vec3 unit = face / area2;
    for (int c = 0; c < 3; ++c) {
      const Vec3 e1 = positions[t[(c + 1) % 3]] - positions[t[c]];
      const Vec3 e2 = positions[t[(c + 2) % 3]] - positions[t[c]];
      const double l1 = glm::length(e1), l2 = glm::length(e2);
      if (!(l1 > 0.0) || !(l2 > 0.0)) continue;
      const double angle = std::acos(std::clamp(glm::dot(e1, e2) / (l1 * l2), -1.0, 1.0));
      sum[group[t[c]]] += angle * unit;
    }
  }
  std::vector<Vec3> normals(positions.size());
  for (size_t v = 0; v < positions.size(); ++v) {
    const Vec3& s = sum[group[v]];
    const double len = glm::length(s);
    normals[v] = len > 0.0 && std::isfinite(len) ? s / len : Vec3(0.0, 0.0, 1.0);
  }
  return normals;
}

Tessellation split_face_normals(const Tessellation& mesh) {
  Tessellation out;
  out.positions.reserve(3 * mesh.triangles.size());
  out.normals.reserve(3 * mesh.triangles.size());
  out.triangles.reserve(mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) {
    const Vec3 face = glm::cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
    const double len = glm::length(face);
    const Vec3 n = len > 0.0 && std::isfinite(len) ? face / len : Vec3(0.0, 0.0, 1.0);
    const uint32_t first = static_cast<uint32_t>(out.positions.size());
    for (uint32_t v : t) {
      out.positions.push_back(mesh.positions[v]);
      out.normals.push_back(n);
    }
    out.triangles.push_back({first, first + 1, first + 2});
  }
  return out;
}

}  // namespace sagitta
