// The trade-report sweep: every scheme over its parameter on each model, each mesh certified,
// error against triangles and time, Pareto front, fitted models, a verdict per scheme.
#include "sagitta/app/report.hpp"

#include "sagitta/app/common.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/esc.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/occt/cad.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/uniform.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>

namespace sagitta::app {

std::string format_number(double x, int digits) {
  std::ostringstream s;
  s << std::setprecision(digits) << x;
  return s.str();
}

namespace {

// One parameter setting of one scheme, before it is run.
struct Setting {
  std::string scheme;  // uniform | esc | pn | occt
  std::string label;   // "level 3", "L 3, rho 0.003", ...
  nlohmann::json params;
  int level = 0;
  double value = 0.0;  // esc: rho; occt: deflection
  int base_level = 0;  // pn
};

std::vector<Setting> sweep_settings(const Model& model, bool occt) {
  const double diag = model_box(model).diagonal();
  std::vector<Setting> out;
  for (int level = 1; level <= 5; ++level) {
    out.push_back({"uniform",
                   "level " + std::to_string(level),
                   {{"level", level}, {"segments", segments_for_level(level)}},
                   level});
  }
  for (int level : {3, 7}) {
    for (double f : {0.0, 1e-3, 3e-3, 1e-2}) {
      if (level == 7 && f == 1e-2) continue;
      const double rho = f * diag;
      out.push_back({"esc",
                     "L " + std::to_string(level) + ", rho " + format_number(rho),
                     {{"level", level}, {"threshold", rho}},
                     level,
                     rho});
    }
  }
  for (int k : {1, 2, 3, 4, 6}) {
    out.push_back({"pn", "base 2, level " + std::to_string(k), {{"base_level", 2}, {"level", k}}, k, 0.0, 2});
  }
  if (occt) {
    for (double f : {1e-2, 3e-3, 1e-3, 3e-4}) {
      const double deflection = f * diag;
      out.push_back({"occt",
                     "deflection " + format_number(deflection),
                     {{"deflection", deflection}, {"angle", 0.5}},
                     0,
                     deflection});
    }
  }
  return out;
}

uint64_t estimated_triangles(const Model& model, const Setting& s) {
  if (s.scheme == "uniform") return uniform_triangle_count(model, segments_for_level(s.level));
  if (s.scheme == "esc") return esc_full_triangle_count(model, s.level);
  if (s.scheme == "pn")
    return uniform_triangle_count(model, segments_for_level(s.base_level)) * uint64_t(s.level) * s.level;
  return 0;  // occt: not known beforehand
}

// Runs one setting: tessellation (timed) and certification.
nlohmann::json run_setting(const Model& model, const Topology& topology, const Setting& s) {
  nlohmann::json point;
  point["scheme"] = s.scheme;
  point["setting"] = s.label;
  point["params"] = s.params;
  DistanceReport distance;
  uint64_t triangles = 0;
  double seconds = 0.0;
  if (s.scheme == "occt") {
    occt::PeerOptions options;
    options.deflection = s.value;
    options.certify = fit_certify_defaults();
    const occt::PeerResult peer = occt::peer_mesh_model(model, options);
    triangles = peer.triangles;
    seconds = peer.mesh_seconds;
    distance = peer.distance;
    point["route"] = peer.route;
  } else {
    // The sweep's settings are bounded by kMaxSweepTriangles, so no front end's size guard.
    SchemeSpec spec;
    spec.scheme = parse_scheme(s.scheme);
    spec.guard = false;
    spec.level = s.level;
    if (spec.scheme == Scheme::kEsc) spec.threshold = s.value;
    if (spec.scheme == Scheme::kPn) spec.base_level = s.base_level;
    // Tessellation time: the fastest of up to three runs (the first pays for thread start-up).
    Tessellation mesh;
    seconds = std::numeric_limits<double>::infinity();
    for (int run = 0; run < 3 && (run == 0 || mesh.triangles.size() < 100'000); ++run) {
      const Stopwatch clock;
      mesh = tessellate(model, topology, spec);
      seconds = std::min(seconds, clock.seconds());
    }
    triangles = mesh.triangles.size();
    distance = certify_distance(model, mesh, fit_certify_defaults());
  }
  point["triangles"] = triangles;
  point["seconds"] = seconds;
  point["certify_seconds"] = distance.seconds;
  point["certified"] = distance.hausdorff.certified;
  point["certified_error"] =
      distance.hausdorff.certified ? nlohmann::json(distance.hausdorff.upper) : nlohmann::json(nullptr);
  point["lower_bound"] = distance.hausdorff.lower;
  return point;
}

// Indices of the points no other point beats: none has <= cost and < error (or < cost and <= error).
std::vector<size_t> pareto_front(const nlohmann::json& points, const char* cost_key) {
  std::vector<size_t> front;
  for (size_t i = 0; i < points.size(); ++i) {
    if (points[i]["certified_error"].is_null()) continue;
    const double ci = points[i][cost_key].get<double>(), ei = points[i]["certified_error"].get<double>();
    bool dominated = false;
    for (size_t j = 0; j < points.size() && !dominated; ++j) {
      if (j == i || points[j]["certified_error"].is_null()) continue;
      const double cj = points[j][cost_key].get<double>(), ej = points[j]["certified_error"].get<double>();
      dominated = (cj <= ci && ej < ei) || (cj < ci && ej <= ei);
    }
    if (!dominated) front.push_back(i);
  }
  std::sort(front.begin(), front.end(),
            [&](size_t a, size_t b) { return points[a][cost_key].get<double>() < points[b][cost_key].get<double>(); });
  return front;
}

nlohmann::json fitted_json(const FittedModel& m) {
  return {{"model", "power_law"},
          {"formula", "certified_error = C * triangles^p"},
          {"C", m.parameters[0]},
          {"p", m.parameters[1]},
          {"log_residuals", m.residuals},
          {"cost", m.cost},
          {"loss", "Huber(0.1) on log(error)"}};
}

// Per-scheme fits, the triangles each needs at the reference error, and the verdicts.
// Fits the scheme's certified points (error against triangles `t`) and records in `s` the fit and the
// triangles it needs for the reference error; returns those triangles (infinity when none fits).
double fit_scheme_points(const std::string& scheme, const std::vector<double>& t, const std::vector<double>& e,
                         double reference_error, nlohmann::json& s) {
  if (scheme == "pn" && t.size() >= 3) {
    // PN converges to the PN surface of its base mesh, not to the exact surface: a floor.
    std::vector<double> x;
    for (double v : t) x.push_back(1.0 / v);
    const FittedModel m = fit_floor_plus_power(x, e);
    s["fit"] = {{"model", "floor_plus_power"},
                {"formula", "certified_error = F + C * triangles^-p"},
                {"F", m.parameters[0]},
                {"C", m.parameters[1]},
                {"p", -m.parameters[2]},
                {"log_residuals", m.residuals},
                {"cost", m.cost},
                {"loss", "Huber(0.1) on log(error)"}};
    const double xs = invert_model(m, reference_error, 1e-12, 1.0);
    const double needed = m.predict(xs) <= reference_error ? 1.0 / xs : std::numeric_limits<double>::infinity();
    s["triangles_at_reference_error"] =
        std::isfinite(needed) ? nlohmann::json(std::round(needed)) : nlohmann::json(nullptr);
    if (!std::isfinite(needed)) s["note"] = "floor " + format_number(m.parameters[0]) + " above the reference error";
    return needed;
  }
  if (t.size() >= 2 && *std::max_element(t.begin(), t.end()) > *std::min_element(t.begin(), t.end())) {
    const FittedModel m = fit_power_law(t, e);
    s["fit"] = fitted_json(m);
    // Triangles the fitted model needs for the reference error (error decreasing in triangles).
    const double p = m.parameters[1];
    const double needed =
        p < 0.0 ? std::pow(reference_error / m.parameters[0], 1.0 / p) : std::numeric_limits<double>::infinity();
    s["triangles_at_reference_error"] =
        std::isfinite(needed) ? nlohmann::json(std::round(needed)) : nlohmann::json(nullptr);
    return needed;
  }
  return std::numeric_limits<double>::infinity();
}

// The scheme's verdict line and rank against the scheme that needs the fewest triangles.
void add_verdict(const std::string& scheme, nlohmann::json& s, double reference_error, const std::string& best_scheme,
                 double best_needed) {
  std::ostringstream v;
  v << s["on_pareto_front"].get<int>() << " of " << s["points"].get<int>() << " settings on the error/triangles front, "
    << s["on_time_pareto_front"].get<int>() << " on the error/time front";
  if (s.contains("triangles_at_reference_error") && !s["triangles_at_reference_error"].is_null()) {
    const double needed = s["triangles_at_reference_error"].get<double>();
    v << "; the fit needs about " << std::llround(needed) << " triangles for error " << format_number(reference_error);
    if (scheme == best_scheme) {
      v << " - the fewest of all schemes";
      s["rank"] = "best";
    } else {
      v << " (" << format_number(needed / best_needed, 2) << "x " << best_scheme << ")";
      s["rank"] = needed <= 1.25 * best_needed ? "close" : "costly";
    }
  } else if (s.contains("note")) {
    v << "; cannot reach error " << format_number(reference_error) << " at this base level ("
      << s["note"].get<std::string>() << ")";
    s["rank"] = "floor";
  } else {
    v << "; too few certified settings to fit";
    s["rank"] = "unknown";
  }
  s["verdict"] = v.str();
}

void summarise_model(nlohmann::json& entry, double reference_error) {
  const nlohmann::json& points = entry["points"];
  const std::vector<size_t> front = pareto_front(points, "triangles");
  const std::vector<size_t> time_front = pareto_front(points, "seconds");
  entry["pareto_triangles"] = front;
  entry["pareto_time"] = time_front;
  std::map<std::string, std::vector<size_t>> by_scheme;
  for (size_t i = 0; i < points.size(); ++i) by_scheme[points[i]["scheme"].get<std::string>()].push_back(i);
  nlohmann::json schemes = nlohmann::json::object();
  double best_needed = std::numeric_limits<double>::infinity();
  std::string best_scheme;
  for (const auto& [scheme, indices] : by_scheme) {
    nlohmann::json s;
    std::vector<double> t, e;
    for (size_t i : indices) {
      if (points[i]["certified_error"].is_null() || points[i]["certified_error"].get<double>() <= 0.0) continue;
      t.push_back(points[i]["triangles"].get<double>());
      e.push_back(points[i]["certified_error"].get<double>());
    }
    s["points"] = indices.size();
    s["on_pareto_front"] = std::count_if(indices.begin(), indices.end(), [&](size_t i) {
      return std::find(front.begin(), front.end(), i) != front.end();
    });
    s["on_time_pareto_front"] = std::count_if(indices.begin(), indices.end(), [&](size_t i) {
      return std::find(time_front.begin(), time_front.end(), i) != time_front.end();
    });
    const double needed = fit_scheme_points(scheme, t, e, reference_error, s);
    if (needed < best_needed) {
      best_needed = needed;
      best_scheme = scheme;
    }
    schemes[scheme] = s;
  }
  for (auto& [scheme, s] : schemes.items()) add_verdict(scheme, s, reference_error, best_scheme, best_needed);
  entry["schemes"] = schemes;
  entry["reference_error"] = reference_error;
}

}  // namespace

nlohmann::json build_trade_report(const std::vector<NamedModel>& models, const ReportOptions& options) {
  nlohmann::json report;
  report["tool"] = "sagitta report";
  report["error"] = "certified Hausdorff upper bound between mesh and exact surface (model units)";
  report["time"] = "tessellation wall time (seconds), certification excluded";
  int total = 0, done = 0;
  std::vector<std::vector<Setting>> plans;
  for (const NamedModel& m : models) {
    plans.push_back(sweep_settings(m.model, options.occt));
    total += static_cast<int>(plans.back().size());
  }
  for (size_t k = 0; k < models.size(); ++k) {
    const Model& model = models[k].model;
    const Topology topology = build_topology(model);
    nlohmann::json entry;
    entry["name"] = models[k].name;
    entry["model"] = model.name;
    entry["patches"] = model.patches.size();
    entry["box_diagonal"] = model_box(model).diagonal();
    nlohmann::json points = nlohmann::json::array();
    nlohmann::json skipped = nlohmann::json::array();
    for (const Setting& s : plans[k]) {
      if (options.progress) options.progress(done, total, models[k].name + ": " + s.scheme + " " + s.label);
      ++done;
      if (estimated_triangles(model, s) > kMaxSweepTriangles) {
        skipped.push_back(s.scheme + " " + s.label);
        continue;
      }
      try {
        points.push_back(run_setting(model, topology, s));
      } catch (const InputError& e) {
        skipped.push_back(s.scheme + " " + s.label + ": " + e.what());
      }
    }
    entry["points"] = points;
    entry["skipped"] = skipped;
    summarise_model(entry, options.target_error > 0.0 ? options.target_error : 1e-3 * model_box(model).diagonal());
    report["models"].push_back(entry);
  }
  report["occt_version"] = options.occt ? occt::occt_version() : "";
  return report;
}

}  // namespace sagitta::app
