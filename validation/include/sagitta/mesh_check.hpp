// Topology verdict of a triangle mesh: open edges (model boundary or crack), T-junctions,
// non-manifold edges, inconsistently oriented edges, degenerate and duplicated triangles, each
// finding located. Counts are exact; the listed findings are capped.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace sagitta {

struct TopologyFinding {
  std::string kind;        // "crack_edge", "model_boundary_edge", "t_junction", "non_manifold_edge",
                           // "inconsistent_orientation_edge", "degenerate_triangle", "duplicated_face"
  Vec3 position{0.0};      // edge midpoint, junction vertex, triangle centroid
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
  uint64_t duplicated_faces = 0;      // extra copies of a face with the same vertex set
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
