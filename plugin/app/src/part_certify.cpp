// The distance certificate of a whole part, face by face (sagitta/app/part.hpp, docs/VALIDATION.md).
#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"
#include "sagitta/app/part.hpp"
#include "sagitta/app/report.hpp"
#include "sagitta/app/validate.hpp"
#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"
#include "sagitta/grid_cut.hpp"

#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <queue>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace sagitta::app {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kUnit = std::numeric_limits<double>::epsilon();
// How far a triangle's (u, v) may lie outside [0, 1]^2 of its patch and still be clamped onto it.
constexpr double kUvTolerance = 1e-12;

using FaceTriangles = std::vector<std::vector<uint32_t>>;

// ---------------------------------------------------------------------------------------------
// The "patch" route: faces kept whole by the scheme, certified together against their patches.

// The sub-mesh of some faces' triangles and the sub-model of their patches (patch indices renumbered,
// (u, v) clamped onto [0, 1]^2). part_triangle[k] is sub-triangle k's index in the part.
struct SubPart {
  Model model;
  Tessellation mesh;
  std::vector<uint32_t> part_triangle;
  double snapped = 0.0;  // the largest control-point move of snap_collapsed_sides
};

// A side whose control points all lie within 1e-4 of the patch's size of its first one is made
// exactly collapsed, so that the certifier recognises it (it reconstructs the triangles a scheme
// drops there): a sphere's or cone's pole after OCCT's conversion (equal but for rounding), or a
// B-spline face closing at a degenerated edge within the B-rep's tolerance (shell1: 1e-6 apart,
// where the mesh has one vertex). The surface moves by at most the largest control-point move (a
// convex combination, weights positive), returned and added to the bounds.
double snap_collapsed_sides(BezierPatch& patch) {
  const double tol = 1e-4 * control_box(patch).diagonal();
  double moved = 0.0;
  const int n = patch.degree_u, m = patch.degree_v;
  const auto snap = [&](auto&& point, int count) {
    double spread = 0.0;
    for (int k = 1; k <= count; ++k) spread = std::max(spread, glm::length(point(k) - point(0)));
    if (!(spread <= tol) || spread == 0.0) return;
    for (int k = 1; k <= count; ++k) point(k) = point(0);
    moved = std::max(moved, spread);
  };
  snap([&](int k) -> Vec3& { return patch.at(0, k); }, m);
  snap([&](int k) -> Vec3& { return patch.at(n, k); }, m);
  snap([&](int k) -> Vec3& { return patch.at(k, 0); }, n);
  snap([&](int k) -> Vec3& { return patch.at(k, m); }, n);
  return moved;
}

SubPart sub_part(const occt::PartMesh& part, const std::vector<int>& faces, const FaceTriangles& face_triangles) {
  SubPart sub;
  sub.model.name = part.name;
  std::vector<int64_t> patch_map(part.model.patches.size(), -1), vertex_map(part.mesh.positions.size(), -1);
  for (const int face : faces) {
    const occt::PartFace& f = part.faces[static_cast<size_t>(face)];
    for (int p = f.first_patch; p < f.first_patch + f.patch_count; ++p) {
      patch_map[static_cast<size_t>(p)] = static_cast<int64_t>(sub.model.patches.size());
      sub.model.patches.push_back(part.model.patches[static_cast<size_t>(p)]);
      sub.snapped = std::max(sub.snapped, snap_collapsed_sides(sub.model.patches.back()));
    }
    for (const uint32_t t : face_triangles[static_cast<size_t>(face)]) {
      Triangle tri{};
      for (int c = 0; c < 3; ++c) {
        int64_t& index = vertex_map[part.mesh.triangles[t][c]];
        if (index < 0) {
          index = static_cast<int64_t>(sub.mesh.positions.size());
          sub.mesh.positions.push_back(part.mesh.positions[part.mesh.triangles[t][c]]);
        }
        tri[c] = static_cast<uint32_t>(index);
      }
      std::array<Vec2, 3> uv = part.mesh.triangle_uv[t];
      for (Vec2& q : uv) q = {std::clamp(q.x, 0.0, 1.0), std::clamp(q.y, 0.0, 1.0)};
      sub.mesh.triangles.push_back(tri);
      sub.mesh.triangle_patch.push_back(static_cast<uint32_t>(patch_map[part.mesh.triangle_patch[t]]));
      sub.mesh.triangle_uv.push_back(uv);
      sub.part_triangle.push_back(t);
    }
  }
  return sub;
}

// A kept-whole face whose triangles all lie in [0, 1]^2 of the face's own patches.
bool inside_own_patches(const occt::PartMesh& part, const occt::PartFace& f, const std::vector<uint32_t>& triangles) {
  for (const uint32_t t : triangles) {
    const uint32_t patch = part.mesh.triangle_patch[t];
    if (patch < static_cast<uint32_t>(f.first_patch) || patch >= static_cast<uint32_t>(f.first_patch + f.patch_count))
      return false;
    for (const Vec2& q : part.mesh.triangle_uv[t]) {
      if (!(q.x >= -kUvTolerance && q.x <= 1.0 + kUvTolerance && q.y >= -kUvTolerance && q.y <= 1.0 + kUvTolerance))
        return false;
    }
  }
  return true;
}

// certify_distance over one face's triangles and patches (the patch route): coverage of every
// patch is the validator's own check (collapsed sides included).
FaceCertificate certify_patch_face(const occt::PartMesh& part, int face, const FaceTriangles& face_triangles,
                                   const CertifyOptions& options, std::vector<double>& triangle_upper) {
  FaceCertificate fc;
  fc.face = face;
  fc.route = "patch";
  const SubPart sub = sub_part(part, {face}, face_triangles);
  CertifyOptions face_options = options;
  // As on the loops route: no refinement below 1e-7 of the part's size. An exact face whose
  // parametrisation is not affine over its triangles (a flat lofted B-spline side: bilinear) has
  // distance ~0 and leaf bounds of second order in their size; with this floor alone drafted_pocket's
  // loft sides still took 8 s each (26-31 s before): what stops them is certify_distance keeping the
  // first pass's bounds when nothing above the floor is seen.
  if (face_options.refine_floor <= 0.0) {
    const double face_size = model_box(sub.model).diagonal();
    face_options.refine_floor = face_size > 0.0 ? 1e-7 * model_box(part.model).diagonal() / face_size : 0.0;
  }
  DistanceReport d = certify_distance(sub.model, sub.mesh, face_options);
  if (sub.snapped > 0.0) {
    // Measured against the snapped surface, which lies within sub.snapped of the face's.
    for (DistanceInterval* i : {&d.mesh_to_surface, &d.surface_to_mesh, &d.hausdorff}) {
      i->lower = std::max(0.0, i->lower - sub.snapped);
      i->upper += sub.snapped;
    }
    for (double& u : d.triangle_upper) u += sub.snapped;
    check_distance_report(d);
  }
  fc.mesh_to_surface = d.mesh_to_surface, fc.surface_to_mesh = d.surface_to_mesh, fc.hausdorff = d.hausdorff;
  fc.certified = d.hausdorff.certified;
  if (!fc.certified) {
    fc.reason = "not certified: " + (d.not_certified_reason.empty() ? d.coverage_note : d.not_certified_reason);
    return fc;
  }
  for (size_t k = 0; k < sub.part_triangle.size(); ++k) triangle_upper[sub.part_triangle[k]] = d.triangle_upper[k];
  return fc;
}

// ---------------------------------------------------------------------------------------------
// The "loops" route.

// The face's patch grid, its periods and (U, V) <-> patch-local maps.
struct Grid {
  const occt::PartFace& f;
  size_t nu = 0, nv = 0;
  explicit Grid(const occt::PartFace& face)
      : f(face),
        nu(face.u_breaks.size() > 1 ? face.u_breaks.size() - 1 : 0),
        nv(face.v_breaks.size() > 1 ? face.v_breaks.size() - 1 : 0) {}
  // (U, V) of a point (s, t) of the face's patch `local` (0-based in the face).
  Vec2 to_uv(uint32_t local, const Vec2& st) const {
    const size_t i = local / nv, j = local % nv;
    const double s = f.reversed ? 1.0 - st.x : st.x;
    return Vec2((1.0 - s) * f.u_breaks[i] + s * f.u_breaks[i + 1], (1.0 - st.y) * f.v_breaks[j] + st.y * f.v_breaks[j + 1]);
  }
  double range() const {
    return std::max(f.u_breaks.back() - f.u_breaks.front(), f.v_breaks.back() - f.v_breaks.front());
  }
};

// A face's triangles cut along its patch grid: every piece lies in one patch (local (s, t) clamped
// onto [0, 1]^2 against rounding), its corners are the triangle's own affine points, so the pieces
// of a triangle tile the same mesh triangle.
struct Pieces {
  Tessellation mesh;             // 3 own vertices per piece; triangle_patch is the face-local patch
  std::vector<uint32_t> source;  // per piece: index into the face's triangle list
};

Pieces cut_along_grid(const occt::PartMesh& part, const Grid& g, const std::vector<Triangle>& vertices,
                      const std::vector<std::array<Vec2, 3>>& corner_uv) {
  const PatchGrid cells{g.f.u_breaks, g.f.v_breaks, g.f.u_period, g.f.v_period, g.f.reversed};
  Pieces out;
  for (size_t k = 0; k < vertices.size(); ++k) {
    const Triangle& tri = vertices[k];
    const Vec3 X[3] = {part.mesh.positions[tri[0]], part.mesh.positions[tri[1]], part.mesh.positions[tri[2]]};
    for (const GridPiece& piece : sagitta::cut_along_grid(corner_uv[k], cells)) {
      const uint32_t base = static_cast<uint32_t>(out.mesh.positions.size());
      for (const Vec3& w : piece.barycentric) out.mesh.positions.push_back(w.x * X[0] + w.y * X[1] + w.z * X[2]);
      out.mesh.triangles.push_back({base, base + 1, base + 2});
      out.mesh.triangle_patch.push_back(piece.patch);
      out.mesh.triangle_uv.push_back(piece.st);
      out.source.push_back(static_cast<uint32_t>(k));
    }
  }
  return out;
}

// Bounds of the Gram matrix of DS = [S_U S_V] over the face's patches: uu >= |S_U|^2, vv >= |S_V|^2,
// uv >= |S_U . S_V|, from the control nets. For S = P / W, |S_s| <= (|(P - o W)_s| + |S - o| |W_s|) /
// min W, each term bounded by the derivative nets' largest entry (convex hull property). For a
// polynomial patch S_U and S_V lie in the hulls of their derivative nets, so |S_U . S_V| is at most
// the largest |d . e| over pairs of net entries (0 for a plane); for a rational one, |S_U| |S_V|.
struct Gram {
  double uu = 0.0, uv = 0.0, vv = 0.0;
};

double polynomial_cross_bound(const BezierPatch& patch) {
  std::vector<Vec3> du, dv;
  for (int i = 0; i < patch.rows(); ++i) {
    for (int j = 0; j < patch.cols(); ++j) {
      if (i + 1 < patch.rows()) du.push_back(double(patch.degree_u) * (patch.at(i + 1, j) - patch.at(i, j)));
      if (j + 1 < patch.cols()) dv.push_back(double(patch.degree_v) * (patch.at(i, j + 1) - patch.at(i, j)));
    }
  }
  double cross = 0.0;
  for (const Vec3& d : du) {
    for (const Vec3& e : dv) cross = std::max(cross, std::abs(glm::dot(d, e)));
  }
  return cross;
}

using Net = std::vector<glm::dvec4>;  // homogeneous control points (w x, w y, w z, w), row-major in u

Net homogeneous_net(const BezierPatch& patch) {
  Net net;
  for (int i = 0; i < patch.rows(); ++i) {
    for (int j = 0; j < patch.cols(); ++j) {
      const double w = patch.weight(i, j);
      net.push_back(glm::dvec4(w * patch.at(i, j), w));
    }
  }
  return net;
}

// The Gram bound of one (sub-)patch whose parameters span span_u x span_v of the face's (U, V),
// before the rounding margin; `slack` is added to each control-net difference (a sub-net's rounding).
Gram net_gram(const BezierPatch& patch, double span_u, double span_v, double slack) {
  Vec3 o(0.0);
  for (const Vec3& q : patch.points) o += q / double(patch.points.size());
  double wmin = kInf, radius = 0.0;
  for (int i = 0; i < patch.rows(); ++i) {
    for (int j = 0; j < patch.cols(); ++j) {
      wmin = std::min(wmin, patch.weight(i, j));
      radius = std::max(radius, glm::length(patch.at(i, j) - o));
    }
  }
  double du = 0.0, dv = 0.0, wu = 0.0, wv = 0.0;
  for (int i = 0; i < patch.rows(); ++i) {
    for (int j = 0; j < patch.cols(); ++j) {
      const Vec3 h = patch.weight(i, j) * (patch.at(i, j) - o);
      if (i + 1 < patch.rows()) {
        du = std::max(du, glm::length(patch.weight(i + 1, j) * (patch.at(i + 1, j) - o) - h));
        wu = std::max(wu, std::abs(patch.weight(i + 1, j) - patch.weight(i, j)));
      }
      if (j + 1 < patch.cols()) {
        dv = std::max(dv, glm::length(patch.weight(i, j + 1) * (patch.at(i, j + 1) - o) - h));
        wv = std::max(wv, std::abs(patch.weight(i, j + 1) - patch.weight(i, j)));
      }
    }
  }
  const double su = patch.degree_u * (du + slack + radius * wu) / wmin;
  const double sv = patch.degree_v * (dv + slack + radius * wv) / wmin;
  const double cross = patch.rational() || slack > 0.0 ? su * sv : polynomial_cross_bound(patch);
  return {(su / span_u) * (su / span_u), std::min(cross, su * sv) / (span_u * span_v), (sv / span_v) * (sv / span_v)};
}

// Per patch of the face (grid order): its Gram bound in the face's (U, V), before the rounding margin.
std::vector<Gram> patch_grams(const Model& model, const Grid& g) {
  std::vector<Gram> grams(model.patches.size());
  for (size_t p = 0; p < model.patches.size(); ++p) {
    const size_t i = p / g.nv, j = p % g.nv;
    grams[p] =
        net_gram(model.patches[p], g.f.u_breaks[i + 1] - g.f.u_breaks[i], g.f.v_breaks[j + 1] - g.f.v_breaks[j], 0.0);
  }
  return grams;
}

// The patch restricted to [s0, s1] x [t0, t1] of its own parameters (de Casteljau on the
// homogeneous net, both ends), and a bound on the rounding of its control points (weighted).
BezierPatch sub_patch(const BezierPatch& patch, double s0, double s1, double t0, double t1, double& rounding) {
  const int rows = patch.rows(), cols = patch.cols();
  Net h = homogeneous_net(patch);
  double size = 0.0, wmax = 0.0;
  for (const Vec3& q : patch.points) size = std::max({size, std::abs(q.x), std::abs(q.y), std::abs(q.z)});
  for (const glm::dvec4& q : h) wmax = std::max(wmax, q.w);
  // One line of n points restricted to [a, b]: de Casteljau at a leaves line[k] = the right part's
  // control point k, then de Casteljau of that at the rescaled b gives the left part's.
  const auto restrict_line = [](std::vector<glm::dvec4>& line, double a, double b) {
    const size_t n = line.size();
    for (size_t level = 1; level < n; ++level) {
      for (size_t k = 0; k + level < n; ++k) line[k] = (1.0 - a) * line[k] + a * line[k + 1];
    }
    const double c = a < 1.0 ? (b - a) / (1.0 - a) : 0.0;
    std::vector<glm::dvec4> left(n);
    for (size_t level = 0; level < n; ++level) {
      left[level] = line[0];
      for (size_t k = 0; k + 1 < n - level; ++k) line[k] = (1.0 - c) * line[k] + c * line[k + 1];
    }
    line = std::move(left);
  };
  std::vector<glm::dvec4> line;
  for (int j = 0; j < cols; ++j) {  // along u
    line.clear();
    for (int i = 0; i < rows; ++i) line.push_back(h[static_cast<size_t>(i * cols + j)]);
    restrict_line(line, s0, s1);
    for (int i = 0; i < rows; ++i) h[static_cast<size_t>(i * cols + j)] = line[static_cast<size_t>(i)];
  }
  for (int i = 0; i < rows; ++i) {  // along v
    line.assign(h.begin() + i * cols, h.begin() + (i + 1) * cols);
    restrict_line(line, t0, t1);
    std::copy(line.begin(), line.end(), h.begin() + i * cols);
  }
  BezierPatch sub = patch;
  for (size_t k = 0; k < h.size(); ++k) {
    sub.points[k] = Vec3(h[k]) / h[k].w;
    if (sub.rational()) sub.weights[k] = h[k].w;
  }
  // Each convex combination rounds by a unit; 4 (n + m) levels of them, through weights >= wmin.
  double wmin = kInf;
  for (size_t k = 0; k < h.size(); ++k) wmin = std::min(wmin, h[k].w);
  rounding = 64.0 * (rows + cols) * kUnit * (size + 1.0) * wmax / wmin;
  return sub;
}

// The cells [first, last) of `breaks` that [a, b] meets, clamped onto the grid (every cell for NaN).
std::pair<size_t, size_t> cell_span(const std::vector<double>& breaks, double a, double b) {
  const size_t n = breaks.size() - 1;
  size_t first = static_cast<size_t>(std::upper_bound(breaks.begin(), breaks.end(), a) - breaks.begin());
  size_t last = static_cast<size_t>(std::lower_bound(breaks.begin(), breaks.end(), b) - breaks.begin());
  first = first == 0 ? 0 : std::min(first - 1, n - 1);
  last = std::max(std::min(last, n), first + 1);
  if (!(a == a) || !(b == b)) first = 0, last = n;  // NaN: every cell
  return {first, last};
}

// The part of the cell [b0, b1] inside [a, b], as fractions of the cell (at least 1e-6 of it wide).
std::pair<double, double> cell_fraction(double b0, double b1, double a, double b) {
  double f0 = std::clamp((a - b0) / (b1 - b0), 0.0, 1.0), f1 = std::clamp((b - b0) / (b1 - b0), 0.0, 1.0);
  if (!(f0 == f0) || !(f1 == f1)) f0 = 0.0, f1 = 1.0;
  if (f1 - f0 < 1e-6) f0 = std::max(0.0, f1 - 1e-6), f1 = f0 + 1e-6;
  return {f0, f1};
}

// The Gram bound over a (U, V) box [lo, hi] inside the grid's range (gram_over's core): for each
// patch whose cell meets it, the sub-net over the part of the cell inside the box (the whole cell's
// bound when that part is most of it), with the rounding margin. Cells are clamped onto the grid.
Gram gram_over_in_range(const Model& model, const std::vector<Gram>& grams, const Grid& g, const Vec2& lo,
                        const Vec2& hi) {
  const auto [i0, i1] = cell_span(g.f.u_breaks, lo.x, hi.x);
  const auto [j0, j1] = cell_span(g.f.v_breaks, lo.y, hi.y);
  Gram gram;
  for (size_t i = i0; i < i1; ++i) {
    for (size_t j = j0; j < j1; ++j) {
      const size_t p = i * g.nv + j;
      Gram cell = grams[p];
      const double bu0 = g.f.u_breaks[i], bu1 = g.f.u_breaks[i + 1], bv0 = g.f.v_breaks[j], bv1 = g.f.v_breaks[j + 1];
      auto [s0, s1] = cell_fraction(bu0, bu1, lo.x, hi.x);
      const auto [t0, t1] = cell_fraction(bv0, bv1, lo.y, hi.y);
      if (s1 - s0 < 0.5 || t1 - t0 < 0.5) {
        if (g.f.reversed) std::tie(s0, s1) = std::pair<double, double>{1.0 - s1, 1.0 - s0};
        double rounding = 0.0;
        const BezierPatch sub = sub_patch(model.patches[p], s0, s1, t0, t1, rounding);
        const Gram local = net_gram(sub, (s1 - s0) * (bu1 - bu0), (t1 - t0) * (bv1 - bv0), rounding);
        if (std::isfinite(local.uu) && std::isfinite(local.vv) && std::isfinite(local.uv)) {
          cell = {std::min(cell.uu, local.uu), std::min(cell.uv, local.uv), std::min(cell.vv, local.vv)};
        }
      }
      gram.uu = std::max(gram.uu, cell.uu), gram.uv = std::max(gram.uv, cell.uv), gram.vv = std::max(gram.vv, cell.vv);
    }
  }
  const double margin = 1.0 + 256.0 * kUnit;
  return {gram.uu * margin, gram.uv * margin + 64.0 * kUnit * std::sqrt(gram.uu * gram.vv), gram.vv * margin};
}

// [lo, hi] of one direction as intervals inside [front, back]: in a periodic direction the box's
// copies whole periods away (a loop past the seam has (U, V) beyond the range), else the box itself
// (clamped onto the grid by the core).
std::vector<std::pair<double, double>> wrapped_intervals(double lo, double hi, double front, double back,
                                                         double period) {
  if (!(period > 0.0) || !(lo == lo) || !(hi == hi) || (lo >= front && hi <= back)) return {{lo, hi}};
  if (hi - lo >= period) return {{front, back}};
  std::vector<std::pair<double, double>> out;
  const double k0 = std::floor((front - hi) / period), k1 = std::ceil((back - lo) / period);
  for (double k = k0; k <= k1; k += 1.0) {
    const double a = std::max(lo + k * period, front), b = std::min(hi + k * period, back);
    if (a <= b) out.push_back({a, b});
  }
  if (out.empty()) out.push_back({lo, hi});  // in a gap the patches do not cover: clamped by the core
  return out;
}

// Calls f(lo', hi') for the parts of the face's (U, V) box [lo, hi] inside the grid's range in
// periodic directions (wrapped_intervals), each part moved there by whole periods.
template <class F>
void for_each_wrapped_box(const Grid& g, const Vec2& lo, const Vec2& hi, F&& f) {
  for (const auto& [u0, u1] : wrapped_intervals(lo.x, hi.x, g.f.u_breaks.front(), g.f.u_breaks.back(), g.f.u_period)) {
    for (const auto& [v0, v1] : wrapped_intervals(lo.y, hi.y, g.f.v_breaks.front(), g.f.v_breaks.back(), g.f.v_period))
      f(Vec2(u0, v0), Vec2(u1, v1));
  }
}

// The Gram bound over the face's (U, V) box [lo, hi] (see gram_over_in_range), its parts whole
// periods away taken where they lie.
Gram gram_over(const Model& model, const std::vector<Gram>& grams, const Grid& g, const Vec2& lo, const Vec2& hi) {
  Gram out{0.0, 0.0, 0.0};
  for_each_wrapped_box(g, lo, hi, [&](const Vec2& a, const Vec2& b) {
    const Gram part = gram_over_in_range(model, grams, g, a, b);
    out = {std::max(out.uu, part.uu), std::max(out.uv, part.uv), std::max(out.vv, part.vv)};
  });
  return out;
}

// Distance from p to the triangle t (the closest point by Voronoi regions, Ericson, "Real-Time
// Collision Detection" 5.1.5); NaN for a triangle without area. The point found lies in t up to
// rounding: callers add a margin.
double triangle_distance(const Vec3& p, const std::array<Vec3, 3>& t) {
  const Vec3 &a = t[0], &b = t[1], &c = t[2];
  const Vec3 ab = b - a, ac = c - a, ap = p - a, bp = p - b, cp = p - c;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return glm::length(ap);
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return glm::length(bp);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return glm::length(p - (a + (d1 / (d1 - d3)) * ab));
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return glm::length(cp);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return glm::length(p - (a + (d2 / (d2 - d6)) * ac));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0)
    return glm::length(p - (b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b)));
  const double area = va + vb + vc;
  if (!(area > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return glm::length(p - (a + (vb / area) * ab + (vc / area) * ac));
}

Vec2 periodic_difference(const Grid& g, Vec2 d);

// Whether every chord and its trace lie in the grid's (U, V) range. In a non-periodic direction
// within 1 % of the range (p-curves of edges along a side wander off it by up to 1e-3 of the range,
// ec_exhaust-A's B-spline faces: the side strips' tolerance). In a periodic direction whose grid
// spans less than a period, the chord moved by whole periods next to the grid, its points taken
// along it (periodic_difference), within 1e-6 of the range (the tiling's matching tolerance); a grid
// of a whole period holds every point. Elsewhere the certificate clamps points onto the grid, so a
// face whose patches miss part of it (a conversion that dropped a knot span) would be certified
// against a surface that lacks that part.
bool chords_inside_grid(const Grid& g) {
  const double range = g.range();
  const Vec2 front(g.f.u_breaks.front(), g.f.v_breaks.front()), back(g.f.u_breaks.back(), g.f.v_breaks.back());
  const Vec2 period(g.f.u_period, g.f.v_period);
  // The point start + d, d taken along the chord (periodic_difference).
  const auto inside = [&](const Vec2& start, const Vec2& d) {
    for (int axis = 0; axis < 2; ++axis) {
      const double lo = front[axis], hi = back[axis], p = period[axis];
      if (!(p > 0.0)) {
        const double x = start[axis] + d[axis];
        if (!(x >= lo - 1e-2 * range && x <= hi + 1e-2 * range)) return false;
        continue;
      }
      if (hi - lo >= p * (1.0 - 1e-9)) continue;
      // The chord's start moved by whole periods next to the grid, the point with it. A chord half a
      // period long (BRepMesh's two chords round a cylinder) runs either way round: both are tried.
      const double shift = p * std::floor((start[axis] - lo) / p), slack = 1e-6 * range;
      const bool half = std::abs(std::abs(d[axis]) - 0.5 * p) <= 1e-9 * p;
      bool found = false;
      for (const double k : {-p, 0.0, p}) {
        const double y0 = start[axis] - shift + k;
        if (!(y0 >= lo - slack && y0 <= hi + slack)) continue;
        for (const double e : {d[axis], half ? d[axis] - std::copysign(p, d[axis]) : d[axis]}) {
          found = found || (y0 + e >= lo - slack && y0 + e <= hi + slack);
        }
      }
      if (!found) return false;
    }
    return true;
  };
  for (const occt::BoundaryChord& c : g.f.chords) {
    const auto along = [&](const Vec2& w) { return periodic_difference(g, w - c.uv_a); };
    if (!inside(c.uv_a, Vec2(0.0)) || !inside(c.uv_a, along(c.uv_b))) return false;
    for (const Vec2& w : c.trace) {
      if (!inside(c.uv_a, along(w))) return false;
    }
  }
  return true;
}

// The surface point of the face at (U, V) (moved by whole periods into the grid's range, clamped
// onto it).
Vec3 surface_point(const Model& model, const Grid& g, Vec2 uv) {
  const auto wrap = [](double x, double front, double back, double period) {
    if (period > 0.0 && (x < front || x > back)) x -= period * std::floor((x - front) / period);
    return std::clamp(x, front, back);
  };
  uv.x = wrap(uv.x, g.f.u_breaks.front(), g.f.u_breaks.back(), g.f.u_period);
  uv.y = wrap(uv.y, g.f.v_breaks.front(), g.f.v_breaks.back(), g.f.v_period);
  const size_t i = cell_span(g.f.u_breaks, uv.x, uv.x).first, j = cell_span(g.f.v_breaks, uv.y, uv.y).first;
  double s = std::clamp((uv.x - g.f.u_breaks[i]) / (g.f.u_breaks[i + 1] - g.f.u_breaks[i]), 0.0, 1.0);
  const double t = std::clamp((uv.y - g.f.v_breaks[j]) / (g.f.v_breaks[j + 1] - g.f.v_breaks[j]), 0.0, 1.0);
  if (g.f.reversed) s = 1.0 - s;
  const std::array<double, 3> p = de_casteljau<double>(model.patches[i * g.nv + j], s, t);
  return Vec3(p[0], p[1], p[2]);
}

// The largest of distance(q) + the rounding of q over the control points q of the sub-nets of the
// surface over the face's (U, V) box [lo, hi] (its parts whole periods away taken where they lie,
// clamped onto the grid; per patch whose cell meets the box, de Casteljau on both ends); distance
// also gets the control point's Greville point (U, V) and the sub-net's weight spread (w_max -
// w_min) / w_min. With positive weights the surface over the
// box lies in the hull of those points, so for a convex `distance` (to a convex set, or the largest
// distance to a few points) this bounds it over the surface. `scale` sizes the rounding of
// distance() itself. NaN when a weight is not positive.
template <class Distance>
double hull_max(const Model& model, const Grid& g, const Vec2& lo, const Vec2& hi, double scale, Distance&& distance) {
  double out = 0.0;
  for_each_wrapped_box(g, lo, hi, [&](const Vec2& box_lo, const Vec2& box_hi) {
    const auto [i0, i1] = cell_span(g.f.u_breaks, box_lo.x, box_hi.x);
    const auto [j0, j1] = cell_span(g.f.v_breaks, box_lo.y, box_hi.y);
    for (size_t i = i0; i < i1; ++i) {
      for (size_t j = j0; j < j1; ++j) {
        auto [s0, s1] = cell_fraction(g.f.u_breaks[i], g.f.u_breaks[i + 1], box_lo.x, box_hi.x);
        const auto [t0, t1] = cell_fraction(g.f.v_breaks[j], g.f.v_breaks[j + 1], box_lo.y, box_hi.y);
        if (g.f.reversed) std::tie(s0, s1) = std::pair<double, double>{1.0 - s1, 1.0 - s0};
        double rounding = 0.0;
        const BezierPatch sub = sub_patch(model.patches[i * g.nv + j], s0, s1, t0, t1, rounding);
        const auto at = [](int k, int n, double a, double b) {
          return n > 1 ? a + (b - a) * k / (n - 1) : 0.5 * (a + b);
        };
        double w_min = kInf, w_max = 0.0;
        for (int r = 0; r < sub.rows(); ++r) {
          for (int c = 0; c < sub.cols(); ++c)
            w_min = std::min(w_min, sub.weight(r, c)), w_max = std::max(w_max, sub.weight(r, c));
        }
        const double spread = (w_max - w_min) / w_min;
        for (int r = 0; r < sub.rows(); ++r) {
          for (int c = 0; c < sub.cols(); ++c) {
            if (!(sub.weight(r, c) > 0.0)) out = std::numeric_limits<double>::quiet_NaN();
            const Vec3& q = sub.at(r, c);
            // The control point's Greville point: in the patch's own (s, t) (s0, s1 are already in
            // the patch's frame), mapped to the face's (U, V) by to_uv (which turns reversed patches).
            const Vec2 st(at(r, sub.rows(), s0, s1), at(c, sub.cols(), t0, t1));
            const Vec2 uv = g.to_uv(static_cast<uint32_t>(i * g.nv + j), st);
            const double d =
                distance(q, uv, spread) + rounding / sub.weight(r, c) + 64.0 * kUnit * (glm::length(q) + scale);
            out = d > out || d != d ? d : out;
          }
        }
      }
    }
  });
  return out;
}

// Branch and bound over slices [s0, s1] of [s_lo, s_hi]: bound(s0, s1) bounds a quantity over a
// slice and seen(s0, s1) is a value it takes there. The largest bound is halved first until it is
// at most `enough`, within 2 % of the largest value seen, 48 slices are left, or the last 8 halvings
// lowered it by less than 1 % (a term the slices do not shrink holds it up): the largest bound then
// bounds the quantity over [s_lo, s_hi]. The caller has a bound `useless` already: the search also
// stops once it cannot end below it (a value seen reaches it) or, after 8 halvings, is still above
// twice it. +infinity when a bound is NaN.
template <class Bound, class Seen>
double slice_bound(double s_lo, double s_hi, double enough, double useless, Bound&& bound, Seen&& seen) {
  constexpr int kSlices = 48;
  struct Slice {
    double s0, s1, bound;
    bool operator<(const Slice& o) const { return bound < o.bound; }
  };
  std::priority_queue<Slice> open;
  double largest_seen = 0.0;
  const auto push = [&](double s0, double s1) {
    const Slice sl{s0, s1, bound(s0, s1)};
    largest_seen = std::max(largest_seen, seen(s0, s1));
    open.push(sl);
    return sl.bound == sl.bound;
  };
  if (!push(s_lo, s_hi)) return kInf;
  constexpr int kStall = 8;             // halvings that must lower the largest bound by 1 % together
  constexpr int kGiveUp = 8;            // halvings after which a bound above twice `useless` is given up
  std::array<double, kStall> recent{};  // the largest bound after the last kStall halvings, cyclic
  for (int slices = 1;; ++slices) {
    const Slice top = open.top();
    if (top.bound <= std::max(1.02 * largest_seen, enough) || slices >= kSlices) return top.bound;
    if (largest_seen >= useless || (slices > kGiveUp && top.bound > 2.0 * useless)) return top.bound;
    if (slices > kStall && top.bound >= 0.99 * recent[static_cast<size_t>(slices % kStall)]) return top.bound;
    recent[static_cast<size_t>(slices % kStall)] = top.bound;
    open.pop();
    const double mid = 0.5 * (top.s0 + top.s1);
    if (!push(top.s0, mid) || !push(mid, top.s1)) return kInf;
  }
}

// The coordinates of chord c's rectangles (metric): s along the chord from uv_a, w across it.
struct ChordFrame {
  Vec2 m{1.0}, a{0.0}, along{1.0, 0.0}, left{0.0, 1.0};
  double length = 0.0;
  ChordFrame(const Grid& g, const occt::BoundaryChord& c) : m(g.f.chord_metric), a(m * c.uv_a) {
    const Vec2 d = m * c.uv_b - a;
    length = glm::length(d);
    if (length > 0.0) along = d / length, left = Vec2(-along.y, along.x);
  }
  Vec2 uv(double s, double w) const { return (a + s * along + w * left) / m; }
  Vec2 sw(const Vec2& uv) const { return Vec2(glm::dot(m * uv - a, along), glm::dot(m * uv - a, left)); }
  // The (U, V) box of {s in [s0, s1], w in [w0, w1]}, widened against the corners' rounding.
  std::pair<Vec2, Vec2> box(const Grid& g, double s0, double s1, double w0, double w1) const {
    Vec2 lo(kInf), hi(-kInf);
    for (const double s : {s0, s1}) {
      for (const double w : {w0, w1}) lo = glm::min(lo, uv(s, w)), hi = glm::max(hi, uv(s, w));
    }
    const Vec2 pad(1e-12 * (g.range() + glm::length(lo) + glm::length(hi)));
    return {lo - pad, hi + pad};
  }
};

// Face -> mesh over the slivers of chord c, whose triangle is t (docs/VALIDATION.md, "the slivers'
// two sides"): a point x of the domain that no triangle covers lies between some chord and its
// curve, and so in that chord's rectangle R = {s in [-overshoot, length + overshoot], w in [-right,
// left]} (ChordFrame), which holds both. Its surface point is within dist(S(x), t) of the mesh:
// slice_bound over R of hull_max of the distance to t (convex). +infinity when not proven.
double sliver_to_triangle(const Model& model, const Grid& g, const occt::BoundaryChord& c, const std::array<Vec3, 3>& t,
                          double enough, double useless) {
  const ChordFrame frame(g, c);
  if (!(frame.length > 0.0) || !std::isfinite(c.overshoot) || !std::isfinite(c.left) || !std::isfinite(c.right))
    return kInf;
  const double t_size = std::max({glm::length(t[0]), glm::length(t[1]), glm::length(t[2])});
  const auto to_t = [&](const Vec3& q, const Vec2& = {}, double = 0.0) { return triangle_distance(q, t); };
  return slice_bound(
      -c.overshoot, frame.length + c.overshoot, enough, useless,
      [&](double s0, double s1) {
        const auto [lo, hi] = frame.box(g, s0, s1, -c.right, c.left);
        return hull_max(model, g, lo, hi, t_size, to_t);
      },
      [&](double s0, double s1) {
        return to_t(surface_point(model, g, frame.uv(0.5 * (s0 + s1), 0.5 * (c.left - c.right))));
      });
}

// Mesh -> face over the part {w in [w0, w1]} of chord c's rectangle (s in [s_lo, s_hi]) for a
// triangle x of the face that meets it, given by its corners' (s, w) and 3D points (docs/VALIDATION.md,
// "the slivers' two sides"). A point y = (s, w_y) of x over (U, V) outside the domain there lies
// between the chord's point y0 = (s, 0) and a point q = (s, w_q) of the curve straight across, and
// S(q) belongs to the face. With M x's affine map (extended beyond x), M(y) = (1 - a) M(y0) + a M(q),
// so dist(M(y), F) <= |M(y) - S(q)| <= max(|M(y0) - S(q)|, |M(q) - S(q)|). Both are |S(p) - A(p)|
// at p = q for an affine A (A(s, w) = M(s, 0), and M), bounded over a slice from the sub-nets over
// its box by the largest |P - A(g)| over control points P and their Greville points g (an affine
// map's Bernstein coefficients are its values there; for rational nets plus A's Lipschitz constant
// times the box's size times the weights' spread (w_max - w_min) / w_min, as the rational surface
// point is the w B-weighted average of the P and p that of the g only up to that; for a direction
// of degree 0, plus A's Lipschitz constant times the box's size). The slices' bound is within a second-order
// term of the truth, where base + width x speed adds the two first-order errors. +infinity when x
// has no area in (U, V).
double across_to_curve(const Model& model, const Grid& g, const ChordFrame& frame, const std::array<Vec2, 3>& x_sw,
                       const std::array<Vec3, 3>& x_3d, double s_lo, double s_hi, double w0, double w1, double enough,
                       double useless) {
  const Vec2 e1 = x_sw[1] - x_sw[0], e2 = x_sw[2] - x_sw[0];
  const double det = e1.x * e2.y - e1.y * e2.x;
  if (!(std::abs(det) > 0.0) || !(s_hi > s_lo)) return kInf;
  const Vec3 d1 = x_3d[1] - x_3d[0], d2 = x_3d[2] - x_3d[0];
  const auto mesh_point = [&](const Vec2& sw) {
    const Vec2 r = sw - x_sw[0];
    return x_3d[0] + ((r.x * e2.y - r.y * e2.x) / det) * d1 + ((e1.x * r.y - e1.y * r.x) / det) * d2;
  };
  const Vec3 along = (e2.y * d1 - e1.y * d2) / det, across = (e1.x * d2 - e2.x * d1) / det;
  const double lipschitz = std::sqrt(glm::dot(along, along) + glm::dot(across, across)) * (1.0 + 1e-12);
  bool exact_coefficients = true;  // nets of degree >= 1 both ways (rational: up to the weights' spread)
  for (const BezierPatch& p : model.patches)
    exact_coefficients = exact_coefficients && p.degree_u >= 1 && p.degree_v >= 1;
  double scale = 0.0;
  for (const Vec3& p : x_3d) scale = std::max(scale, glm::length(p));
  // The affine map's rounding: a few units of its corners' size, relative to how far it reaches.
  const double reach = frame.length + std::abs(w0) + std::abs(w1) + glm::length(e1) + glm::length(e2);
  const double map_rounding = 64.0 * kUnit * (scale + lipschitz * reach);
  const Vec2 a_uv = frame.a / frame.m;
  return slice_bound(
      s_lo, s_hi, enough, useless,
      [&](double s0, double s1) {
        const auto [lo, hi] = frame.box(g, s0, s1, w0, w1);
        const double size = glm::length(frame.m * (hi - lo));
        return hull_max(model, g, lo, hi, scale,
                        [&](const Vec3& q, const Vec2& uv, double spread) {
                          const Vec2 sw = frame.sw(a_uv + periodic_difference(g, uv - a_uv));
                          const double to_chord = glm::length(q - mesh_point(Vec2(sw.x, 0.0)));
                          const double to_map = glm::length(q - mesh_point(sw));
                          return std::max(to_chord, to_map) + (exact_coefficients ? spread : 1.0) * lipschitz * size;
                        }) +
               map_rounding;
      },
      [&](double s0, double s1) {
        const double s = 0.5 * (s0 + s1);
        return glm::length(mesh_point(Vec2(s, 0.0)) -
                           surface_point(model, g, frame.uv(s, std::abs(w0) > std::abs(w1) ? w0 : w1)));
      });
}

Gram face_gram(const std::vector<Gram>& grams, const Grid& g) {
  const Vec2 lo(g.f.u_breaks.front(), g.f.v_breaks.front()), hi(g.f.u_breaks.back(), g.f.v_breaks.back());
  return gram_over(Model{}, grams, g, lo, hi);
}

// |DS h| <= lipschitz |h|_m for h measured with U scaled by m.x and V by m.y: the square root of the
// largest eigenvalue of the Gram bound in those units (increasing in each entry, so the entrywise
// bounds bound it).
double metric_lipschitz(const Gram& g, const Vec2& m) {
  const double a = g.uu / (m.x * m.x), b = g.uv / (m.x * m.y), c = g.vv / (m.y * m.y);
  return std::sqrt(0.5 * (a + c) + std::hypot(0.5 * (a - c), b)) * (1.0 + 8.0 * kUnit);
}

// The slivers' term of chord c (metric m): a bound on |S(p) - S(x)| for a point p between the chord
// and its curve and x the chord's point nearest p, given the Gram bound over the band's box. p lies
// within c.deviation of the chord; where its projection falls inside the chord, p - x is across it
// (the normal n, at most deviation long), else beyond an end by at most c.overshoot along the chord
// direction d and at most deviation across: |DS h| <= deviation |DS n| + overshoot |DS d|, each
// |DS e| at most sqrt(e_u^2 uu + 2 |e_u e_v| uv + e_v^2 vv) for e in (U, V) units. The isotropic
// bound (Lipschitz constant times deviation) where that is smaller or the chord has no length.
// |DS e| for a unit vector e of the metric m, before the rounding margin: at most sqrt(e_u^2 uu +
// 2 |e_u e_v| uv + e_v^2 vv) with e in (U, V) units.
double direction_speed(const Gram& gram, const Vec2& m, const Vec2& e) {
  const double eu = e.x / m.x, ev = e.y / m.y;
  return std::sqrt(eu * eu * gram.uu + 2.0 * std::abs(eu * ev) * gram.uv + ev * ev * gram.vv);
}

double sliver_term(const Gram& gram, const Vec2& m, const occt::BoundaryChord& c) {
  const double isotropic = metric_lipschitz(gram, m) * c.deviation;
  const Vec2 d = m * (c.uv_b - c.uv_a);
  const double length = glm::length(d);
  if (!(length > 0.0) || !std::isfinite(c.overshoot)) return isotropic;
  const Vec2 along = d / length, across(-along.y, along.x);
  const double directional =
      c.deviation * direction_speed(gram, m, across) + c.overshoot * direction_speed(gram, m, along);
  return std::min(isotropic, directional * (1.0 + 8.0 * kUnit));
}

// |DS n| for the unit vector n (metric m) across chord c (direction_speed with the rounding
// margin); the Lipschitz bound when the chord has no length.
double across_speed(const Gram& gram, const Vec2& m, const occt::BoundaryChord& c) {
  const Vec2 d = m * (c.uv_b - c.uv_a);
  const double length = glm::length(d);
  if (!(length > 0.0)) return metric_lipschitz(gram, m);
  return direction_speed(gram, m, Vec2(-d.y / length, d.x / length)) * (1.0 + 8.0 * kUnit);
}

// Distance from p to the segment [a, b].
double segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double len2 = glm::dot(d, d);
  const double s = len2 > 0.0 ? std::clamp(glm::dot(p - a, d) / len2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + s * d));
}

// x - y with whole periods removed (the nearest copy) in periodic directions.
Vec2 periodic_difference(const Grid& g, Vec2 d) {
  if (g.f.u_period > 0.0) d.x -= g.f.u_period * std::round(d.x / g.f.u_period);
  if (g.f.v_period > 0.0) d.y -= g.f.v_period * std::round(d.y / g.f.v_period);
  return d;
}

// The oriented boundary of the face's triangles against its loops' chords, edge by edge: an edge is
// keyed by its two mesh vertices and its midpoint in (U, V) (seam copies apart, whole periods
// ignored). `triangles` counts +1 / -1 per directed use, `chords` likewise.
struct EdgeUse {
  Vec2 mid;
  int triangles = 0, chords = 0;
  uint32_t triangle = 0;  // the last triangle (face-local index) using the edge
};

class EdgeChain {
 public:
  EdgeChain(const Grid& g, double tol) : g_(g), tol_(tol) {}
  EdgeUse& use(uint32_t a, uint32_t b, const Vec2& mid) {
    std::vector<EdgeUse>& list = map_[{std::min(a, b), std::max(a, b)}];
    for (EdgeUse& e : list) {
      if (glm::length(periodic_difference(g_, e.mid - mid)) <= tol_) return e;
    }
    list.push_back({mid});
    return list.back();
  }
  // +1 / -1 for the direction a -> b; an edge from a vertex to itself (along a pole's segment) by its
  // direction in (U, V).
  int sign(uint32_t a, uint32_t b, const Vec2& uv_a, const Vec2& uv_b) const {
    if (a != b) return a < b ? 1 : -1;
    const Vec2 d = periodic_difference(g_, uv_b - uv_a);
    return d.x > 0.0 || (d.x == 0.0 && d.y > 0.0) ? 1 : -1;
  }
  const std::map<std::pair<uint32_t, uint32_t>, std::vector<EdgeUse>>& uses() const { return map_; }

 private:
  const Grid& g_;
  double tol_;
  std::map<std::pair<uint32_t, uint32_t>, std::vector<EdgeUse>> map_;
};

// Why the triangles' (U, V) do not tile the chords' polygon exactly once ("" when they do): every
// triangle has one orientation, and the triangles' oriented boundary equals the chords' chain (up to
// one global sign). Then, by the degree of the map, each point inside the polygon lies in exactly
// one triangle. Fills chord_triangle (per chord: the triangle on it).
//
// A flat triangle (its corners on one line in (U, V) up to a height of 1e-7 of the range: a foreign
// mesh's triangle along a cone's generator with the apex, or one whose two corners are distinct
// vertices at one point, both in float STLs) has no orientation to check. Its boundary chain lies
// within its height of a segment and nearly cancels there, so the other triangles' boundary is the
// chords' chain up to such thin loops: they cover each point of the polygon once except within the
// flat triangles' footprints (which cover the rest: every triangle is certified over its own
// footprint), and no footprint leaves the polygon by more than the flat triangles' heights
// together, returned in flat_reach (the caller adds the surface's speed times it to every bound).
std::string tiling_reason(const Grid& g, const std::vector<Triangle>& vertices,
                          const std::vector<std::array<Vec2, 3>>& corner_uv, std::vector<uint32_t>& chord_triangle,
                          double& flat_reach) {
  const occt::PartFace& f = g.f;
  int orientation = 0;
  const double flat = 1e-7 * g.range();
  flat_reach = 0.0;
  for (const auto& q : corner_uv) {
    const long double area =
        (static_cast<long double>(q[1].x) - q[0].x) * (static_cast<long double>(q[2].y) - q[0].y) -
        (static_cast<long double>(q[2].x) - q[0].x) * (static_cast<long double>(q[1].y) - q[0].y);
    const double longest = std::max({glm::length(q[1] - q[0]), glm::length(q[2] - q[1]), glm::length(q[0] - q[2])});
    const double height = longest > 0.0 ? 2.0 * static_cast<double>(std::abs(area)) / longest : 0.0;
    if (height <= flat) {
      flat_reach += height * (1.0 + 1e-12);
      continue;
    }
    const int s = area > 0.0L ? 1 : -1;
    if (orientation == 0) orientation = s;
    if (s != orientation) return "the triangles fold over in (U, V) (both orientations)";
  }
  if (orientation == 0) return "every triangle is degenerate in (U, V)";
  const double chain_tolerance = 1e-7 * g.range();
  EdgeChain chain(g, chain_tolerance);
  for (size_t k = 0; k < vertices.size(); ++k) {
    const Triangle& tri = vertices[k];
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = tri[c], b = tri[(c + 1) % 3];
      const Vec2 &uv_a = corner_uv[k][c], &uv_b = corner_uv[k][(c + 1) % 3];
      // A vertex to itself at one point (two mesher's nodes of a pinch, one vertex in space, or a
      // pole's copies merged): no edge, for triangles and chords alike.
      if (a == b && glm::length(uv_b - uv_a) <= chain_tolerance) continue;
      EdgeUse& e = chain.use(a, b, 0.5 * (uv_a + uv_b));
      e.triangles += chain.sign(a, b, uv_a, uv_b);
      e.triangle = static_cast<uint32_t>(k);
    }
  }
  for (const occt::BoundaryChord& c : f.chords) {
    if (c.a == c.b && glm::length(c.uv_b - c.uv_a) <= chain_tolerance) continue;
    chain.use(c.a, c.b, 0.5 * (c.uv_a + c.uv_b)).chords += chain.sign(c.a, c.b, c.uv_a, c.uv_b);
  }
  int global = 0;
  for (const auto& [key, list] : chain.uses()) {
    for (const EdgeUse& e : list) {
      if (e.triangles == 0 && e.chords == 0) continue;
      if (global == 0 && e.chords != 0) global = e.triangles * e.chords > 0 ? 1 : -1;
      if (global == 0 || e.triangles != global * e.chords) {
        return "the triangles' boundary in (U, V) differs from the loops' chords (near vertices " +
               std::to_string(key.first) + " and " + std::to_string(key.second) + ")";
      }
    }
  }
  if (global == 0) {
    // No boundary left once seam copies cancel: a closed surface (a whole torus). Triangles of one
    // orientation with an empty boundary cover the (U, V) torus a constant number of times; their
    // total area equal to the whole period rectangle's makes that number 1.
    long double area = 0.0L;
    for (const auto& q : corner_uv) {
      area += 0.5L * std::abs((static_cast<long double>(q[1].x) - q[0].x) * (static_cast<long double>(q[2].y) - q[0].y) -
                              (static_cast<long double>(q[2].x) - q[0].x) * (static_cast<long double>(q[1].y) - q[0].y));
    }
    const bool closed = f.u_period > 0.0 && f.v_period > 0.0 &&
                        std::abs((f.u_breaks.back() - f.u_breaks.front()) - f.u_period) <= 1e-9 * f.u_period &&
                        std::abs((f.v_breaks.back() - f.v_breaks.front()) - f.v_period) <= 1e-9 * f.v_period;
    const long double whole = static_cast<long double>(f.u_period) * f.v_period;
    if (!closed || std::abs(area - whole) > 1e-9L * whole) return "the face's loops have no chord";
  }
  chord_triangle.assign(f.chords.size(), 0);
  for (size_t k = 0; k < f.chords.size(); ++k) {
    const occt::BoundaryChord& c = f.chords[k];
    if (c.a == c.b && glm::length(c.uv_b - c.uv_a) <= chain_tolerance) {
      // A chord of no length: a triangle with that corner there (its curve is within the chord's
      // deviation of that point).
      bool found = false;
      for (size_t t = 0; t < vertices.size() && !found; ++t) {
        for (int i = 0; i < 3 && !found; ++i) {
          found =
              vertices[t][i] == c.a && glm::length(periodic_difference(g, corner_uv[t][i] - c.uv_a)) <= chain_tolerance;
          if (found) chord_triangle[k] = static_cast<uint32_t>(t);
        }
      }
      if (!found) return "a chord of no length has no triangle at its point";
      continue;
    }
    chord_triangle[k] = chain.use(c.a, c.b, 0.5 * (c.uv_a + c.uv_b)).triangle;
  }
  return "";
}

// (U, V) of the corners of the face's triangles.
std::vector<std::array<Vec2, 3>> corner_uvs(const occt::PartMesh& part, const Grid& g,
                                            const std::vector<uint32_t>& triangles, std::string& reason) {
  std::vector<std::array<Vec2, 3>> uv(triangles.size());
  for (size_t k = 0; k < triangles.size(); ++k) {
    const uint32_t t = triangles[k];
    const int64_t local = int64_t(part.mesh.triangle_patch[t]) - g.f.first_patch;
    if (local < 0 || local >= g.f.patch_count) {
      reason = "a triangle refers to another face's patch";
      return {};
    }
    for (int c = 0; c < 3; ++c) uv[k][c] = g.to_uv(static_cast<uint32_t>(local), part.mesh.triangle_uv[t][c]);
  }
  return uv;
}

// A point of the face's (U, V) that may lie outside the trimmed domain: within a chord's deviation
// of that chord (the only places where the chords' polygon and the domain differ).
bool near_a_chord(const Grid& g, const Vec2& w) {
  for (const occt::BoundaryChord& c : g.f.chords) {
    const Vec2 d = c.uv_a - w;
    const Vec2 near = w + (d - periodic_difference(g, d));  // w moved whole periods towards the chord
    const Vec2 m = g.f.chord_metric;
    if (segment_distance(m * near, m * c.uv_a, m * c.uv_b) <= 2.0 * c.deviation + 1e-9 * g.range() * std::max(m.x, m.y))
      return true;
  }
  return false;
}

// Distance between the box [lo, hi] and the segment [a, b] (0 when they meet): attained at an end of
// the segment or a corner of the box when they do not meet.
double box_segment_distance(const Vec2& lo, const Vec2& hi, const Vec2& a, const Vec2& b) {
  const auto inside = [&](const Vec2& p) { return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y; };
  if (inside(a) || inside(b)) return 0.0;
  // Liang-Barsky: the part of the segment inside the box's slabs.
  double t0 = 0.0, t1 = 1.0;
  const Vec2 d = b - a;
  bool meets = true;
  for (int k = 0; k < 2 && meets; ++k) {
    if (d[k] == 0.0) {
      meets = a[k] >= lo[k] && a[k] <= hi[k];
      continue;
    }
    double s0 = (lo[k] - a[k]) / d[k], s1 = (hi[k] - a[k]) / d[k];
    if (s0 > s1) std::swap(s0, s1);
    t0 = std::max(t0, s0), t1 = std::min(t1, s1);
    meets = t0 <= t1;
  }
  if (meets) return 0.0;
  const auto to_box = [&](const Vec2& p) { return glm::length(p - glm::clamp(p, lo, hi)); };
  double dist = std::min(to_box(a), to_box(b));
  for (const Vec2& c : {lo, hi, Vec2(lo.x, hi.y), Vec2(hi.x, lo.y)}) dist = std::min(dist, segment_distance(c, a, b));
  return dist;
}

// Chord c's rectangle {s in [-overshoot, length + overshoot], w in [-right, left]} (ChordFrame),
// which holds its curve, split by the chord's line into the part on the side of the chord's
// triangle (width `inner`) and the other (`outer`). Without proven sides both widths are the
// deviation (the curve lies within it of the chord).
struct ChordRectangle {
  ChordFrame frame;
  double overshoot = kInf, inner = kInf, outer = kInf;
  double toward = 1.0;  // +1: the triangle lies on the left (w > 0), -1: on the right
  ChordRectangle(const Grid& g, const occt::BoundaryChord& c, const std::array<Vec2, 3>& triangle_uv)
      : frame(g, c),
        overshoot(std::isfinite(c.overshoot) ? c.overshoot : c.deviation),
        inner(c.deviation),
        outer(c.deviation) {
    double side = 0.0;  // the triangle's corners off the chord's line (the chord's two are on it)
    for (const Vec2& w : corners(g, triangle_uv)) side += w.y;
    toward = side >= 0.0 ? 1.0 : -1.0;
    if (side != 0.0 && frame.length > 0.0 && std::isfinite(c.left) && std::isfinite(c.right)) {
      inner = side > 0.0 ? c.left : c.right;
      outer = side > 0.0 ? c.right : c.left;
    }
  }
  // A triangle's corners in (s, w), the triangle moved by whole periods next to the chord.
  std::array<Vec2, 3> corners(const Grid& g, const std::array<Vec2, 3>& q) const {
    const Vec2 a_uv = frame.a / frame.m;
    const Vec2 shift = periodic_difference(g, q[0] - a_uv) - (q[0] - a_uv);
    return {frame.sw(q[0] + shift), frame.sw(q[1] + shift), frame.sw(q[2] + shift)};
  }
  // w-ranges of the two parts.
  std::pair<double, double> inner_w() const { return toward > 0.0 ? std::pair{0.0, inner} : std::pair{-inner, 0.0}; }
  std::pair<double, double> outer_w() const { return toward > 0.0 ? std::pair{-outer, 0.0} : std::pair{0.0, outer}; }
  // Whether the triangle with corners p ((s, w)) meets the part's interior (a triangle touching it
  // along its boundary does not): separating axes of a triangle and a rectangle, the two axes and
  // the triangle's edge normals. A chord without length: the triangle's box within the width of
  // the chord's point.
  bool meets(const std::array<Vec2, 3>& p, std::pair<double, double> w) const {
    if (!(frame.length > 0.0)) {
      const Vec2 lo = glm::min(glm::min(p[0], p[1]), p[2]), hi = glm::max(glm::max(p[0], p[1]), p[2]);
      return glm::length(glm::max(glm::max(lo, -hi), Vec2(0.0))) <= std::max(-w.first, w.second);
    }
    const Vec2 lo(-overshoot, w.first), hi(frame.length + overshoot, w.second);
    if (!(hi.x > lo.x) || !(hi.y > lo.y)) return false;
    for (int k = 0; k < 2; ++k) {
      const double mn = std::min({p[0][k], p[1][k], p[2][k]}), mx = std::max({p[0][k], p[1][k], p[2][k]});
      if (mx <= lo[k] || mn >= hi[k]) return false;
    }
    for (int i = 0; i < 3; ++i) {
      const Vec2 e = p[(i + 1) % 3] - p[i], n(-e.y, e.x);
      const double own = glm::dot(p[(i + 2) % 3] - p[i], n);
      double r_min = kInf, r_max = -kInf;
      for (const Vec2& r : {lo, hi, Vec2(lo.x, hi.y), Vec2(hi.x, lo.y)}) {
        const double x = glm::dot(r - p[i], n);
        r_min = std::min(r_min, x), r_max = std::max(r_max, x);
      }
      if ((own >= 0.0 && r_max <= 0.0) || (own <= 0.0 && r_min >= 0.0)) return false;
    }
    return true;
  }
};

// The s-range of the part of the triangle with corners p ((s, w)) inside the strip w0 <= w <= w1:
// that part is a convex polygon whose corners are the triangle's corners inside the strip and its
// edges' crossings of the strip's two lines. Widened by `pad` both ways against the crossings'
// rounding; empty (first > second) when the triangle misses the strip.
std::pair<double, double> strip_s_extent(const std::array<Vec2, 3>& p, double w0, double w1, double pad) {
  double lo = kInf, hi = -kInf;
  for (int i = 0; i < 3; ++i) {
    const Vec2 &a = p[i], &b = p[(i + 1) % 3];
    if (a.y >= w0 && a.y <= w1) lo = std::min(lo, a.x), hi = std::max(hi, a.x);
    for (const double w : {w0, w1}) {
      if ((a.y - w) * (b.y - w) < 0.0) {
        const double s = a.x + (w - a.y) / (b.y - a.y) * (b.x - a.x);
        lo = std::min(lo, s), hi = std::max(hi, s);
      }
    }
  }
  return {lo - pad, hi + pad};
}

// Face -> mesh lower bound from the points of the trimming curves (BoundaryChord::curve_points):
// the largest distance from the face's boundary to its mesh sits there, between a chord and its curve,
// where the triangles' own candidate points never reach.
void raise_lower_on_curves(const occt::PartFace& f, const Tessellation& mesh, DistanceInterval& s2m) {
  std::vector<Vec3> points;
  std::vector<double> error;
  for (const occt::BoundaryChord& c : f.chords) {
    for (const Vec3& p : c.curve_points) points.push_back(p), error.push_back(c.curve_point_error);
  }
  const std::vector<double> lower = distance_lower_bounds(mesh, points);
  for (size_t k = 0; k < points.size(); ++k) {
    const double l = lower[k] - error[k];
    if (l > s2m.lower) {
      s2m.lower = l;
      s2m.witness = points[k];
      s2m.witness_patch = -1;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Mesh -> face lower bounds in the slivers that lie outside the domain (docs/VALIDATION.md,
// "Trimmed faces: lower bounds in the slivers"). Where a trimming curve bulges into the triangle on
// its chord (a hole's circle), the mesh covers a sliver outside D and the chord's midpoint p, a
// mesh point, is off the face by about the sliver's width. The untrimmed surface passes through p,
// so the validator's own lower bound is 0 there; this one proves how far the face really is:
//  1. a disk N of (U, V) (metric chord_metric) around p's (U, V) meets no trimming curve: its
//     radius is the clearance from every chord's trace band (BoundaryChord::trace);
//  2. one point c of N lies outside D. c lies inside the triangle on the chord, so inside the
//     chords' polygon P (the triangles tile P: tiling_reason). The boundary of D is that of P plus
//     the closed loops "curve - chord", and a loop winds around c only when c is within its chord's
//     deviation (the loop lies in that convex band), so D's indicator at c is 1 + the parities of
//     those loops (each loop traced by its polyline, which is homotopic to it inside the trace bands
//     that miss N). N is connected and crosses no curve: all of N lies outside D;
//  3. the face is its patches' surface over D, so d(p, F) >= min over the patches' boxes off N of
//     the distance from p to the box's control-net hull (branch and bound, smallest box bound first:
//     the popped box's bound is the answer).
namespace sliver {

// The halves of a net along u (axis 0) or v (axis 1), by de Casteljau at 1/2.
std::pair<Net, Net> halve(const Net& net, int rows, int cols, int axis) {
  Net low(net.size()), high(net.size());
  const int n = axis == 0 ? rows : cols, lines = axis == 0 ? cols : rows;
  std::vector<glm::dvec4> work(static_cast<size_t>(n));
  for (int l = 0; l < lines; ++l) {
    const auto index = [&](int k) { return static_cast<size_t>(axis == 0 ? k * cols + l : l * cols + k); };
    for (int k = 0; k < n; ++k) work[static_cast<size_t>(k)] = net[index(k)];
    for (int level = 0; level < n; ++level) {
      low[index(level)] = work[0];
      high[index(n - 1 - level)] = work[static_cast<size_t>(n - 1 - level)];
      for (int k = 0; k + 1 < n - level; ++k)
        work[static_cast<size_t>(k)] = 0.5 * (work[static_cast<size_t>(k)] + work[static_cast<size_t>(k + 1)]);
    }
  }
  return {std::move(low), std::move(high)};
}

// Distance from p to the box of the net's points (all weights positive: the surface lies in
// their convex hull); -1 when a weight is not positive.
double hull_distance(const Net& net, const Vec3& p) {
  Vec3 lo(kInf), hi(-kInf);
  for (const glm::dvec4& h : net) {
    if (!(h.w > 0.0)) return -1.0;
    const Vec3 q = Vec3(h) / h.w;
    lo = glm::min(lo, q), hi = glm::max(hi, q);
  }
  const Vec3 d = glm::max(glm::max(lo - p, p - hi), Vec3(0.0));
  return glm::length(d);
}

// Even-odd crossing of a ray from c along +x with the closed polygon `points`.
bool odd_crossings(const std::vector<Vec2>& points, const Vec2& c) {
  bool odd = false;
  for (size_t i = 0, n = points.size(); i < n; ++i) {
    const Vec2 a = points[i], b = points[(i + 1) % n];
    if ((a.y > c.y) != (b.y > c.y)) {
      const double x = a.x + (c.y - a.y) * (b.x - a.x) / (b.y - a.y);
      if (x > c.x) odd = !odd;
    }
  }
  return odd;
}

struct Band {
  Vec2 a, b;                // the chord, metric
  double deviation = kInf;  // of the curve from the chord, metric
  std::vector<Vec2> trace;  // metric
  double trace_deviation = kInf;
  // Distance from x to the trace band's edge (negative inside).
  double clearance(const Vec2& x) const {
    double d = kInf;
    for (size_t i = 0; i + 1 < trace.size(); ++i) d = std::min(d, segment_distance(x, trace[i], trace[i + 1]));
    return d - trace_deviation;
  }
};

}  // namespace sliver

// The face's trimming curves for box_in_domain: per chord, its ends and its trace (the finer
// polyline along the curve, BoundaryChord::trace) in the chord metric.
struct TraceBand {
  Vec2 a, b;
  double deviation = kInf, trace_deviation = kInf;
  std::vector<Vec2> trace;
};
std::vector<TraceBand> trace_bands(const Grid& g) {
  std::vector<TraceBand> bands;
  const Vec2 m = g.f.chord_metric;
  for (const occt::BoundaryChord& c : g.f.chords) {
    TraceBand band{m * c.uv_a, m * c.uv_b, c.deviation, c.trace_deviation, {}};
    for (const Vec2& q : c.trace) band.trace.push_back(m * q);
    // Without a usable trace the chord is its own (its curve within `deviation` of it).
    if (!(band.trace_deviation < kInf) || band.trace.size() < 2)
      band.trace = {band.a, band.b}, band.trace_deviation = c.deviation;
    bands.push_back(std::move(band));
  }
  return bands;
}

// Trimming curves that run along a side of the face's rectangle (an edge whose p-curve is the
// iso-line at the end of a non-periodic parameter, up to its proven deviation, as on a B-spline face
// trimmed on some sides only): the strip next to each side that holds all such curves, in (U, V)
// units (0: none), and which chords they are. Inside the rectangle such a curve separates nothing
// from the rest but that strip.
struct SideStrips {
  double u_lo = 0.0, u_hi = 0.0, v_lo = 0.0, v_hi = 0.0;
  std::vector<char> along_side;  // per chord
};
SideStrips side_strips(const Grid& g, const std::vector<TraceBand>& bands) {
  SideStrips out;
  out.along_side.assign(bands.size(), 0);
  const Vec2 m = g.f.chord_metric;
  const double u0 = g.f.u_breaks.front(), u1 = g.f.u_breaks.back(), v0 = g.f.v_breaks.front(), v1 = g.f.v_breaks.back();
  // A curve within 1 % of the range of a side counts as running along it (its strip is cut from
  // the boxes that the curve's band stops; p-curves of edges on a side wander off it by 1e-3 of the
  // range, ec_exhaust-A's B-spline faces).
  const double thin_u = 1e-2 * (u1 - u0), thin_v = 1e-2 * (v1 - v0);
  const double slack_u = 2e-9 * (u1 - u0), slack_v = 2e-9 * (v1 - v0);
  for (size_t k = 0; k < bands.size(); ++k) {
    const TraceBand& band = bands[k];
    if (!(band.trace_deviation < kInf)) continue;
    // The curve lies within trace_deviation (metric) of its trace: of the side, by the farthest
    // trace point's distance plus that, in (U, V) units.
    double to_u0 = 0.0, to_u1 = 0.0, to_v0 = 0.0, to_v1 = 0.0;
    for (const Vec2& t : band.trace) {
      to_u0 = std::max(to_u0, t.x / m.x - u0), to_u1 = std::max(to_u1, u1 - t.x / m.x);
      to_v0 = std::max(to_v0, t.y / m.y - v0), to_v1 = std::max(to_v1, v1 - t.y / m.y);
    }
    const double du = band.trace_deviation / m.x + slack_u, dv = band.trace_deviation / m.y + slack_v;
    const auto take = [&](double width, double thin, double& strip) {
      if (!(width <= thin)) return false;
      strip = std::max(strip, width);
      return true;
    };
    bool along = false;
    if (g.f.u_period == 0.0) {
      along = take(to_u0 + du, thin_u, out.u_lo) || along;
      along = take(to_u1 + du, thin_u, out.u_hi) || along;
    }
    if (g.f.v_period == 0.0) {
      along = take(to_v0 + dv, thin_v, out.v_lo) || along;
      along = take(to_v1 + dv, thin_v, out.v_hi) || along;
    }
    out.along_side[k] = along ? 1 : 0;
  }
  return out;
}

// How far the surface over the box [lo, hi] of patch `local`'s (s, t) may be from the face: 0 when
// the box lies in the face's domain D, a bound m when every point p of the box has a point p' of D
// with |S(p) - S(p')| <= m, +infinity when neither is shown. `inside` is a point of the box in the
// chords' polygon P (a leaf of a piece: the pieces tile P). The box must lie in the patch and meet
// no trimming curve: clear of every chord's trace band (the curve lies within trace_deviation of its
// trace). It is then in D or outside it as a whole (connected), and which one is D's indicator at
// `inside`: P's (1) flipped by every closed loop "curve - chord" that winds around it, which only a
// loop whose chord is within its deviation can do (the loop lies in that convex band), counted by
// even-odd crossings with the trace closed by its chord (homotopic to the loop within the trace
// band, which misses the box). A point within 1e-6 of the range of a chord (the tiling's matching
// tolerance) is not decided. Where that fails and the box reaches into side strips (SideStrips), the
// test is made again on the box without the strips, which no curve along those sides meets: a point
// p of a strip is then within the strip's width of the cut box along U (or V), so m = sqrt(uu) x the
// U strip's width + sqrt(vv) x the V strip's (Gram bound `gram` of the face). `inside` must lie in
// the (cut) box.
double box_in_domain(const Grid& g, const std::vector<TraceBand>& bands, const SideStrips& strips, const Gram& gram,
                     uint32_t local, const Vec2& lo, const Vec2& hi, const Vec2& inside) {
  if (!(lo.x >= 0.0 && lo.y >= 0.0 && hi.x <= 1.0 && hi.y <= 1.0)) return kInf;
  const Vec2 m = g.f.chord_metric;
  const Vec2 a = g.to_uv(local, lo), b = g.to_uv(local, hi), w = g.to_uv(local, inside);
  const double range = g.range() * std::max(m.x, m.y), slack = 1e-9 * range;
  // Whether the box lies in D; with `cut`, the curves along the sides are not tested (the box
  // has been cut clear of their strips).
  const auto in_domain = [&](const Vec2& box_lo, const Vec2& box_hi, bool cut) {
    if (!(box_lo.x <= w.x && w.x <= box_hi.x && box_lo.y <= w.y && w.y <= box_hi.y)) return false;
    const Vec2 centre = 0.5 * (box_lo + box_hi);
    bool in = true;
    for (size_t k = 0; k < bands.size(); ++k) {
      const TraceBand& band = bands[k];
      const occt::BoundaryChord& c = g.f.chords[k];
      const Vec2 d = c.uv_a - centre;
      const Vec2 shift = m * (d - periodic_difference(g, d));  // the box moved whole periods towards the chord
      const Vec2 box_a = m * box_lo + shift, box_b = m * box_hi + shift, point = m * w + shift;
      // Far from the chord: clear of its curve (within `deviation` of it) and of its trace.
      if (box_segment_distance(box_a, box_b, band.a, band.b) > 2.0 * band.deviation + band.trace_deviation + slack)
        continue;
      for (size_t i = 0; !(cut && strips.along_side[k]) && i + 1 < band.trace.size(); ++i) {
        if (!(box_segment_distance(box_a, box_b, band.trace[i], band.trace[i + 1]) > band.trace_deviation + slack))
          return false;
      }
      const double to_chord = segment_distance(point, band.a, band.b);
      if (to_chord > band.deviation) continue;
      if (to_chord < 1e-6 * range) return false;
      if (sliver::odd_crossings(band.trace, point)) in = !in;
    }
    return in;
  };
  Vec2 box_lo = glm::min(a, b), box_hi = glm::max(a, b);
  if (in_domain(box_lo, box_hi, false)) return 0.0;
  // The side strips cut from the box.
  double cut_u = 0.0, cut_v = 0.0;
  const double u0 = g.f.u_breaks.front(), u1 = g.f.u_breaks.back(), v0 = g.f.v_breaks.front(), v1 = g.f.v_breaks.back();
  if (strips.u_lo > 0.0 && box_lo.x < u0 + strips.u_lo) box_lo.x = u0 + strips.u_lo, cut_u = strips.u_lo;
  if (strips.u_hi > 0.0 && box_hi.x > u1 - strips.u_hi)
    box_hi.x = u1 - strips.u_hi, cut_u = std::max(cut_u, strips.u_hi);
  if (strips.v_lo > 0.0 && box_lo.y < v0 + strips.v_lo) box_lo.y = v0 + strips.v_lo, cut_v = strips.v_lo;
  if (strips.v_hi > 0.0 && box_hi.y > v1 - strips.v_hi)
    box_hi.y = v1 - strips.v_hi, cut_v = std::max(cut_v, strips.v_hi);
  if ((cut_u == 0.0 && cut_v == 0.0) || !in_domain(box_lo, box_hi, true)) return kInf;
  return (std::sqrt(gram.uu) * cut_u + std::sqrt(gram.vv) * cut_v) * (1.0 + 16.0 * kUnit);
}

void raise_lower_in_slivers(const occt::PartMesh& part, const Grid& g, const Model& model,
                            const std::vector<Triangle>& vertices, size_t emitted,
                            const std::vector<std::array<Vec2, 3>>& corner_uv,
                            const std::vector<uint32_t>& chord_triangle, DistanceInterval& m2s) {
  using namespace sliver;
  const occt::PartFace& f = g.f;
  const Vec2 m = f.chord_metric;
  const double range = g.range() * std::max(m.x, m.y);
  std::vector<Band> bands(f.chords.size());
  // The face is its patches' surface over D (the certificate's upper bounds take it so too); the
  // chords and the patch grid must share one (U, V) window (not shifted by a period).
  const Vec2 lo = m * Vec2(f.u_breaks.front(), f.v_breaks.front()), hi = m * Vec2(f.u_breaks.back(), f.v_breaks.back());
  const double slack = 1e-6 * range;
  for (size_t k = 0; k < f.chords.size(); ++k) {
    const occt::BoundaryChord& c = f.chords[k];
    Band& band = bands[k];
    band.a = m * c.uv_a, band.b = m * c.uv_b, band.deviation = c.deviation, band.trace_deviation = c.trace_deviation;
    for (const Vec2& q : c.trace) band.trace.push_back(m * q);
    if (!(c.trace_deviation < kInf) || band.trace.size() < 2) return;
    for (const Vec2& q : band.trace) {
      if (!(q.x >= lo.x - slack && q.x <= hi.x + slack && q.y >= lo.y - slack && q.y <= hi.y + slack)) return;
    }
  }
  // Candidates: chords whose curve bulges to the side of the triangle on them, largest deviation first.
  struct Candidate {
    size_t chord;
    Vec2 edge_mid;                // metric: the midpoint of the triangle's edge on the chord
    std::array<Vec2, 3> corners;  // metric: the triangle's corners at a, b and the third
  };
  std::vector<Candidate> candidates;
  for (size_t k = 0; k < f.chords.size(); ++k) {
    const occt::BoundaryChord& c = f.chords[k];
    const uint32_t t = chord_triangle[k];
    if (c.a == c.b || !(c.deviation > 0.0) || t >= emitted) continue;  // an emitted triangle: p is on the mesh
    int third = -1, at_a = -1, at_b = -1;
    for (int i = 0; i < 3; ++i) {
      const uint32_t v = vertices[t][i];
      if (v == c.a)
        at_a = i;
      else if (v == c.b)
        at_b = i;
      else
        third = i;
    }
    if (third < 0 || at_a < 0 || at_b < 0) continue;
    const Vec2 chord_mid = 0.5 * (c.uv_a + c.uv_b), edge_mid = 0.5 * (corner_uv[t][at_a] + corner_uv[t][at_b]);
    const Vec2 shift = (chord_mid - edge_mid) - periodic_difference(g, chord_mid - edge_mid);
    const Band& band = bands[k];
    const Vec2 w = m * (corner_uv[t][third] + shift), along = band.b - band.a;
    const auto side = [&](const Vec2& x) { return along.x * (x.y - band.a.y) - along.y * (x.x - band.a.x); };
    double bulge = 0.0;
    for (const Vec2& q : band.trace) bulge = std::abs(side(q)) > std::abs(bulge) ? side(q) : bulge;
    if (bulge * side(w) <= 0.0) continue;
    candidates.push_back(
        {k, m * (edge_mid + shift), {m * (corner_uv[t][at_a] + shift), m * (corner_uv[t][at_b] + shift), w}});
  }
  constexpr size_t kCandidates = 24;
  const auto larger = [&](const Candidate& x, const Candidate& y) {
    return f.chords[x.chord].deviation > f.chords[y.chord].deviation;
  };
  if (candidates.size() > kCandidates) {
    std::nth_element(candidates.begin(), candidates.begin() + kCandidates, candidates.end(), larger);
    candidates.resize(kCandidates);
  }
  std::sort(candidates.begin(), candidates.end(), larger);

  // The rounding of sub-nets (halvings average homogeneous points; kNodes boxes are < 64 halvings
  // deep) and of the hull's box, through the weights' spread.
  double patch_size = 0.0, spread = 1.0;
  for (const BezierPatch& patch : model.patches) {
    for (const Vec3& q : patch.points) patch_size = std::max({patch_size, std::abs(q.x), std::abs(q.y), std::abs(q.z)});
    if (patch.rational()) {
      const auto [w0, w1] = std::minmax_element(patch.weights.begin(), patch.weights.end());
      spread = std::max(spread, *w1 / *w0);
    }
  }
  const double net_rounding = 256.0 * kUnit * spread * patch_size;
  constexpr int kNodes = 1500;  // boxes popped per candidate

  // A proven lower bound of d(p, F), F the face, given a disk N (centre `centre`, radius r, metric)
  // of (U, V) that lies wholly outside D: the smallest distance from p to the hull of the patches'
  // boxes not inside N, by branch and bound (smallest bound first). It stops when a box is 1/16 of
  // N's radius, at 98 % of `estimate` (a point of F's distance to p) or after kNodes boxes; the popped
  // bound is the answer, less the sub-nets' rounding. -1 when a weight is not positive.
  struct Box {
    double lower;
    uint32_t patch;
    Vec2 s, t;  // local [s.x, s.y] x [t.x, t.y]
    Net net;
    bool operator>(const Box& o) const { return lower > o.lower; }
  };
  const auto lower_off_disk = [&](const Vec3& p, const Vec2& centre, double r, double estimate) {
    const auto corners_in_n = [&](const Box& b) {
      for (const double s : {b.s.x, b.s.y}) {
        for (const double t : {b.t.x, b.t.y}) {
          if (!(glm::length(m * g.to_uv(b.patch, Vec2(s, t)) - centre) <= r)) return false;
        }
      }
      return true;
    };
    const double rounding = net_rounding + 4.0 * kUnit * glm::length(p);
    std::priority_queue<Box, std::vector<Box>, std::greater<Box>> open;
    bool sound = true;
    const auto push = [&](Box b) {
      if (corners_in_n(b)) return;
      b.lower = hull_distance(b.net, p);
      if (b.lower < 0.0) sound = false;
      open.push(std::move(b));
    };
    for (uint32_t k = 0; k < model.patches.size(); ++k)
      push({0.0, k, Vec2(0.0, 1.0), Vec2(0.0, 1.0), homogeneous_net(model.patches[k])});
    double lower = -1.0;
    for (int nodes = 0; sound && !open.empty(); ++nodes) {
      Box b = open.top();
      open.pop();
      const Vec2 c00 = m * g.to_uv(b.patch, Vec2(b.s.x, b.t.x)), c11 = m * g.to_uv(b.patch, Vec2(b.s.y, b.t.y));
      const Vec2 extent = glm::abs(c11 - c00);
      if (b.lower >= 0.98 * estimate || nodes >= kNodes || std::max(extent.x, extent.y) <= r / 16.0) {
        lower = b.lower;
        break;
      }
      const BezierPatch& patch = model.patches[b.patch];
      const int axis = extent.x >= extent.y ? 0 : 1;
      auto [low, high] = halve(b.net, patch.rows(), patch.cols(), axis);
      Box left = b, right = std::move(b);
      left.net = std::move(low), right.net = std::move(high);
      if (axis == 0) {
        left.s.y = right.s.x = 0.5 * (left.s.x + left.s.y);
      } else {
        left.t.y = right.t.x = 0.5 * (left.t.x + left.t.y);
      }
      push(std::move(left));
      push(std::move(right));
    }
    if (!sound || lower < 0.0) return -1.0;
    return lower * (1.0 - 8.0 * kUnit) - rounding;
  };

  double per_deviation = kInf;  // lower bound found per unit of chord deviation (kInf: none found yet)
  for (const Candidate& cand : candidates) {
    const occt::BoundaryChord& c = f.chords[cand.chord];
    const Band& own = bands[cand.chord];
    const Vec2 mid = 0.5 * (own.a + own.b);
    // 1. The clearance of N: own band first, then the bands whose chord comes that close.
    double r = own.clearance(mid);
    for (const Band& band : bands) {
      if (segment_distance(mid, band.a, band.b) - band.deviation < r) r = std::min(r, band.clearance(mid));
    }
    r -= 1e-12 * range;
    if (!(r > 1e-9 * range)) continue;
    // 2. c on the triangle's median from its edge's midpoint (the chord's, up to the tiling's
    // matching tolerance), inside N and strictly inside the triangle.
    const Vec2 inward = cand.corners[2] - cand.edge_mid;  // towards the triangle's third corner
    const double reach = glm::length(inward);
    if (!(reach > 0.0) || !(glm::length(cand.edge_mid - mid) <= 1e-3 * r)) continue;
    const Vec2 point = cand.edge_mid + std::min(0.49 * r, 0.5 * reach) / reach * inward;
    // Its other two edges may be shared with neighbours matched within the tiling's tolerance: c
    // keeps clear of them too (so no neighbour's triangle covers it as well).
    const auto& tc = cand.corners;
    if (!(segment_distance(point, tc[0], tc[2]) >= 1e-6 * range &&
          segment_distance(point, tc[1], tc[2]) >= 1e-6 * range))
      continue;
    bool outside = false, decided = true;  // indicator of P at c is 1
    for (const Band& band : bands) {
      const double to_chord = segment_distance(point, band.a, band.b);
      if (to_chord > band.deviation) continue;
      // Too near a chord for the crossing test, or within the tiling's matching tolerance (1e-7 of
      // the range) of the polygon's edge.
      if (to_chord < 1e-6 * range) decided = false;
      if (odd_crossings(band.trace, point)) outside = !outside;
    }
    if (!decided || !outside) continue;
    // 3. Branch and bound over the patches' boxes off N.
    const Vec3 p = 0.5 * (part.mesh.positions[c.a] + part.mesh.positions[c.b]);
    double estimate = kInf;  // of d(p, F): the trimming curve's middle point
    for (const Vec3& q : c.curve_points) estimate = std::min(estimate, glm::length(q - p) + c.curve_point_error);
    // A chord as wide as one already bounded yields about as much (the same surface's scale): skip
    // it unless its deviation promises 2 % more.
    if (!(estimate > m2s.lower) || !(1.02 * per_deviation * c.deviation > m2s.lower)) continue;
    const double lower = lower_off_disk(p, mid, r, estimate);
    if (!(lower > m2s.lower)) continue;
    per_deviation = per_deviation == kInf ? lower / c.deviation : std::max(per_deviation, lower / c.deviation);
    m2s.lower = lower;
    m2s.witness = p;
    m2s.witness_patch = -1;
  }

  // Boundary vertices off their trimming curve: a shared edge vertex sits on its edge's 3D curve,
  // which may leave S(p-curve) by up to the edge's tolerance (trj10's planes: a corner 3.2e-4 along
  // the plane from its p-curves' corner). Its nearest point of the untrimmed surface then lies
  // outside D, where the bounds against the untrimmed patches give about 0. The same three steps,
  // with N a disk around that nearest point's (U, V) (Gauss-Newton from the vertex's own (U, V);
  // any point gives a sound bound, a near one a tight bound) classified against P by the tiling:
  // no triangle's (U, V) comes within the matching tolerance of it, so it lies outside P.
  struct VertexCandidate {
    Vec3 p;           // a mesh point: a chord's end or middle
    Vec2 uv;          // its (U, V) on the chord
    double offset;    // |p - S(uv)|, which orders the candidates
    double estimate;  // |p - x| for a point x of F (the branch and bound stops near it)
  };
  std::vector<VertexCandidate> vertex_candidates;
  // The face's patch holding (U, V) (the grid's cell, clamped onto it) and the point's (s, t) there.
  const auto locate = [&](Vec2 uv, Vec2& st) {
    const size_t i = cell_span(f.u_breaks, uv.x, uv.x).first, j = cell_span(f.v_breaks, uv.y, uv.y).first;
    const double s = (uv.x - f.u_breaks[i]) / (f.u_breaks[i + 1] - f.u_breaks[i]);
    st = Vec2(f.reversed ? 1.0 - s : s, (uv.y - f.v_breaks[j]) / (f.v_breaks[j + 1] - f.v_breaks[j]));
    return static_cast<uint32_t>(i * g.nv + j);
  };
  const auto surface_at = [&](const Vec2& uv) {
    Vec2 st;
    const uint32_t local = locate(uv, st);
    return evaluate_with_derivatives(model.patches[local], st.x, st.y).position;
  };
  for (const occt::BoundaryChord& c : f.chords) {
    if (c.a == c.b) continue;
    // The chord's end a: S(uv_a) is a point of F (the trimming curve's end).
    const Vec3 end = part.mesh.positions[c.a];
    const double offset = glm::length(end - surface_at(c.uv_a));
    if (offset > m2s.lower && std::isfinite(offset)) vertex_candidates.push_back({end, c.uv_a, offset, offset});
    // Its middle: the trimming curve's points are points of F.
    const Vec3 middle = 0.5 * (part.mesh.positions[c.a] + part.mesh.positions[c.b]);
    const Vec2 uv_mid = 0.5 * (c.uv_a + c.uv_b);
    double estimate = kInf;
    for (const Vec3& q : c.curve_points) estimate = std::min(estimate, glm::length(q - middle) + c.curve_point_error);
    const double mid_offset = glm::length(middle - surface_at(uv_mid));
    if (estimate > m2s.lower && std::isfinite(mid_offset))
      vertex_candidates.push_back({middle, uv_mid, std::min(mid_offset, estimate), estimate});
  }
  constexpr size_t kVertexCandidates = 8;
  const auto farther = [](const VertexCandidate& x, const VertexCandidate& y) { return x.offset > y.offset; };
  if (vertex_candidates.size() > kVertexCandidates) {
    std::nth_element(vertex_candidates.begin(), vertex_candidates.begin() + kVertexCandidates, vertex_candidates.end(),
                     farther);
    vertex_candidates.resize(kVertexCandidates);
  }
  std::sort(vertex_candidates.begin(), vertex_candidates.end(), farther);
  const Vec2 window_lo(f.u_breaks.front(), f.v_breaks.front()), window_hi(f.u_breaks.back(), f.v_breaks.back());
  for (const VertexCandidate& cand : vertex_candidates) {
    if (!(cand.estimate > m2s.lower)) continue;
    const Vec3& p = cand.p;
    // The nearest point of the untrimmed surface: Gauss-Newton in (U, V), kept in the patch window.
    Vec2 uv = glm::clamp(cand.uv, window_lo, window_hi);
    for (int step = 0; step < 12; ++step) {
      Vec2 st;
      const uint32_t local = locate(uv, st);
      const SurfacePointEval e = evaluate_with_derivatives(model.patches[local], st.x, st.y);
      const size_t i = local / g.nv, j = local % g.nv;
      const Vec3 su = e.du * ((f.reversed ? -1.0 : 1.0) / (f.u_breaks[i + 1] - f.u_breaks[i]));
      const Vec3 sv = e.dv / (f.v_breaks[j + 1] - f.v_breaks[j]);
      const double a = glm::dot(su, su), b = glm::dot(su, sv), d = glm::dot(sv, sv);
      const double det = a * d - b * b;
      if (!(det > 0.0)) break;
      const Vec3 r = p - e.position;
      const double x = glm::dot(su, r), y = glm::dot(sv, r);
      const Vec2 next = glm::clamp(uv + Vec2(d * x - b * y, a * y - b * x) / det, window_lo, window_hi);
      if (!(std::isfinite(next.x) && std::isfinite(next.y))) break;
      const bool still = next == uv;
      uv = next;
      if (still) break;
    }
    const Vec2 centre = m * uv;
    // 1. N's radius: the clearance from every trace band.
    double r = kInf;
    for (const Band& band : bands) r = std::min(r, band.clearance(centre));
    r -= 1e-12 * range;
    if (!(r > 1e-9 * range)) continue;
    // 2. The centre lies outside P: no triangle (whole periods moved towards it) comes within the
    // tiling's matching tolerance of it. D's indicator there is P's (0) flipped by the loops "curve
    // - chord" that wind around it.
    bool outside_p = true;
    for (size_t x = 0; outside_p && x < corner_uv.size(); ++x) {
      const Vec2 d = corner_uv[x][0] - uv;
      const Vec2 here = m * (uv + (d - periodic_difference(g, d)));
      const Vec2 t0 = m * corner_uv[x][0], t1 = m * corner_uv[x][1], t2 = m * corner_uv[x][2];
      const auto side = [&](const Vec2& a, const Vec2& b) {
        return (b.x - a.x) * (here.y - a.y) - (b.y - a.y) * (here.x - a.x);
      };
      const double s0 = side(t0, t1), s1 = side(t1, t2), s2 = side(t2, t0);
      const bool inside = (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0);
      const double edge =
          std::min({segment_distance(here, t0, t1), segment_distance(here, t1, t2), segment_distance(here, t2, t0)});
      if (inside || !(edge >= 1e-6 * range)) outside_p = false;
    }
    if (!outside_p) continue;
    bool in_d = false, decided = true;
    for (size_t k = 0; k < bands.size(); ++k) {
      const Band& band = bands[k];
      const Vec2 d = f.chords[k].uv_a - uv;
      const Vec2 point = m * (uv + (d - periodic_difference(g, d)));  // moved whole periods towards the chord
      const double to_chord = segment_distance(point, band.a, band.b);
      if (to_chord > band.deviation) continue;
      if (to_chord < 1e-6 * range) decided = false;
      if (odd_crossings(band.trace, point)) in_d = !in_d;
    }
    if (!decided || in_d) continue;
    // 3. Branch and bound off N; S(uv) of the vertex's own (U, V) is the estimate.
    const double lower = lower_off_disk(p, centre, r, cand.estimate);
    if (!(lower > m2s.lower)) continue;
    m2s.lower = lower;
    m2s.witness = p;
    m2s.witness_patch = -1;
  }
}

// The loops route for face `face` (see FaceCertificate).
FaceCertificate certify_loop_face(const occt::PartMesh& part, int face, const std::vector<uint32_t>& triangles,
                                  const CertifyOptions& options, std::vector<double>& triangle_upper) {
  const occt::PartFace& f = part.faces[static_cast<size_t>(face)];
  FaceCertificate fc;
  fc.face = face;
  fc.route = "loops";
  fc.chords = f.chords.size();
  const Grid g(f);
  if (g.nu * g.nv != static_cast<size_t>(f.patch_count) || g.nu == 0) {
    fc.reason = "the face's patch grid is unknown";
    return fc;
  }
  if (!chords_inside_grid(g)) {
    fc.reason =
        "the face's trimming curves leave its patches' parameter range (its surface's Bézier form does not cover the "
        "face)";
    return fc;
  }
  std::string reason;
  // The emitted triangles, then the (U, V) triangles collapsed at a pole (PartFace::collapsed): both
  // tile the loops' polygon; a collapsed one is certified as the mesh edge it collapses onto.
  std::vector<std::array<Vec2, 3>> corner_uv = corner_uvs(part, g, triangles, reason);
  if (!reason.empty()) {
    fc.reason = reason;
    return fc;
  }
  std::vector<Triangle> vertices;
  for (const uint32_t t : triangles) vertices.push_back(part.mesh.triangles[t]);
  for (const occt::PartFace::CollapsedTriangle& c : f.collapsed) {
    vertices.push_back(c.vertices);
    corner_uv.push_back(c.uv);
  }
  Model model;
  model.name = part.name + " " + f.name;
  model.patches.assign(part.model.patches.begin() + f.first_patch,
                       part.model.patches.begin() + f.first_patch + f.patch_count);
  const Pieces pieces = cut_along_grid(part, g, vertices, corner_uv);
  if (pieces.mesh.triangles.empty()) {
    fc.reason = "no triangle of the face has a non-degenerate (U, V) image";
    return fc;
  }
  CertifyOptions cut = options;
  // Pieces whose corners sit on the edges' curves (off the surface by the B-rep's tolerance) cannot
  // refine below that offset; past 4^5 leaves the bound no longer moved on the shared parts at
  // uniform densities (bug32745 18 s at depth 8, 0.3 s at depth 5, the same intervals), so the loops
  // route stops there first. A coarse face (the fit's per-face densities) has a few long triangles
  // that need more: when leaves ran out of depth and the interval is wider than twice the boundary
  // offset (which no refinement removes) and above a proven lower bound, the face is certified
  // again to depth 7 (OCC2368's cones and cylinders at 1 segment per side: 1.1-1.3 -> within 1.05).
  // Always depth 7 cost bearing.iges's BRepMesh mesh at 1e-3 of the diagonal 20 s instead of 1 s.
  const int deep = std::min(cut.max_depth, 7);
  cut.max_depth = std::min(cut.max_depth, 5);
  // Pieces of exact (planar) triangles whose corners sit on the edges' curves carry the edges'
  // tolerance: refining them below it would only exhaust the depth budget.
  if (cut.refine_floor <= 0.0) {
    const double face_size = model_box(model).diagonal();
    cut.refine_floor = face_size > 0.0 ? 1e-7 * model_box(part.model).diagonal() / face_size : 0.0;
  }
  cut.in_domain = [&g](uint32_t local, Vec2 st) { return !near_a_chord(g, g.to_uv(local, st)); };
  // An untrimmed face is its patches whole: a triangle may be matched to its corners' projections.
  cut.domain_contains_patches = !f.trimmed;
  // On a trimmed face, where the leaf and its corners' projections lie clear of the trimming curves.
  const std::vector<TraceBand> bands = f.trimmed ? trace_bands(g) : std::vector<TraceBand>{};
  const SideStrips strips = side_strips(g, bands);
  const std::vector<Gram> grams = patch_grams(model, g);
  const Gram gram = face_gram(grams, g);
  if (f.trimmed)
    cut.box_in_domain = [&g, &bands, &strips, &gram](uint32_t local, const Vec2& lo, const Vec2& hi,
                                                     const Vec2& inside) {
      return box_in_domain(g, bands, strips, gram, local, lo, hi, inside);
    };
  DistanceReport d = certify_distance(model, pieces.mesh, cut);
  const double shallow_lower = std::max(d.mesh_to_surface.lower, d.surface_to_mesh.lower);
  const double shallow_upper = std::max(d.mesh_to_surface.upper, d.surface_to_mesh_over_triangles);
  if (deep > cut.max_depth && d.budget_exhausted > 0 && shallow_lower > 0.0 && shallow_upper > 1.05 * shallow_lower &&
      shallow_upper - shallow_lower > 2.0 * f.max_boundary_offset) {
    cut.max_depth = deep;
    d = certify_distance(model, pieces.mesh, cut);
  }

  // Per triangle (and collapsed triangle): its pieces' bound, plus the rounding of the pieces' corners
  // (affine combinations).
  std::vector<double> base(vertices.size(), 0.0);
  for (size_t k = 0; k < pieces.source.size(); ++k) {
    const double rounding = 8.0 * kUnit * glm::length(pieces.mesh.positions[pieces.mesh.triangles[k][0]]);
    base[pieces.source[k]] = std::max(base[pieces.source[k]], d.triangle_upper[k] + rounding);
  }
  std::vector<double> upper = base;
  // The slivers between chords and trimming curves: within `deviation` (metric m) of a chord point c,
  // so within e_T + lipschitz * deviation of the mesh (both directions), T the triangle on the chord.
  // The segment from c to a sliver point lies in the chord's deviation band (convex) and in the
  // face's rectangle (both ends do), so the speed bound is taken over the patches whose cells meet
  // the band's box. A tiling gap of rounding size between neighbours' corners costs the face's
  // largest speed times 1e-12 of the range, and the flat triangles' reach (tiling_reason) its
  // speed times that reach.
  std::vector<uint32_t> chord_triangle;
  double flat_reach = 0.0;
  const std::string tiling = tiling_reason(g, vertices, corner_uv, chord_triangle, flat_reach);
  const double gap = (std::sqrt(gram.uu) + std::sqrt(gram.vv)) * (1e-12 * g.range() + flat_reach);
  double face_upper = 0.0;
  for (const double u : upper) face_upper = std::max(face_upper, u + gap);
  bool deviations_proven = true;
  // A first-order sliver term below 1e-9 of the part's size (a straight edge's chord, whose curve is
  // the chord up to rounding) is kept as it is: the slices could not lower it by anything a report shows.
  const double negligible = 1e-9 * model_box(part.model).diagonal();
  if (tiling.empty()) {
    for (size_t k = 0; k < f.chords.size(); ++k) {
      const occt::BoundaryChord& c = f.chords[k];
      const Vec2 reach = Vec2(c.deviation) / f.chord_metric;
      const Gram local = gram_over(model, grams, g, glm::min(c.uv_a, c.uv_b) - reach, glm::max(c.uv_a, c.uv_b) + reach);
      const double term = sliver_term(local, f.chord_metric, c);
      deviations_proven = deviations_proven && std::isfinite(term);
      const uint32_t t = chord_triangle[k];
      const ChordRectangle rect(g, c, corner_uv[t]);
      const auto corners_3d = [&](size_t x) {
        std::array<Vec3, 3> p;
        for (int i = 0; i < 3; ++i) p[i] = part.mesh.positions[vertices[x][i]];
        return p;
      };
      // Face -> mesh: the first-order term, or the slices' bound against the chord's triangle.
      double to_mesh = base[t] + term;
      if (t < triangles.size() && c.a != c.b && term > std::max(0.02 * base[t], negligible))
        to_mesh = std::min(to_mesh, sliver_to_triangle(model, g, c, corners_3d(t), base[t], to_mesh));
      // Mesh -> face: a mesh point over (U, V) outside the domain near this chord lies in a triangle
      // meeting the rectangle's part on the chord triangle's side (width `inner`) or, past a reflex
      // corner, the other part (`outer`), and within that width of the curve straight across: the
      // first-order bound, or the slices' bound between the triangle and the curve.
      const double speed = across_speed(local, f.chord_metric, c);
      const auto from_mesh = [&](size_t x, const std::array<Vec2, 3>& p, double width, std::pair<double, double> w) {
        double bound = base[x] + width * speed;
        if (x < triangles.size() && rect.frame.length > 0.0 && width * speed > std::max(0.02 * base[x], negligible)) {
          // Only x's part inside the strip w in [w.first, w.second] can lie over the sliver: a
          // neighbour that meets it near a chord's end is bounded there, not along the whole chord.
          const double reach =
              rect.frame.length + rect.overshoot + std::max({std::abs(p[0].x), std::abs(p[1].x), std::abs(p[2].x)});
          auto [lo, hi] = strip_s_extent(p, w.first, w.second, 1e-9 * reach);
          if (!(lo <= hi)) lo = std::min({p[0].x, p[1].x, p[2].x}), hi = std::max({p[0].x, p[1].x, p[2].x});
          const double s0 = std::max(-rect.overshoot, lo);
          const double s1 = std::min(rect.frame.length + rect.overshoot, hi);
          const double across =
              across_to_curve(model, g, rect.frame, p, corners_3d(x), s0, s1, w.first, w.second, base[x], bound);
          bound = std::min(bound, std::max(base[x], across));
        }
        return bound;
      };
      const double own = from_mesh(t, rect.corners(g, corner_uv[t]), rect.inner, rect.inner_w());
      fc.sliver = std::max({fc.sliver, to_mesh - base[t], own - base[t]});
      upper[t] = std::max({upper[t], to_mesh + gap, own + gap});
      face_upper = std::max(face_upper, upper[t]);
      for (size_t x = 0; x < vertices.size(); ++x) {
        if (x == t) continue;
        const std::array<Vec2, 3> p = rect.corners(g, corner_uv[x]);
        double bound = 0.0;
        if (rect.meets(p, rect.inner_w())) bound = from_mesh(x, p, rect.inner, rect.inner_w());
        if (rect.meets(p, rect.outer_w())) bound = std::max(bound, from_mesh(x, p, rect.outer, rect.outer_w()));
        if (bound > 0.0) fc.sliver = std::max(fc.sliver, bound - base[x]);
        upper[x] = std::max(upper[x], bound + gap);
        face_upper = std::max(face_upper, upper[x]);
      }
    }
  }
  fc.mesh_to_surface = d.mesh_to_surface;
  fc.surface_to_mesh = d.surface_to_mesh;
  if (!tiling.empty()) {
    // The face -> mesh witnesses are points of the triangles' (U, V) footprints, which are points of
    // the face only where the triangles tile its domain: a folded footprint may lie in a hole (a
    // "lower bound" of 10.3 where the mesh is within 1.37 of the face). Only the points on the
    // trimming curves (below) remain. The mesh -> face bound is a distance to the face's whole
    // patches and stays.
    fc.surface_to_mesh.lower = 0.0;
    fc.surface_to_mesh.witness = Vec3(0.0);
    fc.surface_to_mesh.witness_patch = -1;
  }
  fc.triangles_mesh_to_surface = d.mesh_to_surface.upper;
  raise_lower_on_curves(f, pieces.mesh, fc.surface_to_mesh);
  if (tiling.empty())
    raise_lower_in_slivers(part, g, model, vertices, triangles.size(), corner_uv, chord_triangle, fc.mesh_to_surface);
  fc.mesh_to_surface.upper = face_upper;
  fc.surface_to_mesh.upper = face_upper;
  if (!tiling.empty()) {
    fc.reason = tiling;
    fc.mesh_dependent = true;
  } else if (!deviations_proven) {
    fc.reason = "a trimming curve's deviation from its chords is not proven (its p-curve has no exact Bézier form)";
  } else if (!d.not_certified_reason.empty()) {
    fc.reason = d.not_certified_reason;
  } else if (!d.mesh_to_surface.certified || !std::isfinite(d.surface_to_mesh_over_triangles) ||
             !std::isfinite(face_upper)) {
    fc.reason = "the bound over the triangles is not finite";
  }
  fc.certified = fc.reason.empty();
  for (DistanceInterval* i : {&fc.mesh_to_surface, &fc.surface_to_mesh}) {
    i->certified = fc.certified;
    if (!fc.certified) i->upper = kInf;
  }
  fc.hausdorff = fc.mesh_to_surface.lower >= fc.surface_to_mesh.lower ? fc.mesh_to_surface : fc.surface_to_mesh;
  fc.hausdorff.upper = fc.certified ? face_upper : kInf;
  if (fc.certified) {
    for (size_t k = 0; k < triangles.size(); ++k) triangle_upper[triangles[k]] = upper[k];
  }
  return fc;
}

// Folds the faces into the part's report: lower bounds over every face, upper bounds certified only
// when every face is.
void fold_faces(PartCertificate& cert) {
  DistanceReport& d = cert.distance;
  d = DistanceReport{};
  bool all = !cert.faces.empty();
  for (const FaceCertificate& f : cert.faces) {
    all = all && f.certified;
    const std::pair<DistanceInterval*, const DistanceInterval*> pairs[] = {
        {&d.mesh_to_surface, &f.mesh_to_surface}, {&d.surface_to_mesh, &f.surface_to_mesh}, {&d.hausdorff, &f.hausdorff}};
    for (const auto& [to, from] : pairs) {
      if (from->lower > to->lower) {
        to->lower = from->lower;
        to->witness = from->witness;
        to->witness_patch = from->witness_patch;
      }
    }
    if (f.certified) cert.certified_faces_upper = std::max(cert.certified_faces_upper, f.hausdorff.upper);
  }
  double m2s = 0.0, s2m = 0.0;
  for (const FaceCertificate& f : cert.faces) {
    m2s = std::max(m2s, f.mesh_to_surface.upper);
    s2m = std::max(s2m, f.surface_to_mesh.upper);
  }
  d.mesh_to_surface.upper = all ? m2s : kInf;
  d.surface_to_mesh.upper = all ? s2m : kInf;
  d.hausdorff.upper = all ? std::max(m2s, s2m) : kInf;
  for (DistanceInterval* i : {&d.mesh_to_surface, &d.surface_to_mesh, &d.hausdorff}) i->certified = all;
  d.coverage_ok = all;
  check_distance_report(d);
  cert.all_certified = all && d.hausdorff.certified;
}

}  // namespace

PartCertificate certify_part(const occt::PartMesh& part, const CertifyOptions& options, double stop_above) {
  const Stopwatch clock;
  if (!part.mesh.has_surface()) throw InputError(part.name + ": the part mesh has no (u, v) to certify");
  budget::check_memory(validation_bytes(double(part.mesh.triangles.size())),
                       part.name + ": certifying " + std::to_string(part.mesh.triangles.size()) + " triangles",
                       "lower --level or raise --max-memory");
  PartCertificate cert;
  cert.triangle_upper.assign(part.mesh.triangles.size(), kInf);
  FaceTriangles face_triangles(part.faces.size());
  for (size_t t = 0; t < part.triangle_face.size(); ++t) face_triangles[part.triangle_face[t]].push_back(static_cast<uint32_t>(t));
  cert.faces.resize(part.faces.size());
  // The first face found whose certified lower bound exceeds stop_above (SIZE_MAX: none yet).
  std::atomic<size_t> decided{SIZE_MAX};
  std::atomic<size_t> skipped{0};
  // Faces in parallel; each face's certificate is itself parallel over its triangles.
  tbb::parallel_for(size_t(0), part.faces.size(), [&](size_t k) {
    budget::check("certifying the part");  // per face (the validator checks per refinement leaf)
    const occt::PartFace& f = part.faces[k];
    FaceCertificate& fc = cert.faces[k];
    fc.face = f.face_index;
    if (f.status != "tessellated" || face_triangles[k].empty()) {
      fc.reason = "not tessellated: " + (f.reason.empty() ? std::string("no triangles") : f.reason);
      return;
    }
    if (decided.load() != SIZE_MAX) {
      fc.reason = "not certified: skipped, the part's distance is already proven above " + format_number(stop_above, 6);
      ++skipped;
      return;
    }
    const Stopwatch face_clock;
    try {
      if (f.kept_whole && !f.trimmed && inside_own_patches(part, f, face_triangles[k])) {
        fc = certify_patch_face(part, f.face_index, face_triangles, options, cert.triangle_upper);
      } else {
        fc = certify_loop_face(part, f.face_index, face_triangles[k], options, cert.triangle_upper);
      }
    } catch (const InputError& e) {
      fc.reason = std::string("not certified: ") + e.what();
    }
    if (part.welded > 0.0) {
      // Measured on the welded mesh; the mesh as read lies within `welded` of it.
      for (DistanceInterval* i : {&fc.mesh_to_surface, &fc.surface_to_mesh, &fc.hausdorff}) {
        i->lower = std::max(0.0, i->lower - part.welded);
        i->upper += part.welded;
      }
      for (const uint32_t t : face_triangles[k]) cert.triangle_upper[t] += part.welded;
    }
    if (fc.certified) fc.upper = fc.hausdorff.upper;
    fc.seconds = face_clock.seconds();
    if (fc.hausdorff.lower > stop_above) {
      size_t none = SIZE_MAX;
      decided.compare_exchange_strong(none, k);
    }
  });
  for (const FaceCertificate& fc : cert.faces) {
    if (!fc.certified) continue;
    ++cert.faces_certified;
    const occt::PartFace& f = part.faces[static_cast<size_t>(fc.face)];
    cert.triangles += face_triangles[static_cast<size_t>(fc.face)].size();
    cert.patches += static_cast<uint64_t>(f.patch_count);
  }
  fold_faces(cert);
  if (decided.load() != SIZE_MAX) {
    const size_t k = decided.load();
    cert.note = "stopped early: " + part.faces[k].name + "'s certified lower bound " +
                format_number(cert.faces[k].hausdorff.lower, 6) + " is above " + format_number(stop_above, 6) + "; " +
                std::to_string(skipped.load()) + " faces skipped";
  }
  if (part.unassigned_triangles > 0) {
    // A foreign mesh's triangles on no single face are in no face's certificate: the mesh as read
    // has no certified upper bound (its lower bounds still hold).
    cert.all_certified = false;
    cert.note = std::to_string(part.unassigned_triangles) + " triangles of the mesh lie on no single face of the part";
    for (DistanceInterval* i : {&cert.distance.mesh_to_surface, &cert.distance.surface_to_mesh, &cert.distance.hausdorff}) {
      i->upper = kInf;
      i->certified = false;
    }
  }
  cert.seconds = clock.seconds();
  return cert;
}

std::string part_certificate_headline(const occt::PartMesh& part, const PartCertificate& cert) {
  std::ostringstream line;
  if (cert.all_certified) {
    line << "certified: hausdorff in [" << cert.distance.hausdorff.lower << ", " << cert.distance.hausdorff.upper
         << "] on all " << part.faces.size() << " faces";
    return line.str();
  }
  line << "not certified: " << cert.faces_certified << " of " << part.faces.size() << " faces certified";
  if (!cert.note.empty()) line << " (" << cert.note << ")";
  if (cert.faces_certified > 0)
    line << " (the certified faces' largest upper bound " << cert.certified_faces_upper << ")";
  line << "; largest lower bound over all faces " << cert.distance.hausdorff.lower;
  return line.str();
}

nlohmann::json part_certificate_json(const occt::PartMesh& part, const PartCertificate& c) {
  nlohmann::json j;
  j["certified"] = c.all_certified;
  j["faces_certified"] = c.faces_certified;
  j["faces_total"] = part.faces.size();
  nlohmann::json missing = nlohmann::json::array(), faces = nlohmann::json::array();
  for (const FaceCertificate& f : c.faces) {
    const occt::PartFace& pf = part.faces[static_cast<size_t>(f.face)];
    if (!f.certified) missing.push_back({{"face", pf.name}, {"reason", f.reason}});
    nlohmann::json row = {{"face", pf.name},           {"surface", pf.surface_type}, {"trimmed", pf.trimmed},
                          {"route", f.route},          {"certified", f.certified},   {"lower", f.hausdorff.lower},
                          {"upper", number_or_null(f.certified ? f.hausdorff.upper : kInf)}};
    if (f.route == "loops") {
      row["chords"] = f.chords, row["sliver"] = f.sliver;
      row["triangles_mesh_to_surface"] = number_or_null(f.triangles_mesh_to_surface);
    }
    // Where each direction's lower bound is reached: a mesh point of the face's triangles (its
    // distance to the face is at least the bound), a point of the face (likewise to the triangles).
    for (const auto& [key, interval] :
         {std::pair<const char*, const DistanceInterval*>{"mesh_to_surface", &f.mesh_to_surface},
          {"surface_to_mesh", &f.surface_to_mesh}}) {
      if (interval->lower > 0.0)
        row[key] = {{"lower", interval->lower},
                    {"witness", {interval->witness.x, interval->witness.y, interval->witness.z}}};
    }
    row["triangles"] = pf.triangles;
    if (pf.segments > 0) row["segments"] = pf.segments, row["grid"] = {pf.segments_u, pf.segments_v};
    if (pf.graded_u > 0) row["graded_grid"] = {pf.graded_u, pf.graded_v}, row["graded_segments"] = pf.graded_segments;
    row["seconds"] = f.seconds;
    if (!f.certified) row["reason"] = f.reason;
    faces.push_back(std::move(row));
  }
  j["faces_not_certified"] = missing;
  if (!c.note.empty()) j["note"] = c.note;
  j["faces"] = faces;
  j["certified_faces_upper"] = c.certified_faces_upper;
  j["certified_triangles"] = c.triangles;
  j["certified_patches"] = c.patches;
  j["hausdorff"] = interval_json(c.distance.hausdorff);
  j["mesh_to_surface"] = interval_json(c.distance.mesh_to_surface);
  j["surface_to_mesh"] = interval_json(c.distance.surface_to_mesh);
  j["seconds"] = c.seconds;
  return j;
}

}  // namespace sagitta::app
