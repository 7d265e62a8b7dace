// Internal: a cheap proven bound on how far a Bézier patch (rational or not) is from the affine
// interpolation of its own points at the corners of a (u, v) triangle, from bounds on its second
// derivatives over a grid of sub-boxes of the domain. certify.cpp uses it to settle the many
// triangles whose error is far below the largest one without the exact (blossom) bound.
#pragma once

#include "sagitta/patch.hpp"

#include <array>
#include <vector>

namespace sagitta::detail {

class CurvatureGrid {
 public:
  CurvatureGrid() = default;
  // `cells` boxes per side (a power of two, 1 to 64). Empty when a weight is not a positive finite
  // number, or the weights' lower bound over a box is not positive after rounding.
  CurvatureGrid(const BezierPatch& patch, int cells);
  bool empty() const { return cells_ == 0; }

  // An upper bound, over every (u, v) = sum b_i q_i of the triangle q, of
  // |S(u, v) - sum b_i S(q_i)| in exact arithmetic (the patch against the affine interpolation of
  // its exact points at the corners); +inf when the grid is empty or a corner leaves [0, 1]^2.
  double interpolation_bound(const Vec2 q[3]) const;

 private:
  int cells_ = 0;
  // Per box (row-major in u): upper bounds on |S_uu|, |S_uv|, |S_vv| over the box.
  std::vector<std::array<double, 3>> second_;
};

}  // namespace sagitta::detail
