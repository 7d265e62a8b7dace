// Scheme selection shared by every subcommand that tessellates (tessellate, validate, fit, bench).
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace sagitta::cli {

struct SchemeOptions {
  std::string scheme = "uniform";
  int level = -1;       // uniform: 2^L segments; esc: pattern level; pn: segments per edge
  int segments = -1;    // uniform: N segments per side
  double threshold = 0.0;  // esc: distance threshold rho
  bool per_edge_levels = false;  // esc: EscParams::per_edge_levels (smallest sufficient level per refined edge)
  uint64_t max_triangles = 200'000'000;
  bool surface_data = true;  // keep (patch, u, v) so the result can be validated
  // pn
  std::string pattern = "integer";   // integer | fractional_odd
  std::string pn_variant = "basic";  // basic | aen
  int base_level = -1;               // patch model: uniform base with 2^L segments, then PN
  double tess_factor = -1.0;         // fractional_odd: factor in 1..63 (may be non-integer), instead of --level
  std::string normals = "file";      // mesh input: file | smooth | face
};

// The schemes --scheme accepts.
std::vector<std::string> scheme_names();

// Adds --scheme, --level, --segments, --threshold and --max-triangles to a subcommand.
void add_scheme_options(CLI::App* command, SchemeOptions& options);

// The resource guard of every command that tessellates: refuses (one line saying what to do) an
// estimated output above options.max_triangles, or whose memory (the mesh plus `other_bytes`)
// exceeds --max-memory (sagitta/budget.hpp; the kernels check again where they allocate).
void check_triangle_estimate(double estimate, const SchemeOptions& options, double other_bytes = 0.0);

// Triangles the chosen scheme makes on the model at most (esc: its full pattern; pn on a patch
// model: the uniform base, whose refinement run_scheme checks before running it).
double scheme_triangle_estimate(const Model& model, const SchemeOptions& options);

// Runs the chosen scheme; fills `stats` with the scheme's parameters and counts (not timing).
// Refuses, with a message, a tessellation whose estimated size exceeds max_triangles.
Tessellation run_scheme(const Model& model, const Topology& topology, const SchemeOptions& options, nlohmann::json& stats);

// The pn scheme on a triangle mesh (normals chosen by options.normals); fills `stats` likewise.
Tessellation run_pn_on_mesh(const Tessellation& mesh, const SchemeOptions& options, nlohmann::json& stats);

}  // namespace sagitta::cli
