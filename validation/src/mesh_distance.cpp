#include "mesh_distance.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <limits>
#include <vector>

namespace sagitta::detail {

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using CTriangle = K::Triangle_3;
using Iterator = std::vector<CTriangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<K, Iterator>;
using Traits = CGAL::AABB_traits<K, Primitive>;
using Tree = CGAL::AABB_tree<Traits>;
constexpr double kUnit = std::numeric_limits<double>::epsilon() / 2;
}  // namespace

struct MeshDistance::Impl {
  std::vector<CTriangle> triangles;
  std::vector<int64_t> index;  // mesh triangle of each CGAL triangle
  Tree tree;
  double scale = 0.0;  // largest absolute coordinate of the mesh
};

MeshDistance::MeshDistance(const Tessellation& mesh) : impl_(std::make_unique<Impl>()) {
  auto P = [&](uint32_t i) {
    const Vec3& p = mesh.positions[i];
    return K::Point_3(p.x, p.y, p.z);
  };
  impl_->triangles.reserve(mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) {
    const CTriangle tri(P(t[0]), P(t[1]), P(t[2]));
    if (tri.is_degenerate()) continue;  // zero area: its points lie on its edges, shared or reported
    impl_->triangles.push_back(tri);
    impl_->index.push_back(static_cast<int64_t>(&t - mesh.triangles.data()));
  }
  for (const Vec3& p : mesh.positions) {
    impl_->scale = std::max({impl_->scale, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  }
  if (impl_->triangles.empty()) return;
  impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();
}

MeshDistance::~MeshDistance() = default;

bool MeshDistance::empty() const { return impl_->triangles.empty(); }

double MeshDistance::distance(const Vec3& p, Vec3* closest) const {
  if (empty()) return std::numeric_limits<double>::infinity();
  const K::Point_3 q(p.x, p.y, p.z);
  const K::Point_3 c = impl_->tree.closest_point(q);
  if (closest) *closest = Vec3(c.x(), c.y(), c.z());
  return glm::length(Vec3(c.x(), c.y(), c.z()) - p);
}

int64_t MeshDistance::closest_triangle(const Vec3& p) const {
  if (empty()) return -1;
  const auto hit = impl_->tree.closest_point_and_primitive(K::Point_3(p.x, p.y, p.z));
  return impl_->index[static_cast<size_t>(hit.second - impl_->triangles.cbegin())];
}

double MeshDistance::rounding_bound(const Vec3& p) const {
  // The closest point is a projection onto a plane or a segment computed in double; its error is a
  // few units of rounding of the coordinates involved. 64 u (|p| + scale) is a wide margin.
  const double mag = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return 64.0 * kUnit * (mag + impl_->scale);
}

}  // namespace sagitta::detail
