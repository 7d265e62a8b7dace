// Whole parts fitted to a certified target error (sagitta/app/part.hpp, fit_part).
#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"
#include "sagitta/app/part.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace sagitta::app {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The first face the certificate does not cover, as "k of n faces not certified (e.g. Face 12: why)".
std::string uncertified_faces(const PartRun& run) {
  const PartCertificate& c = run.certificate;
  const size_t n = run.part.faces.size();
  std::string text = std::to_string(n - static_cast<size_t>(c.faces_certified)) + " of " + std::to_string(n) +
                     " faces not certified";
  for (const FaceCertificate& f : c.faces) {
    if (!f.certified) return text + " (e.g. " + run.part.faces[static_cast<size_t>(f.face)].name + ": " + f.reason + ")";
  }
  return text;
}

}  // namespace

PartFit fit_part(const std::function<occt::PartMesh(const occt::PartOptions&)>& mesher, double target,
                 const CertifyOptions& certify, const std::function<void(int, int)>& progress) {
  if (!(target > 0.0) || !std::isfinite(target)) {
    throw InputError("the target error must be a positive number of model units, got " + std::to_string(target));
  }
  const Stopwatch clock;
  PartFit fit;
  fit.target = target;
  fit.edge_tolerance = 0.5 * target;
  SolidCheckOptions check_options;
  check_options.self_intersections = false;
  // One tessellate-validate-certify step at N segments; true when the certified faces meet the
  // target. The search follows the certified faces' largest upper bound (the part's when every face
  // is certified): a face that is not certified at some N (a (U, V) triangle degenerate at a coarse
  // N, a p-curve with no exact Bézier form at any N) does not stop it, but the fit is met only when
  // every face is certified.
  const auto attempt = [&](int segments, PartRun& run) {
    const Stopwatch step;
    if (progress) progress(static_cast<int>(fit.steps.size()) + 1, segments);
    SchemeSpec scheme;
    scheme.scheme = Scheme::kUniform;
    scheme.segments = segments;
    run.part = mesher(part_options(scheme, fit.edge_tolerance));
    run.validation = validate_part(run.part, check_options);
    run.certificate = certify_part(run.part, certify);
    const PartCertificate& c = run.certificate;
    const double upper = c.all_certified ? c.distance.hausdorff.upper : kInf;
    const double faces_upper = c.faces_certified > 0 ? c.certified_faces_upper : kInf;
    fit.steps.push_back({segments, run.part.mesh.triangles.size(), c.all_certified, upper, faces_upper,
                         c.distance.hausdorff.lower, step.seconds()});
    return faces_upper <= target;
  };
  const auto finish = [&](int segments, PartRun&& run) {
    fit.segments = segments;
    fit.run = std::move(run);
    fit.seconds = clock.seconds();
    if (fit.reason.empty() && !fit.run.certificate.all_certified) {
      fit.reason = "cannot be certified: " + uncertified_faces(fit.run) + "; the certified faces' largest bound " +
                   std::to_string(fit.run.certificate.certified_faces_upper) + " meets the target";
    }
    fit.met = fit.reason.empty();
    return fit;
  };
  // Doubling until met (or no face can be certified, or the cap); `lo` is the largest N known to fail.
  int lo = 0, n = 1;
  PartRun run;
  std::vector<int> previous_uncertified;
  while (true) {
    if (attempt(n, run)) break;
    if (run.certificate.faces_certified == 0) {
      fit.reason = "cannot be certified: " + uncertified_faces(run);
      return finish(n, std::move(run));
    }
    lo = n;
    // The same faces not certified at two doublings in a row: their reasons do not depend on N (a
    // p-curve with no exact Bézier form), so the fit cannot be met and doubling on would only cost
    // time.
    std::vector<int> uncertified;
    for (const FaceCertificate& f : run.certificate.faces) {
      if (!f.certified) uncertified.push_back(f.face);
    }
    if (!uncertified.empty() && uncertified == previous_uncertified) {
      fit.reason = "cannot be certified at " + std::to_string(n / 2) + " or " + std::to_string(n) +
                   " segments: " + uncertified_faces(run);
      return finish(n, std::move(run));
    }
    previous_uncertified = std::move(uncertified);
    if (n == kMaxFitSegments) {
      fit.reason = "not met at " + std::to_string(n) + " segments per patch side (certified error " +
                   std::to_string(fit.steps.back().faces_upper) +
                   (run.certificate.all_certified ? ")" : " on the certified faces; " + uncertified_faces(run) + ")");
      return finish(n, std::move(run));
    }
    n = std::min(2 * n, kMaxFitSegments);
  }
  // Bisection between lo (fails) and n (meets).
  int hi = n;
  PartRun best = std::move(run);
  while (hi - lo > 1) {
    const int mid = lo + (hi - lo) / 2;
    PartRun trial;
    if (attempt(mid, trial)) {
      hi = mid;
      best = std::move(trial);
    } else {
      lo = mid;
    }
  }
  return finish(hi, std::move(best));
}

nlohmann::json part_fit_json(const PartFit& fit) {
  nlohmann::json j;
  j["met"] = fit.met;
  j["reason"] = fit.reason;
  j["target_error"] = fit.target;
  j["scheme"] = "uniform";
  j["segments"] = fit.segments;
  j["edge_tolerance"] = fit.edge_tolerance;
  j["triangles"] = fit.run.part.mesh.triangles.size();
  j["certified"] = fit.run.certificate.all_certified;
  j["certified_error"] = number_or_null(fit.run.certificate.all_certified ? fit.run.certificate.distance.hausdorff.upper : kInf);
  j["certified_lower_bound"] = fit.run.certificate.distance.hausdorff.lower;
  j["certified_faces_error"] =
      number_or_null(fit.run.certificate.faces_certified > 0 ? fit.run.certificate.certified_faces_upper : kInf);
  nlohmann::json steps = nlohmann::json::array();
  for (const PartFit::Step& s : fit.steps) {
    steps.push_back({{"segments", s.segments},
                     {"triangles", s.triangles},
                     {"certified", s.certified},
                     {"upper", number_or_null(s.upper)},
                     {"certified_faces_upper", number_or_null(s.faces_upper)},
                     {"lower", s.lower},
                     {"seconds", s.seconds}});
  }
  j["steps"] = steps;
  j["seconds"] = fit.seconds;
  j["part"] = part_run_json(fit.run);
  return j;
}

}  // namespace sagitta::app
