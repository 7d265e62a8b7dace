// PN triangles (issue 4): the PN surface at corners and edges on random triangles, the integer and
// fractional_odd patterns, crack-freeness on real meshes, creases (basic vs AEN) and surface data.
#include "sagitta/evaluate.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/mesh_normals.hpp"
#include "sagitta/model.hpp"
#include "sagitta/pn.hpp"
#include "sagitta/uniform.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cstring>
#include <random>

namespace sagitta {
namespace {

using test::count_topology;
using test::shared_data;
using namespace detail;  // the PN triangle and the patterns

Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  for (;;) {
    const Vec3 v(g(rng), g(rng), g(rng));
    if (glm::length(v) > 1e-3) return glm::normalize(v);
  }
}

struct RandomTriangle {
  std::array<Vec3, 3> p;
  std::array<Vec3, 3> n;
};

// A non-degenerate triangle with normals tilted up to ~35 degrees from its face normal.
RandomTriangle random_triangle(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (;;) {
    RandomTriangle t;
    for (Vec3& p : t.p) p = Vec3(u(rng), u(rng), u(rng)) * 3.0 + Vec3(10.0, -5.0, 2.0);
    const Vec3 face = glm::cross(t.p[1] - t.p[0], t.p[2] - t.p[0]);
    if (glm::length(face) < 0.5) continue;
    for (Vec3& n : t.n) n = glm::normalize(glm::normalize(face) + 0.35 * random_unit(rng));
    return t;
  }
}

bool same_bits(const Vec3& a, const Vec3& b) { return std::memcmp(&a, &b, sizeof(Vec3)) == 0; }

// Vlachos' boundary curve written out independently of pn_edge: Bernstein form with
// c0 = (2 p0 + p1 - ((p1 - p0) . n0) n0) / 3 and c1 likewise.
Vec3 reference_edge_point(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1, double t) {
  const Vec3 c0 = (p0 * 2.0 + p1 - n0 * glm::dot(p1 - p0, n0)) / 3.0;
  const Vec3 c1 = (p1 * 2.0 + p0 - n1 * glm::dot(p0 - p1, n1)) / 3.0;
  const double s = 1.0 - t;
  return p0 * (s * s * s) + c0 * (3 * s * s * t) + c1 * (3 * s * t * t) + p1 * (t * t * t);
}

TEST(PnSurface, InterpolatesCornersAndNormalsAndIsTangentThere) {
  std::mt19937_64 rng(20260422);
  for (int trial = 0; trial < 200; ++trial) {
    const RandomTriangle rt = random_triangle(rng);
    const PnTriangle pn = pn_triangle(rt.p, rt.n);
    for (int c = 0; c < 3; ++c) {
      Bary b(0.0);
      b[c] = 1.0;
      EXPECT_TRUE(same_bits(pn_position(pn, b), rt.p[c])) << "corner " << c;
      EXPECT_LT(glm::length(pn_normal(pn, b) - rt.n[c]), 1e-14);
      // Finite-difference tangents towards both other corners are orthogonal to the vertex normal.
      for (int d = 1; d <= 2; ++d) {
        const double h = 1e-6;
        Bary bh = b;
        bh[c] -= h;
        bh[(c + d) % 3] += h;
        const Vec3 tangent = (pn_position(pn, bh) - rt.p[c]) / h;
        EXPECT_LT(std::abs(glm::dot(tangent, rt.n[c])) / glm::length(tangent), 1e-5) << "trial " << trial;
      }
    }
  }
}

TEST(PnSurface, EdgeCurveDependsOnlyOnTheEdge) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 100; ++trial) {
    const RandomTriangle a = random_triangle(rng);
    // A second triangle across edge (p0, p1), wound the other way, with a different third vertex.
    const Vec3 mid = 0.5 * (a.p[0] + a.p[1]);
    const Vec3 apex = mid - (a.p[2] - mid) + Vec3(u(rng), u(rng), u(rng));
    const Vec3 apex_normal = random_unit(rng);
    const PnTriangle t1 = pn_triangle(a.p, a.n);
    const PnTriangle t2 = pn_triangle({a.p[1], a.p[0], apex}, {a.n[1], a.n[0], apex_normal});
    for (int q = 0; q <= 16; ++q) {
      const double t = q / 16.0;
      const Vec3 ref = reference_edge_point(a.p[0], a.n[0], a.p[1], a.n[1], t);
      EXPECT_LT(glm::length(pn_position(t1, Bary(1 - t, t, 0)) - ref), 1e-12);
      EXPECT_LT(glm::length(pn_position(t2, Bary(t, 1 - t, 0)) - ref), 1e-12);
      EXPECT_LT(glm::length(pn_normal(t1, Bary(1 - t, t, 0)) - pn_normal(t2, Bary(t, 1 - t, 0))), 1e-12);
    }

    // Through the scheme: each triangle tessellated on its own; the shared edge's samples are
    // bit-identical, and tessellating both together shares them (no open edge inside).
    Tessellation m1, m2, both;
    m1.positions = {a.p[0], a.p[1], a.p[2]};
    m1.normals = {a.n[0], a.n[1], a.n[2]};
    m1.triangles = {{0, 1, 2}};
    m2.positions = {a.p[1], a.p[0], apex};
    m2.normals = {a.n[1], a.n[0], apex_normal};
    m2.triangles = {{0, 1, 2}};
    both.positions = {a.p[0], a.p[1], a.p[2], apex};
    both.normals = {a.n[0], a.n[1], a.n[2], apex_normal};
    both.triangles = {{0, 1, 2}, {1, 0, 3}};
    PnParams params;
    params.factor = 5;
    const Tessellation o1 = tessellate_pn(m1, params), o2 = tessellate_pn(m2, params);
    size_t matched = 0;
    for (const Vec3& x : o1.positions) {
      for (const Vec3& y : o2.positions) matched += same_bits(x, y) ? 1 : 0;
    }
    EXPECT_EQ(matched, 6u) << "2 corners + 4 edge samples shared bit for bit";
    const auto counts = count_topology(tessellate_pn(both, params));
    EXPECT_EQ(counts.open_edges, 4u * 5u);
    EXPECT_EQ(counts.misoriented_edges, 0u);
  }
}

TEST(PnPattern, IntegerPatternCountsAndSides) {
  for (int k = 1; k <= 9; ++k) {
    const TrianglePattern p = integer_pattern(k);
    EXPECT_EQ(p.triangles.size(), static_cast<size_t>(k * k));
    EXPECT_EQ(p.vertices.size(), static_cast<size_t>((k + 1) * (k + 2) / 2));
    for (int s = 0; s < 3; ++s) {
      ASSERT_EQ(p.side[s].size(), static_cast<size_t>(k + 1));
      for (size_t q = 0; q <= static_cast<size_t>(k); ++q) {
        const Bary& b = p.vertices[p.side[s][q]];
        EXPECT_EQ(b[(s + 2) % 3], 0.0);
        EXPECT_NEAR(b[(s + 1) % 3], static_cast<double>(q) / k, 1e-15);
      }
    }
  }
}

// Checks a pattern is a triangulation of the reference triangle: every triangle counter-clockwise
// with positive area, areas summing to the whole, a disc (Euler 1) with 3 * segments open edges.
void expect_valid_pattern(const TrianglePattern& p, size_t boundary_segments) {
  double area = 0.0;
  for (const Triangle& t : p.triangles) {
    const Bary& a = p.vertices[t[0]];
    const Bary& b = p.vertices[t[1]];
    const Bary& c = p.vertices[t[2]];
    const double signed_area = 0.5 * ((b[1] - a[1]) * (c[2] - a[2]) - (c[1] - a[1]) * (b[2] - a[2]));
    EXPECT_GT(signed_area, 0.0);
    area += signed_area;
  }
  EXPECT_NEAR(area, 0.5, 1e-12);
  Tessellation mesh;
  mesh.triangles = p.triangles;
  const auto c = count_topology(mesh);
  EXPECT_EQ(c.open_edges, boundary_segments);
  EXPECT_EQ(c.nonmanifold_edges, 0u);
  EXPECT_EQ(c.misoriented_edges, 0u);
  EXPECT_EQ(c.euler(), 1);
}

TEST(PnPattern, FractionalOddEdgeParameters) {
  for (int n = 1; n <= 63; n += 2) {
    const std::vector<double> t = fractional_odd_edge_params(n);
    ASSERT_EQ(t.size(), static_cast<size_t>(n + 1));
    for (int q = 0; q <= n; ++q) EXPECT_EQ(t[static_cast<size_t>(q)], static_cast<double>(q) / n);
  }
  // f = 2.5: three segments, the two new ones at the ends, each 3/4 of the way to a third.
  const std::vector<double> t25 = fractional_odd_edge_params(2.5);
  ASSERT_EQ(t25.size(), 4u);
  EXPECT_DOUBLE_EQ(t25[1], 0.25);
  EXPECT_DOUBLE_EQ(t25[2], 0.75);
  for (double f = 1.0; f <= 63.0; f += 0.37) {
    const std::vector<double> t = fractional_odd_edge_params(f);
    const int n = static_cast<int>(t.size()) - 1;
    EXPECT_EQ(n % 2, 1);
    EXPECT_GE(n, f);
    EXPECT_LT(n, f + 2.0);
    EXPECT_EQ(n, fractional_odd_segments(f));
    EXPECT_EQ(t.front(), 0.0);
    EXPECT_EQ(t.back(), 1.0);
    for (int q = 0; q < n; ++q) EXPECT_LT(t[static_cast<size_t>(q)], t[static_cast<size_t>(q + 1)]) << f;
    for (int q = 0; q <= n; ++q) EXPECT_NEAR(t[static_cast<size_t>(n - q)], 1.0 - t[static_cast<size_t>(q)], 1e-15);
  }
}

TEST(PnPattern, FractionalOddTrianglesAreValidAndMonotone) {
  size_t previous = 0;
  for (double f = 1.0; f <= 21.0; f += 0.25) {
    const TrianglePattern p = fractional_odd_pattern({f, f, f}, f);
    expect_valid_pattern(p, 3 * static_cast<size_t>(fractional_odd_segments(f)));
    EXPECT_GE(p.triangles.size(), previous) << "f = " << f;
    previous = p.triangles.size();
  }
  // Odd integer n = 2m + 1: rings with n, n - 2, ..., 1 segments per side; by Euler's formula on
  // the disc (F = 2V - 2 - B, V = 3 (n + (n - 2) + ... + 1) = 3 (m + 1)^2, B = 3n) that is
  // 1 + 6 m (m + 1) triangles: equal to the integer pattern's k^2 only at n = 1.
  for (int m = 0; m <= 10; ++m) {
    const int n = 2 * m + 1;
    const TrianglePattern p = fractional_odd_pattern({double(n), double(n), double(n)}, n);
    EXPECT_EQ(p.vertices.size(), static_cast<size_t>(3 * (m + 1) * (m + 1)));
    EXPECT_EQ(p.triangles.size(), static_cast<size_t>(1 + 6 * m * (m + 1)));
    // Its sides carry the same points as the integer pattern with k = n: the two can be neighbours.
    const TrianglePattern ip = integer_pattern(n);
    for (int s = 0; s < 3; ++s) {
      for (size_t q = 0; q < p.side[s].size(); ++q) {
        EXPECT_EQ(p.vertices[p.side[s][q]][(s + 1) % 3], ip.vertices[ip.side[s][q]][(s + 1) % 3]);
      }
    }
  }
  EXPECT_EQ(fractional_odd_pattern({1, 1, 1}, 1).triangles.size(), integer_pattern(1).triangles.size());
  // Different outer and inside factors still make a valid triangulation.
  expect_valid_pattern(fractional_odd_pattern({1.0, 7.3, 3.0}, 5.5), 1 + 9 + 3);
  expect_valid_pattern(fractional_odd_pattern({4.0, 4.0, 2.0}, 1.0), 5 + 5 + 3);
}

Tessellation read_spot() { return io::read_mesh(shared_data("mesh/spot_triangulated.obj")); }

TEST(PnScheme, SpotIntegerLevelsAreClosed) {
  const std::string path = shared_data("mesh/spot_triangulated.obj");
  SAGITTA_REQUIRE_DATA(path);
  const Tessellation spot = read_spot();
  ASSERT_EQ(spot.triangles.size(), 5856u);
  for (int k = 1; k <= 4; ++k) {
    PnParams params;
    params.factor = k;
    PnStats stats;
    const Tessellation out = tessellate_pn(spot, params, &stats);
    EXPECT_EQ(out.triangles.size(), 5856u * k * k);
    EXPECT_EQ(out.normals.size(), out.positions.size());
    const auto c = count_topology(out);
    EXPECT_EQ(c.open_edges, 0u) << "k = " << k;
    EXPECT_EQ(c.nonmanifold_edges, 0u);
    EXPECT_EQ(c.misoriented_edges, 0u);
    EXPECT_EQ(c.euler(), 2);
    EXPECT_EQ(stats.open_edges, 0u);
    EXPECT_EQ(stats.crease_edges, 0u);
    for (const Vec3& n : out.normals) ASSERT_NEAR(glm::length(n), 1.0, 1e-12);
  }
}

TEST(PnScheme, SpotFractionalOddIsClosed) {
  const std::string path = shared_data("mesh/spot_triangulated.obj");
  SAGITTA_REQUIRE_DATA(path);
  const Tessellation spot = read_spot();
  for (double f : {1.0, 2.5, 3.0, 4.2}) {
    PnParams params;
    params.pattern = PnPatternKind::kFractionalOdd;
    params.factor = f;
    const Tessellation out = tessellate_pn(spot, params);
    EXPECT_EQ(out.triangles.size(), 5856u * fractional_odd_pattern({f, f, f}, f).triangles.size());
    const auto c = count_topology(out);
    EXPECT_EQ(c.open_edges, 0u) << "f = " << f;
    EXPECT_EQ(c.nonmanifold_edges, 0u);
    EXPECT_EQ(c.misoriented_edges, 0u);
    EXPECT_EQ(c.euler(), 2);
  }
}

TEST(PnScheme, CubeWithFaceNormalsCracksInBasicAndClosesInAen) {
  const std::string path = shared_data("mesh/cube.obj");
  SAGITTA_REQUIRE_DATA(path);
  const Tessellation cube = split_face_normals(io::read_mesh(path));
  ASSERT_EQ(cube.triangles.size(), 12u);
  for (int k = 1; k <= 4; ++k) {
    PnParams params;
    params.factor = k;
    PnStats basic_stats, aen_stats;
    const Tessellation basic = tessellate_pn(cube, params, &basic_stats);
    // 12 cube edges, each split into two one-sided edges of k segments; quad diagonals stay shared.
    EXPECT_EQ(count_topology(basic).open_edges, 24u * k);
    EXPECT_EQ(basic_stats.open_edges, 24u * k);
    EXPECT_EQ(basic_stats.crack_edges, 24u * k);
    EXPECT_EQ(basic_stats.crease_edges, 12u);
    // Face normals are orthogonal to every edge of their face: both sides' curves are the straight
    // edge, so the crack is topological (split vertices), with zero width.
    EXPECT_EQ(basic_stats.max_crack_gap, 0.0);

    params.variant = PnVariant::kAen;
    const Tessellation aen = tessellate_pn(cube, params, &aen_stats);
    const auto c = count_topology(aen);
    EXPECT_EQ(c.open_edges, 0u);
    EXPECT_EQ(c.nonmanifold_edges, 0u);
    EXPECT_EQ(c.misoriented_edges, 0u);
    EXPECT_EQ(c.euler(), 2);
    EXPECT_EQ(aen.triangles.size(), 12u * k * k);
    EXPECT_EQ(aen_stats.crease_edges, 12u);
  }
}

TEST(PnScheme, SplitNormalsOpenWideCracksThatAenCloses) {
  // An octahedron whose corners carry a different, tilted normal in each face: every edge is a
  // crease and the two sides' curves bulge differently.
  const std::vector<Vec3> p = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const std::vector<Triangle> faces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  Tessellation mesh;
  for (const Triangle& f : faces) {
    const Vec3 face = glm::normalize(glm::cross(p[f[1]] - p[f[0]], p[f[2]] - p[f[0]]));
    const uint32_t first = static_cast<uint32_t>(mesh.positions.size());
    for (uint32_t v : f) {
      mesh.positions.push_back(p[v]);
      mesh.normals.push_back(glm::normalize(face + p[v]));  // between face and radial direction
    }
    mesh.triangles.push_back({first, first + 1, first + 2});
  }
  PnParams params;
  params.factor = 4;
  PnStats basic;
  const auto cb = count_topology(tessellate_pn(mesh, params, &basic));
  EXPECT_EQ(cb.open_edges, 2u * 12u * 4u);
  EXPECT_EQ(basic.crease_edges, 12u);
  EXPECT_GT(basic.max_crack_gap, 1e-3);
  params.variant = PnVariant::kAen;
  const Tessellation aen = tessellate_pn(mesh, params);
  const auto ca = count_topology(aen);
  EXPECT_EQ(ca.open_edges, 0u);
  EXPECT_EQ(ca.euler(), 2);
  // Where the normals agree (a smooth mesh), AEN reproduces the basic surface exactly.
  Tessellation smooth = mesh;
  smooth.normals.clear();
  PnParams pb;
  pb.factor = 3;
  PnParams pa = pb;
  pa.variant = PnVariant::kAen;
  const Tessellation sb = tessellate_pn(smooth, pb), sa = tessellate_pn(smooth, pa);
  ASSERT_EQ(sb.triangles.size(), sa.triangles.size());
  EXPECT_EQ(count_topology(sb).open_edges, 0u);  // computed normals are per position: no creases
  for (size_t t = 0; t < sb.triangles.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_LT(glm::length(sb.positions[sb.triangles[t][c]] - sa.positions[sa.triangles[t][c]]), 1e-15);
    }
  }
}

TEST(PnScheme, CarriesSurfaceDataFromAUniformBase) {
  const Model model = fixtures::pillow_box();
  const Topology topology = build_topology(model);
  UniformParams up;
  up.segments = 2;
  const Tessellation base = tessellate_uniform(model, topology, up);
  PnParams params;
  params.factor = 3;
  const Tessellation out = tessellate_pn(base, params);
  ASSERT_TRUE(out.has_surface());
  ASSERT_EQ(out.triangle_patch.size(), out.triangles.size());
  ASSERT_EQ(out.surface_points.size(), out.positions.size());
  EXPECT_EQ(out.triangles.size(), base.triangles.size() * 9);
  const auto c = count_topology(out);
  EXPECT_EQ(c.open_edges, 0u);
  EXPECT_EQ(c.euler(), 2);
  const double size = model_box(model).diagonal();
  for (size_t t = 0; t < out.triangles.size(); ++t) {
    const BezierPatch& patch = model.patches[out.triangle_patch[t]];
    for (int k = 0; k < 3; ++k) {
      const Vec2 uv = out.triangle_uv[t][k];
      ASSERT_GE(uv.x, -1e-15);
      ASSERT_LE(uv.x, 1 + 1e-15);
      // Each vertex is close to the exact surface at its interpolated parameter: PN approximates
      // the surface from exact points and normals (the base has only 2 segments per patch side).
      const auto s = de_casteljau<double>(patch, uv.x, uv.y);
      EXPECT_LT(glm::length(Vec3(s[0], s[1], s[2]) - out.positions[out.triangles[t][k]]), 0.05 * size);
    }
  }
  // Every vertex records a (patch, u, v) near it; vertices of the base lie exactly there.
  for (size_t v = 0; v < out.positions.size(); ++v) {
    const SurfacePoint& sp = out.surface_points[v];
    ASSERT_LT(sp.patch, model.patches.size());
    const auto s = de_casteljau<double>(model.patches[sp.patch], sp.u, sp.v);
    EXPECT_LT(glm::length(Vec3(s[0], s[1], s[2]) - out.positions[v]), 0.05 * size);
  }
  for (size_t v = 0; v < base.positions.size(); ++v) {
    const SurfacePoint& sp = out.surface_points[v];
    const auto s = de_casteljau<double>(model.patches[sp.patch], sp.u, sp.v);
    EXPECT_LT(glm::length(Vec3(s[0], s[1], s[2]) - out.positions[v]), 1e-12 * size);
  }
}

TEST(PnScheme, RejectsBadInput) {
  Tessellation t;
  t.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  t.triangles = {{0, 1, 2}};
  PnParams params;
  params.factor = 0;
  EXPECT_THROW(tessellate_pn(t, params), InputError);
  params.factor = 2.5;
  EXPECT_THROW(tessellate_pn(t, params), InputError);  // integer pattern needs a whole number
  params.pattern = PnPatternKind::kFractionalOdd;
  params.factor = 64;
  EXPECT_THROW(tessellate_pn(t, params), InputError);
  params.factor = 2.5;
  EXPECT_NO_THROW(tessellate_pn(t, params));
  t.normals = {{0, 0, 1}, {0, 0, 0}, {0, 0, 1}};
  EXPECT_THROW(tessellate_pn(t, params), InputError);
  t.normals.clear();
  t.triangles = {{0, 1, 3}};
  EXPECT_THROW(tessellate_pn(t, params), InputError);
}

}  // namespace
}  // namespace sagitta
