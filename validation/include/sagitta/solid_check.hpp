// Per-solid verdict of a whole-part mesh: each solid's triangles (by the id the part mesher gives
// every triangle) checked as one closed surface: open edges split into model boundary (on a free
// B-rep edge) and cracks, T-junctions, non-manifold and inconsistently oriented edges, degenerate
// triangles, components, Euler characteristic and enclosed volume; then independent verdicts from
// CGAL (closed, outward, self-intersections, volume) on the same triangles.
#pragma once

#include "sagitta/mesh_check.hpp"
#include "sagitta/tessellation.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace sagitta {

struct SolidCheckOptions {
  bool cgal = true;                // run the CGAL verdicts
  bool self_intersections = true;  // count CGAL's self-intersecting pairs (the expensive part)
  uint64_t max_listed = 20;        // findings listed per kind and solid (replaces topology.max_listed)
  TopologyOptions topology;        // T-junction tolerance (its boundary options are unused here)
};

struct SolidCheck {
  int32_t solid = -1;  // the id in triangle_solid (-1: the triangles outside any solid, checked together)
  uint64_t triangles = 0, vertices = 0, edges = 0;  // vertices/edges actually used by this solid's triangles
  uint64_t open_edges = 0, model_boundary_edges = 0,
           crack_edges = 0;  // open = used once; boundary if in boundary_edges
  uint64_t non_manifold_edges = 0, t_junctions = 0, inconsistent_orientation_edges = 0, degenerate_triangles = 0;
  uint64_t components = 0;           // connected through shared vertices
  int64_t euler_characteristic = 0;  // V - E + F over the solid's used vertices, edges, triangles
  bool closed = false;               // no open, non-manifold or inconsistently oriented edge
  // Enclosed volume by the divergence theorem (the tetrahedra from the solid's box centre to its
  // triangles), > 0 when they wind counter-clockwise seen from outside; 0 when not closed.
  double signed_volume = 0.0;
  // Independent verdicts from CGAL (Surface_mesh built from the solid's triangles + Polygon_mesh_processing):
  bool cgal_checked = false;
  std::string cgal_note;                           // why not checked (not requested, soup not a polygon mesh)
  bool cgal_closed = false, cgal_outward = false;  // CGAL::is_closed, PMP::is_outward_oriented (only when closed)
  uint64_t cgal_self_intersections = 0;            // pairs of distinct faces from PMP::self_intersections
  double cgal_volume = 0.0;                        // PMP::volume when closed
  // Located findings (mesh_check.hpp's kinds, indices in the whole mesh), at most max_listed per kind.
  std::vector<TopologyFinding> findings;
};

// Checks every solid of a whole-part mesh. triangle_solid has one id per triangle (-1: in no
// solid); boundary_edges are the mesh edges (vertex pairs, either order) lying on free B-rep
// edges, so an open edge is model boundary when it is one of them and a crack otherwise. Returns
// one verdict per id present, sorted by id (-1 first); deterministic. Throws InputError when the
// sizes disagree or an index is out of range.
std::vector<SolidCheck> check_solids(const Tessellation& mesh, const std::vector<int32_t>& triangle_solid,
                                     const std::vector<std::array<uint32_t, 2>>& boundary_edges,
                                     const SolidCheckOptions& options = {});

}  // namespace sagitta
