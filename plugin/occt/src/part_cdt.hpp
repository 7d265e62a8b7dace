// The constrained Delaunay triangulation the part mesher fills trimmed regions with (CGAL), kept
// in its own translation unit: CGAL and OCCT headers cannot meet (both define `Handle`).
#pragma once

#include "sagitta/patch.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace sagitta::occt::detail {

struct CdtResult {
  // The input points, then the points CGAL created where two constraints cross.
  std::vector<Vec2> points;
  // Per input point: the index of the point it was merged with (the first input at the same place).
  std::vector<uint32_t> merged;
  // Every finite face, counter-clockwise, as indices into `points` (merged indices for inputs).
  std::vector<std::array<uint32_t, 3>> triangles;
  // Per face: inside the loops, i.e. reached from the unbounded face across an odd number of loop
  // edges (CGAL's "mark domains" flood fill). Decided by the triangulation's adjacency, not by a
  // point test, so slivers along a loop are on the side they are on.
  std::vector<bool> inside;
};

// CGAL::Constrained_Delaunay_triangulation_2 (exact predicates) of the points with the segments
// (index pairs into points) as constraints; crossing constraints are split at a new point. The
// first `loop_constraints` constraints are the loops (they bound the inside); the others only
// force edges (they are never split: the caller keeps them clear of the loops).
CdtResult constrained_delaunay(const std::vector<Vec2>& points, const std::vector<std::array<uint32_t, 2>>& constraints,
                               size_t loop_constraints);

}  // namespace sagitta::occt::detail
