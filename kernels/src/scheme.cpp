#include "sagitta/scheme.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/mesh_normals.hpp"
#include "sagitta/uniform.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace sagitta {

std::string scheme_name(Scheme scheme) {
  switch (scheme) {
    case Scheme::kUniform:
      return "uniform";
    case Scheme::kEsc:
      return "esc";
    case Scheme::kPn:
      return "pn";
  }
  return "?";
}

Scheme parse_scheme(const std::string& name) {
  if (name == "uniform") return Scheme::kUniform;
  if (name == "esc") return Scheme::kEsc;
  if (name == "pn") return Scheme::kPn;
  throw InputError("unknown scheme '" + name + "' (expected uniform, esc or pn)");
}

std::vector<std::string> scheme_names() { return {"uniform", "pn", "esc"}; }

std::string pn_normals_name(PnNormals normals) {
  switch (normals) {
    case PnNormals::kFile:
      return "file";
    case PnNormals::kSmooth:
      return "smooth";
    case PnNormals::kFace:
      return "face";
  }
  return "?";
}

std::string pn_pattern_name(PnPatternKind pattern) {
  return pattern == PnPatternKind::kFractionalOdd ? "fractional_odd" : "integer";
}

std::string pn_variant_name(PnVariant variant) { return variant == PnVariant::kAen ? "aen" : "basic"; }

PnNormals parse_pn_normals(const std::string& name) {
  if (name == "file") return PnNormals::kFile;
  if (name == "smooth") return PnNormals::kSmooth;
  if (name == "face") return PnNormals::kFace;
  throw InputError("unknown normals '" + name + "' (expected file, smooth or face)");
}

PnPatternKind parse_pn_pattern(const std::string& name) {
  if (name == "integer") return PnPatternKind::kInteger;
  if (name == "fractional_odd") return PnPatternKind::kFractionalOdd;
  throw InputError("unknown pattern '" + name + "' (expected integer or fractional_odd)");
}

PnVariant parse_pn_variant(const std::string& name) {
  if (name == "basic") return PnVariant::kBasic;
  if (name == "aen") return PnVariant::kAen;
  throw InputError("unknown pn variant '" + name + "' (expected basic or aen)");
}

void check_triangle_estimate(double estimate, const SchemeSpec& spec, double other_bytes) {
  if (estimate > static_cast<double>(spec.max_triangles)) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(0) << "this would make " << estimate << " triangles (about "
      << std::ceil(estimate * 64.0 / (1 << 30)) << " GiB), more than --max-triangles " << spec.max_triangles
      << "; lower the level or raise --max-triangles";
    throw InputError(s.str());
  }
  budget::check_memory(
      tessellation_bytes(estimate, estimate) + other_bytes,
      "this tessellation (" + std::to_string(static_cast<uint64_t>(std::min(estimate, 1e19))) + " triangles)",
      "lower the level or --copies, or raise --max-memory");
}

double estimated_triangles(const Model& model, const SchemeSpec& spec) {
  const double patches = static_cast<double>(model.patches.size());
  if (spec.scheme == Scheme::kUniform) {
    const double n = spec.level >= 0 ? segments_for_level(spec.level) : std::max(spec.segments, 1);
    const double nv = spec.segments_v > 0 && spec.level < 0 ? spec.segments_v : n;
    return 2.0 * n * nv * patches;
  }
  if (spec.scheme == Scheme::kEsc && spec.level >= 0 && spec.level <= kMaxEscLevel) {
    return static_cast<double>(esc_full_triangle_count(model, spec.level));
  }
  if (spec.scheme == Scheme::kPn && spec.base_level >= 0) {
    const double n = segments_for_level(spec.base_level);
    return 2.0 * n * n * patches;  // the base; its refinement is checked (with its pattern's limits) before it runs
  }
  return 2.0 * patches;  // every patch makes at least 2 triangles
}

namespace {

// check_triangle_estimate where the spec asks for the guard.
void guard(double estimate, const SchemeSpec& spec) {
  if (spec.guard) check_triangle_estimate(estimate, spec);
}

Tessellation run_uniform(const Model& model, const Topology& topology, const SchemeSpec& spec, SchemeStats* stats) {
  UniformParams params;
  params.patch_levels = spec.patch_levels;
  params.normals = spec.vertex_normals;
  params.surface_data = spec.surface_data;
  if (spec.patch_levels.empty()) {
    if ((spec.level >= 0) == (spec.segments >= 0)) {
      throw InputError("uniform scheme: give exactly one of --level L or --segments N");
    }
    const int n = spec.level >= 0 ? segments_for_level(spec.level) : spec.segments;
    if (n < 1) throw InputError("--segments must be >= 1, got " + std::to_string(n));
    if (spec.segments_v > 0 && spec.level >= 0) throw InputError("uniform scheme: segments along v need --segments N");
    const int nv = spec.segments_v > 0 ? spec.segments_v : n;
    guard(2.0 * n * nv * static_cast<double>(model.patches.size()), spec);  // uniform_triangle_count, unwrapped
    params.segments = n;
    params.segments_v = spec.segments_v;
  } else {
    params.segments = spec.segments;  // unused with per-patch levels
  }
  if (stats) {
    stats->level = spec.level;
    stats->segments = params.segments;
  }
  return tessellate_uniform(model, topology, params);
}

Tessellation run_esc(const Model& model, const Topology& topology, const SchemeSpec& spec, SchemeStats* stats) {
  if (spec.level < 0) throw InputError("esc scheme: give --level L (L + 1 segments per coarse edge; the paper uses 3)");
  if (spec.segments >= 0) throw InputError("esc scheme: --segments does not apply; give --level L and --threshold RHO");
  EscParams params;
  params.level = spec.level;
  params.threshold = spec.threshold;
  params.per_edge_levels = spec.per_edge_levels;
  params.patch_thresholds = spec.patch_thresholds;
  params.normals = spec.vertex_normals;
  params.surface_data = spec.surface_data;
  if (spec.guard && spec.level <= kMaxEscLevel)
    check_triangle_estimate(esc_full_triangle_count(model, spec.level), spec);
  EscStats counts;
  Tessellation out = tessellate_esc(model, topology, params, &counts);
  if (stats) {
    stats->level = spec.level;
    stats->threshold = spec.threshold;
    stats->per_edge_levels = spec.per_edge_levels;
    stats->esc = counts;
  }
  return out;
}

// The pn checks and parameters, in the order the CLI checks them.
PnParams pn_params(const SchemeSpec& spec) {
  PnParams params;
  params.pattern = spec.pattern;
  params.variant = spec.pn_variant;
  if (spec.tess_factor >= 0.0) {
    if (spec.level >= 0) throw InputError("pn scheme: give --level K or --tess-factor F, not both");
    if (params.pattern != PnPatternKind::kFractionalOdd)
      throw InputError("--tess-factor needs --pattern fractional_odd");
    params.factor = spec.tess_factor;
  } else {
    if (spec.level < 1)
      throw InputError("pn scheme: give --level K >= 1 (segments per edge, or the fractional_odd factor)");
    params.factor = spec.level;
  }
  return params;
}

// PN on `input` (normals already chosen).
Tessellation run_pn(const Tessellation& input, const PnParams& params, const SchemeSpec& spec, SchemeStats* stats) {
  guard(pn_triangles_per_input(params) * input.triangles.size(), spec);
  PnStats counts;
  Tessellation out = tessellate_pn(input, params, &counts);
  if (stats) {
    stats->pattern = spec.pattern;
    stats->pn_variant = spec.pn_variant;
    stats->factor = params.factor;
    stats->normals = spec.normals;
    stats->pn = counts;
  }
  return out;
}

Tessellation run_pn_on_patches(const Model& model, const Topology& topology, const SchemeSpec& spec,
                               SchemeStats* stats) {
  if (spec.base_level < 0) {
    throw InputError("pn scheme on a patch model: give --base-level L (uniform base with 2^L segments) and --level K");
  }
  UniformParams base_params;
  base_params.segments = segments_for_level(spec.base_level);
  base_params.surface_data = spec.surface_data;
  guard(static_cast<double>(uniform_triangle_count(model, base_params.segments)), spec);
  if (stats) stats->base_level = spec.base_level;
  return tessellate_mesh(tessellate_uniform(model, topology, base_params), spec, stats);
}

}  // namespace

Tessellation tessellate(const Model& model, const Topology& topology, const SchemeSpec& spec, SchemeStats* stats) {
  if (stats) stats->scheme = spec.scheme;
  switch (spec.scheme) {
    case Scheme::kUniform:
      return run_uniform(model, topology, spec, stats);
    case Scheme::kPn:
      return run_pn_on_patches(model, topology, spec, stats);
    case Scheme::kEsc:
      return run_esc(model, topology, spec, stats);
  }
  throw InputError("unknown scheme");
}

Tessellation tessellate_mesh(const Tessellation& mesh, const SchemeSpec& spec, SchemeStats* stats) {
  if (spec.scheme != Scheme::kPn) {
    throw InputError("a mesh file can only be refined with --scheme pn (got '" + scheme_name(spec.scheme) + "')");
  }
  if (stats) stats->scheme = Scheme::kPn;
  const PnParams params = pn_params(spec);
  if (spec.normals == PnNormals::kFile) return run_pn(mesh, params, spec, stats);
  Tessellation input = mesh;
  if (spec.normals == PnNormals::kSmooth) {
    input.normals = angle_weighted_normals(input.positions, input.triangles);
  } else {
    input = split_face_normals(input);
  }
  return run_pn(input, params, spec, stats);
}

}  // namespace sagitta
