// The ESC adaptive scheme (seed 000, sections 2.2 and 3): a coarse mesh of two triangles per control
// net cell, a fixed pattern of level L inside every coarse triangle, a distance test that decides
// which candidate vertices on the coarse edges are inserted, and triangle strips rebuilt with
// virtual vertices. See docs/ESC.md for the reconstruction of the lost figures.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <vector>

namespace sagitta {

inline constexpr int kMaxEscLevel = 15;

struct EscParams {
  int level = 3;           // pattern level L: L + 1 segments per coarse edge, 0..kMaxEscLevel
  double threshold = 0.0;  // rho >= 0; a candidate is inserted when |net - surface| > rho; rho == 0 inserts all
  // Beyond the paper: an edge that the test refines takes the smallest level l in 1..L whose
  // (nested) vertices keep the edge's polyline within rho of the surface at all L candidates,
  // instead of inserting exactly the candidates that failed. See docs/ESC.md.
  bool per_edge_levels = false;
  // Optional per-patch thresholds (one per patch; empty: every patch uses `threshold`). A patch side
  // shared by several patches is decided with the smallest of their thresholds, so the decision
  // stays one per boundary curve (crack-free) and every patch keeps at least its own refinement.
  std::vector<double> patch_thresholds;
  bool normals = true;
  bool surface_data = true;  // fill surface_points, triangle_patch, triangle_uv (needed to validate)
};

struct EscStats {
  uint64_t candidates = 0;         // distinct candidate positions on coarse edges (shared ones once)
  uint64_t inserted_vertices = 0;  // candidates that passed the distance test
  uint64_t strips = 0;             // triangle strips emitted (one per non-empty band of a coarse triangle)
};

// Triangles the pattern holds before any test (emitted + degenerate at threshold 0):
// 2 * n * m * (L + 1)^2 per patch of degree (n, m).
uint64_t esc_full_triangle_count(const Model& model, int level);

// Guarantees: a candidate on a coarse edge is decided once; on a patch side the decision and the
// vertex depend only on that boundary curve's control polygon in its canonical direction, so
// neighbours share vertex ids and bit-identical positions (no welding); the output is crack-free and
// T-junction-free wherever the model's sides match exactly. `strips` describe exactly the emitted
// triangles (strip triangles with a repeated index are skipped, orientation alternates as usual).
// Triangles collapsed by a collapsed patch side are counted in degenerate_triangles, not emitted;
// only vertices that some triangle uses are output. Each triangle is oriented like its patch's
// (u, v) square (normal du x dv). Patches run in parallel; the output does not depend on the thread
// count. Throws InputError for a level outside 0..kMaxEscLevel, a negative / non-finite threshold,
// or patch_thresholds of the wrong size.
Tessellation tessellate_esc(const Model& model, const Topology& topology, const EscParams& params,
                            EscStats* stats = nullptr);

namespace detail {
// tessellate_esc by way of per-patch buffers copied into place: the same result, slower. It is
// what tessellate_esc falls back to where its in-place path cannot predict the vertices the strips
// use (around collapsed sides); public for the tests that compare the two.
Tessellation tessellate_esc_by_copy(const Model& model, const Topology& topology, const EscParams& params,
                                    EscStats* stats = nullptr);
// Whether tessellate_esc takes its in-place path for these inputs (for tests).
bool esc_direct_path_applies(const Model& model, const Topology& topology, const EscParams& params);
}  // namespace detail

}  // namespace sagitta
