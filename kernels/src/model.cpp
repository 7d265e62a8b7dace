#include "sagitta/model.hpp"

#include "sagitta/budget.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <tuple>
#include <unordered_map>

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

double points_box_diagonal(const std::vector<Vec3>& points) {
  if (points.empty()) return 0.0;
  Box box{points.front(), points.front()};
  for (const Vec3& p : points) box.lo = glm::min(box.lo, p), box.hi = glm::max(box.hi, p);
  return box.diagonal();
}

double model_bytes(size_t patches, int du, int dv, bool rational) {
  const double points = double(du + 1) * double(dv + 1);
  constexpr double kHeapBlock = 32.0;  // allocator overhead per vector buffer
  return double(patches) * (sizeof(BezierPatch) + points * sizeof(Vec3) + kHeapBlock +
                            (rational ? points * sizeof(double) + kHeapBlock : 0.0));
}

double topology_bytes(size_t patches, int degree) {
  // Per side: its SideInfo; a map node with its key (d + 1 points and weights) and, per edge, the
  // Edge with its point, weight and use vectors; the forward and backward keys while matching.
  const double d1 = double(degree + 1);
  const double per_side = sizeof(Topology::SideInfo) + 96.0 + d1 * 4 * sizeof(double) +
                          sizeof(Topology::Edge) + 4 * 32.0 + d1 * (sizeof(Vec3) + sizeof(double)) + 16.0;
  // Per corner: union-find parent, class, class of root, position.
  const double per_corner = sizeof(uint32_t) * 2 + sizeof(int64_t) + sizeof(Vec3);
  return double(patches) * 4.0 * (per_side + per_corner);
}

Model replicate(const Model& model, int copies) {
  if (copies < 1) throw InputError("--copies must be >= 1, got " + std::to_string(copies));
  if (copies == 1) return model;
  int du = 1, dv = 1;
  for (const BezierPatch& p : model.patches) du = std::max(du, p.degree_u), dv = std::max(dv, p.degree_v);
  budget::check_memory(model_bytes(model.patches.size() * static_cast<size_t>(copies), du, dv, true),
                       std::to_string(copies) + " copies of the model", "lower --copies or raise --max-memory");
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

namespace detail {

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

}  // namespace detail

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

// splitmix64's finaliser: every input bit affects every output bit.
uint64_t mix64(uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Hash of a key consistent with its == (which takes -0.0 == 0.0: both hash as +0.0).
struct CurveKeyHash {
  size_t operator()(const CurveKey& key) const {
    uint64_t h = key.size();
    for (const std::array<double, 4>& q : key) {
      for (double x : q) {
        const double positive_zero = x + 0.0;
        uint64_t bits;
        std::memcpy(&bits, &positive_zero, sizeof bits);
        h = mix64(h ^ bits);
      }
    }
    return static_cast<size_t>(h);
  }
};

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

// An unmatched side for the near-miss search: its tolerance, the midpoint of its end points and
// the grid level whose cells (2^level wide) are at least as wide as the tolerance.
struct OpenSide {
  SideRef ref;
  Vec3 mid{0.0};
  double extent = 0.0;  // largest distance of a control point from the first one
  double tol = 0.0;     // this side's near-miss tolerance
  int level = 0;
};

struct NearMissIndex {
  std::vector<OpenSide> sides;
};

// The unmatched sides with their tolerances: `absolute` when > 0, else the smaller of
// kNearMissModelFraction of the model's box diagonal and kNearMissPatchFraction of the side's
// patch's control-box diagonal (so copies spread far apart, or many small disjoint patches, do not
// make everything "near"). Stores the model-wide tolerance in `model_tol`.
NearMissIndex near_miss_sides(const Model& model, const Topology& topo, double absolute, double* model_tol) {
  const double model_wide = absolute > 0.0 ? absolute : kNearMissModelFraction * model_box(model).diagonal();
  *model_tol = model_wide;
  NearMissIndex index;
  for (const Topology::Edge& e : topo.edges) {
    if (e.uses.size() != 1) continue;
    const SideRef ref = e.uses.front();
    const BezierPatch& patch = model.patches[ref.patch];
    OpenSide s;
    s.ref = ref;
    const int d = side_degree(patch, ref.side);
    const Vec3 first = side_point(patch, ref.side, 0);
    s.mid = 0.5 * (first + side_point(patch, ref.side, d));
    for (int k = 1; k <= d; ++k) s.extent = std::max(s.extent, glm::length(side_point(patch, ref.side, k) - first));
    s.tol = absolute > 0.0 ? absolute : std::min(model_wide, kNearMissPatchFraction * control_box(patch).diagonal());
    if (!(s.tol > 0.0) || !std::isfinite(s.tol)) s.tol = 0.0;
    std::frexp(s.tol, &s.level);  // tol < 2^level
    index.sides.push_back(s);
  }
  return index;
}

// Grid cell of a point at a level (cells 2^level wide); clamped so that huge coordinates share a cell
// (more candidates, never a missed one).
std::array<int64_t, 3> grid_cell(const Vec3& p, int level) {
  std::array<int64_t, 3> c{};
  for (int k = 0; k < 3; ++k) {
    const double x = std::floor(std::ldexp(p[k], -level));
    c[static_cast<size_t>(k)] = static_cast<int64_t>(std::clamp(std::isnan(x) ? 0.0 : x, -4e18, 4e18));
  }
  return c;
}

struct CellKey {
  int level;
  std::array<int64_t, 3> cell;
  bool operator==(const CellKey& o) const { return level == o.level && cell == o.cell; }
};
struct CellHash {
  size_t operator()(const CellKey& k) const {
    uint64_t h = mix64(static_cast<uint64_t>(k.level));
    for (int64_t c : k.cell) h = mix64(h ^ static_cast<uint64_t>(c));
    return static_cast<size_t>(h);
  }
};

// Pairs of unmatched sides of equal degree whose control polygons (either direction) lie within
// the smaller of the two tolerances, found with a multi-level hash grid: a pair within tolerance has
// midpoints within it too, so each side looks only in the few cells its midpoint +- that distance
// meets, on each level not above its own. Linear in the sides for models of
// similar-sized patches.
std::vector<Topology::NearMiss> find_near_misses(const Model& model, const NearMissIndex& index) {
  const std::vector<OpenSide>& sides = index.sides;
  std::unordered_map<CellKey, std::vector<uint32_t>, CellHash> grid;
  std::vector<int> levels;
  for (uint32_t i = 0; i < sides.size(); ++i) {
    if (sides[i].tol <= 0.0) continue;
    grid[{sides[i].level, grid_cell(sides[i].mid, sides[i].level)}].push_back(i);
    levels.push_back(sides[i].level);
  }
  std::sort(levels.begin(), levels.end());
  levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
  std::vector<Topology::NearMiss> out;
  for (uint32_t a = 0; a < sides.size(); ++a) {
    const OpenSide& sa = sides[a];
    if (sa.tol <= 0.0) continue;
    if ((a & 1023u) == 0) budget::check("the near-miss search");
    const BezierPatch& pa = model.patches[sa.ref.patch];
    for (int level : levels) {
      if (level > sa.level) break;
      // Partners on this level are closer than min(tol_a, 2^level): only the cells that box meets.
      const Vec3 reach(std::min(sa.tol, std::ldexp(1.0, level)));
      const std::array<int64_t, 3> lo = grid_cell(sa.mid - reach, level), hi = grid_cell(sa.mid + reach, level);
      for (int64_t x = lo[0]; x <= hi[0]; ++x) {
        for (int64_t y = lo[1]; y <= hi[1]; ++y) {
          for (int64_t z = lo[2]; z <= hi[2]; ++z) {
            const auto it = grid.find({level, {x, y, z}});
            if (it == grid.end()) continue;
            for (uint32_t b : it->second) {
              const OpenSide& sb = sides[b];
              if (sb.level == sa.level && b <= a) continue;  // each pair once, from the lower index
              const double tol = std::min(sa.tol, sb.tol);
              if (!(glm::length(sa.mid - sb.mid) < tol)) continue;
              const BezierPatch& pb = model.patches[sb.ref.patch];
              if (side_degree(pa, sa.ref.side) != side_degree(pb, sb.ref.side)) continue;
              const double d = std::min(polygon_distance(pa, sa.ref.side, pb, sb.ref.side, false),
                                        polygon_distance(pa, sa.ref.side, pb, sb.ref.side, true));
              if (d < tol) out.push_back(a < b ? Topology::NearMiss{sa.ref, sb.ref, d} : Topology::NearMiss{sb.ref, sa.ref, d});
            }
          }
        }
      }
    }
  }
  auto key = [](const Topology::NearMiss& m) {
    return std::make_tuple(m.a.patch, static_cast<int>(m.a.side), m.b.patch, static_cast<int>(m.b.side));
  };
  std::sort(out.begin(), out.end(), [&](const auto& x, const auto& y) { return key(x) < key(y); });
  return out;
}

}  // namespace

Topology build_topology(const Model& model, double near_miss_tolerance) {
  Topology topo;
  const size_t np = model.patches.size();
  int degree = 1;
  for (const BezierPatch& p : model.patches) degree = std::max({degree, p.degree_u, p.degree_v});
  budget::check_memory(topology_bytes(np, degree), "the topology of " + std::to_string(np) + " patches",
                       "use fewer patches or raise --max-memory");
  topo.sides.resize(np * 4);
  std::unordered_map<CurveKey, int32_t, CurveKeyHash> edge_of_key;
  edge_of_key.reserve(np * 2);
  UnionFind corners(np * kCornersPerPatch);

  for (uint32_t p = 0; p < np; ++p) {
    if ((p & 4095u) == 0) budget::check("building the topology");
    const BezierPatch& patch = model.patches[p];
    for (Side s : kAllSides) {
      Topology::SideInfo& info = topo.sides[p * 4 + static_cast<int>(s)];
      const auto [c0, c1] = detail::side_corners(s);
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
        const auto [f0, f1] = detail::side_corners(first.side);
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
  const NearMissIndex index = near_miss_sides(model, topo, near_miss_tolerance, &topo.near_miss_tolerance);
  topo.near_miss_patch_fraction = near_miss_tolerance > 0.0 ? 0.0 : kNearMissPatchFraction;
  for (const OpenSide& s : index.sides) {
    if (s.extent < s.tol) topo.near_collapsed.push_back(s.ref);
  }
  topo.near_misses = find_near_misses(model, index);
  return topo;
}

}  // namespace sagitta
