// Per-solid verdicts (see solid_check.hpp): each solid's triangles become a mesh of their own,
// checked by check_mesh_topology (T-junctions, non-manifold, orientation, degenerate triangles,
// components); open edges are classified here from the given boundary edges, and the Euler
// characteristic, the volume and CGAL's independent verdicts are added.
#include "sagitta/solid_check.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

#include <boost/iterator/function_output_iterator.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <limits>
#include <map>
#include <unordered_set>

namespace sagitta {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<K::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

uint64_t edge_key(uint32_t a, uint32_t b) { return (static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b); }

// A solid's triangles as a mesh of their own: the vertices they use renumbered in order of first
// use, with the maps back to the whole mesh.
struct SubMesh {
  Tessellation mesh;
  std::vector<uint32_t> triangle;  // whole-mesh index of each triangle
  std::vector<uint32_t> vertex;    // whole-mesh index of each vertex
};

// `local` maps whole-mesh vertices to sub-mesh ones; it is kNone everywhere on entry and on return.
SubMesh extract(const Tessellation& mesh, std::vector<uint32_t> triangles, std::vector<uint32_t>& local) {
  SubMesh s;
  const bool with_patch = mesh.triangle_patch.size() == mesh.triangles.size();
  s.mesh.triangles.reserve(triangles.size());
  for (uint32_t t : triangles) {
    Triangle lt;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.triangles[t][k];
      if (local[v] == kNone) {
        local[v] = static_cast<uint32_t>(s.vertex.size());
        s.vertex.push_back(v);
        s.mesh.positions.push_back(mesh.positions[v]);
      }
      lt[k] = local[v];
    }
    s.mesh.triangles.push_back(lt);
    if (with_patch) s.mesh.triangle_patch.push_back(mesh.triangle_patch[t]);
  }
  for (uint32_t v : s.vertex) local[v] = kNone;
  s.triangle = std::move(triangles);
  return s;
}

// The sub-mesh's findings with whole-mesh triangle and vertex indices.
TopologyFinding to_whole(TopologyFinding f, const SubMesh& s) {
  if (f.triangle >= 0) f.triangle = s.triangle[static_cast<size_t>(f.triangle)];
  for (int64_t& v : f.vertices) {
    if (v >= 0) v = s.vertex[static_cast<size_t>(v)];
  }
  return f;
}

// Open edges (used by one triangle) split into model boundary (in `boundary`, whole-mesh keys) and
// cracks, counted and listed (in edge order, at most max_listed of each kind).
void classify_open_edges(const SubMesh& s, const std::unordered_set<uint64_t>& boundary, size_t max_listed,
                         SolidCheck& c) {
  std::vector<std::pair<uint64_t, uint32_t>> uses;  // (sub-mesh edge key, sub-mesh triangle)
  uses.reserve(3 * s.mesh.triangles.size());
  for (uint32_t i = 0; i < s.mesh.triangles.size(); ++i) {
    const Triangle& t = s.mesh.triangles[i];
    for (int k = 0; k < 3; ++k) {
      if (t[k] != t[(k + 1) % 3]) uses.emplace_back(edge_key(t[k], t[(k + 1) % 3]), i);
    }
  }
  std::sort(uses.begin(), uses.end());
  size_t listed_boundary = 0, listed_cracks = 0;
  for (size_t i = 0; i < uses.size();) {
    size_t j = i + 1;
    while (j < uses.size() && uses[j].first == uses[i].first) ++j;
    if (j - i == 1) {
      const uint32_t a = static_cast<uint32_t>(uses[i].first >> 32);
      const uint32_t b = static_cast<uint32_t>(uses[i].first & 0xffffffffu);
      const bool on_boundary = boundary.count(edge_key(s.vertex[a], s.vertex[b])) != 0;
      ++(on_boundary ? c.model_boundary_edges : c.crack_edges);
      if (++(on_boundary ? listed_boundary : listed_cracks) <= max_listed) {
        const uint32_t tri = uses[i].second;
        const int64_t patch = s.mesh.triangle_patch.empty() ? -1 : int64_t(s.mesh.triangle_patch[tri]);
        const Vec3 mid = 0.5 * (s.mesh.positions[a] + s.mesh.positions[b]);
        c.findings.push_back(
            to_whole({on_boundary ? "model_boundary_edge" : "crack_edge", mid, patch, int64_t(tri), {a, b}}, s));
      }
    }
    i = j;
  }
}

// Signed volume by the divergence theorem: the tetrahedra from the box centre (which only reduces
// cancellation) to each triangle, summed in triangle order.
double signed_volume(const Tessellation& m) {
  Vec3 lo = m.positions.front(), hi = lo;
  for (const Vec3& p : m.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const Vec3 centre = 0.5 * (lo + hi);
  double six_v = 0.0;
  for (const Triangle& t : m.triangles) {
    six_v += glm::dot(m.positions[t[0]] - centre, glm::cross(m.positions[t[1]] - centre, m.positions[t[2]] - centre));
  }
  return six_v / 6.0;
}

// CGAL's verdicts on the sub-mesh, built as a Surface_mesh when the triangles form a polygon mesh.
void cgal_verdicts(const Tessellation& m, const SolidCheckOptions& options, SolidCheck& c) {
  if (!options.cgal) {
    c.cgal_note = "not requested";
    return;
  }
  std::vector<std::array<std::size_t, 3>> polygons;
  polygons.reserve(m.triangles.size());
  for (const Triangle& t : m.triangles) polygons.push_back({t[0], t[1], t[2]});
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons)) {
    c.cgal_note =
        "the triangles are not a polygon mesh (a repeated vertex in a triangle, an edge used twice in "
        "one direction or more than twice, or a non-manifold vertex)";
    return;
  }
  std::vector<K::Point_3> points;
  points.reserve(m.positions.size());
  for (const Vec3& p : m.positions) points.emplace_back(p.x, p.y, p.z);
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
  c.cgal_checked = true;
  c.cgal_closed = CGAL::is_closed(sm);
  if (c.cgal_closed) {
    c.cgal_outward = PMP::is_outward_oriented(sm);
    c.cgal_volume = PMP::volume(sm);
  }
  if (options.self_intersections) {
    // Sequential: the box intersection in one thread, so the run is reproducible. A degenerate
    // face is reported paired with itself; it is counted in degenerate_triangles instead.
    uint64_t pairs = 0;
    using Face = SurfaceMesh::Face_index;
    PMP::self_intersections<CGAL::Sequential_tag>(
        sm, boost::make_function_output_iterator([&pairs](const std::pair<Face, Face>& p) {
          if (p.first != p.second) ++pairs;
        }));
    c.cgal_self_intersections = pairs;
  }
}

// The verdict of one solid.
SolidCheck check_solid(int32_t id, const SubMesh& s, const std::unordered_set<uint64_t>& boundary,
                       const SolidCheckOptions& options) {
  SolidCheck c;
  c.solid = id;
  TopologyOptions topology_options = options.topology;
  topology_options.max_listed = options.max_listed;
  const TopologyReport r = check_mesh_topology(s.mesh, nullptr, nullptr, topology_options);
  c.triangles = r.triangles;
  c.vertices = s.mesh.positions.size();
  c.edges = r.edges;
  c.open_edges = r.open_edges;
  c.non_manifold_edges = r.non_manifold_edges;
  c.t_junctions = r.t_junctions;
  c.inconsistent_orientation_edges = r.inconsistent_orientation_edges;
  c.degenerate_triangles = r.degenerate_triangles;
  c.components = r.components;
  c.euler_characteristic = int64_t(c.vertices) - int64_t(c.edges) + int64_t(c.triangles);
  c.closed = c.open_edges == 0 && c.non_manifold_edges == 0 && c.inconsistent_orientation_edges == 0;
  if (c.closed) c.signed_volume = signed_volume(s.mesh);
  // Without a model every open edge is a crack there; the split comes from the boundary edges.
  for (const TopologyFinding& f : r.findings) {
    if (f.kind != "crack_edge") c.findings.push_back(to_whole(f, s));
  }
  classify_open_edges(s, boundary, options.max_listed, c);
  cgal_verdicts(s.mesh, options, c);
  return c;
}

// Throws InputError when the per-triangle ids or an index do not fit the mesh.
void check_input(const Tessellation& mesh, const std::vector<int32_t>& triangle_solid,
                 const std::vector<std::array<uint32_t, 2>>& boundary_edges) {
  if (triangle_solid.size() != mesh.triangles.size()) {
    throw InputError("solid check: " + std::to_string(triangle_solid.size()) + " solid ids for " +
                     std::to_string(mesh.triangles.size()) + " triangles");
  }
  const size_t n = mesh.positions.size();
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t v : t) {
      if (v >= n)
        throw InputError("solid check: a triangle refers to vertex " + std::to_string(v) + " but the mesh has " +
                         std::to_string(n));
    }
  }
  for (const auto& e : boundary_edges) {
    if (e[0] >= n || e[1] >= n)
      throw InputError("solid check: a boundary edge refers to a vertex the mesh does not have");
  }
}

}  // namespace

std::vector<SolidCheck> check_solids(const Tessellation& mesh, const std::vector<int32_t>& triangle_solid,
                                     const std::vector<std::array<uint32_t, 2>>& boundary_edges,
                                     const SolidCheckOptions& options) {
  check_input(mesh, triangle_solid, boundary_edges);
  std::map<int32_t, std::vector<uint32_t>> by_solid;  // ordered: verdicts sorted by id
  for (uint32_t t = 0; t < triangle_solid.size(); ++t) by_solid[triangle_solid[t]].push_back(t);
  std::unordered_set<uint64_t> boundary;
  boundary.reserve(boundary_edges.size());
  for (const auto& e : boundary_edges) boundary.insert(edge_key(e[0], e[1]));
  std::vector<uint32_t> local(mesh.positions.size(), kNone);
  std::vector<SolidCheck> result;
  for (auto& [id, triangles] : by_solid) {
    const SubMesh s = extract(mesh, std::move(triangles), local);
    result.push_back(check_solid(id, s, boundary, options));
  }
  return result;
}

}  // namespace sagitta
