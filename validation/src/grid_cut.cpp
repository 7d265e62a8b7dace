// Triangles cut along a patch grid (sagitta/grid_cut.hpp).
#include "sagitta/grid_cut.hpp"

#include <algorithm>
#include <cmath>

namespace sagitta {

namespace {

// Breaks extended by one period on each side (periodic directions), with each cell's own index.
struct Breaks {
  std::vector<double> at;
  std::vector<uint32_t> cell;
};

Breaks extend(const std::vector<double>& b, double period) {
  Breaks out;
  const size_t n = b.size() - 1;
  // Only a grid spanning the whole period continues across the seam; a face over part of a closed
  // surface never needs to.
  const bool closed = period > 0.0 && std::abs((b[n] - b[0]) - period) <= 1e-9 * period;
  const int copies = closed ? 1 : 0;
  for (int c = -copies; c <= copies; ++c) {
    for (size_t k = 0; k < n; ++k) {
      out.at.push_back(b[k] + c * period);
      out.cell.push_back(static_cast<uint32_t>(k));
    }
  }
  out.at.push_back(b[n] + copies * period);
  return out;
}

size_t locate(const std::vector<double>& breaks, double x) {
  const auto it = std::upper_bound(breaks.begin(), breaks.end(), x);
  const size_t k = it == breaks.begin() ? 0 : static_cast<size_t>(it - breaks.begin()) - 1;
  return std::min(k, breaks.size() - 2);
}

struct ClipVertex {
  Vec2 uv;
  Vec3 b;
};

double cross(const Vec2& a, const Vec2& b) { return a.x * b.y - a.y * b.x; }

// Sutherland-Hodgman: the part of `poly` with sign * (coordinate axis - value) >= 0.
std::vector<ClipVertex> clip(const std::vector<ClipVertex>& poly, int axis, double value, double sign) {
  std::vector<ClipVertex> out;
  for (size_t k = 0; k < poly.size(); ++k) {
    const ClipVertex& a = poly[k];
    const ClipVertex& b = poly[(k + 1) % poly.size()];
    const double da = sign * (a.uv[axis] - value), db = sign * (b.uv[axis] - value);
    if (da >= 0) out.push_back(a);
    if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
      const double t = da / (da - db);
      ClipVertex c{a.uv + t * (b.uv - a.uv), a.b + t * (b.b - a.b)};
      c.uv[axis] = value;  // on the grid line exactly
      out.push_back(c);
    }
  }
  return out;
}

}  // namespace

std::vector<GridPiece> cut_along_grid(const std::array<Vec2, 3>& q, const PatchGrid& grid) {
  std::vector<GridPiece> pieces;
  if (grid.u_breaks.size() < 2 || grid.v_breaks.size() < 2) return pieces;
  const Breaks bu = extend(grid.u_breaks, grid.u_period), bv = extend(grid.v_breaks, grid.v_period);
  const uint32_t nv = static_cast<uint32_t>(grid.v_breaks.size() - 1);
  const size_t i0 = std::min({locate(bu.at, q[0].x), locate(bu.at, q[1].x), locate(bu.at, q[2].x)});
  const size_t i1 = std::max({locate(bu.at, q[0].x), locate(bu.at, q[1].x), locate(bu.at, q[2].x)});
  const size_t j0 = std::min({locate(bv.at, q[0].y), locate(bv.at, q[1].y), locate(bv.at, q[2].y)});
  const size_t j1 = std::max({locate(bv.at, q[0].y), locate(bv.at, q[1].y), locate(bv.at, q[2].y)});
  for (size_t i = i0; i <= i1; ++i) {
    for (size_t j = j0; j <= j1; ++j) {
      std::vector<ClipVertex> poly{{q[0], Vec3(1, 0, 0)}, {q[1], Vec3(0, 1, 0)}, {q[2], Vec3(0, 0, 1)}};
      if (i0 != i1 || j0 != j1) {
        if (i > 0) poly = clip(poly, 0, bu.at[i], 1.0);
        if (i + 2 < bu.at.size() && !poly.empty()) poly = clip(poly, 0, bu.at[i + 1], -1.0);
        if (j > 0 && !poly.empty()) poly = clip(poly, 1, bv.at[j], 1.0);
        if (j + 2 < bv.at.size() && !poly.empty()) poly = clip(poly, 1, bv.at[j + 1], -1.0);
      }
      for (size_t k = 1; k + 1 < poly.size(); ++k) {
        const ClipVertex* v[3] = {&poly[0], &poly[k], &poly[k + 1]};
        if (0.5 * cross(v[1]->uv - v[0]->uv, v[2]->uv - v[0]->uv) == 0.0) continue;
        GridPiece piece;
        piece.patch = bu.cell[i] * nv + bv.cell[j];
        for (int m = 0; m < 3; ++m) {
          const double s = std::clamp((v[m]->uv.x - bu.at[i]) / (bu.at[i + 1] - bu.at[i]), 0.0, 1.0);
          const double t = std::clamp((v[m]->uv.y - bv.at[j]) / (bv.at[j + 1] - bv.at[j]), 0.0, 1.0);
          piece.st[m] = Vec2(grid.reversed ? 1.0 - s : s, t);
          piece.barycentric[m] = v[m]->b;
        }
        pieces.push_back(piece);
      }
    }
  }
  return pieces;
}

}  // namespace sagitta
