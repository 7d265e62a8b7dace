// One entry point for "tessellate this model with that scheme": the scheme as an enum, its
// parameters in one SchemeSpec, the counts it reports in SchemeStats. Every front end (CLI, Python,
// FreeCAD) and the fit go through tessellate() here instead of calling the kernels one by one.
#pragma once

#include "sagitta/esc.hpp"
#include "sagitta/model.hpp"
#include "sagitta/pn.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace sagitta {

enum class Scheme { kUniform, kEsc, kPn };

// "uniform" | "esc" | "pn".
std::string scheme_name(Scheme scheme);
// The scheme named `name`; throws InputError for any other name.
Scheme parse_scheme(const std::string& name);
// Every scheme's name, in the order the CLI lists them: uniform, pn, esc.
std::vector<std::string> scheme_names();

// Normals of a mesh refined by PN: the mesh's own (computed when it has none), angle-weighted
// smooth normals, or one normal per face (every edge a crease).
enum class PnNormals { kFile, kSmooth, kFace };
// The names of the pn options, and the options by name (InputError for any other name).
std::string pn_normals_name(PnNormals normals);      // "file" | "smooth" | "face"
std::string pn_pattern_name(PnPatternKind pattern);  // "integer" | "fractional_odd"
std::string pn_variant_name(PnVariant variant);      // "basic" | "aen"
PnNormals parse_pn_normals(const std::string& name);
PnPatternKind parse_pn_pattern(const std::string& name);
PnVariant parse_pn_variant(const std::string& name);

// A scheme and its parameters, as the CLI options give them (-1: not given).
struct SchemeSpec {
  Scheme scheme = Scheme::kUniform;
  int level = -1;                                   // uniform: 2^L segments; esc: pattern level; pn: segments per edge
  int segments = -1;                                // uniform: N segments per side
  int segments_v = 0;                               // uniform: > 0: segments along v (UniformParams::segments_v)
  double threshold = 0.0;                           // esc: distance threshold rho
  bool per_edge_levels = false;                     // esc: EscParams::per_edge_levels
  std::vector<int> patch_levels;                    // uniform: UniformParams::patch_levels (then `segments` is unused)
  std::vector<double> patch_thresholds;             // esc: EscParams::patch_thresholds
  PnPatternKind pattern = PnPatternKind::kInteger;  // pn
  PnVariant pn_variant = PnVariant::kBasic;         // pn
  int base_level = -1;                              // pn on a patch model: uniform base with 2^L segments, then PN
  double tess_factor = -1.0;             // pn fractional_odd: factor in 1..63 (may be non-integer), instead of level
  PnNormals normals = PnNormals::kFile;  // pn on a mesh
  bool vertex_normals = true;            // uniform, esc: UniformParams/EscParams::normals
  bool surface_data = true;              // keep (patch, u, v) so the result can be validated
  uint64_t max_triangles = 200'000'000;
  // The up-front resource guard (check_triangle_estimate) before each kernel. Off for callers that
  // bound their sizes themselves (the fit, bench, the scene planner); the kernels still check
  // their parameters and, where they allocate, the memory limit.
  bool guard = true;
};

// What a run reports besides the mesh: the parameters it used and the scheme's counts.
struct SchemeStats {
  Scheme scheme = Scheme::kUniform;
  int level = -1;                                   // uniform: the level given (-1: segments given); esc: L
  int segments = 0;                                 // uniform: N
  int base_level = -1;                              // pn on a patch model: the uniform base's level (-1: pn on a mesh)
  double threshold = 0.0;                           // esc
  bool per_edge_levels = false;                     // esc
  EscStats esc;                                     // esc
  PnPatternKind pattern = PnPatternKind::kInteger;  // pn
  PnVariant pn_variant = PnVariant::kBasic;         // pn
  double factor = 0.0;                              // pn: the level or tess factor used
  PnNormals normals = PnNormals::kFile;             // pn
  PnStats pn;                                       // pn
};

// The resource guard of every command that tessellates: refuses (InputError, one line saying what
// to do) an estimated output above spec.max_triangles, or whose memory (the mesh plus
// `other_bytes`) exceeds --max-memory (sagitta/budget.hpp; the kernels check again where they
// allocate). The estimate is a double: products of large counts must not wrap around.
void check_triangle_estimate(double estimate, const SchemeSpec& spec, double other_bytes = 0.0);

// Triangles the chosen scheme makes on the model at most (esc: its full pattern; pn on a patch
// model: the uniform base, whose refinement tessellate() checks before running it).
double estimated_triangles(const Model& model, const SchemeSpec& spec);

// Runs the chosen scheme; fills `stats` (when given) with its parameters and counts. Refuses, with
// the CLI's messages, parameters that do not fit the scheme and (spec.guard) an estimated size
// above spec.max_triangles or the memory limit. pn on a patch model refines a uniform base.
Tessellation tessellate(const Model& model, const Topology& topology, const SchemeSpec& spec,
                        SchemeStats* stats = nullptr);

// The pn scheme on a triangle mesh (normals chosen by spec.normals); fills `stats` likewise.
// Refuses any other scheme.
Tessellation tessellate_mesh(const Tessellation& mesh, const SchemeSpec& spec, SchemeStats* stats = nullptr);

}  // namespace sagitta
