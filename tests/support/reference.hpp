// Long-double reference for the extreme-geometry suite, independent of the kernels and the
// validator: Bernstein bases by the stable two-term recurrence, points taken relative to the
// patch's first control point (so far from the origin the digits are kept), and the distance from
// a point to a patch by damped Gauss-Newton from several seeds.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace sagitta::extreme {

using LD = long double;

struct LVec {
  LD x = 0, y = 0, z = 0;
};
inline LVec operator-(LVec a, LVec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline LD dot(LVec a, LVec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline LVec to_lvec(const Vec3& p) { return {p.x, p.y, p.z}; }

// B_i^n(t) and its derivative for i = 0..n by the recurrence B_i^k = (1 - t) B_i^{k-1} + t B_{i-1}^{k-1}.
inline void bernstein(int n, LD t, LD* b, LD* db) {
  LD prev[kMaxDegree + 2] = {1};  // degree k basis after step k
  for (int k = 1; k < n; ++k) {   // up to degree n - 1
    for (int i = k; i >= 0; --i) prev[i] = (i < k ? (1 - t) * prev[i] : 0) + (i > 0 ? t * prev[i - 1] : 0);
  }
  // prev holds B^{n-1}; the derivative is n (B_{i-1}^{n-1} - B_i^{n-1}), the value one more step.
  for (int i = 0; i <= n; ++i) {
    const LD left = i > 0 ? prev[i - 1] : 0, right = i < n ? prev[i] : 0;
    b[i] = (1 - t) * right + t * left;
    db[i] = n * (left - right);
  }
}

// Position (relative to `origin`) and partials of the patch at (u, v), in long double.
inline void evaluate(const BezierPatch& p, const LVec& origin, LD u, LD v, LVec& s, LVec& su, LVec& sv) {
  LD bu[32], dbu[32], bv[32], dbv[32];
  bernstein(p.degree_u, u, bu, dbu);
  bernstein(p.degree_v, v, bv, dbv);
  LD n[3] = {0, 0, 0}, nu[3] = {0, 0, 0}, nv[3] = {0, 0, 0}, w = 0, wu = 0, wv = 0;
  for (int i = 0; i <= p.degree_u; ++i) {
    for (int j = 0; j <= p.degree_v; ++j) {
      const LD wij = p.weight(i, j);
      const LVec c = to_lvec(p.at(i, j)) - origin;
      const LD cc[3] = {c.x, c.y, c.z};
      for (int k = 0; k < 3; ++k) {
        n[k] += bu[i] * bv[j] * wij * cc[k];
        nu[k] += dbu[i] * bv[j] * wij * cc[k];
        nv[k] += bu[i] * dbv[j] * wij * cc[k];
      }
      w += bu[i] * bv[j] * wij;
      wu += dbu[i] * bv[j] * wij;
      wv += bu[i] * dbv[j] * wij;
    }
  }
  s = {n[0] / w, n[1] / w, n[2] / w};
  su = {(nu[0] - s.x * wu) / w, (nu[1] - s.y * wu) / w, (nu[2] - s.z * wu) / w};
  sv = {(nv[0] - s.x * wv) / w, (nv[1] - s.y * wv) / w, (nv[2] - s.z * wv) / w};
}

// Distance from x to the patch: damped Gauss-Newton from (u, v), clamped to the unit square, a step
// kept only when it lowers the distance. The result is a distance to a point of the patch, so it is
// >= the true distance and equals it when the seed is in the right basin.
inline LD newton_distance(const BezierPatch& p, const LVec& x_in, LD u, LD v) {
  const LVec origin = to_lvec(p.points[0]);
  const LVec x = x_in - origin;
  LVec s, su, sv;
  evaluate(p, origin, u, v, s, su, sv);
  LD best = std::sqrt(dot(x - s, x - s));
  for (int it = 0; it < 50; ++it) {
    const LVec r = x - s;
    const LD a = dot(su, su), b = dot(su, sv), c = dot(sv, sv), det = a * c - b * b;
    if (!(det > 0) || !std::isfinite(det)) break;
    const LD ru = dot(su, r), rv = dot(sv, r);
    LD du = (c * ru - b * rv) / det, dv = (a * rv - b * ru) / det;
    // A parameter on a side where the distance decreases outwards stays there and the other one
    // takes the 1D step (a clamped 2D step can stall short of the nearest point of the side).
    const bool hold_u = (u <= 0 && ru < 0) || (u >= 1 && ru > 0), hold_v = (v <= 0 && rv < 0) || (v >= 1 && rv > 0);
    if (hold_u && hold_v) break;
    if (hold_u) du = 0, dv = rv / c;
    if (hold_v) dv = 0, du = ru / a;
    bool moved = false;
    for (int half = 0; half < 24 && !moved; ++half, du /= 2, dv /= 2) {
      const LD nu = std::clamp(u + du, LD(0), LD(1)), nv = std::clamp(v + dv, LD(0), LD(1));
      LVec ns, nsu, nsv;
      evaluate(p, origin, nu, nv, ns, nsu, nsv);
      const LD d = std::sqrt(dot(x - ns, x - ns));
      if (d < best) {
        best = d;
        u = nu;
        v = nv;
        s = ns;
        su = nsu;
        sv = nsv;
        moved = true;
      }
    }
    if (!moved) break;
  }
  return best;
}

// Distance from x to one patch: the smallest Newton result over a seed grid of (seeds_per_side + 1)^2
// points (none when seeds_per_side is 0) and the optional hint.
inline LD patch_distance(const BezierPatch& p, const LVec& x, int seeds_per_side, const Vec2* hint = nullptr) {
  LD d = hint ? newton_distance(p, x, hint->x, hint->y) : LD(INFINITY);
  if (seeds_per_side < 1) return d;
  for (int i = 0; i <= seeds_per_side; ++i) {
    for (int j = 0; j <= seeds_per_side; ++j) {
      d = std::min(d, newton_distance(p, x, LD(i) / seeds_per_side, LD(j) / seeds_per_side));
    }
  }
  return d;
}

// Distance from x to the union of the model's patches (every patch, 5 x 5 seeds each).
inline LD model_distance(const Model& model, const Vec3& x) {
  LD d = INFINITY;
  for (const BezierPatch& p : model.patches) d = std::min(d, patch_distance(p, to_lvec(x), 4));
  return d;
}

// Largest distance from sampled mesh points (k + 1)(k + 2) / 2 per triangle, every stride-th
// triangle) to the triangle's own patch, each projected by Newton from the triangle's own (u, v).
// Each value is the distance to a point of the own patch, so the certified mesh->surface upper
// bound (which matches every triangle to its own patch first) must be at least the largest.
inline LD sampled_mesh_to_surface(const Model& model, const Tessellation& mesh, int k, size_t stride) {
  LD worst = 0;
  for (size_t t = 0; t < mesh.triangles.size(); t += stride) {
    const BezierPatch& patch = model.patches[mesh.triangle_patch[t]];
    const auto& uv = mesh.triangle_uv[t];
    Vec3 corner[3];
    for (int c = 0; c < 3; ++c) corner[c] = mesh.positions[mesh.triangles[t][c]];
    for (int i = 0; i <= k; ++i) {
      for (int j = 0; i + j <= k; ++j) {
        const LD b0 = LD(i) / k, b1 = LD(j) / k, b2 = 1 - b0 - b1;
        // The sample in long double, relative to the first corner (exact differences of doubles).
        const LVec c0 = to_lvec(corner[0]), e1 = to_lvec(corner[1]) - c0, e2 = to_lvec(corner[2]) - c0;
        const LVec x{c0.x + b1 * e1.x + b2 * e2.x, c0.y + b1 * e1.y + b2 * e2.y, c0.z + b1 * e1.z + b2 * e2.z};
        const Vec2 hint = double(b0) * uv[0] + double(b1) * uv[1] + double(b2) * uv[2];
        worst = std::max(worst, patch_distance(patch, x, 0, &hint));
      }
    }
  }
  return worst;
}

}  // namespace sagitta::extreme
