// The output of every scheme and the input of the validator.
#pragma once

#include "sagitta/patch.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace sagitta {

// Where a vertex lies on the exact surface. A vertex shared by several patches records one of them.
struct SurfacePoint {
  uint32_t patch = 0;
  double u = 0.0;
  double v = 0.0;
};

using Triangle = std::array<uint32_t, 3>;

struct Tessellation {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;                  // unit normals, one per position (may be empty)
  std::vector<SurfacePoint> surface_points;   // per vertex; empty for meshes with no exact surface
  std::vector<Triangle> triangles;            // counter-clockwise seen from the normal side
  std::vector<uint32_t> triangle_patch;       // per triangle; empty when unknown
  std::vector<std::array<Vec2, 3>> triangle_uv;  // per triangle corner, in triangle_patch's domain
  std::vector<std::vector<uint32_t>> strips;  // triangle strips (ESC), same triangles as above
  uint64_t degenerate_triangles = 0;          // collapsed to a point or a segment: counted, not emitted

  bool has_surface() const { return !triangle_patch.empty() && !triangle_uv.empty(); }
};

// Bytes of a tessellation with every array filled (triangle, patch and (u, v) per triangle;
// position, normal and surface point per vertex), for the memory guard (sagitta/budget.hpp).
inline double tessellation_bytes(double triangles, double vertices) {
  return triangles * double(sizeof(Triangle) + sizeof(uint32_t) + sizeof(std::array<Vec2, 3>)) +
         vertices * double(2 * sizeof(Vec3) + sizeof(SurfacePoint));
}

}  // namespace sagitta
