// The uniform parametric-map scheme (seed 001): each patch is sampled on a regular (N+1) x (N+1)
// grid of its parameter square and every grid cell becomes two triangles.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <vector>

namespace sagitta {

struct UniformParams {
  int segments = 8;  // N >= 1 segments per patch side (along u when segments_v is given)
  // > 0: an anisotropic grid, `segments` along u and segments_v along v on every patch (each shared
  // side must then be a u side or a v side for all its users); 0: segments along both.
  int segments_v = 0;
  // Optional per-patch levels (one per patch; empty: every patch uses `segments`). Patch p is sampled
  // on a 2^L x 2^L grid; a side shared with a finer neighbour takes the neighbour's samples and the
  // patch stitches its border cells to them (see tessellate_uniform).
  std::vector<int> patch_levels;
  bool normals = true;
  bool surface_data = true;  // fill surface_points, triangle_patch, triangle_uv (needed to validate)
};

// Segments for `--level L`: 2^L (levels nest). Throws InputError when L is outside 0..kMaxUniformLevel.
inline constexpr int kMaxUniformLevel = 12;
int segments_for_level(int level);
namespace detail {
// The seed's level l samples 2^(l+1) points per side: N = 2^(l+1) - 1 (its tests reproduce the seed's
// table with it). Throws InputError when l is outside 1..kMaxUniformLevel.
int segments_for_paper_level(int level);
}  // namespace detail

// Triangles the scheme will produce (emitted + degenerate) before allocating anything.
uint64_t uniform_triangle_count(const Model& model, int segments, int segments_v = 0);

// Guarantees: vertices on a shared side are computed once from that side's boundary curve in its
// canonical direction and indexed once, so neighbours share them exactly (no welding); vertices on
// a collapsed side are the collapse point itself; triangles with two equal vertex indices are
// counted in degenerate_triangles and not emitted; each triangle is oriented like its patch's
// (u, v) square (normal du x dv). Patches are processed in parallel; the output does not depend
// on the thread count.
// With patch_levels: a shared side uses the finest level among the patches using it (one segment
// count per unique boundary curve, so neighbours still share vertices exactly); a patch's grid cell
// whose side holds more samples than the cell's own corners is triangulated as a fan from its
// corner inside the patch (or from an extra vertex at the parameter centre when the patch is a
// single cell), so there are no T-junctions. Throws InputError when patch_levels has the wrong size
// or a level outside 0..kMaxUniformLevel.
Tessellation tessellate_uniform(const Model& model, const Topology& topology, const UniformParams& params);

}  // namespace sagitta
