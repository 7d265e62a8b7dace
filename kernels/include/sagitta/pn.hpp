// Curved PN triangles (Vlachos, Peters, Boyd, Mitchell 2001; seed 002): every input triangle with
// vertex positions and normals becomes a cubic Bézier triangle (10 control points) with a quadratic
// normal field (6 coefficients), sampled on an integer or a Direct3D 11 fractional_odd pattern.
#pragma once

#include "sagitta/tessellation.hpp"

#include <array>
#include <string>
#include <vector>

namespace sagitta {

// Largest factor Direct3D 11 accepts; larger factors are clamped to it, smaller than 1 to 1.
inline constexpr double kMaxTessFactor = 63.0;

// The PN triangle and the patterns are the scheme's building blocks, exported for its tests only.
namespace detail {

// ---- The PN triangle --------------------------------------------------------------------------

// Barycentric coordinates (b0, b1, b2) weight corners 0, 1, 2; b0 + b1 + b2 = 1.
using Bary = glm::dvec3;

// One edge of a PN triangle, read from p0 to p1: the cubic Bézier boundary curve (p0, c0, c1, p1)
// and the quadratic normal coefficients (n0, n01, n1). Depends on the two end points and their
// normals only, which is what makes neighbours sharing both agree.
struct PnEdge {
  Vec3 p0{0.0}, c0{0.0}, c1{0.0}, p1{0.0};
  Vec3 n0{0.0}, n01{0.0}, n1{0.0};
};

// Vlachos' edge control points: c0 = (2 p0 + p1 - w01 n0) / 3 with w01 = (p1 - p0) . n0 (the
// projection of the third-point onto the tangent plane at p0), likewise c1; n01 is the average
// normal reflected across the plane perpendicular to the edge, normalised. A zero-length edge gets
// n01 = normalize(n0 + n1). n0 and n1 must be unit vectors.
PnEdge pn_edge(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1);

// Point and unit normal of the edge at parameter t (0 at p0), from the edge alone. Deterministic:
// the same edge and t give bit-identical results, whichever triangle asks.
Vec3 pn_edge_position(const PnEdge& edge, double t);
Vec3 pn_edge_normal(const PnEdge& edge, double t);

// A full PN triangle. Cubic control points b[ijk] (exponents of b0, b1, b2) are stored as
// b300, b030, b003, b210, b120, b021, b012, b102, b201, b111 (the thesis' order); quadratic normal
// coefficients as n200, n020, n002, n110, n011, n101.
struct PnTriangle {
  std::array<Vec3, 10> b;
  std::array<Vec3, 6> n;
};
enum PnControl : int { k300, k030, k003, k210, k120, k021, k012, k102, k201, k111 };
enum PnNormal : int { k200, k020, k002, k110, k011, k101 };

// Control points from three corners with unit normals (the seed's Appendix C / Vlachos): edge
// points from pn_edge, centre b111 = E + (E - V) / 2 with E the mean of the six edge points and V
// the mean of the corners.
PnTriangle pn_triangle(const std::array<Vec3, 3>& p, const std::array<Vec3, 3>& n);
// The same with the six edge points given (PN-AEN's averaged edges); edges[s] runs from corner s
// to corner (s + 1) % 3.
PnTriangle pn_triangle(const std::array<PnEdge, 3>& edges);

// Position (cubic) and unit normal (quadratic, normalised; Vlachos' weights, all 1) at b.
Vec3 pn_position(const PnTriangle& t, const Bary& b);
Vec3 pn_normal(const PnTriangle& t, const Bary& b);

// ---- Patterns on the triangle domain ------------------------------------------------------------

// A triangulation of the reference triangle. Vertices are barycentric coordinates; triangles are
// counter-clockwise in the (corner 0, corner 1, corner 2) orientation. side[s] lists the vertex
// ids on side s (corner s to corner (s + 1) % 3) in that order, both corners included; on side s
// the coordinate of corner (s + 2) % 3 is exactly 0 and the parameter along it is b[(s + 1) % 3].
struct TrianglePattern {
  std::vector<Bary> vertices;
  std::vector<Triangle> triangles;
  std::array<std::vector<uint32_t>, 3> side;
};

// Integer partition: k >= 1 segments per side, (k + 1)(k + 2) / 2 vertices, k^2 triangles.
TrianglePattern integer_pattern(int k);

// Parameters in [0, 1] of the points on an edge with a fractional_odd factor f: the segment count
// is the smallest odd integer >= f; at a non-odd f two segments are shorter and grow as f rises,
// placed by D3D11's ruler-function split point. Symmetric: t[N - q] = 1 - t[q] (exactly at odd
// integer factors, where t[q] = q / N). See docs/PN.md for the reconstruction.
std::vector<double> fractional_odd_edge_params(double factor);
// Segments on an edge for a fractional_odd factor (odd, 1..63).
int fractional_odd_segments(double factor);

// The D3D11 triangle-domain pattern for fractional_odd partitioning: outer[s] is the factor of
// side s, `inside` the inside factor. The outer ring carries the edge parameters of each side's
// factor; inner rings come from the inside factor, each ring shrunk towards the centre as in D3D11,
// down to a single centre triangle. Adjacent rings are stitched by a zipper that advances along
// the ring with the smaller next parameter (same triangle count as D3D11; diagonals may differ).
TrianglePattern fractional_odd_pattern(const std::array<double, 3>& outer, double inside);

}  // namespace detail

// ---- The scheme ---------------------------------------------------------------------------------

enum class PnPatternKind { kInteger, kFractionalOdd };
enum class PnVariant { kBasic, kAen };

struct PnParams {
  PnPatternKind pattern = PnPatternKind::kInteger;
  double factor = 2.0;  // integer: segments k per edge (a whole number >= 1); fractional_odd: 1..63
  PnVariant variant = PnVariant::kBasic;
};

struct PnStats {
  size_t input_triangles = 0;
  size_t skipped_triangles = 0;  // input triangles with two corners at one vertex: not refined
  size_t edges = 0;              // distinct input edges after matching (see tessellate_pn)
  size_t crease_edges = 0;       // edges whose two sides have the same positions but different normals
  size_t open_edges = 0;         // output edges used by one triangle: model boundary plus cracks
  size_t crack_edges = 0;        // of those, the output segments on crease edges (basic variant only)
  double max_crack_gap = 0.0;    // largest distance between the two sides' curves on a crease edge
  int segments_per_edge = 0;
};

// Refines a triangle mesh (positions, triangles, optional normals) into PN triangles.
// Normals: the input's (normalised), or angle_weighted_normals when the input has none.
// Guarantees:
// - Basic: input vertices with bit-identical position and normal are one vertex; an edge between
//   two such vertices is sampled once from pn_edge in a canonical direction (the lexicographically
//   smaller (position, normal) first) and indexed once, so neighbours sharing position and normal
//   are crack-free by construction, with no welding. Edges whose normals differ across the edge
//   (creases) stay open: counted in stats.crease_edges / crack_edges / max_crack_gap.
// - AEN: vertices are matched by exact position only; each edge's control points are the average
//   of those computed from every adjacent triangle's normals (PN-AEN), and the output vertex normal
//   on a crease is the normalised average of the sides' normals. No cracks at creases.
// - Output normals are the quadratic normal field; triangles keep the input orientation.
// - Surface data: when `base` has triangle_patch/triangle_uv, each output triangle takes its base
//   triangle's patch and the barycentric interpolation of its triangle_uv; surface_points (when
//   `base` has them) are filled the same way (a vertex shared by several base triangles records one).
// Throws InputError for a bad factor, an out-of-range index, non-finite data or a zero normal.
Tessellation tessellate_pn(const Tessellation& base, const PnParams& params, PnStats* stats = nullptr);

// Output triangles tessellate_pn makes per input triangle.
uint64_t pn_triangles_per_input(const PnParams& params);

}  // namespace sagitta
