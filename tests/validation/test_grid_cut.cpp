// cut_along_grid against an independent reference: every piece's corners, mapped back through the
// piece's own patch, give the point of the original (u, v) triangle at the piece's barycentric
// coordinates; the pieces' (u, v) areas add up to the triangle's; grids over part of a period never
// wrap, grids over a whole period carry a triangle across the seam.
#include "sagitta/grid_cut.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace sagitta {
namespace {

constexpr double kPi = 3.14159265358979323846;

// (U, V) of a piece corner, through the grid's own breaks (no period): the cell's span, unmirrored.
Vec2 corner_uv(const PatchGrid& g, const GridPiece& p, int c) {
  const size_t nv = g.v_breaks.size() - 1, i = p.patch / nv, j = p.patch % nv;
  const double s = g.reversed ? 1.0 - p.st[c].x : p.st[c].x;
  return Vec2(g.u_breaks[i] + s * (g.u_breaks[i + 1] - g.u_breaks[i]),
              g.v_breaks[j] + p.st[c].y * (g.v_breaks[j + 1] - g.v_breaks[j]));
}

double area(const Vec2& a, const Vec2& b, const Vec2& c) {
  return 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
}

// Each piece corner is the triangle's point at its barycentric coordinates, modulo `period` in U.
void expect_consistent(const PatchGrid& g, const std::array<Vec2, 3>& q, double period) {
  const std::vector<GridPiece> pieces = cut_along_grid(q, g);
  ASSERT_FALSE(pieces.empty());
  double total = 0.0;
  for (const GridPiece& p : pieces) {
    std::array<Vec2, 3> uv;
    for (int c = 0; c < 3; ++c) {
      const Vec3& b = p.barycentric[c];
      const Vec2 expected = b.x * q[0] + b.y * q[1] + b.z * q[2];
      uv[c] = corner_uv(g, p, c);
      double du = uv[c].x - expected.x;
      if (period > 0.0) du -= period * std::round(du / period);
      EXPECT_NEAR(du, 0.0, 1e-12);
      EXPECT_NEAR(uv[c].y, expected.y, 1e-12);
    }
    const double pieces_area = area(p.barycentric[0].x * q[0] + p.barycentric[0].y * q[1] + p.barycentric[0].z * q[2],
                                    p.barycentric[1].x * q[0] + p.barycentric[1].y * q[1] + p.barycentric[1].z * q[2],
                                    p.barycentric[2].x * q[0] + p.barycentric[2].y * q[1] + p.barycentric[2].z * q[2]);
    total += pieces_area;
  }
  EXPECT_NEAR(total, area(q[0], q[1], q[2]), 1e-12);
}

TEST(GridCut, PiecesMapBackOntoTheTriangle) {
  PatchGrid g{{0.0, 0.5, 1.5, 2.0}, {-1.0, 0.0, 1.0}, 0.0, 0.0, false};
  expect_consistent(g, {Vec2(0.1, -0.9), Vec2(1.9, 0.2), Vec2(0.7, 0.95)}, 0.0);
  g.reversed = true;
  expect_consistent(g, {Vec2(0.1, -0.9), Vec2(1.9, 0.2), Vec2(0.7, 0.95)}, 0.0);
}

// A cone face over 0.4 rad of a 2 pi period: one patch; a triangle inside it is one piece whose
// (s, t) are its affine coordinates in the patch (a continued grid would put it in a 2 pi wide cell).
TEST(GridCut, PartOfAPeriodDoesNotWrap) {
  const PatchGrid g{{2.94, 3.34}, {34.6, 35.4}, 2 * kPi, 0.0, false};
  const std::array<Vec2, 3> q = {Vec2(3.24, 35.35), Vec2(3.33, 35.2), Vec2(3.339, 35.35)};
  const std::vector<GridPiece> pieces = cut_along_grid(q, g);
  ASSERT_EQ(pieces.size(), 1u);
  EXPECT_NEAR(pieces[0].st[0].x, (3.24 - 2.94) / 0.4, 1e-12);
  expect_consistent(g, q, 0.0);
}

// A whole turn in four patches: a triangle across the seam is cut at it, each side in its own patch.
TEST(GridCut, WholePeriodCarriesTheSeam) {
  const PatchGrid g{{0.0, 0.5 * kPi, kPi, 1.5 * kPi, 2 * kPi}, {0.0, 1.0}, 2 * kPi, 0.0, false};
  const std::array<Vec2, 3> q = {Vec2(2 * kPi - 0.2, 0.1), Vec2(2 * kPi + 0.3, 0.2), Vec2(2 * kPi, 0.8)};
  const std::vector<GridPiece> pieces = cut_along_grid(q, g);
  bool first = false, last = false;
  for (const GridPiece& p : pieces) first = first || p.patch == 0, last = last || p.patch == 3;
  EXPECT_TRUE(first && last);
  expect_consistent(g, q, 2 * kPi);
}

}  // namespace
}  // namespace sagitta
