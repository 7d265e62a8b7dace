// Internal: distance from points to a triangle mesh through CGAL AABB trees. The trees live in
// mesh_distance.cpp behind Impl, so this header is CGAL-free and its users (certify.cpp,
// external.cpp) need not include the AABB headers. Zero-area triangles count as the segment or point
// they are, so a mesh of degenerate triangles (a patch collapsed to a line) has a distance too.
// Queries are thread-safe after construction.
#pragma once

#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <memory>
#include <vector>

namespace sagitta::detail {

class MeshDistance {
 public:
  explicit MeshDistance(const Tessellation& mesh) : MeshDistance(mesh, nullptr) {}
  // Only the listed triangles (indices into the mesh's), when `subset` is given: then a query's
  // answer is the whole mesh's only where its nearest triangle is listed (the caller guarantees it).
  MeshDistance(const Tessellation& mesh, const std::vector<uint32_t>* subset);
  ~MeshDistance();
  MeshDistance(const MeshDistance&) = delete;
  MeshDistance& operator=(const MeshDistance&) = delete;

  // Closest point on the mesh and the distance to it, as computed in double by CGAL (Epick); +inf
  // (and closest_triangle -1) for a query point that is not finite.
  // The rounding of this value is bounded by rounding_bound(p).
  double distance(const Vec3& p, Vec3* closest = nullptr) const;
  // A generous bound on |computed distance - true distance| for a query at p.
  double rounding_bound(const Vec3& p) const;
  // Index (into the mesh's triangles) of a triangle nearest to p; -1 when the mesh is empty.
  int64_t closest_triangle(const Vec3& p) const;
  bool empty() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace sagitta::detail
