// Searches for the cheapest setting that certifies a target error: ours among the schemes, and
// OCCT's BRepMesh deflection (`sagitta bench` compares the two at equal certified error).
#pragma once

#include "sagitta/fit.hpp"
#include "sagitta/model.hpp"
#include "sagitta/occt/cad.hpp"
#include "sagitta/scheme.hpp"

#include <string>

namespace sagitta::app {

struct FittedSetting {
  std::string scheme;  // "uniform" | "uniform_per_patch" | "esc"
  FitResult fit;       // without its mesh
  SchemeSpec spec;     // the fitted setting (with surface data, so it can be certified)
};

// Fewest-triangle setting among uniform (global and per patch) and ESC that certifies <= target;
// among settings within 1 % of the fewest triangles, the fastest scheme (uniform, per patch, ESC).
// Returns false when no fit meets the target.
bool fit_fewest_triangles(const Model& model, const Topology& topo, double target, FittedSetting& best);

// OCCT's largest deflection (searched by factors of 2, then one geometric midpoint) whose mesh
// certifies <= target. Returns false when none of the tried deflections certifies.
bool fit_occt_deflection(const Model& model, double target, occt::PeerResult& best, double& deflection);

}  // namespace sagitta::app
