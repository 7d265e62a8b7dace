// Topology verdict of a triangle mesh: open edges (model boundary or crack), T-junctions,
// non-manifold edges, inconsistently oriented edges, degenerate and duplicated triangles, each
// finding located; and the connected components with the signed volume of the closed ones, so an
// inside-out (mirrored) part is found. Counts are exact; the listed findings are capped.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace sagitta {

struct TopologyFinding {
  std::string kind;        // "crack_edge", "model_boundary_edge", "t_junction", "non_manifold_edge",
                           // "inconsistent_orientation_edge", "degenerate_triangle", "duplicated_face",
                           // "inside_out_component"
  Vec3 position{0.0};      // edge midpoint, junction vertex, triangle centroid, component box centre
  int64_t patch = -1;      // patch of the triangle concerned; -1 when unknown
  int64_t triangle = -1;   // triangle index
  std::array<int64_t, 2> vertices{-1, -1};  // the edge's vertices (or the junction vertex and -1)
};

struct TopologyOptions {
  size_t max_listed = 50;  // findings listed per kind (counts stay exact)
  // A vertex is a T-junction on edge (a, b) when its distance to the segment is at most
  // t_junction_tolerance * |b - a| and it projects strictly inside, at least that fraction of
  // |b - a| away from both ends. Exactly collinear cases are decided by CGAL's exact predicate.
  double t_junction_tolerance = 1e-7;
  // For meshes without (u, v): an open edge is model boundary when both its vertices lie within
  // this times the model's box diagonal of the same free boundary curve (1e-6 absorbs the float
  // coordinates of STL files) and its midpoint within a quarter of its length of that curve.
  double boundary_tolerance = 1e-6;
  size_t max_listed_components = 1000;  // components listed (closed ones first); counts stay exact
};

// A connected component: triangles linked through shared vertices. It is closed when every edge of
// it is used by exactly two of its triangles in opposite directions; then signed_volume is the
// enclosed volume (divergence theorem, sum of the tetrahedra to the box centre), positive when the
// triangles wind counter-clockwise seen from outside, and inside_out says it is clearly negative.
struct MeshComponent {
  uint64_t triangles = 0;
  int64_t first_triangle = -1;  // lowest triangle index in the component
  int64_t patch = -1;           // patch of that triangle; -1 when unknown
  Vec3 box_min{0.0}, box_max{0.0};
  bool closed = false;
  double signed_volume = 0.0;   // 0 when not closed
  bool inside_out = false;
};

struct TopologyReport {
  uint64_t triangles = 0;
  uint64_t edges = 0;
  uint64_t open_edges = 0;
  uint64_t model_boundary_edges = 0;
  uint64_t crack_edges = 0;
  uint64_t t_junctions = 0;
  uint64_t non_manifold_edges = 0;
  uint64_t inconsistent_orientation_edges = 0;
  uint64_t degenerate_triangles = 0;  // zero area (exact predicate) among the emitted triangles
  uint64_t duplicated_faces = 0;      // extra copies of a face with the same vertex set (either winding)
  uint64_t components = 0;            // connected components (shared vertices)
  uint64_t closed_components = 0;
  uint64_t inside_out_components = 0;  // closed with negative signed volume
  std::vector<MeshComponent> component_list;  // closed first, then open, each by first triangle; capped
  bool classified_with_uv = false;    // open edges classified from (patch, u, v), else geometrically
  std::vector<TopologyFinding> findings;
  bool watertight() const { return crack_edges == 0 && t_junctions == 0 && non_manifold_edges == 0; }
};

// Checks a mesh. With `model` and its `topology`, open edges are split into model boundary (both
// ends on the same free-boundary curve of the model) and cracks (all other open edges); without a
// model every open edge is a crack. Uses (patch, u, v) when the mesh has them, else the distance
// of the edge's vertices to the free boundary curves.
TopologyReport check_mesh_topology(const Tessellation& mesh, const Model* model, const Topology* topology,
                                   const TopologyOptions& options = {});

}  // namespace sagitta
