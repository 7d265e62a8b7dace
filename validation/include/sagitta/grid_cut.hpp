// A (u, v) triangle cut along a face's grid of Bézier patches, so that each piece lies in one patch
// and can be certified against it (certify_distance). Used for OCCT's triangles of a trimmed face
// (peer) and for the part mesher's own triangles (the whole-part certificate).
#pragma once

#include "sagitta/patch.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace sagitta {

// Patch (i, j) of the grid spans [u_breaks[i], u_breaks[i + 1]] x [v_breaks[j], v_breaks[j + 1]]
// and is number i * (v_breaks.size() - 1) + j; inside it u is mirrored when `reversed`. A period
// > 0 over which the breaks span exactly one period continues the grid by one period on each side
// (a triangle across a closed surface's seam).
struct PatchGrid {
  std::vector<double> u_breaks, v_breaks;
  double u_period = 0.0, v_period = 0.0;
  bool reversed = false;
};

struct GridPiece {
  uint32_t patch = 0;               // in the grid's numbering
  std::array<Vec2, 3> st;           // the piece's corners in the patch's own (s, t), clamped onto [0, 1]^2
  std::array<Vec3, 3> barycentric;  // the same corners in the triangle's barycentric coordinates
};

// The pieces of triangle `uv` (counter-clockwise or not), fanned from each clipped polygon; pieces of
// zero area are left out. The outer ends of the (extended) grid are not clipped: corners beyond them
// by rounding stay with the end cells.
std::vector<GridPiece> cut_along_grid(const std::array<Vec2, 3>& uv, const PatchGrid& grid);

}  // namespace sagitta
