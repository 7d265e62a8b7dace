#include "schemes.hpp"

#include "sagitta/uniform.hpp"

#include <cmath>
#include <sstream>

namespace sagitta::cli {

std::vector<std::string> scheme_names() { return {"uniform"}; }

void add_scheme_options(CLI::App* command, SchemeOptions& o) {
  command->add_option("--scheme", o.scheme, "Tessellation scheme")->check(CLI::IsMember(scheme_names()))->capture_default_str();
  command->add_option("--level", o.level,
                      "uniform: 2^L segments per patch side (levels nest), 0.." + std::to_string(kMaxUniformLevel));
  command->add_option("--segments", o.segments, "uniform: N >= 1 segments per patch side (the seed's level l is N = 2^(l+1) - 1)");
  command->add_option("--max-triangles", o.max_triangles,
                      "Refuse to tessellate when the estimated triangle count exceeds this (protects memory)")
      ->capture_default_str();
}

namespace {

void check_size(uint64_t estimate, const SchemeOptions& o) {
  if (estimate > o.max_triangles) {
    std::ostringstream s;
    s << "this would make " << estimate << " triangles (about " << std::ceil(estimate * 64.0 / (1 << 30))
      << " GiB), more than --max-triangles " << o.max_triangles << "; lower the level or raise --max-triangles";
    throw InputError(s.str());
  }
}

}  // namespace

Tessellation run_scheme(const Model& model, const Topology& topology, const SchemeOptions& o, nlohmann::json& stats) {
  stats["scheme"] = o.scheme;
  if (o.scheme == "uniform") {
    if ((o.level >= 0) == (o.segments >= 0)) throw InputError("uniform scheme: give exactly one of --level L or --segments N");
    const int n = o.level >= 0 ? segments_for_level(o.level) : o.segments;
    if (n < 1) throw InputError("--segments must be >= 1, got " + std::to_string(n));
    check_size(uniform_triangle_count(model, n), o);
    if (o.level >= 0) stats["level"] = o.level;
    stats["segments"] = n;
    UniformParams params;
    params.segments = n;
    params.surface_data = o.surface_data;
    return tessellate_uniform(model, topology, params);
  }
  throw InputError("unknown scheme '" + o.scheme + "'");
}

}  // namespace sagitta::cli
