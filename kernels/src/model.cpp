#include "sagitta/model.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>

namespace sagitta {

void validate_model(const Model& model, const std::string& what) {
  if (model.patches.empty()) throw InputError(what + ": the model has no patches");
  for (size_t p = 0; p < model.patches.size(); ++p) validate_patch(model.patches[p], what + ": patch " + std::to_string(p));
}

void normalize_weights(Model& model) {
  for (BezierPatch& patch : model.patches) normalize_weights(patch);
}

Box model_box(const Model& model) {
  Box box = control_box(model.patches.front());
  for (const BezierPatch& patch : model.patches) {
    const Box b = control_box(patch);
    box.lo = glm::min(box.lo, b.lo);
    box.hi = glm::max(box.hi, b.hi);
  }
  return box;
}

Model replicate(const Model& model, int copies) {
  if (copies < 1) throw InputError("--copies must be >= 1, got " + std::to_string(copies));
  if (copies == 1) return model;
  const Box box = model_box(model);
  const Vec3 size = box.hi - box.lo;
  const double gap = 0.25 * std::max({size.x, size.y, size.z, 1e-300});
  const int per_row = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(copies))));
  Model out;
  out.name = model.name + " x" + std::to_string(copies);
  out.patches.reserve(model.patches.size() * static_cast<size_t>(copies));
  for (int c = 0; c < copies; ++c) {
    const Vec3 offset((c % per_row) * (size.x + gap), (c / per_row) * (size.y + gap), 0.0);
    for (BezierPatch patch : model.patches) {
      for (Vec3& p : patch.points) p += offset;
      out.patches.push_back(std::move(patch));
    }
  }
  return out;
}

std::array<int, 2> side_corners(Side side) {
  switch (side) {
    case Side::kU0: return {0, 1};
    case Side::kU1: return {2, 3};
    case Side::kV0: return {0, 2};
    case Side::kV1: return {1, 3};
  }
  return {0, 0};
}

Vec2 corner_uv(int corner) { return {corner >= 2 ? 1.0 : 0.0, (corner & 1) ? 1.0 : 0.0}; }

size_t Topology::free_edges() const {
  return static_cast<size_t>(std::count_if(edges.begin(), edges.end(), [](const Edge& e) { return e.uses.size() == 1; }));
}
size_t Topology::shared_edges() const {
  return static_cast<size_t>(std::count_if(edges.begin(), edges.end(), [](const Edge& e) { return e.uses.size() == 2; }));
}
size_t Topology::nonmanifold_edges() const {
  return static_cast<size_t>(std::count_if(edges.begin(), edges.end(), [](const Edge& e) { return e.uses.size() > 2; }));
}
size_t Topology::collapsed_sides() const {
  return static_cast<size_t>(std::count_if(sides.begin(), sides.end(), [](const SideInfo& s) { return s.collapsed; }));
}

namespace {

// A boundary curve's control polygon with weights, as an exact key.
using CurveKey = std::vector<std::array<double, 4>>;

CurveKey side_key(const BezierPatch& patch, Side side, bool reversed) {
  const int d = side_degree(patch, side);
  CurveKey key(static_cast<size_t>(d + 1));
  for (int k = 0; k <= d; ++k) {
    const int src = reversed ? d - k : k;
    const Vec3& p = side_point(patch, side, src);
    key[static_cast<size_t>(k)] = {p.x, p.y, p.z, side_weight(patch, side, src)};
  }
  return key;
}

bool all_equal(const CurveKey& key) {
  return std::all_of(key.begin(), key.end(), [&](const std::array<double, 4>& q) {
    return q[0] == key[0][0] && q[1] == key[0][1] && q[2] == key[0][2];
  });
}

struct UnionFind {
  std::vector<uint32_t> parent;
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t find(uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

double polygon_distance(const BezierPatch& a, Side sa, const BezierPatch& b, Side sb, bool reversed) {
  const int d = side_degree(a, sa);
  double worst = 0.0;
  for (int k = 0; k <= d; ++k) {
    worst = std::max(worst, glm::length(side_point(a, sa, k) - side_point(b, sb, reversed ? d - k : k)));
  }
  return worst;
}

}  // namespace

Topology build_topology(const Model& model, double near_miss_tolerance) {
  Topology topo;
  const size_t np = model.patches.size();
  topo.sides.resize(np * 4);
  std::map<CurveKey, int32_t> edge_of_key;
  UnionFind corners(np * kCornersPerPatch);

  for (uint32_t p = 0; p < np; ++p) {
    const BezierPatch& patch = model.patches[p];
    for (Side s : kAllSides) {
      Topology::SideInfo& info = topo.sides[p * 4 + static_cast<int>(s)];
      const auto [c0, c1] = side_corners(s);
      CurveKey forward = side_key(patch, s, false);
      if (all_equal(forward)) {
        info.collapsed = true;
        corners.unite(p * 4 + c0, p * 4 + c1);
        continue;
      }
      CurveKey backward = side_key(patch, s, true);
      const bool reversed = backward < forward;
      const CurveKey& canonical = reversed ? backward : forward;
      auto [it, inserted] = edge_of_key.emplace(canonical, static_cast<int32_t>(topo.edges.size()));
      if (inserted) {
        Topology::Edge edge;
        for (const auto& q : canonical) {
          edge.points.emplace_back(q[0], q[1], q[2]);
          edge.weights.push_back(q[3]);
        }
        if (!patch.rational()) edge.weights.clear();
        topo.edges.push_back(std::move(edge));
      }
      Topology::Edge& edge = topo.edges[static_cast<size_t>(it->second)];
      info.edge = it->second;
      info.reversed = reversed;
      if (!edge.uses.empty()) {
        // Unite the corners at the canonical start and end with those of the first use.
        const SideRef first = edge.uses.front();
        const auto [f0, f1] = side_corners(first.side);
        const bool first_rev = edge.use_reversed.front();
        const uint32_t first_start = first.patch * 4 + static_cast<uint32_t>(first_rev ? f1 : f0);
        const uint32_t first_end = first.patch * 4 + static_cast<uint32_t>(first_rev ? f0 : f1);
        corners.unite(first_start, p * 4 + static_cast<uint32_t>(reversed ? c1 : c0));
        corners.unite(first_end, p * 4 + static_cast<uint32_t>(reversed ? c0 : c1));
      }
      edge.uses.push_back({p, s});
      edge.use_reversed.push_back(reversed);
    }
  }

  // Number the corner classes in order of first appearance.
  topo.corner_class.assign(np * 4, 0);
  std::vector<int64_t> class_of_root(np * 4, -1);
  for (uint32_t k = 0; k < np * 4; ++k) {
    const uint32_t root = corners.find(k);
    if (class_of_root[root] < 0) {
      class_of_root[root] = topo.corner_classes++;
      const BezierPatch& patch = model.patches[k / 4];
      const int c = static_cast<int>(k % 4);
      topo.corner_position.push_back(patch.at(c >= 2 ? patch.degree_u : 0, (c & 1) ? patch.degree_v : 0));
    }
    topo.corner_class[k] = static_cast<uint32_t>(class_of_root[root]);
  }

  // Report unmatched sides that nearly coincide with another unmatched side, and near-collapsed sides.
  double tol = near_miss_tolerance;
  if (!(tol > 0.0)) tol = 1e-2 * model_box(model).diagonal();
  std::vector<SideRef> open;
  for (const Topology::Edge& e : topo.edges) {
    if (e.uses.size() == 1) open.push_back(e.uses.front());
  }
  for (const SideRef& s : open) {
    const BezierPatch& patch = model.patches[s.patch];
    double extent = 0.0;
    for (int k = 1; k <= side_degree(patch, s.side); ++k) {
      extent = std::max(extent, glm::length(side_point(patch, s.side, k) - side_point(patch, s.side, 0)));
    }
    if (extent < tol) topo.near_collapsed.push_back(s);
  }
  // Sweep over the sides sorted by the x of their end points' midpoint: two polygons within `tol`
  // pointwise have midpoints within `tol`, so only neighbours in that order need comparing.
  auto mid_x = [&](const SideRef& s) {
    const BezierPatch& patch = model.patches[s.patch];
    return 0.5 * (side_point(patch, s.side, 0).x + side_point(patch, s.side, side_degree(patch, s.side)).x);
  };
  std::sort(open.begin(), open.end(), [&](const SideRef& a, const SideRef& b) { return mid_x(a) < mid_x(b); });
  for (size_t a = 0; a < open.size(); ++a) {
    const double xa = mid_x(open[a]);
    for (size_t b = a + 1; b < open.size() && mid_x(open[b]) - xa <= tol; ++b) {
      const BezierPatch& pa = model.patches[open[a].patch];
      const BezierPatch& pb = model.patches[open[b].patch];
      if (side_degree(pa, open[a].side) != side_degree(pb, open[b].side)) continue;
      const double d = std::min(polygon_distance(pa, open[a].side, pb, open[b].side, false),
                                polygon_distance(pa, open[a].side, pb, open[b].side, true));
      if (d < tol) topo.near_misses.push_back({open[a], open[b], d});
    }
  }
  return topo;
}

}  // namespace sagitta
