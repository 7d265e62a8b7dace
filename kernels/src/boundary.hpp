// Shared vertices on patch boundaries (private to the kernels): one global vertex per corner class and
// per sample of each unique boundary curve, evaluated from the curve alone in its canonical direction.
// Every scheme that samples patch sides uniformly uses this, which is what makes neighbours crack-free.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <functional>

namespace sagitta {

struct BoundaryLayout {
  uint32_t corner_base = 0;         // corner class c has vertex id corner_base + c
  std::vector<uint32_t> edge_base;  // edge e: interior samples k = 1..N-1 have ids edge_base[e] + k - 1
  std::vector<int> edge_segments;   // N for each edge
  uint32_t end = 0;                 // one past the last id used
};

// Allocates ids starting at `first_id`. `segments_for_edge(e)` gives N >= 1 for edge e; both
// neighbours of a shared edge must ask for the same N, which holds when it depends only on the edge.
BoundaryLayout layout_boundary(const Topology& topology, const std::function<int(size_t edge)>& segments_for_edge,
                               uint32_t first_id);

// Vertex id of sample k (0..N) along a patch side read in the side's own increasing direction.
uint32_t side_vertex(const BoundaryLayout& layout, const Topology& topology, uint32_t patch, Side side, int k);

// Number of segments N the layout uses on a patch side (1 for a collapsed side).
int side_segments(const BoundaryLayout& layout, const Topology& topology, uint32_t patch, Side side);

// Writes positions (and normals / surface points when those vectors are sized) of every boundary
// vertex in the layout. Corners are the exact control points; edge samples are de Casteljau on the
// canonical control polygon at t = k / N.
void fill_boundary(const Model& model, const Topology& topology, const BoundaryLayout& layout, Tessellation& out);

}  // namespace sagitta
