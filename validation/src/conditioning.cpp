#include "conditioning.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace sagitta::detail {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Magnitudes within 2^-kSafeExponent .. 2^kSafeExponent need no rescaling: their products of
// degree 6 stay far inside double's range.
constexpr int kSafeExponent = 100;

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

// The exponent that brings a magnitude to [1, 2), or 0 when it is already in the safe range.
int rescale_exponent(double magnitude) {
  if (!(magnitude > 0.0)) return 0;
  const int e = std::ilogb(magnitude);
  return std::abs(e) > kSafeExponent ? e : 0;
}

// x * 2^-e, and whether that is exact (no rounding into the subnormal range, no overflow).
bool scale_exactly(double& x, int e) {
  if (e == 0 || x == 0.0) return true;
  const double y = std::ldexp(x, -e);
  if (!std::isfinite(y) || std::ldexp(y, e) != x || (y != 0.0 && std::abs(y) < std::numeric_limits<double>::min())) {
    return false;
  }
  x = y;
  return true;
}

bool scale_exactly(Vec3& p, int e) { return scale_exactly(p.x, e) && scale_exactly(p.y, e) && scale_exactly(p.z, e); }

double max_abs(const Vec3& p) { return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}); }

struct Plan {
  int exponent = 0;                   // coordinates are multiplied by 2^-exponent
  std::vector<int> weight_exponent;   // per patch: weights multiplied by 2^-e
  bool identity = true;
  std::string reason;                 // non-empty: the arithmetic cannot be made safe
};

Plan make_plan(const Model& model, const std::vector<Vec3>& points) {
  Plan plan;
  double magnitude = 0.0;
  for (const Vec3& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      plan.reason = "the mesh has a vertex with a coordinate that is not a finite number";
      return plan;
    }
    magnitude = std::max(magnitude, max_abs(p));
  }
  plan.weight_exponent.assign(model.patches.size(), 0);
  for (size_t i = 0; i < model.patches.size(); ++i) {
    const BezierPatch& patch = model.patches[i];
    for (const Vec3& p : patch.points) magnitude = std::max(magnitude, max_abs(p));
    if (!patch.rational()) continue;
    const auto [lo, hi] = std::minmax_element(patch.weights.begin(), patch.weights.end());
    if (!(*lo > 0.0) || *hi / *lo > kMaxWeightSpan || !std::isfinite(*hi / *lo)) {
      plan.reason = "patch " + std::to_string(i) + "'s weights span a factor of " + number(*hi / *lo) +
                    " (largest / smallest), more than the 1e60 the certified bounds can carry without underflow";
      return plan;
    }
    plan.weight_exponent[i] = rescale_exponent(*hi);
    if (plan.weight_exponent[i] != 0) plan.identity = false;
  }
  plan.exponent = rescale_exponent(magnitude);
  if (plan.exponent != 0) plan.identity = false;
  // The smallest non-zero coordinate, once rescaled, must stay above 2^-200: fourth powers of the
  // coordinates' differences (squared normals of CGAL's closest-point projections, ~1e-81 against
  // 1 in a fuzzed mesh) would underflow, and the projections turn into NaN.
  double smallest = std::numeric_limits<double>::max();
  const auto visit = [&](const Vec3& p) {
    for (double c : {p.x, p.y, p.z}) {
      if (c != 0.0) smallest = std::min(smallest, std::abs(c));
    }
  };
  for (const Vec3& p : points) visit(p);
  for (const BezierPatch& patch : model.patches) {
    for (const Vec3& p : patch.points) visit(p);
  }
  if (smallest != std::numeric_limits<double>::max() && std::ldexp(smallest, -plan.exponent) < std::ldexp(1.0, -200)) {
    plan.reason = "the coordinates span too many orders of magnitude (largest " + number(magnitude) +
                  ", smallest non-zero " + number(smallest) + ") for the certified arithmetic";
  }
  return plan;
}

const char* kInexact = "the coordinates span too many orders of magnitude to be rescaled exactly into the range where "
                       "the certified arithmetic holds";

// The model rescaled by the plan; false (with the plan's reason set) when a value would round.
bool rescale(const Model& model, Plan& plan, Model& out) {
  out.name = model.name;
  out.patches = model.patches;
  for (size_t i = 0; i < out.patches.size(); ++i) {
    BezierPatch& patch = out.patches[i];
    for (Vec3& p : patch.points) {
      if (!scale_exactly(p, plan.exponent)) {
        plan.reason = kInexact;
        return false;
      }
    }
    for (double& w : patch.weights) {
      if (!scale_exactly(w, plan.weight_exponent[i])) {
        plan.reason = std::string("patch ") + std::to_string(i) + "'s weights cannot be rescaled exactly";
        return false;
      }
    }
  }
  return true;
}

void scale_back(DistanceInterval& d, int e) {
  d.lower = std::min(std::ldexp(d.lower, e), std::numeric_limits<double>::max());
  d.upper = std::ldexp(d.upper, e);
  d.witness = Vec3(std::ldexp(d.witness.x, e), std::ldexp(d.witness.y, e), std::ldexp(d.witness.z, e));
}

DistanceReport not_certified(size_t triangles, const std::string& reason) {
  DistanceReport report;
  report.triangle_upper.assign(triangles, kInf);
  report.not_certified_reason = reason;
  return report;
}

void check_direction(DistanceInterval& d, const char* name, std::string& reason) {
  if (!(d.lower >= 0.0)) d.lower = 0.0;  // NaN or negative: 0 is always a lower bound
  std::string why;
  if (std::isnan(d.upper)) {
    why = std::string(name) + " upper bound is not a number";
  } else if (d.certified && !std::isfinite(d.upper)) {
    why = std::string(name) + " upper bound is not finite";
  } else if (d.upper < d.lower) {
    why = std::string("internal check failed: the ") + name + " upper bound " + number(d.upper) +
          " is below its certified lower bound " + number(d.lower);
  }
  if (!why.empty()) {
    d.upper = kInf;
    d.certified = false;
    if (reason.empty()) reason = why;
  }
  if (!d.certified) d.upper = kInf;
}

}  // namespace

void check_report(DistanceReport& report) {
  for (double& t : report.triangle_upper) {
    if (std::isnan(t)) {
      t = kInf;
      report.mesh_to_surface.certified = false;
      report.surface_to_mesh.certified = false;
      if (report.not_certified_reason.empty()) report.not_certified_reason = "a triangle's bound is not a number";
    }
  }
  check_direction(report.mesh_to_surface, "mesh->surface", report.not_certified_reason);
  check_direction(report.surface_to_mesh, "surface->mesh", report.not_certified_reason);
  DistanceInterval& h = report.hausdorff;
  const DistanceInterval& winner =
      report.mesh_to_surface.lower >= report.surface_to_mesh.lower ? report.mesh_to_surface : report.surface_to_mesh;
  h.lower = winner.lower;
  h.witness = winner.witness;
  h.witness_patch = winner.witness_patch;
  h.certified = report.mesh_to_surface.certified && report.surface_to_mesh.certified;
  h.upper = h.certified ? std::max(report.mesh_to_surface.upper, report.surface_to_mesh.upper) : kInf;
}

DistanceReport with_safe_arithmetic(const Model& model, const Tessellation& mesh,
                                    const std::function<DistanceReport(const Model&, const Tessellation&)>& certify) {
  Plan plan = make_plan(model, mesh.positions);
  if (!plan.reason.empty()) return not_certified(mesh.triangles.size(), plan.reason);
  DistanceReport report;
  if (plan.identity) {
    report = certify(model, mesh);
  } else {
    Model scaled;
    if (!rescale(model, plan, scaled)) return not_certified(mesh.triangles.size(), plan.reason);
    Tessellation scaled_mesh = mesh;
    for (Vec3& p : scaled_mesh.positions) {
      if (!scale_exactly(p, plan.exponent)) return not_certified(mesh.triangles.size(), kInexact);
    }
    report = certify(scaled, scaled_mesh);
    const int e = plan.exponent;
    for (DistanceInterval* d : {&report.mesh_to_surface, &report.surface_to_mesh, &report.hausdorff}) scale_back(*d, e);
    for (double& t : report.triangle_upper) t = std::ldexp(t, e);
    report.rounding = std::ldexp(report.rounding, e);
    report.surface_to_mesh_over_triangles = std::ldexp(report.surface_to_mesh_over_triangles, e);
  }
  check_report(report);
  return report;
}

double lower_with_safe_arithmetic(const Model& model, const Vec3& x,
                                  const std::function<double(const Model&, const Vec3&, double)>& lower) {
  Plan plan = make_plan(model, {x});
  if (!plan.reason.empty()) return 0.0;
  if (plan.identity) {
    const double d = lower(model, x, 1.0);
    return d >= 0.0 ? d : 0.0;
  }
  Model scaled;
  Vec3 y = x;
  if (!rescale(model, plan, scaled) || !scale_exactly(y, plan.exponent)) return 0.0;
  const double d = std::min(std::ldexp(lower(scaled, y, std::ldexp(1.0, -plan.exponent)), plan.exponent), std::numeric_limits<double>::max());
  return d >= 0.0 ? d : 0.0;
}

}  // namespace sagitta::detail

namespace sagitta {

void check_distance_report(DistanceReport& report) { detail::check_report(report); }

}  // namespace sagitta
