#include "boundary.hpp"

#include "sagitta/evaluate.hpp"

#include <tbb/parallel_for.h>

namespace sagitta {

BoundaryLayout layout_boundary(const Topology& topology, const std::function<int(size_t edge)>& segments_for_edge,
                               uint32_t first_id) {
  BoundaryLayout layout;
  layout.corner_base = first_id;
  uint64_t next = static_cast<uint64_t>(first_id) + topology.corner_classes;
  layout.edge_base.resize(topology.edges.size());
  layout.edge_segments.resize(topology.edges.size());
  for (size_t e = 0; e < topology.edges.size(); ++e) {
    const int n = segments_for_edge(e);
    if (n < 1) throw InputError("internal: an edge asked for " + std::to_string(n) + " segments");
    layout.edge_segments[e] = n;
    layout.edge_base[e] = static_cast<uint32_t>(next);
    next += static_cast<uint64_t>(n - 1);
  }
  if (next > UINT32_MAX) throw InputError("the tessellation needs more than 2^32 vertices; lower the level");
  layout.end = static_cast<uint32_t>(next);
  return layout;
}

int side_segments(const BoundaryLayout& layout, const Topology& topology, uint32_t patch, Side side) {
  const Topology::SideInfo& info = topology.side(patch, side);
  return info.collapsed ? 1 : layout.edge_segments[static_cast<size_t>(info.edge)];
}

uint32_t side_vertex(const BoundaryLayout& layout, const Topology& topology, uint32_t patch, Side side, int k) {
  const Topology::SideInfo& info = topology.side(patch, side);
  const auto corners = detail::side_corners(side);
  if (info.collapsed) return layout.corner_base + topology.corner_class[patch * 4 + static_cast<uint32_t>(corners[0])];
  const int n = layout.edge_segments[static_cast<size_t>(info.edge)];
  if (k <= 0) return layout.corner_base + topology.corner_class[patch * 4 + static_cast<uint32_t>(corners[0])];
  if (k >= n) return layout.corner_base + topology.corner_class[patch * 4 + static_cast<uint32_t>(corners[1])];
  const int canonical = info.reversed ? n - k : k;
  return layout.edge_base[static_cast<size_t>(info.edge)] + static_cast<uint32_t>(canonical - 1);
}

void fill_boundary(const Model& model, const Topology& topology, const BoundaryLayout& layout, Tessellation& out) {
  const bool normals = !out.normals.empty();
  const bool surface = !out.surface_points.empty();
  // Corners: the exact control point. Normal and surface point from the first patch using the class.
  std::vector<bool> done(topology.corner_classes, false);
  for (uint32_t k = 0; k < topology.corner_class.size(); ++k) {
    const uint32_t c = topology.corner_class[k];
    if (done[c]) continue;
    done[c] = true;
    const uint32_t id = layout.corner_base + c;
    out.positions[id] = topology.corner_position[c];
    const Vec2 uv = detail::corner_uv(static_cast<int>(k % 4));
    if (normals) out.normals[id] = detail::surface_normal(model.patches[k / 4], uv.x, uv.y);
    if (surface) out.surface_points[id] = {k / 4, uv.x, uv.y};
  }
  tbb::parallel_for(size_t{0}, topology.edges.size(), [&](size_t e) {
    const Topology::Edge& edge = topology.edges[e];
    const int n = layout.edge_segments[e];
    const SideRef owner = edge.uses.front();
    const bool owner_reversed = edge.use_reversed.front();
    const BezierPatch& patch = model.patches[owner.patch];
    const double diagonal = normals && n > 1 ? control_box(patch).diagonal() : 0.0;
    for (int k = 1; k < n; ++k) {
      const double t = static_cast<double>(k) / n;
      const uint32_t id = layout.edge_base[e] + static_cast<uint32_t>(k - 1);
      out.positions[id] = de_casteljau_curve(edge.points, edge.weights, t);
      const Vec2 uv = side_uv(owner.side, owner_reversed ? 1.0 - t : t);
      if (normals) out.normals[id] = detail::surface_normal(patch, uv.x, uv.y, diagonal);
      if (surface) out.surface_points[id] = {owner.patch, uv.x, uv.y};
    }
  });
}

}  // namespace sagitta
