// Vertex normals for meshes that come without them.
#pragma once

#include "sagitta/tessellation.hpp"

#include <vector>

namespace sagitta {

// Angle-weighted vertex normals (Thürmer & Wüthrich 1998): each triangle adds its unit face normal
// times its interior angle at the corner. Vertices are grouped by exactly equal position, so an
// unindexed mesh (STL: three private vertices per triangle) still gets smooth normals, and all
// vertices at one position get the same bit-identical normal. Degenerate triangles (zero area)
// add nothing; a position touched only by degenerate triangles gets (0, 0, 1).
// Returns one unit normal per entry of `positions`; counter-clockwise triangles give outward normals.
std::vector<Vec3> angle_weighted_normals(const std::vector<Vec3>& positions, const std::vector<Triangle>& triangles);

// The same mesh with every triangle given three private vertices carrying its unit face normal
// (counter-clockwise orientation; (0, 0, 1) for a degenerate triangle). Surface data is dropped.
// This is the "creases everywhere" input: neighbours share positions but not normals.
Tessellation split_face_normals(const Tessellation& mesh);

}  // namespace sagitta
