// Positions-only uniform tessellation into a caller's buffer: the throughput path, writing at memory speed.
//
// Every patch is sampled on its own regular (N+1) x (N+1) grid and written as interleaved x, y, z
// (float32 or double), patch after patch; there are no normals, no surface data, no shared
// vertices and no allocation per vertex. The triangles are implicit: every patch uses the same
// index pattern (uniform_grid_pattern) offset by patch * (N+1)^2, as a GPU would instance it.
// Vertices on a side shared by two patches are computed by each patch from its own control net,
// so they agree to rounding, not bit for bit (tessellate_uniform is the crack-free path).
#pragma once

#include "sagitta/evaluate.hpp"
#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <vector>

namespace sagitta {

// Vertices per patch ((N+1)^2) and in all (patches * (N+1)^2). Throws InputError for segments < 1.
uint64_t uniform_grid_patch_vertices(int segments);
uint64_t uniform_grid_vertices(const Model& model, int segments);

// The 2 N^2 triangles of one patch's grid, indices into that patch's (N+1)^2 vertices (row a, column
// b at a * (N+1) + b), oriented like the (u, v) square, in the order tessellate_uniform emits them
// for a patch without refined sides.
std::vector<Triangle> uniform_grid_pattern(int segments);

// Guarantees: xyz[3 * (p * (N+1)^2 + a * (N+1) + b) + k] is coordinate k of patch p at
// (u, v) = (a / N, b / N), equal to PatchEvaluator(patch).position(u, v) (same operations, so
// identical in double; rounded once to float for the float overload). xyz must hold
// 3 * uniform_grid_vertices(model, segments) values. Patches run in parallel (TBB); the output does
// not depend on the thread count. Throws InputError for segments < 1.
void tessellate_uniform_grid(const Model& model, int segments, float* xyz);
void tessellate_uniform_grid(const Model& model, int segments, double* xyz);

// The per-patch precomputation of tessellate_uniform_grid (each patch's matrix form and the
// v-basis tables for `segments`), kept for repeated tessellation of one model, as a renderer does
// every frame. run() writes exactly what tessellate_uniform_grid writes. Throws InputError for
// segments < 1.
namespace detail {
// The grid kernels, in increasing order of the instruction sets they need: portable C++ (also
// compiled for AVX2 by target_clones), AVX2 intrinsics, AVX-512 intrinsics (v-degrees 1 to 3 in
// the power basis; other patches always take the portable one). All write the same bits.
enum class GridKernel { kGeneric = 0, kAvx2 = 1, kAvx512 = 2 };
GridKernel best_grid_kernel();  // the best this CPU runs (the default)
GridKernel grid_kernel();       // the one in use
// For tests and measurements: use `kernel` from now on (process-wide). False, and nothing changes,
// when this CPU cannot run it.
bool force_grid_kernel(GridKernel kernel);
void reset_grid_kernel();
}  // namespace detail

class UniformGridPlan {
 public:
  UniformGridPlan(const Model& model, int segments);
  int segments() const { return segments_; }
  uint64_t vertices() const;  // 3 * vertices() values are written
  void run(float* xyz) const;
  void run(double* xyz) const;

 private:
  template <class Out>
  void run_impl(Out* xyz) const;

  int segments_;
  std::vector<detail::PatchEvaluator> evals_;
  std::vector<char> unit_weight_;  // per patch: polynomial in the power basis (no division needed)
  std::vector<const double*> tables_;    // per patch: its v-basis table (basis-major)
  std::vector<const double*> u_tables_;  // per patch: its u-basis table (row-major)
  std::vector<std::vector<double>> table_store_;
};

}  // namespace sagitta
