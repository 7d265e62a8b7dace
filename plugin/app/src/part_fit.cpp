// Whole parts fitted to a certified target error (sagitta/app/part.hpp, fit_part).
#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"
#include "sagitta/app/part.hpp"
#include "sagitta/app/report.hpp"

#include <algorithm>
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

// Per face (by index): the faces that share a mesh vertex with it (an edge or a B-rep vertex).
std::vector<std::vector<int>> face_neighbours(const occt::PartMesh& part) {
  std::vector<std::vector<int>> by_vertex(part.mesh.positions.size());
  for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
    const int face = static_cast<int>(part.triangle_face[t]);
    for (uint32_t v : part.mesh.triangles[t]) {
      std::vector<int>& faces = by_vertex[v];
      if (std::find(faces.begin(), faces.end(), face) == faces.end()) faces.push_back(face);
    }
  }
  std::vector<std::vector<int>> neighbours(part.faces.size());
  for (const std::vector<int>& faces : by_vertex) {
    for (int a : faces) {
      for (int b : faces) {
        if (a != b) neighbours[static_cast<size_t>(a)].push_back(b);
      }
    }
  }
  for (std::vector<int>& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return neighbours;
}

// The ratio limit of face f (trimmed or not).
double ratio_limit(const PartRun& run, size_t face) {
  return run.part.faces[face].trimmed ? kFitRatioTrimmed : kFitRatioUntrimmed;
}

// face_over_ratio_limit with the exactness threshold (1e-9 of the part's size) already computed.
bool over_limit(const PartRun& run, size_t face, double exact) {
  const FaceCertificate& c = run.certificate.faces[face];
  return c.certified && c.upper > exact && c.upper > ratio_limit(run, face) * c.hausdorff.lower;
}

double exact_threshold(const PartRun& run) { return 1e-9 * model_box(run.part.model).diagonal(); }

}  // namespace

bool face_over_ratio_limit(const PartRun& run, size_t face) { return over_limit(run, face, exact_threshold(run)); }

int faces_over_ratio_limits(const PartRun& run) {
  const double exact = exact_threshold(run);
  int over = 0;
  for (size_t f = 0; f < run.certificate.faces.size(); ++f) over += over_limit(run, f, exact) ? 1 : 0;
  return over;
}

PartFit fit_part(const std::function<occt::PartMesh(const occt::PartOptions&)>& mesher, double target,
                 const CertifyOptions& certify, const std::function<void(int, int)>& progress, bool tighten) {
  if (!(target > 0.0) || !std::isfinite(target)) {
    throw InputError("the target error must be a positive number of model units, got " + std::to_string(target));
  }
  const Stopwatch clock;
  PartFit fit;
  fit.target = target;
  fit.edge_tolerance = 0.5 * target;
  SolidCheckOptions check_options;
  check_options.self_intersections = false;
  // One tessellate-validate-certify step: N segments on every face (face_segments empty), or each
  // face its own. True when the certified faces meet the target. The search follows the certified
  // faces' largest upper bound (the part's when every face is certified): a face that is not
  // certified at some N (a (U, V) triangle degenerate at a coarse N, a p-curve with no exact Bézier
  // form at any N) does not stop it, but the fit is met only when every face is certified.
  const auto attempt = [&](int segments, const std::vector<int>& face_segments, PartRun& run,
                           double edge_tolerance = 0.0, const std::vector<double>& face_edge_tolerance = {},
                           const std::vector<double>& face_graded = {}) {
    const Stopwatch step;
    if (progress) progress(static_cast<int>(fit.steps.size()) + 1, segments);
    SchemeSpec scheme;
    scheme.scheme = Scheme::kUniform;
    scheme.segments = segments;
    if (!(edge_tolerance > 0.0)) edge_tolerance = fit.edge_tolerance;
    occt::PartOptions options = part_options(scheme, edge_tolerance);
    options.face_segments = face_segments;
    options.face_edge_tolerance = face_edge_tolerance;
    options.face_graded_segments = face_graded;
    run.part = mesher(options);
    run.validation = validate_part(run.part, check_options);
    run.certificate = certify_part(run.part, certify);
    const PartCertificate& c = run.certificate;
    const double upper = c.all_certified ? c.distance.hausdorff.upper : kInf;
    const double faces_upper = c.faces_certified > 0 ? c.certified_faces_upper : kInf;
    fit.steps.push_back({segments, run.part.mesh.triangles.size(), c.all_certified, upper, faces_upper,
                         c.distance.hausdorff.lower, step.seconds(), !face_segments.empty(), edge_tolerance});
    return faces_upper <= target;
  };
  // Face f of a run meets the target on its own: certified with an upper bound <= target.
  const auto face_meets = [&](const PartRun& run, size_t f) {
    const FaceCertificate& c = run.certificate.faces[f];
    return c.certified && c.upper <= target;
  };
  const auto all_meet = [&](const PartRun& run) {
    return run.certificate.all_certified && run.certificate.distance.hausdorff.upper <= target;
  };
  const auto finish = [&](int segments, std::vector<int> face_segments, PartRun&& run) {
    fit.segments = segments;
    fit.face_segments = std::move(face_segments);
    fit.run = std::move(run);
    fit.seconds = clock.seconds();
    if (fit.reason.empty() && !fit.run.certificate.all_certified) {
      fit.reason = "cannot be certified: " + uncertified_faces(fit.run) + "; the certified faces' largest bound " +
                   std::to_string(fit.run.certificate.certified_faces_upper) + " meets the target";
    }
    fit.met = fit.reason.empty();
    return fit;
  };
  // 1. Doubling one N for every face until the part meets the target, or every face has met it at
  //    some N (or no face can be certified, or the cap). Per face: lo, the largest N known to fail,
  //    and hi, the smallest N known to meet (0: none yet).
  std::vector<int> lo, hi;
  // A face that misses because of its slivers (the sliver term is over a quarter of its bound and
  // its triangles alone are within 0.9 E) keeps its N and gets a tighter edge tolerance instead,
  // scaled by how much the sliver term must shrink (up to 3 times; tried in the next run): a finer
  // grid would not move the chords, and finer edges cost fewer triangles.
  std::vector<double> tolerance;  // per face edge tolerance (0: the part's)
  std::vector<int> tightened;
  const auto tighten_edges = [&](const PartRun& r, size_t f) {
    const FaceCertificate& c = r.certificate.faces[f];
    if (!c.certified || !(c.sliver > 0.0) || tightened[f] >= 3) return false;
    const double own = c.upper - c.sliver;
    if (!(own < 0.9 * target) || c.sliver < 0.25 * c.upper) return false;
    const double factor = std::clamp((0.9 * target - own) / c.sliver, 0.1, 0.9);
    // Only where finer edges are the cheaper remedy: a chord's error goes with the square of its
    // length, so the face's boundary vertices grow by 1 / sqrt(factor), each adding about a
    // triangle on either side of its edge; raising N by half (what a miss otherwise costs) grows
    // the face's triangles by 1.5x per direction that has more than one cell per span.
    const occt::PartFace& face = r.part.faces[f];
    const double boundary = static_cast<double>(face.boundary_vertices);
    const double finer_edges = 2.0 * boundary * (1.0 / std::sqrt(factor) - 1.0);
    const int n = std::max(1, face.segments), raised = n + std::max(1, n / 2);
    const double growth = static_cast<double>(raised) / n;
    const bool one_way = face.graded_u == 0 && std::min(face.segments_u, face.segments_v) <= 1;
    const double finer_grid = static_cast<double>(face.triangles) * ((one_way ? growth : growth * growth) - 1.0);
    if (!(finer_edges < finer_grid)) return false;
    const double now = tolerance[f] > 0.0 ? tolerance[f] : fit.edge_tolerance;
    tolerance[f] = now * factor;
    ++tightened[f];
    return true;
  };
  int n = 1;
  PartRun run;
  std::vector<int> previous_uncertified;
  std::vector<double> stuck_lower;  // per face: its lower bound at the last N where it and its edges' offset exceeded E
  bool met = false;
  while (true) {
    met = attempt(n, {}, run, 0.0, tolerance);
    const size_t faces = run.certificate.faces.size();
    lo.resize(faces, 0), hi.resize(faces, 0), tolerance.resize(faces, 0.0), tightened.resize(faces, 0);
    for (size_t f = 0; f < faces; ++f) {
      if (hi[f] > 0) continue;
      if (face_meets(run, f) || tighten_edges(run, f)) {
        hi[f] = n;
      } else {
        lo[f] = n;
      }
    }
    // Met on the certified faces only: the others may be certified at a finer N (a coarse grid's
    // loops crossing themselves in (U, V)); the rule below stops when the same faces fail twice.
    if (met && run.certificate.all_certified) break;
    // No face certified for reasons a finer mesh cannot change. A face whose triangles did not tile
    // its domain may tile it at a finer N (a doubly periodic B-spline torus at 1 segment per side:
    // its 3D corners are one vertex), so the doubling goes on for it.
    const bool finer_may_certify =
        std::any_of(run.certificate.faces.begin(), run.certificate.faces.end(),
                    [](const FaceCertificate& f) { return !f.certified && f.mesh_dependent; });
    if (run.certificate.faces_certified == 0 && !finer_may_certify) {
      fit.reason = "cannot be certified: " + uncertified_faces(run);
      return finish(n, {}, std::move(run));
    }
    // A face proven farther from its mesh than the target at two doublings in a row, its lower bound
    // no lower than 0.9 of the last one, while its B-rep edges lie farther than the target from its
    // surface: the mesh's boundary vertices sit on those edges at every density, so doubling on
    // would not meet the target (a shelled solid whose inner face kept its edges 2 mm away).
    stuck_lower.resize(run.certificate.faces.size(), -1.0);
    for (const FaceCertificate& c : run.certificate.faces) {
      const occt::PartFace& face = run.part.faces[static_cast<size_t>(c.face)];
      double& last = stuck_lower[static_cast<size_t>(c.face)];
      const bool above = c.hausdorff.lower > target && face.max_boundary_offset > target;
      const bool stuck = above && last > 0.0 && c.hausdorff.lower >= 0.9 * last;
      last = above ? c.hausdorff.lower : -1.0;
      if (stuck) {
        fit.reason = "cannot be met with this B-rep: " + face.name + "'s edges lie up to " +
                     format_number(face.max_boundary_offset, 6) + " from its surface (its certified lower bound " +
                     format_number(c.hausdorff.lower, 6) + "), above the target";
        return finish(n, {}, std::move(run));
      }
    }
    if (std::all_of(hi.begin(), hi.end(), [](int h) { return h > 0; })) break;
    // The same faces not certified at two doublings in a row: their reasons do not depend on N (a
    // p-curve with no exact Bézier form), so the fit cannot be met and doubling on would only cost
    // time. Faces whose mesh did not tile their domain are left out: a finer grid may tile it (a
    // helical sweep's coarse rows beside its densely sampled seam); the cap ends those.
    std::vector<int> uncertified;
    for (const FaceCertificate& f : run.certificate.faces) {
      if (!f.certified && !f.mesh_dependent) uncertified.push_back(f.face);
    }
    if (!uncertified.empty() && uncertified == previous_uncertified) {
      fit.reason = "cannot be certified at " + std::to_string(n / 2) + " or " + std::to_string(n) +
                   " segments: " + uncertified_faces(run);
      return finish(n, {}, std::move(run));
    }
    previous_uncertified = std::move(uncertified);
    if (n == kMaxFitSegments) {
      fit.reason = "not met at " + std::to_string(n) + " segments per patch side (certified error " +
                   std::to_string(fit.steps.back().faces_upper) +
                   (run.certificate.all_certified ? ")" : " on the certified faces; " + uncertified_faces(run) + ")");
      return finish(n, {}, std::move(run));
    }
    n = std::min(2 * n, kMaxFitSegments);
  }
  // Met on the certified faces only, and some face was never certified: the fit cannot be met.
  if (met && std::find(hi.begin(), hi.end(), 0) != hi.end()) return finish(n, {}, std::move(run));
  // The best run that meets the target on every face (fewest triangles); the uniform one if it met.
  const bool uniform_met = all_meet(run);
  PartRun best;
  std::vector<int> best_segments;
  std::vector<double> best_tolerance, best_graded;
  int best_n = n;
  const std::vector<std::vector<int>> neighbours = face_neighbours(run.part);
  if (uniform_met) best = std::move(run), best_tolerance = tolerance;
  const auto keep_if_better = [&](PartRun& trial, const std::vector<int>& segments,
                                  const std::vector<double>& tolerances, const std::vector<double>& graded = {}) {
    if (!all_meet(trial)) return;
    if (!best.part.faces.empty() && best.part.mesh.triangles.size() <= trial.part.mesh.triangles.size()) return;
    best = std::move(trial);
    best_segments = segments;
    best_tolerance = tolerances;
    best_graded = graded;
    if (!segments.empty()) best_n = *std::max_element(segments.begin(), segments.end());
  };
  // 2. Each face its own density. Every face's N is bisected between its lo and hi, all faces at
  //    once, one whole-part run per round; only runs in which every face meets are kept. Faces share
  //    their edges' samples, and an edge owned by an untrimmed neighbour takes that neighbour's scheme
  //    vertices: a face kept at its hi can miss once its neighbours are coarser (a trimmed sphere's
  //    chords through its re-parametrisation). Such a face is first raised itself by half its N
  //    (often its own grid is just short; up to twice while that lowers its bound); then its
  //    neighbours get at least its N, and when they already have it, the face itself is doubled.
  //    A face that misses because of its slivers keeps its N with finer edges (tighten_edges).
  std::vector<int> at_least(hi.size(), 0);  // per face: the N its neighbours' misses asked for
  std::vector<int> self_raised(hi.size(), 0);
  std::vector<double> raised_from(hi.size(), -1.0);  // per face: its bound when last raised itself
  std::vector<int> segments(hi.begin(), hi.end());
  bool tightening = false;  // the last round tightened some face's edges: its trial is new
  for (int step = 0; step < 16; ++step) {
    std::vector<int> trial = segments;
    bool bisecting = false;
    for (size_t f = 0; f < trial.size(); ++f) {
      if (hi[f] - lo[f] > 1) trial[f] = lo[f] + (hi[f] - lo[f]) / 2, bisecting = true;
    }
    if (!bisecting && !tightening && step > 0 && trial == best_segments) break;
    // Every face at the uniform run's N: that run is already known.
    if (!bisecting && !tightening && uniform_met &&
        std::all_of(trial.begin(), trial.end(), [&](int t) { return t == n; }))
      break;
    PartRun per_face;
    attempt(*std::max_element(trial.begin(), trial.end()), trial, per_face, 0.0, tolerance);
    bool all = true;
    tightening = false;
    for (size_t f = 0; f < trial.size(); ++f) {
      const bool meets = face_meets(per_face, f);
      all = all && meets;
      if (!meets && tighten_edges(per_face, f)) {  // this N with finer edges: tried next round
        hi[f] = trial[f];
        tightening = true;
        continue;
      }
      if (trial[f] != hi[f]) {  // bisected
        (meets ? hi[f] : lo[f]) = trial[f];
        continue;
      }
      if (meets) continue;
      // Kept at hi and missed: first itself by half (up to twice). Where that moved its bound by
      // less than 5 %, its error comes from its boundary (the neighbours' samples): its neighbours
      // get its N, and where they have it, itself is doubled.
      const FaceCertificate& fc = per_face.certificate.faces[f];
      const double upper = fc.certified ? fc.upper : kInf;
      const bool own_grid_helps = raised_from[f] < 0.0 || upper < 0.95 * raised_from[f];
      if (own_grid_helps && self_raised[f] < 2) {
        ++self_raised[f];
        raised_from[f] = upper;
        lo[f] = hi[f];
        hi[f] = std::min(hi[f] + std::max(1, hi[f] / 2), kMaxFitSegments);
        continue;
      }
      bool raised = false;
      for (int g : neighbours[f]) {
        if (at_least[static_cast<size_t>(g)] < trial[f]) at_least[static_cast<size_t>(g)] = trial[f], raised = true;
      }
      if (!raised) {
        lo[f] = hi[f];
        hi[f] = std::min(2 * hi[f], kMaxFitSegments);
      }
    }
    // No bisection below at_least.
    for (size_t g = 0; g < hi.size(); ++g) {
      hi[g] = std::max(hi[g], at_least[g]);
      lo[g] = std::max(lo[g], at_least[g] - 1);
    }
    keep_if_better(per_face, trial, tolerance);
    segments = hi;
    if (!bisecting && all) break;
    if (!bisecting && !tightening && segments == trial) break;  // nothing left to change (faces at the cap)
  }
  if (!best.part.faces.empty()) {
    // 2b. Graded faces between two integer N: a graded grid's cells follow its N continuously
    //     (occt::PartOptions::face_graded_segments), so a face that misses at N - 1 and meets at N
    //     with room to spare (bug24595's fillets: 0.107 at N = 2 against E = 0.150) is bisected
    //     over real N in (N - 1, N] (in (N / 2, N] when N - 1 was never tried), all such faces at
    //     once, three rounds; the whole-part runs in which every face meets are kept as in step 2.
    {
      const size_t faces = best.part.faces.size();
      std::vector<int> grid = best_segments;
      if (grid.empty()) grid.assign(faces, best_n);
      std::vector<double> lo_real(faces, 0.0), hi_real(faces, 0.0);
      bool any = false;
      for (size_t f = 0; f < faces; ++f) {
        if (best.part.faces[f].graded_u <= 0 || grid[f] < 1) continue;
        hi_real[f] = grid[f];
        lo_real[f] = f < lo.size() && lo[f] >= 1 && lo[f] < grid[f] ? lo[f] : 0.5 * grid[f];
        any = true;
      }
      std::vector<double> tried;
      for (int round = 0; any && round < 4; ++round) {
        // Rounds 0-2 bisect; round 3 runs every face at its smallest real N known to meet.
        std::vector<double> trial(faces, 0.0);
        for (size_t f = 0; f < faces; ++f) {
          if (hi_real[f] > 0.0) trial[f] = round < 3 ? 0.5 * (lo_real[f] + hi_real[f]) : hi_real[f];
        }
        if (trial == tried || trial == best_graded) break;
        tried = trial;
        PartRun graded;
        attempt(best_n, grid, graded, 0.0, best_tolerance, trial);
        for (size_t f = 0; f < faces && round < 3; ++f) {
          if (hi_real[f] > 0.0) (face_meets(graded, f) ? hi_real[f] : lo_real[f]) = trial[f];
        }
        keep_if_better(graded, grid, best_tolerance, trial);
      }
    }
    // 3. Coarser edges: the edge chord tolerance E / 2 is conservative (its chords are checked at
    //    quarter points, the certificate measures the rest); with up to 2E the same face densities may
    //    still meet the target with fewer edge samples. The coarsest tolerance that meets is kept.
    for (double factor : {2.0, 1.4, 1.0, 0.75}) {
      PartRun coarser;
      const std::vector<int> face_segments = best_segments;
      const std::vector<double> graded = best_graded;
      attempt(best_n, face_segments, coarser, factor * target, best_tolerance, graded);
      if (!all_meet(coarser)) continue;
      const bool fewer = coarser.part.mesh.triangles.size() < best.part.mesh.triangles.size();
      keep_if_better(coarser, face_segments, best_tolerance, graded);
      if (fewer) fit.edge_tolerance = factor * target;
      break;
    }
    // 4. Tightness: a face whose interval is wider than the ratio limits because of the slivers
    //    between its trimming curves and their chords (the certificate adds the sliver term to the
    //    triangles' bound, docs/VALIDATION.md) gets a tighter edge tolerance, scaled by how much the
    //    sliver term must shrink (it follows the chords' deviation, which follows the tolerance); one
    //    whose triangles' own bound is too wide gets a finer grid (N + max(1, N / 2): long coarse
    //    triangles bound loosely). Up to 6 rounds, each from the last, while the target is met (a
    //    round that misses puts the missing faces back and runs again); the run with the fewest
    //    faces over the limits is kept.
    const double exact = exact_threshold(best);  // every run meshes the same part
    std::vector<double> face_tolerance = best_tolerance, current_tolerance = best_tolerance;
    std::vector<int> face_grid = best_segments, current_grid = best_segments;
    if (current_grid.empty()) current_grid.assign(best.certificate.faces.size(), best_n);
    std::vector<double> face_graded = best_graded, current_graded = best_graded;
    current_graded.resize(best.certificate.faces.size(), 0.0);
    PartRun current = best;
    std::vector<double> trial_tolerance, trial_graded;
    std::vector<int> trial_grid;
    bool pending = false;  // a trial with some faces' changes undone, to run as it is
    for (int round = 0; tighten && round < 6 && faces_over_ratio_limits(best) > 0; ++round) {
      if (!pending) {
        trial_tolerance = current_tolerance;
        trial_tolerance.resize(current.certificate.faces.size(), 0.0);
        trial_grid = current_grid;
        trial_graded = current_graded;
        bool changed = false;
        for (size_t f = 0; f < current.certificate.faces.size(); ++f) {
          if (!over_limit(current, f, exact)) continue;
          const FaceCertificate& c = current.certificate.faces[f];
          const double sliver_goal = 0.9 * ratio_limit(current, f) * c.hausdorff.lower - (c.upper - c.sliver);
          if (c.sliver > 0.0 && sliver_goal > 0.0) {
            const double now = trial_tolerance[f] > 0.0 ? trial_tolerance[f] : fit.edge_tolerance;
            trial_tolerance[f] = now * std::clamp(sliver_goal / c.sliver, 0.1, 0.9);
          } else {  // the triangles' own bound is too wide: not the slivers
            trial_grid[f] = std::min(trial_grid[f] + std::max(1, trial_grid[f] / 2), kMaxFitSegments);
            trial_graded[f] = 0.0;  // the raised integer N
          }
          changed = true;
        }
        if (!changed) break;
      }
      pending = false;
      PartRun tighter;
      attempt(*std::max_element(trial_grid.begin(), trial_grid.end()), trial_grid, tighter, fit.edge_tolerance,
              trial_tolerance, trial_graded);
      if (!all_meet(tighter)) {
        // The faces that now miss the target go back to their last values (or, where a face missed
        // unchanged, its changed neighbours: their edges are its edges), and the rest is tried again.
        current_tolerance.resize(trial_tolerance.size(), 0.0);
        const auto revert = [&](size_t f) {
          if (trial_tolerance[f] == current_tolerance[f] && trial_grid[f] == current_grid[f] &&
              trial_graded[f] == current_graded[f])
            return false;
          trial_tolerance[f] = current_tolerance[f];
          trial_grid[f] = current_grid[f];
          trial_graded[f] = current_graded[f];
          return true;
        };
        for (size_t f = 0; f < trial_grid.size(); ++f) {
          if (face_meets(tighter, f)) continue;
          if (revert(f)) {
            pending = true;
            continue;
          }
          for (int g : neighbours[f]) pending = revert(static_cast<size_t>(g)) || pending;
        }
        if (!pending) break;
        continue;
      }
      current = std::move(tighter);
      current_tolerance = trial_tolerance;
      current_grid = trial_grid;
      current_graded = trial_graded;
      if (faces_over_ratio_limits(current) < faces_over_ratio_limits(best)) {
        best = current;
        face_tolerance = current_tolerance;
        face_grid = current_grid;
        face_graded = current_graded;
      }
    }
    if (face_grid != best_segments && !face_grid.empty()) {
      best_segments = face_grid;
      best_n = *std::max_element(face_grid.begin(), face_grid.end());
    }
    if (std::any_of(face_tolerance.begin(), face_tolerance.end(), [](double t) { return t > 0.0; }))
      fit.face_edge_tolerance = face_tolerance;
    if (std::any_of(face_graded.begin(), face_graded.end(), [](double t) { return t > 0.0; }))
      fit.face_graded_segments = face_graded;
    return finish(best_n, best_segments, std::move(best));
  }
  // No per-face run met every face and the uniform run did not either: the uniform doubling goes on.
  while (n < kMaxFitSegments) {
    n = std::min(2 * n, kMaxFitSegments);
    if (attempt(n, {}, run) && run.certificate.all_certified) return finish(n, {}, std::move(run));
  }
  fit.reason = "not met at " + std::to_string(n) + " segments per patch side (certified error " +
               std::to_string(fit.steps.back().faces_upper) + ")";
  return finish(n, {}, std::move(run));
}

nlohmann::json faces_over_ratio_limits_json(const PartRun& run) {
  const double exact = exact_threshold(run);
  std::vector<size_t> over;
  for (size_t f = 0; f < run.certificate.faces.size(); ++f) {
    if (over_limit(run, f, exact)) over.push_back(f);
  }
  const auto ratio = [&](size_t f) {
    const FaceCertificate& c = run.certificate.faces[f];
    return c.hausdorff.lower > 0.0 ? c.upper / c.hausdorff.lower : kInf;
  };
  std::stable_sort(over.begin(), over.end(), [&](size_t a, size_t b) { return ratio(a) > ratio(b); });
  nlohmann::json list = nlohmann::json::array();
  for (const size_t f : over) {
    const occt::PartFace& face = run.part.faces[f];
    const FaceCertificate& c = run.certificate.faces[f];
    list.push_back({{"face", face.name},
                    {"surface", face.surface_type},
                    {"trimmed", face.trimmed},
                    {"lower", c.hausdorff.lower},
                    {"upper", c.upper},
                    {"ratio", number_or_null(ratio(f))}});
  }
  return list;
}

nlohmann::json part_fit_summary(const PartFit& fit) {
  nlohmann::json j = part_fit_json(fit);
  j.erase("part");
  j["steps"] = fit.steps.size();
  j["faces"] = fit.run.part.faces.size();
  j["faces_over_ratio_limits"] = faces_over_ratio_limits(fit.run);
  return j;
}

nlohmann::json part_fit_json(const PartFit& fit) {
  nlohmann::json j;
  j["met"] = fit.met;
  j["reason"] = fit.reason;
  j["target_error"] = fit.target;
  j["scheme"] = "uniform";
  j["segments"] = fit.segments;
  if (!fit.face_segments.empty()) j["face_segments"] = fit.face_segments;
  if (!fit.face_graded_segments.empty()) j["face_graded_segments"] = fit.face_graded_segments;
  j["edge_tolerance"] = fit.edge_tolerance;
  if (!fit.face_edge_tolerance.empty()) j["face_edge_tolerance"] = fit.face_edge_tolerance;
  j["triangles"] = fit.run.part.mesh.triangles.size();
  j["certified"] = fit.run.certificate.all_certified;
  j["certified_error"] = number_or_null(fit.run.certificate.all_certified ? fit.run.certificate.distance.hausdorff.upper : kInf);
  j["certified_lower_bound"] = fit.run.certificate.distance.hausdorff.lower;
  j["certified_faces_error"] =
      number_or_null(fit.run.certificate.faces_certified > 0 ? fit.run.certificate.certified_faces_upper : kInf);
  j["faces_over_ratio_limits_detail"] = faces_over_ratio_limits_json(fit.run);
  nlohmann::json steps = nlohmann::json::array();
  for (const PartFit::Step& s : fit.steps) {
    steps.push_back({{"segments", s.segments},
                     {"triangles", s.triangles},
                     {"certified", s.certified},
                     {"upper", number_or_null(s.upper)},
                     {"certified_faces_upper", number_or_null(s.faces_upper)},
                     {"lower", s.lower},
                     {"seconds", s.seconds},
                     {"per_face", s.per_face},
                     {"edge_tolerance", s.edge_tolerance}});
  }
  j["steps"] = steps;
  j["seconds"] = fit.seconds;
  j["part"] = part_run_json(fit.run);
  return j;
}

}  // namespace sagitta::app
