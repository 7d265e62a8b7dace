// Mesh topology checks (see mesh_check.hpp). Exact predicates from CGAL decide degeneracy and
// exact collinearity.
#include "sagitta/mesh_check.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <unordered_set>

namespace sagitta {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
K::Point_3 cgal_point(const Vec3& p) { return K::Point_3(p.x, p.y, p.z); }

struct EdgeUse {
  uint32_t count = 0;
  uint32_t forward = 0;    // uses running from the smaller to the larger vertex index
  uint32_t triangle = 0;   // first triangle using the edge
};

uint64_t edge_key(uint32_t a, uint32_t b) {
  return (static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

// Bit mask (1 << Side) of the unit square's sides that the parameter point lies on.
unsigned sides_of(const Vec2& p) {
  unsigned m = 0;
  if (p.x == 0.0) m |= 1u << static_cast<int>(Side::kU0);
  if (p.x == 1.0) m |= 1u << static_cast<int>(Side::kU1);
  if (p.y == 0.0) m |= 1u << static_cast<int>(Side::kV0);
  if (p.y == 1.0) m |= 1u << static_cast<int>(Side::kV1);
  return m;
}

// The sides a point with these sides also lies on because a side of the patch is collapsed: the
// whole collapsed side is one surface point, which is also both end corners of that side, so it
// lies on the two sides meeting it (u = 0 collapsed: v = 0 and v = 1).
unsigned with_collapsed_corners(unsigned sides, const Topology& topology, uint32_t patch) {
  const auto bit = [](Side s) { return 1u << static_cast<int>(s); };
  const unsigned v_sides = bit(Side::kV0) | bit(Side::kV1), u_sides = bit(Side::kU0) | bit(Side::kU1);
  unsigned m = sides;
  for (Side s : kAllSides) {
    const bool u_side = s == Side::kU0 || s == Side::kU1;
    if ((sides & bit(s)) && topology.side(patch, s).collapsed) m |= u_side ? v_sides : u_sides;
  }
  return m;
}

// Free boundary curves of the model, with a distance query for points (dense samples and a
// bracketing refinement on the curve parameter).
struct FreeCurves {
  struct Curve {
    std::vector<Vec3> points;
    std::vector<double> weights;
    std::vector<Vec3> samples;
  };
  std::vector<Curve> curves;
  static constexpr int kSamples = 256;

  FreeCurves(const Topology& topology) {
    for (const Topology::Edge& e : topology.edges) {
      if (e.uses.size() != 1) continue;
      Curve c{e.points, e.weights, {}};
      for (int k = 0; k <= kSamples; ++k) c.samples.push_back(de_casteljau_curve(c.points, c.weights, double(k) / kSamples));
      curves.push_back(std::move(c));
    }
  }
  // Distance from p to free curve i (dense samples, then a ternary search around the best one).
  double distance(size_t i, const Vec3& p) const {
    const Curve& c = curves[i];
    int k_best = 0;
    double d_best = std::numeric_limits<double>::infinity();
    for (int k = 0; k <= kSamples; ++k) {
      const double d = glm::length(c.samples[k] - p);
      if (d < d_best) {
        d_best = d;
        k_best = k;
      }
    }
    double lo = std::max(0.0, (k_best - 1.0) / kSamples), hi = std::min(1.0, (k_best + 1.0) / kSamples);
    for (int it = 0; it < 80; ++it) {
      const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
      if (glm::length(de_casteljau_curve(c.points, c.weights, m1) - p) <
          glm::length(de_casteljau_curve(c.points, c.weights, m2) - p)) {
        hi = m2;
      } else {
        lo = m1;
      }
    }
    return std::min(d_best, glm::length(de_casteljau_curve(c.points, c.weights, 0.5 * (lo + hi)) - p));
  }
  // True when a, b lie within tol of one same free curve and the midpoint within mid_tol of it.
  bool on_same_curve(const Vec3& a, const Vec3& b, double tol, double mid_tol) const {
    for (size_t i = 0; i < curves.size(); ++i) {
      if (distance(i, a) <= tol && distance(i, b) <= tol && distance(i, 0.5 * (a + b)) <= mid_tol) return true;
    }
    return false;
  }
};

// The report being built; findings listed up to max_listed per kind (counts stay exact).
struct Findings {
  TopologyReport& r;
  size_t max_listed;
  std::unordered_map<std::string, size_t> listed;
  void add(TopologyFinding f) {
    if (listed[f.kind]++ < max_listed) r.findings.push_back(std::move(f));
  }
};

int64_t patch_of(const Tessellation& mesh, size_t t) {
  return mesh.triangle_patch.size() > t ? static_cast<int64_t>(mesh.triangle_patch[t]) : int64_t(-1);
}

Vec3 centroid(const Tessellation& mesh, const Triangle& t) {
  return (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3.0;
}

// Throws InputError when a triangle refers to a vertex the mesh does not have.
void check_vertex_indices(const Tessellation& mesh) {
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t v : t) {
      if (v >= mesh.positions.size()) throw InputError("mesh check: a triangle refers to vertex " + std::to_string(v) +
                                                       " but the mesh has " + std::to_string(mesh.positions.size()));
    }
  }
}

// Degenerate and duplicated faces (a duplicate is a triangle with the vertex set of an earlier one).
void find_degenerate_and_duplicated(const Tessellation& mesh, Findings& f) {
  TopologyReport& r = f.r;
  std::vector<std::pair<Triangle, uint32_t>> sorted(mesh.triangles.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    if ((i & 0xffffu) == 0) budget::check("mesh check");  // a cancelled run stops within milliseconds
    const Triangle& t = mesh.triangles[i];
    const bool same_index = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    if (same_index || CGAL::collinear(cgal_point(mesh.positions[t[0]]), cgal_point(mesh.positions[t[1]]),
                                      cgal_point(mesh.positions[t[2]]))) {
      ++r.degenerate_triangles;
      f.add({"degenerate_triangle", centroid(mesh, t), patch_of(mesh, i), static_cast<int64_t>(i), {t[0], t[1]}});
    }
    Triangle s = t;
    std::sort(s.begin(), s.end());
    sorted[i] = {s, static_cast<uint32_t>(i)};
  }
  std::sort(sorted.begin(), sorted.end());
  std::vector<uint32_t> duplicates;
  for (size_t k = 1; k < sorted.size(); ++k) {
    if (sorted[k].first == sorted[k - 1].first) duplicates.push_back(sorted[k].second);
  }
  std::sort(duplicates.begin(), duplicates.end());
  for (uint32_t i : duplicates) {
    const Triangle& t = mesh.triangles[i];
    ++r.duplicated_faces;
    f.add({"duplicated_face", centroid(mesh, t), patch_of(mesh, i), static_cast<int64_t>(i), {t[0], t[1]}});
  }
}

// The mesh's edges (vertex pairs with a != b) in increasing key order, with their uses.
struct EdgeUses {
  std::vector<uint64_t> keys;
  std::vector<EdgeUse> uses;
  size_t size() const { return keys.size(); }
  // The uses of edge (a, b); nullptr when no triangle has it.
  const EdgeUse* find(uint64_t key) const {
    const auto it = std::lower_bound(keys.begin(), keys.end(), key);
    return it != keys.end() && *it == key ? &uses[static_cast<size_t>(it - keys.begin())] : nullptr;
  }
};

// Edge uses, bucketed by the smaller vertex (counting sort), each bucket sorted by the larger one.
EdgeUses count_edge_uses(const Tessellation& mesh) {
  const size_t vertices = mesh.positions.size();
  std::vector<uint32_t> start(vertices + 1, 0);
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      if (t[k] != t[(k + 1) % 3]) ++start[std::min(t[k], t[(k + 1) % 3]) + 1];
    }
  }
  for (size_t v = 0; v < vertices; ++v) start[v + 1] += start[v];
  struct HalfEdge {
    uint32_t other, triangle;
    bool forward;
  };
  std::vector<HalfEdge> half(start[vertices]);
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    if ((i & 0xffffu) == 0) budget::check("mesh check");
    const Triangle& t = mesh.triangles[i];
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      if (a == b) continue;
      half[fill[std::min(a, b)]++] = {std::max(a, b), static_cast<uint32_t>(i), a < b};
    }
  }
  EdgeUses edges;
  edges.keys.reserve(half.size() / 2 + 1);
  edges.uses.reserve(half.size() / 2 + 1);
  for (size_t v = 0; v < vertices; ++v) {
    if ((v & 0xffffu) == 0) budget::check("mesh check");
    const auto first = half.begin() + start[v], last = half.begin() + start[v + 1];
    // Stable: within one edge the uses stay in triangle order, so the first is the earliest.
    std::stable_sort(first, last, [](const HalfEdge& x, const HalfEdge& y) { return x.other < y.other; });
    for (auto it = first; it != last; ++it) {
      if (it == first || it->other != (it - 1)->other) {
        edges.keys.push_back(edge_key(static_cast<uint32_t>(v), it->other));
        edges.uses.push_back({0, 0, it->triangle});
      }
      EdgeUse& e = edges.uses.back();
      ++e.count;
      if (it->forward) ++e.forward;
    }
  }
  return edges;
}

// Model boundary from (patch, u, v): both ends of the open edge (a, b) of triangle `tri` on one free
// side of the patch (a point of a collapsed side counts as on the sides meeting it, so a fan at an
// apex between two free sides is boundary).
bool on_free_side(const Tessellation& mesh, const Topology& topology, uint32_t tri, uint32_t a, uint32_t b) {
  const Triangle& t = mesh.triangles[tri];
  const auto& uv = mesh.triangle_uv[tri];
  Vec2 ua{-1.0}, ub{-1.0};
  for (int k = 0; k < 3; ++k) {
    if (t[k] == a) ua = uv[k];
    if (t[k] == b) ub = uv[k];
  }
  const uint32_t patch = mesh.triangle_patch[tri];
  const unsigned common =
      with_collapsed_corners(sides_of(ua), topology, patch) & with_collapsed_corners(sides_of(ub), topology, patch);
  bool boundary = false;
  for (int side = 0; side < 4 && !boundary; ++side) {
    if (!(common >> side & 1u)) continue;
    const Topology::SideInfo& info = topology.side(patch, static_cast<Side>(side));
    boundary = info.edge >= 0 && topology.edges[static_cast<size_t>(info.edge)].uses.size() == 1;
  }
  return boundary;
}

// Every edge classified (non-manifold, inconsistently oriented, open: model boundary or crack);
// returns the open edges.
std::vector<std::pair<uint32_t, uint32_t>> classify_edges(const Tessellation& mesh, const Model* model,
                                                          const Topology* topology, const TopologyOptions& options,
                                                          bool with_uv, const EdgeUses& edges, Findings& f) {
  TopologyReport& r = f.r;
  std::unique_ptr<FreeCurves> curves;
  double boundary_tol = 0.0;
  if (!with_uv && model && topology) {
    curves = std::make_unique<FreeCurves>(*topology);
    boundary_tol = options.boundary_tolerance * model_box(*model).diagonal();
  }
  std::vector<std::pair<uint32_t, uint32_t>> open;
  for (size_t k = 0; k < edges.size(); ++k) {
    const uint64_t key = edges.keys[k];
    const EdgeUse& e = edges.uses[k];
    const uint32_t a = static_cast<uint32_t>(key >> 32), b = static_cast<uint32_t>(key & 0xffffffffu);
    const Vec3 mid = 0.5 * (mesh.positions[a] + mesh.positions[b]);
    if (e.count > 2) {
      ++r.non_manifold_edges;
      f.add({"non_manifold_edge", mid, patch_of(mesh, e.triangle), e.triangle, {a, b}});
    } else if (e.count == 2 && e.forward != 1) {
      ++r.inconsistent_orientation_edges;
      f.add({"inconsistent_orientation_edge", mid, patch_of(mesh, e.triangle), e.triangle, {a, b}});
    } else if (e.count == 1) {
      ++r.open_edges;
      open.emplace_back(a, b);
      bool boundary = false;
      if (with_uv) {
        boundary = on_free_side(mesh, *topology, e.triangle, a, b);
      } else if (curves && !curves->curves.empty()) {
        boundary = curves->on_same_curve(mesh.positions[a], mesh.positions[b], boundary_tol,
                                         boundary_tol + 0.25 * glm::length(mesh.positions[a] - mesh.positions[b]));
      }
      if (boundary) {
        ++r.model_boundary_edges;
        f.add({"model_boundary_edge", mid, patch_of(mesh, e.triangle), e.triangle, {a, b}});
      } else {
        ++r.crack_edges;
        f.add({"crack_edge", mid, patch_of(mesh, e.triangle), e.triangle, {a, b}});
      }
    }
  }
  return open;
}

// T-junctions: a vertex of an open edge strictly inside another open edge. Candidates come from
// a uniform grid over the open edges' vertices (cell = mean open-edge length).
void find_t_junctions(const Tessellation& mesh, const std::vector<std::pair<uint32_t, uint32_t>>& open,
                      const EdgeUses& edges, const TopologyOptions& options, Findings& f) {
  std::vector<uint32_t> verts;
  double mean = 0.0;
  for (const auto& [a, b] : open) {
    verts.push_back(a);
    verts.push_back(b);
    mean += glm::length(mesh.positions[a] - mesh.positions[b]);
  }
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  mean /= static_cast<double>(open.size());
  const double cell = mean > 0.0 ? mean : 1.0;
  auto cell_of = [&](const Vec3& p) {
    return glm::i64vec3(std::floor(p.x / cell), std::floor(p.y / cell), std::floor(p.z / cell));
  };
  auto hash = [](const glm::i64vec3& c) {
    return static_cast<uint64_t>(c.x * 73856093LL) ^ static_cast<uint64_t>(c.y * 19349663LL) ^
           static_cast<uint64_t>(c.z * 83492791LL);
  };
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
  for (uint32_t v : verts) grid[hash(cell_of(mesh.positions[v]))].push_back(v);
  std::unordered_set<uint32_t> junctions;
  for (const auto& [a, b] : open) {
    const Vec3 pa = mesh.positions[a], pb = mesh.positions[b];
    const Vec3 ab = pb - pa;
    const double len2 = glm::dot(ab, ab);
    if (!(len2 > 0.0)) continue;
    const double len = std::sqrt(len2), tol = options.t_junction_tolerance * len;
    const glm::i64vec3 lo = cell_of(glm::min(pa, pb) - Vec3(tol)), hi = cell_of(glm::max(pa, pb) + Vec3(tol));
    const long long cells = (hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1);
    if (cells > 4096) continue;  // an edge far longer than the mean; skipped (documented limit)
    for (int64_t x = lo.x; x <= hi.x; ++x) {
      for (int64_t y = lo.y; y <= hi.y; ++y) {
        for (int64_t z = lo.z; z <= hi.z; ++z) {
          const auto it = grid.find(hash({x, y, z}));
          if (it == grid.end()) continue;
          for (uint32_t v : it->second) {
            if (v == a || v == b || junctions.count(v)) continue;
            const Vec3 p = mesh.positions[v];
            if (p == pa || p == pb) continue;
            bool inside = false;
            const K::Point_3 ca = cgal_point(pa), cb = cgal_point(pb), cp = cgal_point(p);
            if (CGAL::collinear(ca, cp, cb)) {
              inside = CGAL::collinear_are_strictly_ordered_along_line(ca, cp, cb);
            } else {
              const double t = glm::dot(p - pa, ab) / len2;
              inside = t * len > tol && (1.0 - t) * len > tol && glm::length(p - (pa + t * ab)) <= tol;
            }
            if (inside) {
              junctions.insert(v);
              const EdgeUse* e = edges.find(edge_key(a, b));
              f.add({"t_junction", p, patch_of(mesh, e->triangle), e->triangle, {v, -1}});
            }
          }
        }
      }
    }
  }
  f.r.t_junctions = junctions.size();
}

// Components through shared vertices (union-find), closedness from the edge uses, and the signed
// volume of each closed one: the sum over its triangles of det(p0 - c, p1 - c, p2 - c) / 6 with c
// the component's box centre (the divergence theorem; c only reduces cancellation).
void find_components(const Tessellation& mesh, const EdgeUses& edges, const TopologyOptions& options, Findings& f) {
  TopologyReport& r = f.r;
  std::vector<uint32_t> parent(mesh.positions.size());
  for (uint32_t v = 0; v < parent.size(); ++v) parent[v] = v;
  auto find = [&](uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Triangle& t : mesh.triangles) {
    for (int k = 1; k < 3; ++k) {
      const uint32_t a = find(t[0]), b = find(t[k]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  constexpr size_t kNone = ~size_t(0);
  std::vector<size_t> component_of_root(mesh.positions.size(), kNone);
  std::vector<MeshComponent> comps;
  std::vector<size_t> tri_component(mesh.triangles.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    if ((i & 0xffffu) == 0) budget::check("mesh check");
    const Triangle& t = mesh.triangles[i];
    size_t& component = component_of_root[find(t[0])];
    if (component == kNone) {
      component = comps.size();
      MeshComponent c;
      c.first_triangle = static_cast<int64_t>(i);
      c.patch = patch_of(mesh, i);
      c.box_min = c.box_max = mesh.positions[t[0]];
      c.closed = true;
      comps.push_back(c);
    }
    tri_component[i] = component;
    MeshComponent& c = comps[component];
    ++c.triangles;
    for (uint32_t v : t) {
      c.box_min = glm::min(c.box_min, mesh.positions[v]);
      c.box_max = glm::max(c.box_max, mesh.positions[v]);
    }
  }
  for (const EdgeUse& e : edges.uses) {
    if (e.count != 2 || e.forward != 1) comps[tri_component[e.triangle]].closed = false;
  }
  std::vector<double> magnitude(comps.size(), 0.0);
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    MeshComponent& c = comps[tri_component[i]];
    if (!c.closed) continue;
    const Vec3 centre = 0.5 * (c.box_min + c.box_max);
    const Triangle& t = mesh.triangles[i];
    const double six_v = glm::dot(mesh.positions[t[0]] - centre,
                                  glm::cross(mesh.positions[t[1]] - centre, mesh.positions[t[2]] - centre));
    c.signed_volume += six_v / 6.0;
    magnitude[tri_component[i]] += std::abs(six_v) / 6.0;
  }
  for (size_t k = 0; k < comps.size(); ++k) {
    MeshComponent& c = comps[k];
    // Negative beyond the rounding of the sum: a flat closed shell (volume ~0) is not flagged.
    c.inside_out = c.closed && c.signed_volume < -1e-9 * magnitude[k];
    r.closed_components += c.closed;
    if (c.inside_out) {
      ++r.inside_out_components;
      f.add({"inside_out_component", 0.5 * (c.box_min + c.box_max), c.patch, c.first_triangle, {-1, -1}});
    }
  }
  r.components = comps.size();
  std::stable_partition(comps.begin(), comps.end(), [](const MeshComponent& c) { return c.closed; });
  if (comps.size() > options.max_listed_components) comps.resize(options.max_listed_components);
  r.component_list = std::move(comps);
}

}  // namespace

TopologyReport check_mesh_topology(const Tessellation& mesh, const Model* model, const Topology* topology,
                                   const TopologyOptions& options) {
  TopologyReport r;
  r.triangles = mesh.triangles.size();
  const bool with_uv = mesh.has_surface() && model && topology && mesh.triangle_patch.size() == mesh.triangles.size();
  r.classified_with_uv = with_uv;
  Findings f{r, options.max_listed, {}};
  check_vertex_indices(mesh);
  find_degenerate_and_duplicated(mesh, f);
  const EdgeUses edges = count_edge_uses(mesh);
  r.edges = edges.size();
  const std::vector<std::pair<uint32_t, uint32_t>> open =
      classify_edges(mesh, model, topology, options, with_uv, edges, f);
  if (!open.empty()) find_t_junctions(mesh, open, edges, options, f);
  find_components(mesh, edges, options, f);
  return r;
}

}  // namespace sagitta
