#include "schemes.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/mesh_normals.hpp"
#include "sagitta/pn.hpp"
#include "sagitta/esc.hpp"
#include "sagitta/uniform.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace sagitta::cli {

std::vector<std::string> scheme_names() { return {"uniform", "pn", "esc"}; }

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

namespace {

// The estimate is a double: products of large counts (2 N^2 patches) must not wrap around.
// `other_bytes`: what the run holds besides the mesh (a replicated model, its topology).
void check_size(double estimate, const SchemeOptions& o, double other_bytes = 0.0) {
  if (estimate > static_cast<double>(o.max_triangles)) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(0) << "this would make " << estimate << " triangles (about " << std::ceil(estimate * 64.0 / (1 << 30))
      << " GiB), more than --max-triangles " << o.max_triangles << "; lower the level or raise --max-triangles";
    throw InputError(s.str());
  }
  budget::check_memory(tessellation_bytes(estimate, estimate) + other_bytes,
                       "this tessellation (" + std::to_string(static_cast<uint64_t>(std::min(estimate, 1e19))) + " triangles)",
                       "lower the level or --copies, or raise --max-memory");
}

}  // namespace

void check_triangle_estimate(double estimate, const SchemeOptions& options, double other_bytes) {
  check_size(estimate, options, other_bytes);
}

double scheme_triangle_estimate(const Model& model, const SchemeOptions& o) {
  const double patches = static_cast<double>(model.patches.size());
  if (o.scheme == "uniform") {
    const double n = o.level >= 0 ? segments_for_level(o.level) : std::max(o.segments, 1);
    return 2.0 * n * n * patches;
  }
  if (o.scheme == "esc" && o.level >= 0 && o.level <= kMaxEscLevel) return static_cast<double>(esc_full_triangle_count(model, o.level));
  if (o.scheme == "pn" && o.base_level >= 0) {
    const double n = segments_for_level(o.base_level);
    return 2.0 * n * n * patches;  // the base; its refinement is checked (with its pattern's limits) before it runs
  }
  return 2.0 * patches;  // every patch makes at least 2 triangles
}

Tessellation run_scheme(const Model& model, const Topology& topology, const SchemeOptions& o, nlohmann::json& stats) {
  stats["scheme"] = o.scheme;
  if (o.scheme == "uniform") {
    if ((o.level >= 0) == (o.segments >= 0)) throw InputError("uniform scheme: give exactly one of --level L or --segments N");
    const int n = o.level >= 0 ? segments_for_level(o.level) : o.segments;
    if (n < 1) throw InputError("--segments must be >= 1, got " + std::to_string(n));
    check_size(2.0 * n * n * static_cast<double>(model.patches.size()), o);  // uniform_triangle_count, unwrapped
    if (o.level >= 0) stats["level"] = o.level;
    stats["segments"] = n;
    UniformParams params;
    params.segments = n;
    params.surface_data = o.surface_data;
    return tessellate_uniform(model, topology, params);
  }
  if (o.scheme == "pn") {
    if (o.base_level < 0) throw InputError("pn scheme on a patch model: give --base-level L (uniform base with 2^L segments) and --level K");
    UniformParams base_params;
    base_params.segments = segments_for_level(o.base_level);
    base_params.surface_data = o.surface_data;
    check_size(uniform_triangle_count(model, base_params.segments), o);
    stats["base_level"] = o.base_level;
    return run_pn_on_mesh(tessellate_uniform(model, topology, base_params), o, stats);
  }
  if (o.scheme == "esc") {
    if (o.level < 0) throw InputError("esc scheme: give --level L (L + 1 segments per coarse edge; the paper uses 3)");
    if (o.segments >= 0) throw InputError("esc scheme: --segments does not apply; give --level L and --threshold RHO");
    EscParams params;
    params.level = o.level;
    params.threshold = o.threshold;
    params.per_edge_levels = o.per_edge_levels;
    params.surface_data = o.surface_data;
    if (o.level <= kMaxEscLevel) check_size(esc_full_triangle_count(model, o.level), o);
    EscStats s;
    Tessellation out = tessellate_esc(model, topology, params, &s);
    stats["level"] = o.level;
    stats["threshold"] = o.threshold;
    stats["per_edge_levels"] = o.per_edge_levels;
    stats["candidates"] = s.candidates;
    stats["inserted_vertices"] = s.inserted_vertices;
    stats["strips"] = s.strips;
    return out;
  }
  throw InputError("unknown scheme '" + o.scheme + "'");
}

Tessellation run_pn_on_mesh(const Tessellation& mesh, const SchemeOptions& o, nlohmann::json& stats) {
  if (o.scheme != "pn") throw InputError("a mesh file can only be refined with --scheme pn (got '" + o.scheme + "')");
  PnParams params;
  params.pattern = o.pattern == "fractional_odd" ? PnPatternKind::kFractionalOdd : PnPatternKind::kInteger;
  params.variant = o.pn_variant == "aen" ? PnVariant::kAen : PnVariant::kBasic;
  if (o.tess_factor >= 0.0) {
    if (o.level >= 0) throw InputError("pn scheme: give --level K or --tess-factor F, not both");
    if (params.pattern != PnPatternKind::kFractionalOdd) throw InputError("--tess-factor needs --pattern fractional_odd");
    params.factor = o.tess_factor;
  } else {
    if (o.level < 1) throw InputError("pn scheme: give --level K >= 1 (segments per edge, or the fractional_odd factor)");
    params.factor = o.level;
  }
  Tessellation input = mesh;
  if (o.normals == "smooth") {
    input.normals = angle_weighted_normals(input.positions, input.triangles);
  } else if (o.normals == "face") {
    input = split_face_normals(input);
  }
  check_size(pn_triangles_per_input(params) * input.triangles.size(), o);
  PnStats s;
  Tessellation out = tessellate_pn(input, params, &s);
  stats["pattern"] = o.pattern;
  stats["pn_variant"] = o.pn_variant;
  stats["factor"] = params.factor;
  stats["normals"] = o.normals;
  stats["segments_per_edge"] = s.segments_per_edge;
  stats["input_triangles"] = s.input_triangles;
  stats["skipped_triangles"] = s.skipped_triangles;
  stats["crease_edges"] = s.crease_edges;
  stats["open_edges"] = s.open_edges;
  stats["crack_edges"] = s.crack_edges;
  stats["max_crack_gap"] = s.max_crack_gap;
  return out;
}

}  // namespace sagitta::cli
