// Scheme selection shared by every subcommand that tessellates (tessellate, validate, fit, bench).
#pragma once

#include "sagitta/app/json.hpp"
#include "sagitta/model.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/tessellation.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace sagitta::cli {

// The scheme options as CLI11 binds them (names as strings, checked with IsMember so the messages stay
// CLI11's); scheme_spec() turns them into the scheme API's SchemeSpec.
struct SchemeOptions {
  std::string scheme = "uniform";
  int level = -1;       // uniform: 2^L segments; esc: pattern level; pn: segments per edge
  int segments = -1;    // uniform: N segments per side
  double threshold = 0.0;  // esc: distance threshold rho
  bool per_edge_levels = false;  // esc: EscParams::per_edge_levels (smallest sufficient level per refined edge)
  uint64_t max_triangles = 200'000'000;
  // pn
  std::string pattern = "integer";   // integer | fractional_odd
  std::string pn_variant = "basic";  // basic | aen
  int base_level = -1;               // patch model: uniform base with 2^L segments, then PN
  double tess_factor = -1.0;         // fractional_odd: factor in 1..63 (may be non-integer), instead of --level
  std::string normals = "file";      // mesh input: file | smooth | face
};

// Adds --scheme, --level, --segments, --threshold and --max-triangles to a subcommand.
void add_scheme_options(CLI::App* command, SchemeOptions& options);

// The options as the scheme API's spec (CLI11 has checked the names).
SchemeSpec scheme_spec(const SchemeOptions& options);

using app::scheme_stats_json;

}  // namespace sagitta::cli
