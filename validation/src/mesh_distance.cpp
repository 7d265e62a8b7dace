#include "mesh_distance.hpp"

#include "sagitta/certify.hpp"

#include <CGAL/AABB_segment_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <tuple>
#include <vector>

namespace sagitta::detail {

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using CTriangle = K::Triangle_3;
using CSegment = K::Segment_3;
using TriangleTree =
    CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, std::vector<CTriangle>::const_iterator>>>;
using SegmentTree =
    CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_segment_primitive<K, std::vector<CSegment>::const_iterator>>>;
constexpr double kUnit = std::numeric_limits<double>::epsilon() / 2;
constexpr double kInf = std::numeric_limits<double>::infinity();

double length_between(const Vec3& a, const Vec3& b) { return glm::length(a - b); }
Vec3 to_vec(const K::Point_3& p) { return Vec3(p.x(), p.y(), p.z()); }
}  // namespace

// Triangles of positive area go into a triangle tree. A zero-area triangle is still part of the
// mesh: it is the segment between its two farthest corners (kept in a segment tree), or a point.
struct MeshDistance::Impl {
  std::vector<CTriangle> triangles;
  std::vector<int64_t> index;  // mesh triangle of each CGAL triangle
  TriangleTree tree;
  std::vector<CSegment> segments;
  std::vector<int64_t> segment_index;
  SegmentTree segment_tree;
  std::vector<Vec3> points;  // triangles collapsed to one point (duplicates removed)
  std::vector<int64_t> point_index;
  double scale = 0.0;  // largest absolute coordinate of the mesh
};

MeshDistance::MeshDistance(const Tessellation& mesh, const std::vector<uint32_t>* subset)
    : impl_(std::make_unique<Impl>()) {
  auto P = [&](uint32_t i) {
    const Vec3& p = mesh.positions[i];
    return K::Point_3(p.x, p.y, p.z);
  };
  const size_t count = subset ? subset->size() : mesh.triangles.size();
  impl_->triangles.reserve(count);
  std::vector<std::pair<std::tuple<double, double, double>, int64_t>> points;
  for (size_t k = 0; k < count; ++k) {
    const int64_t id = subset ? static_cast<int64_t>((*subset)[k]) : static_cast<int64_t>(k);
    const Triangle& t = mesh.triangles[static_cast<size_t>(id)];
    const CTriangle tri(P(t[0]), P(t[1]), P(t[2]));
    if (!tri.is_degenerate()) {
      impl_->triangles.push_back(tri);
      impl_->index.push_back(id);
      continue;
    }
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    std::array<std::pair<Vec3, Vec3>, 3> pairs = {{{a, b}, {b, c}, {c, a}}};
    const auto longest = *std::max_element(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) {
      return length_between(x.first, x.second) < length_between(y.first, y.second);
    });
    if (longest.first != longest.second) {
      impl_->segments.emplace_back(K::Point_3(longest.first.x, longest.first.y, longest.first.z),
                                   K::Point_3(longest.second.x, longest.second.y, longest.second.z));
      impl_->segment_index.push_back(id);
    } else {
      points.push_back({{a.x, a.y, a.z}, id});
    }
  }
  std::sort(points.begin(), points.end());
  for (size_t i = 0; i < points.size(); ++i) {
    if (i > 0 && points[i].first == points[i - 1].first) continue;
    const auto& [x, y, z] = points[i].first;
    impl_->points.emplace_back(x, y, z);
    impl_->point_index.push_back(points[i].second);
  }
  for (const Vec3& p : mesh.positions) {
    impl_->scale = std::max({impl_->scale, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  }
  if (!impl_->triangles.empty()) {
    impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
    impl_->tree.build();
    impl_->tree.accelerate_distance_queries();
  }
  if (!impl_->segments.empty()) {
    impl_->segment_tree.insert(impl_->segments.cbegin(), impl_->segments.cend());
    impl_->segment_tree.build();
    impl_->segment_tree.accelerate_distance_queries();
  }
}

MeshDistance::~MeshDistance() = default;

bool MeshDistance::empty() const { return impl_->triangles.empty() && impl_->segments.empty() && impl_->points.empty(); }

namespace {
struct Hit {
  double distance = kInf;
  Vec3 closest{0.0};
  int64_t triangle = -1;
};
}  // namespace

// The nearest of the three kinds of primitives; the point list is scanned (it holds only triangles
// collapsed to a point, after removing duplicates).
static Hit nearest(const MeshDistance::Impl& m, const Vec3& p) {
  Hit best;
  // A query beyond double's range (an overflow upstream) has no nearest point: +inf and no
  // triangle. CGAL's exact fallback would hand the infinite coordinate to GMP, which raises SIGFPE.
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return best;
  const K::Point_3 q(p.x, p.y, p.z);
  if (!m.triangles.empty()) {
    const auto hit = m.tree.closest_point_and_primitive(q);
    best = {length_between(to_vec(hit.first), p), to_vec(hit.first), m.index[static_cast<size_t>(hit.second - m.triangles.cbegin())]};
  }
  if (!m.segments.empty()) {
    const auto hit = m.segment_tree.closest_point_and_primitive(q);
    const double d = length_between(to_vec(hit.first), p);
    if (d < best.distance) best = {d, to_vec(hit.first), m.segment_index[static_cast<size_t>(hit.second - m.segments.cbegin())]};
  }
  for (size_t i = 0; i < m.points.size(); ++i) {
    const double d = length_between(m.points[i], p);
    if (d < best.distance) best = {d, m.points[i], m.point_index[i]};
  }
  return best;
}

double MeshDistance::distance(const Vec3& p, Vec3* closest) const {
  const Hit hit = nearest(*impl_, p);
  if (closest) *closest = hit.closest;
  return hit.distance;
}

int64_t MeshDistance::closest_triangle(const Vec3& p) const { return nearest(*impl_, p).triangle; }

double MeshDistance::rounding_bound(const Vec3& p) const {
  // The closest point is a projection onto a plane or a segment computed in double; its error is a
  // few units of rounding of the coordinates involved. 64 u (|p| + scale) is a wide margin.
  const double mag = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return 64.0 * kUnit * (mag + impl_->scale);
}

}  // namespace sagitta::detail

namespace sagitta {

std::vector<double> distance_lower_bounds(const Tessellation& mesh, const std::vector<Vec3>& points) {
  std::vector<double> lower(points.size(), 0.0);
  if (mesh.triangles.empty() || points.empty()) return lower;
  const detail::MeshDistance distance(mesh);
  for (size_t k = 0; k < points.size(); ++k) {
    const Vec3& p = points[k];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const double d = distance.distance(p) - distance.rounding_bound(p);
    lower[k] = std::isfinite(d) ? std::max(0.0, d) : 0.0;
  }
  return lower;
}

}  // namespace sagitta
