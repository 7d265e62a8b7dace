#include "sagitta/app/fit_search.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace sagitta::app {

bool fit_fewest_triangles(const Model& model, const Topology& topo, double target, FittedSetting& best) {
  // Candidates in the order of their schemes' speed: the uniform grid, per-patch uniform, ESC.
  std::vector<FittedSetting> met;
  for (int kind = 0; kind < 3; ++kind) {
    FittedSetting f;
    FitOptions options;
    options.per_patch = kind == 1;
    const Scheme scheme = kind == 2 ? Scheme::kEsc : Scheme::kUniform;
    f.fit = fit_to_error(model, topo, scheme, target, options);
    f.fit.mesh = Tessellation();
    f.spec.scheme = scheme;
    f.spec.guard = false;  // the fit bounded its size
    if (kind == 2) {
      f.scheme = "esc";
      f.spec.level = f.fit.level;
      f.spec.threshold = f.fit.threshold;
    } else if (kind == 1) {
      f.scheme = "uniform_per_patch";
      for (const PatchChoice& c : f.fit.patches) f.spec.patch_levels.push_back(c.level);
    } else {
      f.scheme = "uniform";
      f.spec.segments = f.fit.level;
    }
    if (f.fit.met) met.push_back(std::move(f));
  }
  if (met.empty()) return false;
  size_t fewest = met.front().fit.triangles;
  for (const FittedSetting& f : met) fewest = std::min(fewest, f.fit.triangles);
  // The fastest scheme among those within 1 % of the fewest triangles (the teapot at 1e-3: uniform
  // N = 42 with 112,560 triangles, ESC with 112,552).
  for (FittedSetting& f : met) {
    if (static_cast<double>(f.fit.triangles) <= 1.01 * static_cast<double>(fewest)) {
      best = std::move(f);
      return true;
    }
  }
  return false;
}

bool fit_occt_deflection(const Model& model, double target, occt::PeerResult& best, double& deflection) {
  occt::PeerOptions options;
  options.certify = fit_certify_defaults();
  auto passes = [&](double d, occt::PeerResult& r) {
    options.deflection = d;
    r = occt::peer_mesh_model(model, options);
    return r.distance.hausdorff.certified && r.distance.hausdorff.upper <= target;
  };
  double pass = 0.0, fail = 0.0;
  occt::PeerResult r;
  double d = target;
  if (passes(d, r)) {
    pass = d;
    best = r;
    for (int i = 0; i < 4 && fail == 0.0; ++i) {
      d *= 2.0;
      if (passes(d, r)) {
        pass = d;
        best = r;
      } else {
        fail = d;
      }
    }
  } else {
    fail = d;
    for (int i = 0; i < 6 && pass == 0.0; ++i) {
      d *= 0.5;
      if (passes(d, r)) {
        pass = d;
        best = r;
      } else {
        fail = d;
      }
    }
  }
  if (pass == 0.0) return false;
  if (fail > 0.0) {
    const double mid = std::sqrt(pass * fail);
    if (passes(mid, r)) {
      pass = mid;
      best = r;
    }
  }
  deflection = pass;
  return true;
}

}  // namespace sagitta::app
