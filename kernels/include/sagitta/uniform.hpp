// The uniform parametric-map scheme (seed 001): each patch is sampled on a regular (N+1) x (N+1)
// grid of its parameter square and every grid cell becomes two triangles.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

namespace sagitta {

struct UniformParams {
  int segments = 8;        // N >= 1 segments per patch side
  bool normals = true;
  bool surface_data = true;  // fill surface_points, triangle_patch, triangle_uv (needed to validate)
};

// Segments for `--level L`: 2^L (levels nest). Throws InputError when L is outside 0..kMaxUniformLevel.
inline constexpr int kMaxUniformLevel = 12;
int segments_for_level(int level);
// The seed's level l samples 2^(l+1) points per side: N = 2^(l+1) - 1.
int segments_for_paper_level(int level);

// Triangles the scheme will produce (emitted + degenerate) before allocating anything.
uint64_t uniform_triangle_count(const Model& model, int segments);

// Guarantees: vertices on a shared side are computed once from that side's boundary curve in its
// canonical direction and indexed once, so neighbours share them exactly (no welding); vertices on
// a collapsed side are the collapse point itself; triangles with two equal vertex indices are
// counted in degenerate_triangles and not emitted; each triangle is oriented like its patch's
// (u, v) square (normal du x dv). Patches are processed in parallel; the output does not depend
// on the thread count.
Tessellation tessellate_uniform(const Model& model, const Topology& topology, const UniformParams& params);

}  // namespace sagitta
