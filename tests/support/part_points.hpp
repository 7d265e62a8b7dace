// Exact surface points of a part's faces for the part tests (header-only).
#pragma once

#include "sagitta/evaluate.hpp"
#include "sagitta/occt/part.hpp"

#include <algorithm>
#include <vector>

namespace sagitta::test {

// The surface point of face f at (U, V) of its patch grid, evaluated in long double: the patch of
// the grid cell holding (U, V) (the end cells for points past the grid), at (U, V)'s place in it
// (clamped onto it; u mirrored on a reversed face).
inline Vec3 face_point_uv(const occt::PartMesh& part, const occt::PartFace& f, double U, double V) {
  const size_t nv = f.v_breaks.size() - 1;
  const auto span = [](const std::vector<double>& b, double x) {
    size_t k = 0;
    while (k + 2 < b.size() && x > b[k + 1]) ++k;
    return k;
  };
  const size_t I = span(f.u_breaks, U), J = span(f.v_breaks, V);
  const double S = std::clamp((U - f.u_breaks[I]) / (f.u_breaks[I + 1] - f.u_breaks[I]), 0.0, 1.0);
  const double T = std::clamp((V - f.v_breaks[J]) / (f.v_breaks[J + 1] - f.v_breaks[J]), 0.0, 1.0);
  const BezierPatch& p = part.model.patches[static_cast<size_t>(f.first_patch) + I * nv + J];
  const auto x = de_casteljau<long double>(p, f.reversed ? 1.0 - S : S, T);
  return Vec3(static_cast<double>(x[0]), static_cast<double>(x[1]), static_cast<double>(x[2]));
}

}  // namespace sagitta::test
