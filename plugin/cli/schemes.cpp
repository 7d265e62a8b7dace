#include "schemes.hpp"

#include "sagitta/esc.hpp"
#include "sagitta/uniform.hpp"

namespace sagitta::cli {

void add_scheme_options(CLI::App* command, SchemeOptions& o) {
  command->add_option("--scheme", o.scheme, "Tessellation scheme")->check(CLI::IsMember(scheme_names()))->capture_default_str();
  command->add_option("--level", o.level,
                      "uniform: 2^L segments per patch side (levels nest), 0.." + std::to_string(kMaxUniformLevel) +
                          "; esc: pattern level L, L + 1 segments per coarse edge (the paper uses 3), 0.." +
                          std::to_string(kMaxEscLevel) + "; pn: K segments per edge (or the fractional_odd factor)");
  command->add_option("--segments", o.segments, "uniform: N >= 1 segments per patch side (the seed's level l is N = 2^(l+1) - 1)");
  command->add_option("--pattern", o.pattern, "pn: integer (k segments per edge, k^2 triangles) or fractional_odd (Direct3D 11)")
      ->check(CLI::IsMember({"integer", "fractional_odd"}))
      ->capture_default_str();
  command->add_option("--pn-variant", o.pn_variant, "pn: basic (Vlachos) or aen (averaged edge control points: no cracks at creases)")
      ->check(CLI::IsMember({"basic", "aen"}))
      ->capture_default_str();
  command->add_option("--base-level", o.base_level, "pn on a patch model: uniform base with 2^L segments per side, then PN at --level");
  command->add_option("--tess-factor", o.tess_factor, "pn fractional_odd: factor in 1..63, may be non-integer (instead of --level)");
  command->add_option("--normals", o.normals, "pn on a mesh: file (the file's, else computed), smooth (angle-weighted), face (split per face)")
      ->check(CLI::IsMember({"file", "smooth", "face"}))
      ->capture_default_str();
  command->add_flag("--per-edge-levels", o.per_edge_levels,
                    "esc: a refined coarse edge takes the smallest level whose vertices keep it within the threshold "
                    "(instead of the paper's per-candidate test; docs/ESC.md)");
  command->add_option("--threshold", o.threshold,
                      "esc: distance threshold rho >= 0 (model units); 0 inserts every candidate (the non-adaptive pattern)")
      ->capture_default_str();
  command->add_option("--max-triangles", o.max_triangles,
                      "Refuse to tessellate when the estimated triangle count exceeds this (protects memory)")
      ->capture_default_str();
}

SchemeSpec scheme_spec(const SchemeOptions& o) {
  SchemeSpec spec;
  spec.scheme = parse_scheme(o.scheme);
  spec.level = o.level;
  spec.segments = o.segments;
  spec.threshold = o.threshold;
  spec.per_edge_levels = o.per_edge_levels;
  spec.pattern = parse_pn_pattern(o.pattern);
  spec.pn_variant = parse_pn_variant(o.pn_variant);
  spec.base_level = o.base_level;
  spec.tess_factor = o.tess_factor;
  spec.normals = parse_pn_normals(o.normals);
  spec.max_triangles = o.max_triangles;
  return spec;
}

}  // namespace sagitta::cli
