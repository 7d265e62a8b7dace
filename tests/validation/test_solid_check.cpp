// Per-solid verdicts of a whole-part mesh (issue 14): synthetic meshes built here (boxes, tori,
// planted defects), every expected count from a hand count or a formula (Euler's, the box and
// polygonal-torus volumes), CGAL's verdicts against the same references.
#include "sagitta/solid_check.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace sagitta {
namespace {

// A mesh being built with the solid id of every triangle.
struct Part {
  Tessellation mesh;
  std::vector<int32_t> solid;
  std::vector<std::array<uint32_t, 2>> boundary;

  uint32_t vertex(const Vec3& p) {
    mesh.positions.push_back(p);
    return static_cast<uint32_t>(mesh.positions.size() - 1);
  }
  void triangle(uint32_t a, uint32_t b, uint32_t c, int32_t id) {
    mesh.triangles.push_back({a, b, c});
    solid.push_back(id);
  }
};

// The box's corners, corner k at (x, y, z) = (k & 1, k & 2, k & 4) of [lo, hi], first index returned.
uint32_t box_corners(Part& part, const Vec3& lo, const Vec3& hi) {
  const uint32_t first = static_cast<uint32_t>(part.mesh.positions.size());
  for (int k = 0; k < 8; ++k) part.vertex({k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z});
  return first;
}

// The box's six faces as corner quads, counter-clockwise seen from outside (normals -z, +z, -y,
// +y, -x, +x), each split along its first diagonal: (a, b, c), (a, c, d).
constexpr std::array<std::array<uint32_t, 4>, 6> kBoxQuads{
    {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}}};

// The 12 triangles of a box, outward; `skip_top` leaves the +z face out (an open box).
void add_box(Part& part, const Vec3& lo, const Vec3& hi, int32_t id, bool skip_top = false) {
  const uint32_t c = box_corners(part, lo, hi);
  for (size_t f = 0; f < kBoxQuads.size(); ++f) {
    if (skip_top && f == 1) continue;
    const auto& q = kBoxQuads[f];
    part.triangle(c + q[0], c + q[1], c + q[2], id);
    part.triangle(c + q[0], c + q[2], c + q[3], id);
  }
}

// A polygonal torus: n rings around z at radius R, each a regular m-gon of circumradius s in the
// (radial, z) plane starting at angle phase, quads between rings split in two, outward.
void add_torus(Part& part, int n, int m, double R, double s, double phase, int32_t id) {
  const uint32_t first = static_cast<uint32_t>(part.mesh.positions.size());
  const double pi = std::acos(-1.0);
  for (int i = 0; i < n; ++i) {
    const double theta = 2.0 * pi * i / n;
    for (int j = 0; j < m; ++j) {
      const double phi = phase + 2.0 * pi * j / m, rho = R + s * std::cos(phi);
      part.vertex({rho * std::cos(theta), rho * std::sin(theta), s * std::sin(phi)});
    }
  }
  auto at = [&](int i, int j) { return first + static_cast<uint32_t>((i % n) * m + (j % m)); };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      part.triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1), id);
      part.triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1), id);
    }
  }
}

// Volume of that torus: each of the n wedges is {rho w(s) + z e_z}, s in [0, 1], over the m-gon,
// of volume sin(2 pi / n) times the m-gon's first moment about the axis, which is its area
// m/2 s^2 sin(2 pi / m) times its centroid's radius R.
double torus_volume(int n, int m, double R, double s) {
  const double pi = std::acos(-1.0);
  return n * std::sin(2.0 * pi / n) * R * 0.5 * m * s * s * std::sin(2.0 * pi / m);
}

std::vector<SolidCheck> check(const Part& part, const SolidCheckOptions& options = {}) {
  return check_solids(part.mesh, part.solid, part.boundary, options);
}

size_t count_kind(const SolidCheck& c, const std::string& kind) {
  size_t n = 0;
  for (const TopologyFinding& f : c.findings) n += f.kind == kind;
  return n;
}

// Box counts: V = 8, E = 12 box edges + 6 face diagonals, F = 12.
constexpr uint64_t kBoxV = 8, kBoxE = 18, kBoxF = 12;

TEST(SolidCheck, ClosedCube) {
  Part part;
  const Vec3 lo{1.0, 2.0, 3.0}, hi{3.0, 5.0, 4.5};
  add_box(part, lo, hi, 0);
  const auto r = check(part);
  ASSERT_EQ(r.size(), 1u);
  const SolidCheck& c = r[0];
  const double volume = (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
  EXPECT_EQ(c.solid, 0);
  EXPECT_EQ(c.triangles, kBoxF);
  EXPECT_EQ(c.vertices, kBoxV);
  EXPECT_EQ(c.edges, kBoxE);
  EXPECT_EQ(c.euler_characteristic, 2);  // a sphere
  EXPECT_EQ(c.open_edges + c.crack_edges + c.model_boundary_edges + c.non_manifold_edges + c.t_junctions +
                c.inconsistent_orientation_edges + c.degenerate_triangles,
            0u);
  EXPECT_EQ(c.components, 1u);
  EXPECT_TRUE(c.closed);
  EXPECT_NEAR(c.signed_volume, volume, 1e-12 * volume);
  EXPECT_TRUE(c.findings.empty());
  EXPECT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_TRUE(c.cgal_closed);
  EXPECT_TRUE(c.cgal_outward);
  EXPECT_EQ(c.cgal_self_intersections, 0u);
  EXPECT_NEAR(c.cgal_volume, volume, 1e-12 * volume);
}

TEST(SolidCheck, TorusHasEulerCharacteristicZero) {
  const int n = 12, m = 4;
  const double R = 3.0, r = 1.0;
  Part part;
  add_torus(part, n, m, R, r * std::sqrt(2.0), -std::acos(-1.0) / 4, 7);  // square cross-section of side 2r
  const auto res = check(part);
  ASSERT_EQ(res.size(), 1u);
  const SolidCheck& c = res[0];
  EXPECT_EQ(c.solid, 7);
  EXPECT_EQ(c.vertices, uint64_t(n * m));
  EXPECT_EQ(c.edges, uint64_t(3 * n * m));  // per quad: two grid edges and a diagonal
  EXPECT_EQ(c.triangles, uint64_t(2 * n * m));
  EXPECT_EQ(c.euler_characteristic, 0);
  EXPECT_TRUE(c.closed);
  EXPECT_EQ(c.components, 1u);
  // The square case of torus_volume, by the prism over each wedge's trapezoid: 4 n R r^2 sin(2 pi / n).
  const double volume = 4.0 * n * R * r * r * std::sin(2.0 * std::acos(-1.0) / n);
  EXPECT_NEAR(torus_volume(n, m, R, r * std::sqrt(2.0)), volume, 1e-12 * volume);
  EXPECT_NEAR(c.signed_volume, volume, 1e-12 * volume);
  EXPECT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_TRUE(c.cgal_closed);
  EXPECT_TRUE(c.cgal_outward);
  EXPECT_EQ(c.cgal_self_intersections, 0u);
  EXPECT_NEAR(c.cgal_volume, volume, 1e-12 * volume);
}

TEST(SolidCheck, TwoSolidsAndLooseTrianglesGetSeparateVerdictsSortedById) {
  Part a, b, part;
  add_box(a, {0.0, 0.0, 0.0}, {1.0, 2.0, 3.0}, 1);
  add_box(b, {5.0, 5.0, 5.0}, {7.0, 7.0, 7.0}, 0);
  // Interleave the two boxes' triangles (B's vertices after A's) with a loose triangle in the middle.
  part.mesh.positions = a.mesh.positions;
  part.mesh.positions.insert(part.mesh.positions.end(), b.mesh.positions.begin(), b.mesh.positions.end());
  const uint32_t loose = part.vertex({10.0, 0.0, 0.0});
  part.vertex({11.0, 0.0, 0.0});
  part.vertex({10.0, 1.0, 0.0});
  size_t loose_index = 0;
  for (size_t t = 0; t < kBoxF; ++t) {
    part.triangle(a.mesh.triangles[t][0], a.mesh.triangles[t][1], a.mesh.triangles[t][2], 1);
    if (t == 5) {
      loose_index = part.mesh.triangles.size();
      part.triangle(loose, loose + 1, loose + 2, -1);
    }
    const Triangle& tb = b.mesh.triangles[t];
    part.triangle(tb[0] + 8, tb[1] + 8, tb[2] + 8, 0);
  }
  const auto r = check(part);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0].solid, -1);
  EXPECT_EQ(r[1].solid, 0);
  EXPECT_EQ(r[2].solid, 1);
  const double volume_a = 1.0 * 2.0 * 3.0, volume_b = 2.0 * 2.0 * 2.0;
  for (int k : {1, 2}) {
    const SolidCheck& c = r[k];
    const double volume = k == 1 ? volume_b : volume_a;
    EXPECT_EQ(c.triangles, kBoxF);
    EXPECT_EQ(c.vertices, kBoxV);  // only the solid's own vertices
    EXPECT_EQ(c.edges, kBoxE);
    EXPECT_EQ(c.euler_characteristic, 2);
    EXPECT_TRUE(c.closed);
    EXPECT_EQ(c.open_edges, 0u);
    EXPECT_NEAR(c.signed_volume, volume, 1e-12 * volume);
    EXPECT_TRUE(c.cgal_closed && c.cgal_outward);
    EXPECT_NEAR(c.cgal_volume, volume, 1e-12 * volume);
  }
  // The loose triangle: a disk (chi 1) of three open edges, all cracks, located in the whole mesh.
  const SolidCheck& l = r[0];
  EXPECT_EQ(l.triangles, 1u);
  EXPECT_EQ(l.vertices, 3u);
  EXPECT_EQ(l.edges, 3u);
  EXPECT_EQ(l.euler_characteristic, 1);
  EXPECT_EQ(l.open_edges, 3u);
  EXPECT_EQ(l.crack_edges, 3u);
  EXPECT_FALSE(l.closed);
  ASSERT_EQ(count_kind(l, "crack_edge"), 3u);
  for (const TopologyFinding& f : l.findings) {
    EXPECT_EQ(f.triangle, int64_t(loose_index));
    for (int64_t v : f.vertices) {
      EXPECT_GE(v, int64_t(loose));
      EXPECT_LE(v, int64_t(loose + 2));
    }
  }
  // Deterministic: a second run gives the same verdicts.
  const auto again = check(part);
  ASSERT_EQ(again.size(), r.size());
  for (size_t k = 0; k < r.size(); ++k) {
    EXPECT_EQ(again[k].signed_volume, r[k].signed_volume);
    EXPECT_EQ(again[k].cgal_volume, r[k].cgal_volume);
    ASSERT_EQ(again[k].findings.size(), r[k].findings.size());
    for (size_t i = 0; i < r[k].findings.size(); ++i) {
      EXPECT_EQ(again[k].findings[i].kind, r[k].findings[i].kind);
      EXPECT_EQ(again[k].findings[i].vertices, r[k].findings[i].vertices);
    }
  }
}

TEST(SolidCheck, FlippedTriangleIsInconsistentlyOriented) {
  Part part;
  add_box(part, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, 0);
  std::swap(part.mesh.triangles[0][1], part.mesh.triangles[0][2]);
  const SolidCheck c = check(part).at(0);
  // Each of the flipped triangle's three edges now runs the same way as in its neighbour.
  EXPECT_EQ(c.inconsistent_orientation_edges, 3u);
  EXPECT_EQ(count_kind(c, "inconsistent_orientation_edge"), 3u);
  EXPECT_EQ(c.open_edges, 0u);
  EXPECT_EQ(c.non_manifold_edges, 0u);
  EXPECT_EQ(c.euler_characteristic, 2);
  EXPECT_FALSE(c.closed);
  EXPECT_FALSE(c.cgal_checked && c.cgal_outward);
  EXPECT_FALSE(c.cgal_checked);  // an edge twice in one direction: not a polygon mesh
  EXPECT_FALSE(c.cgal_note.empty());
}

TEST(SolidCheck, MissingTriangleLeavesThreeCracks) {
  Part part;
  add_box(part, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, 0);
  const Triangle removed = part.mesh.triangles[4];
  part.mesh.triangles.erase(part.mesh.triangles.begin() + 4);
  part.solid.pop_back();
  const SolidCheck c = check(part).at(0);
  EXPECT_EQ(c.triangles, kBoxF - 1);
  EXPECT_EQ(c.edges, kBoxE);  // each of the removed triangle's edges is still used by its neighbour
  EXPECT_EQ(c.euler_characteristic, int64_t(kBoxV) - int64_t(kBoxE) + int64_t(kBoxF - 1));
  EXPECT_EQ(c.open_edges, 3u);
  EXPECT_EQ(c.crack_edges, 3u);
  EXPECT_EQ(c.model_boundary_edges, 0u);
  EXPECT_FALSE(c.closed);
  EXPECT_EQ(c.signed_volume, 0.0);  // no enclosed volume
  ASSERT_EQ(count_kind(c, "crack_edge"), 3u);
  for (const TopologyFinding& f : c.findings) {
    if (f.kind != "crack_edge") continue;
    const auto in_removed = [&](int64_t v) {
      return std::find(removed.begin(), removed.end(), uint32_t(v)) != removed.end();
    };
    EXPECT_TRUE(in_removed(f.vertices[0]) && in_removed(f.vertices[1]));
  }
  EXPECT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_FALSE(c.cgal_closed);
  EXPECT_FALSE(c.cgal_outward);
  EXPECT_EQ(c.cgal_volume, 0.0);
}

TEST(SolidCheck, OpenBoxRimIsModelBoundary) {
  Part part;
  add_box(part, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, 0, /*skip_top=*/true);
  const std::array<std::array<uint32_t, 2>, 4> rim{{{4, 5}, {7, 5}, {6, 7}, {4, 6}}};  // either order
  const SolidCheck without = check(part).at(0);
  part.boundary.assign(rim.begin(), rim.end());
  const SolidCheck c = check(part).at(0);
  for (const SolidCheck* s : {&without, &c}) {
    EXPECT_EQ(s->triangles, kBoxF - 2);
    EXPECT_EQ(s->edges, kBoxE - 1);         // the top diagonal is gone
    EXPECT_EQ(s->euler_characteristic, 1);  // a disk
    EXPECT_EQ(s->open_edges, 4u);
    EXPECT_FALSE(s->closed);
  }
  EXPECT_EQ(without.crack_edges, 4u);
  EXPECT_EQ(without.model_boundary_edges, 0u);
  EXPECT_EQ(c.model_boundary_edges, 4u);
  EXPECT_EQ(c.crack_edges, 0u);
  EXPECT_EQ(count_kind(c, "model_boundary_edge"), 4u);
  EXPECT_EQ(count_kind(c, "crack_edge"), 0u);
  EXPECT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_FALSE(c.cgal_closed);
}

TEST(SolidCheck, VertexOnOneSideOfAnEdgeIsATJunction) {
  Part part;
  add_box(part, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, 0);
  // Triangle 4 is (0, 1, 5) of the -y face; split it at the midpoint of edge (0, 1), which the -z
  // face's triangle (0, 3, 1) keeps whole.
  ASSERT_EQ(part.mesh.triangles[4], (Triangle{0, 1, 5}));
  const uint32_t mid = part.vertex({0.5, 0.0, 0.0});
  part.mesh.triangles[4] = {0, mid, 5};
  part.triangle(mid, 1, 5, 0);
  const SolidCheck c = check(part).at(0);
  EXPECT_EQ(c.t_junctions, 1u);
  ASSERT_EQ(count_kind(c, "t_junction"), 1u);
  for (const TopologyFinding& f : c.findings) {
    if (f.kind == "t_junction") {
      EXPECT_EQ(f.vertices[0], int64_t(mid));
    }
  }
  EXPECT_EQ(c.open_edges, 3u);  // (0, mid), (mid, 1) and (0, 1)
  EXPECT_EQ(c.crack_edges, 3u);
  EXPECT_EQ(c.vertices, kBoxV + 1);
  EXPECT_EQ(c.edges, kBoxE + 3);  // (0, mid), (mid, 1), (mid, 5)
  EXPECT_EQ(c.triangles, kBoxF + 1);
  EXPECT_EQ(c.euler_characteristic, 1);
  EXPECT_FALSE(c.closed);
  EXPECT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_FALSE(c.cgal_closed);
}

TEST(SolidCheck, InterpenetratingBoxesSelfIntersect) {
  Part part;
  add_box(part, {0.0, 0.0, 0.0}, {4.0, 4.0, 4.0}, 0);
  add_box(part, {1.0, 2.5, 3.0}, {2.0, 3.5, 5.0}, 0);  // pokes through the big box's top
  const SolidCheck c = check(part).at(0);
  EXPECT_TRUE(c.closed);
  EXPECT_EQ(c.components, 2u);
  EXPECT_EQ(c.euler_characteristic, 4);                     // two spheres
  const double volume = 4.0 * 4.0 * 4.0 + 1.0 * 1.0 * 2.0;  // the overlap counted twice
  EXPECT_NEAR(c.signed_volume, volume, 1e-12 * volume);
  ASSERT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_TRUE(c.cgal_closed);
  EXPECT_NEAR(c.cgal_volume, volume, 1e-12 * volume);
  // The big box's top (z = 4) is split along y = x; the small box's footprint [1, 2] x [2.5, 3.5]
  // lies strictly in its y > x triangle. Each of the small box's 8 side triangles spans z 3..5, so
  // crosses z = 4 inside that one triangle; no other pair meets.
  EXPECT_EQ(c.cgal_self_intersections, 8u);
  SolidCheckOptions no_si;
  no_si.self_intersections = false;
  EXPECT_EQ(check(part, no_si).at(0).cgal_self_intersections, 0u);
  SolidCheckOptions no_cgal;
  no_cgal.cgal = false;
  const SolidCheck n = check(part, no_cgal).at(0);
  EXPECT_FALSE(n.cgal_checked);
  EXPECT_EQ(n.cgal_note, "not requested");
  EXPECT_EQ(n.euler_characteristic, 4);
}

TEST(SolidCheck, InsideOutCubeHasNegativeVolume) {
  Part part;
  add_box(part, {-1.0, 0.0, 2.0}, {1.0, 2.0, 4.0}, 3);
  for (Triangle& t : part.mesh.triangles) std::swap(t[1], t[2]);
  const SolidCheck c = check(part).at(0);
  EXPECT_EQ(c.solid, 3);
  EXPECT_TRUE(c.closed);  // consistently, if wrongly, oriented
  EXPECT_EQ(c.euler_characteristic, 2);
  EXPECT_NEAR(c.signed_volume, -8.0, 1e-12 * 8.0);
  EXPECT_EQ(count_kind(c, "inside_out_component"), 1u);
  ASSERT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_TRUE(c.cgal_closed);
  EXPECT_FALSE(c.cgal_outward);
  EXPECT_NEAR(c.cgal_volume, -8.0, 1e-12 * 8.0);
}

TEST(SolidCheck, DegenerateTriangleIsNotASelfIntersection) {
  Part part;
  const uint32_t a = part.vertex({0.0, 0.0, 0.0});
  part.vertex({1.0, 0.0, 0.0});
  part.vertex({0.0, 1.0, 0.0});
  const uint32_t d = part.vertex({5.0, 0.0, 0.0});
  part.vertex({6.0, 1.0, 1.0});
  part.vertex({7.0, 2.0, 2.0});  // on the line through the previous two
  part.triangle(a, a + 1, a + 2, -1);
  part.triangle(d, d + 1, d + 2, -1);
  const SolidCheck c = check(part).at(0);
  EXPECT_EQ(c.degenerate_triangles, 1u);
  EXPECT_EQ(c.components, 2u);
  EXPECT_EQ(c.open_edges, 6u);
  EXPECT_EQ(c.euler_characteristic, 6 - 6 + 2);
  ASSERT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_EQ(c.cgal_self_intersections, 0u);  // CGAL pairs the collinear face with itself: not counted
}

TEST(SolidCheck, BadInputThrows) {
  Part part;
  add_box(part, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, 0);
  part.solid.pop_back();
  EXPECT_THROW(check(part), InputError);
  part.solid.push_back(0);
  part.boundary.push_back({0, 8});
  EXPECT_THROW(check(part), InputError);
  part.boundary.clear();
  part.mesh.triangles[0][0] = 8;
  EXPECT_THROW(check(part), InputError);
}

// Scale: a million-triangle torus, self-intersections included, in seconds.
TEST(SolidCheck, MillionTriangleTorus) {
  const int n = 1000, m = 500;
  const double R = 10.0, s = 2.0;
  Part part;
  add_torus(part, n, m, R, s, 0.0, 0);
  const auto start = std::chrono::steady_clock::now();
  const SolidCheck c = check(part).at(0);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("check_solids on %zu triangles: %.2f s\n", part.mesh.triangles.size(), seconds);
  EXPECT_EQ(c.triangles, uint64_t(2 * n * m));
  EXPECT_EQ(c.euler_characteristic, 0);
  EXPECT_TRUE(c.closed);
  const double volume = torus_volume(n, m, R, s);
  EXPECT_NEAR(c.signed_volume, volume, 1e-9 * volume);
  ASSERT_TRUE(c.cgal_checked) << c.cgal_note;
  EXPECT_TRUE(c.cgal_outward);
  EXPECT_EQ(c.cgal_self_intersections, 0u);
  EXPECT_NEAR(c.cgal_volume, volume, 1e-9 * volume);
}

}  // namespace
}  // namespace sagitta
