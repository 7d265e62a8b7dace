// Whole CAD parts (docs/CAD.md, "Whole parts"): edges first, then every face.
//
// 1. Every B-rep vertex becomes one mesh vertex; every edge is sampled once (its density follows the
//    scheme on each face that uses it, its turning and an optional chord tolerance) and its interior
//    samples become mesh vertices. A face only refers to these: two faces meeting at an edge share
//    its vertices by index, so the part is watertight by construction. A degenerated edge (sphere
//    pole, cone apex) is one vertex; a seam is shared by the face with itself.
// 2. Inside a face the scheme runs on the face's Bézier patches. Its triangles are kept where they
//    lie inside the trimmed domain and clear of the trimming loops; the rest of the domain (between
//    the kept triangles and the loops) is filled by CGAL's constrained Delaunay triangulation in the
//    patches' parameters, with the loops' chords and the kept triangles' edges as constraints.
#include "sagitta/occt/part.hpp"

#include "occt_shape.hpp"
#include "part_cdt.hpp"
#include "part_chords.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"
#include "sagitta/scheme.hpp"

#include <glm/geometric.hpp>

#include <BRepAdaptor_Curve.hxx>
#include <BRepBndLib.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepGProp.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRepTools_WireExplorer.hxx>
#include <BRepTopAdaptor_FClass2d.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GProp_GProps.hxx>
#include <Geom2d_Curve.hxx>
#include <GeomAPI_ProjectPointOnCurve.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Geom_BSplineSurface.hxx>
#include <Geom_BezierSurface.hxx>
#include <Geom_Curve.hxx>
#include <Geom_RectangularTrimmedSurface.hxx>
#include <Geom_Surface.hxx>
#include <Poly_PolygonOnTriangulation.hxx>
#include <Poly_Triangulation.hxx>
#include <ShapeAnalysis_Surface.hxx>
#include <Standard_Failure.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopTools_ListOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Solid.hxx>
#include <TopoDS_Vertex.hxx>
#include <TopoDS_Wire.hxx>
#include <gp_Pnt2d.hxx>
#include <gp_Vec.hxx>

#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

namespace sagitta::occt {

namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 to_vec(const gp_Pnt& p) { return Vec3(p.X(), p.Y(), p.Z()); }

// ---------------------------------------------------------------------------------------------
// The shape's maps: faces, edges, vertices and solids numbered once (TopExp::MapShapes order).
struct ShapeIndex {
  TopTools_IndexedMapOfShape faces, edges, vertices, solids;
  TopTools_IndexedDataMapOfShapeListOfShape edge_faces, face_solids;
};

ShapeIndex index_shape(const TopoDS_Shape& shape) {
  ShapeIndex x;
  TopExp::MapShapes(shape, TopAbs_FACE, x.faces);
  TopExp::MapShapes(shape, TopAbs_EDGE, x.edges);
  TopExp::MapShapes(shape, TopAbs_VERTEX, x.vertices);
  TopExp::MapShapes(shape, TopAbs_SOLID, x.solids);
  TopExp::MapShapesAndAncestors(shape, TopAbs_EDGE, TopAbs_FACE, x.edge_faces);
  TopExp::MapShapesAndAncestors(shape, TopAbs_FACE, TopAbs_SOLID, x.face_solids);
  return x;
}

// Distinct faces (by TShape and location) that use an edge.
std::vector<int> faces_of_edge(const ShapeIndex& x, const TopoDS_Shape& edge) {
  std::vector<int> out;
  const int k = x.edge_faces.FindIndex(edge);
  if (k == 0) return out;
  for (TopTools_ListOfShape::Iterator it(x.edge_faces(k)); it.More(); it.Next()) {
    const int f = x.faces.FindIndex(it.Value()) - 1;
    if (f >= 0 && std::find(out.begin(), out.end(), f) == out.end()) out.push_back(f);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---------------------------------------------------------------------------------------------
// A face's surface and the Bézier patches it splits into, with the map from the face's (u, v) to
// the patches' parameters (U, V): the identity for B-spline and Bézier surfaces; for analytic
// surfaces OCCT's exact conversion re-parametrises the circular directions (tan(theta/2)), so the
// point S(u, v) is found on the converted surface by Gauss-Newton seeded at (u, v).
struct FaceGeometry {
  TopoDS_Face face;
  FaceReport report;
  std::vector<BezierPatch> patches;
  Handle(Geom_Surface) surface;
  Handle(Geom_BSplineSurface) converted;  // null: (U, V) = (u, v)
  bool reversed = false;
  int nu = 0, nv = 0;             // patch grid
  double su = 1.0, sv = 1.0;      // mean |dS/dU|, |dS/dV|: the metric of chords and certificates
  // Scale of U and V in the loops and the CDT: (su, sv), with the direction the anisotropic grid
  // coarsened shrunk by the same factor, so grid cells keep the shape an N x N grid gives them and
  // the Delaunay triangles stay about one cell wide across the coarse direction.
  double cu = 1.0, cv = 1.0;
  double u_period = 0.0, v_period = 0.0;  // of the face's surface (0: not periodic)
  // (U, V) = (u, v): B-spline and Bézier faces, and planes (whose conversion keeps the parameters,
  // checked at 9 points); otherwise face_to_uv solves for (U, V).
  bool identity_map = true;
  // Per patch span along U (V): tan(a / 2), a the span's half width, where OCCT converted a circle
  // of angle u (v) into rational quadratic arcs (circle_spans); empty otherwise. face_to_uv's first
  // guess then is the arcs' exact inverse, and its Newton steps only confirm it.
  std::vector<double> u_arc_tan, v_arc_tan;
  // The scheme's tessellation of the face's patches (made once per part) and each of its vertices'
  // (U, V) (exact patch-grid values on the patches' sides).
  Tessellation scheme;
  std::vector<Vec2> scheme_uv;
  // The scheme's vertices on the outer sides of the patch range, by (U, V): a vertex the scheme
  // shares across a closed surface's seam is listed at both sides.
  std::map<std::pair<double, double>, uint32_t> scheme_sides;
  int solid = -1;
  int segments = 1;  // the scheme's segments per patch side on this face (ESC: 1, the edge density's unit)
  // The real N a graded grid is built for: PartOptions::face_graded_segments where > 0 (at most
  // `segments`), else `segments`.
  double graded_segments = 1.0;
  // The uniform scheme's grid on every patch of the face: segments_u x segments_v (face_grid: the
  // larger equal to `segments`, 1 x 1 when flat; 1 x 1 for ESC: the edge density's unit).
  int segments_u = 1, segments_v = 1;
  // A graded grid (try_graded_grid): the face's own lines in U and V, replacing the per-patch grid
  // (empty when the face uses the per-patch grid).
  std::vector<double> grid_u, grid_v;
};

double clamp(double x, double lo, double hi) { return std::min(std::max(x, lo), hi); }

// The span of `breaks` that holds x and x's fraction in it (not clamped: outside gives < 0 or > 1).
std::pair<int, double> locate_span(const std::vector<double>& breaks, double x) {
  const int spans = static_cast<int>(breaks.size()) - 1;
  int i = static_cast<int>(std::upper_bound(breaks.begin(), breaks.end(), x) - breaks.begin()) - 1;
  i = std::max(0, std::min(i, spans - 1));
  const double a = breaks[i], b = breaks[i + 1];
  return {i, (x - a) / (b - a)};
}

// (patch index in the face, local (s, t) in that patch's own frame) of the point (U, V).
std::pair<int, Vec2> locate_patch(const FaceGeometry& g, double U, double V) {
  const auto [i, s] = locate_span(g.report.u_breaks, U);
  const auto [j, t] = locate_span(g.report.v_breaks, V);
  return {i * g.nv + j, Vec2(g.reversed ? 1.0 - s : s, t)};
}

// (U, V) of a patch-local point (s, t): exact at the patch corners (s, t in {0, 1} give the breaks).
Vec2 patch_to_uv(const FaceGeometry& g, int patch, const Vec2& st) {
  const int i = patch / g.nv, j = patch % g.nv;
  const double s = g.reversed ? 1.0 - st.x : st.x, t = st.y;
  const auto lerp = [](double a, double b, double x) { return (1.0 - x) * a + x * b; };
  return Vec2(lerp(g.report.u_breaks[i], g.report.u_breaks[i + 1], s),
              lerp(g.report.v_breaks[j], g.report.v_breaks[j + 1], t));
}

std::pair<Vec2, Vec2> wrap_uv(const FaceGeometry& g, const Vec2& UV);

Vec3 eval_uv(const FaceGeometry& g, const Vec2& unwrapped) {
  const Vec2 UV = wrap_uv(g, unwrapped).first;
  const auto [p, st] = locate_patch(g, UV.x, UV.y);
  const auto e = de_casteljau<double>(g.patches[p], clamp(st.x, 0.0, 1.0), clamp(st.y, 0.0, 1.0));
  return Vec3(e[0], e[1], e[2]);
}

// x's copy a whole number of periods away that lies in [lo, hi], and the shift removed (x itself
// and 0 when the direction is not periodic or x is in range).
std::pair<double, double> wrap(double x, double lo, double hi, double period) {
  if (period <= 0.0 || (x >= lo - 1e-9 * period && x <= hi + 1e-9 * period)) return {x, 0.0};
  const double shift = std::floor((x - lo) / period) * period;
  return {x - shift, shift};
}

// The patch parameters (U, V) of the face's point (u, v) (see FaceGeometry). In a periodic
// direction (u, v) may lie whole periods away from the patches' range (a face winding around its
// surface's seam): the result keeps that offset, so loops stay continuous in the (U, V) plane.
Vec2 face_to_uv(const FaceGeometry& g, double u, double v) {
  const std::vector<double>& ub = g.report.u_breaks;
  const std::vector<double>& vb = g.report.v_breaks;
  const auto [wu, shift_u] = wrap(u, ub.front(), ub.back(), g.u_period);
  const auto [wv, shift_v] = wrap(v, vb.front(), vb.back(), g.v_period);
  double U = clamp(wu, ub.front(), ub.back()), V = clamp(wv, vb.front(), vb.back());
  if (g.converted.IsNull()) return Vec2(U + shift_u, V + shift_v);
  if (!g.u_arc_tan.empty()) U = detail::circle_arc_parameter(ub, g.u_arc_tan, U);
  if (!g.v_arc_tan.empty()) V = detail::circle_arc_parameter(vb, g.v_arc_tan, V);
  const gp_Pnt target = g.surface->Value(u, v);
  // Newton's steps shrink quadratically until rounding takes over; a step near rounding level that
  // no longer halves the previous one is noise (it would oscillate by an ulp for all 40 iterations).
  const double range_u = ub.back() - ub.front(), range_v = vb.back() - vb.front();
  double previous_step = std::numeric_limits<double>::infinity();
  const Vec3 q = to_vec(target);
  for (int iteration = 0; iteration < 40; ++iteration) {
    // The converted surface is the face's Bézier patches: evaluated there (de Casteljau), with the
    // patch's local derivatives scaled to (U, V).
    const auto [patch, st] = locate_patch(g, U, V);
    const int i = patch / g.nv, j = patch % g.nv;
    const SurfacePointEval e = evaluate_with_derivatives(g.patches[static_cast<size_t>(patch)], st.x, st.y);
    const Vec3 du = e.du * ((g.reversed ? -1.0 : 1.0) / (ub[i + 1] - ub[i]));
    const Vec3 dv = e.dv * (1.0 / (vb[j + 1] - vb[j]));
    const Vec3 r = e.position - q;
    const double a = glm::dot(du, du), b = glm::dot(du, dv), c = glm::dot(dv, dv);
    const double ru = glm::dot(r, du), rv = glm::dot(r, dv);
    const double reg = 1e-12 * (a + c) + std::numeric_limits<double>::min();
    const double det = (a + reg) * (c + reg) - b * b;
    if (!(det > 0.0)) break;
    const double dU = -((c + reg) * ru - b * rv) / det, dV = -((a + reg) * rv - b * ru) / det;
    const double U1 = clamp(U + dU, ub.front(), ub.back()), V1 = clamp(V + dV, vb.front(), vb.back());
    const double step = std::max(std::abs(U1 - U) / range_u, std::abs(V1 - V) / range_v);
    U = U1, V = V1;
    if (step <= 1e-15 || (step <= 1e-12 && step >= 0.5 * previous_step)) break;
    previous_step = step;
  }
  return Vec2(U + shift_u, V + shift_v);
}

// (U, V) moved whole periods into the patches' range, and the shift removed.
std::pair<Vec2, Vec2> wrap_uv(const FaceGeometry& g, const Vec2& UV) {
  const auto [u, su] = wrap(UV.x, g.report.u_breaks.front(), g.report.u_breaks.back(), g.u_period);
  const auto [v, sv] = wrap(UV.y, g.report.v_breaks.front(), g.report.v_breaks.back(), g.v_period);
  return {Vec2(u, v), Vec2(su, sv)};
}

// A p-curve of a periodic surface may run whole periods away from the range the patches cover
// (u in [-0.58, 2.56] on a face over [5.70, 8.84]). The shift (a multiple of each period) that
// brings the curve's middle closest to the range; one shift for the whole curve, so that a curve
// running along a full period stays in one piece.
Vec2 pcurve_shift(const FaceGeometry& g, const Handle(Geom2d_Curve)& pc, double first, double last) {
  const gp_Pnt2d mid = pc->Value(0.5 * (first + last));
  const auto shift = [](double x, double lo, double hi, double period) {
    if (period <= 0.0) return 0.0;
    const auto outside = [&](double y) { return std::max({lo - y, y - hi, 0.0}); };
    const double k = std::round((0.5 * (lo + hi) - x) / period);
    return outside(x + k * period) + 1e-9 * period < outside(x) ? k * period : 0.0;
  };
  return Vec2(shift(mid.X(), g.report.u_breaks.front(), g.report.u_breaks.back(), g.u_period),
              shift(mid.Y(), g.report.v_breaks.front(), g.report.v_breaks.back(), g.v_period));
}

// Mean |dS/dU| and |dS/dV| over the patches (3 x 3 points each): the CDT's scale, so that its
// Delaunay criterion sees triangles shaped roughly as they are in space.
void set_scale(FaceGeometry& g) {
  double su = 0.0, sv = 0.0;
  int n = 0;
  for (int p = 0; p < static_cast<int>(g.patches.size()); ++p) {
    const int i = p / g.nv, j = p % g.nv;
    const double span_u = g.report.u_breaks[i + 1] - g.report.u_breaks[i];
    const double span_v = g.report.v_breaks[j + 1] - g.report.v_breaks[j];
    for (double s : {0.25, 0.5, 0.75}) {
      for (double t : {0.25, 0.5, 0.75}) {
        const SurfacePointEval e = evaluate_with_derivatives(g.patches[p], s, t);
        su += glm::length(e.du) / span_u;
        sv += glm::length(e.dv) / span_v;
        ++n;
      }
    }
  }
  g.su = n > 0 && std::isfinite(su) && su > 0.0 ? su / n : 1.0;
  g.sv = n > 0 && std::isfinite(sv) && sv > 0.0 ? sv / n : 1.0;
  g.cu = g.su;
  g.cv = g.sv;
}

// A converted surface whose (U, V) equal OCCT's (u, v) (a plane: its bilinear form keeps the
// parameters), checked at 3 x 3 points of the patch range: the patches at (u, v) are OCCT's surface
// at (u, v) to 1e-12 of the face's size plus the rounding of coordinates that large. (Compared in
// (U, V) to 1e-12 of the range, a plane 1e6 from the origin failed: its points round by 1e-10, the
// (U, V) solved for them were 5e-10 off, and its trimming curves went untraced, its sliver bounds
// 10 % looser and without a lower bound.)
bool keeps_parameters(const FaceGeometry& g) {
  const std::vector<double>& ub = g.report.u_breaks;
  const std::vector<double>& vb = g.report.v_breaks;
  Vec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  double magnitude = 0.0;
  for (const BezierPatch& p : g.patches) {
    for (const Vec3& x : p.points) {
      lo = glm::min(lo, x), hi = glm::max(hi, x);
      magnitude = std::max({magnitude, std::abs(x.x), std::abs(x.y), std::abs(x.z)});
    }
  }
  const double tol = 1e-12 * glm::length(hi - lo) + 64.0 * std::numeric_limits<double>::epsilon() * magnitude;
  for (double s : {0.1, 0.5, 0.9}) {
    for (double t : {0.1, 0.5, 0.9}) {
      const double u = ub.front() + s * (ub.back() - ub.front()), v = vb.front() + t * (vb.back() - vb.front());
      if (!(glm::length(eval_uv(g, Vec2(u, v)) - to_vec(g.surface->Value(u, v))) <= tol)) return false;
    }
  }
  return true;
}

// tan(a / 2) per patch span along U (along_u) or V, a the span's half width, when every patch is a
// rational quadratic in that direction with weights w, w cos a, w (to 1e-12) on every row: OCCT's
// conversion of a circle parametrised by its angle (Convert_TgtThetaOver2: knots at the angles).
// Empty when any span differs or is wider than a half circle. Only face_to_uv's first guess uses it.
std::vector<double> circle_spans(const FaceGeometry& g, bool along_u) {
  const std::vector<double>& breaks = along_u ? g.report.u_breaks : g.report.v_breaks;
  const int spans = along_u ? g.nu : g.nv;
  std::vector<double> arc_tan;
  for (int k = 0; k < spans; ++k) {
    const double half = 0.5 * (breaks[k + 1] - breaks[k]);
    if (!(half > 0.0 && half < 0.5 * M_PI)) return {};
    const double c = std::cos(half);
    for (int other = 0; other < (along_u ? g.nv : g.nu); ++other) {
      const BezierPatch& p = g.patches[static_cast<size_t>(along_u ? k * g.nv + other : other * g.nv + k)];
      if (p.weights.empty() || (along_u ? p.degree_u : p.degree_v) != 2) return {};
      const int rows = (along_u ? p.degree_v : p.degree_u) + 1;
      for (int r = 0; r < rows; ++r) {
        const auto w = [&](int i) { return along_u ? p.weight(i, r) : p.weight(r, i); };
        const double ends = w(0);
        if (!(ends > 0.0) || std::abs(w(2) - ends) > 1e-12 * ends || std::abs(w(1) - c * ends) > 1e-12 * ends)
          return {};
      }
    }
    arc_tan.push_back(std::tan(0.5 * half));
  }
  return arc_tan;
}

FaceGeometry face_geometry(const ShapeIndex& x, int f, const std::string& name, const CadOptions& options) {
  FaceGeometry g;
  g.face = TopoDS::Face(x.faces(f + 1));
  g.report.face_index = f;
  g.report.name = "Face " + std::to_string(f + 1);
  g.patches = face_patches(g.face, name, options, g.report, &g.converted);
  g.reversed = g.face.Orientation() == TopAbs_REVERSED;
  const int k = x.face_solids.FindIndex(g.face);
  if (k > 0 && !x.face_solids(k).IsEmpty()) g.solid = x.solids.FindIndex(x.face_solids(k).First()) - 1;
  if (g.patches.empty()) return g;
  g.surface = exact_surface(g.face);  // as face_patches converted it
  const Handle(Geom_Surface) basis = untrimmed(g.surface);
  if (basis->IsUPeriodic()) g.u_period = basis->UPeriod();
  if (basis->IsVPeriodic()) g.v_period = basis->VPeriod();
  g.nu = static_cast<int>(g.report.u_breaks.size()) - 1;
  g.nv = static_cast<int>(g.report.v_breaks.size()) - 1;
  // B-spline and Bézier faces keep their parameters; only analytic ones need the map.
  if (basis->IsKind(STANDARD_TYPE(Geom_BSplineSurface)) || basis->IsKind(STANDARD_TYPE(Geom_BezierSurface)))
    g.converted.Nullify();
  set_scale(g);
  g.identity_map = g.converted.IsNull() || keeps_parameters(g);
  if (!g.identity_map) {
    g.u_arc_tan = circle_spans(g, true);
    g.v_arc_tan = circle_spans(g, false);
  }
  return g;
}

// The scheme's tessellation of the face's patches into g.scheme / g.scheme_uv.
// How the face bends, from its patches' control nets: aspect = segments along v per segment along
// u that balance its chord error, sqrt((Av + T) / (Au + T)), where Au, Av are the largest second
// differences along u and v times d (d - 1) and T the largest twist times du dv (the derivative
// bounds of a polynomial patch; for a rational one, of its control polygon). With an error like
// Au / nu^2 + Av / nv^2 this ratio gives the fewest triangles nu nv for a given error. Aspect 0
// (straight along v) or infinity (straight along u) where every patch is straight one way (a
// cylinder's or a cone's rulings): one segment per patch there. `flat`: every second difference and twist vanishes (to
// 1e-12 of the net's size), the patches are planar parallelograms and one cell per patch is exact.
struct FaceBend {
  double aspect = 1.0;
  bool flat = false;
};
// One patch's bending terms (face_bend): the largest second differences along u and v times d (d - 1)
// and the largest twist times du dv, of its control net.
struct PatchBend {
  double u = 0.0, v = 0.0, twist = 0.0;
};
PatchBend patch_bend(const BezierPatch& p) {
  PatchBend b;
  const int du = p.degree_u, dv = p.degree_v;
  for (int i = 0; i <= du; ++i) {
    for (int j = 0; j <= dv; ++j) {
      if (i + 2 <= du)
        b.u = std::max(b.u, du * (du - 1) * glm::length(p.at(i + 2, j) - 2.0 * p.at(i + 1, j) + p.at(i, j)));
      if (j + 2 <= dv)
        b.v = std::max(b.v, dv * (dv - 1) * glm::length(p.at(i, j + 2) - 2.0 * p.at(i, j + 1) + p.at(i, j)));
      if (i + 1 <= du && j + 1 <= dv)
        b.twist =
            std::max(b.twist, du * dv * glm::length(p.at(i + 1, j + 1) - p.at(i + 1, j) - p.at(i, j + 1) + p.at(i, j)));
    }
  }
  return b;
}

FaceBend face_bend(const std::vector<BezierPatch>& patches) {
  double au = 0.0, av = 0.0, twist = 0.0;
  Vec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const BezierPatch& p : patches) {
    for (const Vec3& q : p.points) lo = glm::min(lo, q), hi = glm::max(hi, q);
    const PatchBend b = patch_bend(p);
    au = std::max(au, b.u), av = std::max(av, b.v), twist = std::max(twist, b.twist);
  }
  FaceBend bend;
  if (!std::isfinite(au + av + twist) || patches.empty()) return bend;
  const double size = glm::length(hi - lo);
  // A rational patch's control polygon may be flat while its weights still bend the surface.
  bool rational = false;
  for (const BezierPatch& p : patches) rational = rational || p.rational();
  bend.flat = !rational && au + av + twist <= 1e-12 * size;
  if (bend.flat) return bend;
  // Straight along u (and bending along v): one segment per patch along u.
  bend.aspect = au + twist > 0.0 ? std::sqrt((av + twist) / (au + twist)) : std::numeric_limits<double>::infinity();
  return bend;
}

// The face's grid for `segments` N: 1 x 1 when flat, else N along the direction that bends more and
// N * aspect (rounded up, at least 1) along the other.
std::pair<int, int> face_grid(int segments, const FaceBend& bend) {
  if (bend.flat) return {1, 1};
  const double aspect = bend.aspect;
  if (std::isinf(aspect)) return {1, segments};
  if (!(aspect >= 0.0)) return {segments, std::max(1, segments)};  // NaN
  if (aspect <= 1.0) return {segments, std::max(1, static_cast<int>(std::ceil(segments * aspect - 1e-9)))};
  return {std::max(1, static_cast<int>(std::ceil(segments / aspect - 1e-9))), segments};
}

// ---------------------------------------------------------------------------------------------
// Graded grids: one set of grid lines for the whole face instead of N x N cells on every patch.
// A B-spline face's knot spans may differ in size by a factor of 100 (a fillet swept along a path:
// spans 0.09 mm and 4.5 mm long side by side, bug24595); a per-patch grid spends its N cells on
// each of them alike. Here every span gets the cells its own bending needs, spans that need less
// than one are merged into shared cells, and the lines ignore the knots inside merged cells (the
// certificate cuts triangles along the patch grid, so cells may span several patches).

// Per span of one direction: cells that span needs (real), from the second differences and twists
// of its patches' control nets (face_bend's terms, span-local), scaled so that the face's most
// bending patch gets `segments` cells along the direction it bends most (face_grid's rule).
// `kink_u[k]`: the surface turns across knot k (between spans k - 1 and k) along U: a line stays there.
struct SpanNeeds {
  std::vector<double> u, v;
  std::vector<bool> kink_u, kink_v;
};

// Whether the unit directions a and b differ by more than about 1e-6 radians (either may be zero:
// a collapsed side, no direction to compare).
bool turns(const Vec3& a, const Vec3& b) {
  const double la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0) || !(lb > 0.0)) return false;
  return glm::length(a / la - b / lb) > 1e-6;
}

// Whether span [a, b] of a direction with period `period` (0: none) meets [lo, hi].
bool span_meets(double a, double b, double lo, double hi, double period) {
  for (int k = -1; k <= 1; ++k) {
    if (period <= 0.0 && k != 0) continue;
    const double shift = k * period;
    if (b >= lo + shift && a <= hi + shift) return true;
  }
  return false;
}

SpanNeeds span_needs(const FaceGeometry& g, double segments) {
  const int nu = g.nu, nv = g.nv;
  std::vector<PatchBend> bends;
  for (const BezierPatch& patch : g.patches) bends.push_back(patch_bend(patch));
  // Only the patches the trimmed domain meets decide a line's density (the (U, V) box of the face's
  // p-curves; every patch when the face's parameters are not the patches').
  const std::vector<double>& ub = g.report.u_breaks;
  const std::vector<double>& vb = g.report.v_breaks;
  std::vector<bool> in_u(nu, true), in_v(nv, true);
  if (g.converted.IsNull()) {
    double u0 = 0.0, u1 = 0.0, v0 = 0.0, v1 = 0.0;
    BRepTools::UVBounds(g.face, u0, u1, v0, v1);
    if (u0 <= u1 && v0 <= v1) {
      for (int i = 0; i < nu; ++i) in_u[i] = span_meets(ub[i], ub[i + 1], u0, u1, g.u_period);
      for (int j = 0; j < nv; ++j) in_v[j] = span_meets(vb[j], vb[j + 1], v0, v1, g.v_period);
      if (std::none_of(in_u.begin(), in_u.end(), [](bool x) { return x; })) in_u.assign(nu, true);
      if (std::none_of(in_v.begin(), in_v.end(), [](bool x) { return x; })) in_v.assign(nv, true);
    }
  }
  SpanNeeds need;
  need.u.assign(nu, 0.0), need.v.assign(nv, 0.0);
  std::vector<double> twist_u(nu, 0.0), twist_v(nv, 0.0);
  double worst = 0.0, worst_twist = 0.0;
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const size_t p = static_cast<size_t>(i * nv + j);
      const PatchBend& bend = bends[p];
      if (in_v[j]) need.u[i] = std::max(need.u[i], bend.u), twist_u[i] = std::max(twist_u[i], bend.twist);
      if (in_u[i]) need.v[j] = std::max(need.v[j], bend.v), twist_v[j] = std::max(twist_v[j], bend.twist);
      if (in_u[i] && in_v[j])
        worst = std::max({worst, bend.u, bend.v}), worst_twist = std::max(worst_twist, bend.twist);
    }
  }
  // Every span needs at least its share of `segments` cells over the whole range, so that a larger
  // N refines every cell (a direction the nets call straight included).
  const double scale = worst + worst_twist > 0.0 ? segments / std::sqrt(worst + worst_twist) : 0.0;
  const double range_u = ub.back() - ub.front(), range_v = vb.back() - vb.front();
  for (int i = 0; i < nu; ++i) {
    const double bend = need.u[i] > 0.0 ? scale * std::sqrt(need.u[i] + twist_u[i]) : 0.0;
    need.u[i] = std::max(bend, segments * (ub[i + 1] - ub[i]) / range_u);
  }
  for (int j = 0; j < nv; ++j) {
    const double bend = need.v[j] > 0.0 ? scale * std::sqrt(need.v[j] + twist_v[j]) : 0.0;
    need.v[j] = std::max(bend, segments * (vb[j + 1] - vb[j]) / range_v);
  }
  // Knots where the surface is not tangent-continuous (a crease between two patches: the nets'
  // end differences across the knot point different ways) keep their line. Along U on a reversed
  // face, a patch's s runs against U.
  need.kink_u.assign(nu + 1, false), need.kink_v.assign(nv + 1, false);
  for (int i = 1; i < nu; ++i) {
    for (int j = 0; j < nv && !need.kink_u[i]; ++j) {
      if (!in_v[j]) continue;
      const BezierPatch& left = g.patches[static_cast<size_t>((i - 1) * nv + j)];
      const BezierPatch& right = g.patches[static_cast<size_t>(i * nv + j)];
      const int dl = left.degree_u, dr = right.degree_u;
      for (int r = 0; r <= std::min(left.degree_v, right.degree_v) && !need.kink_u[i]; ++r) {
        const Vec3 end = g.reversed ? left.at(0, r) - left.at(1, r) : left.at(dl, r) - left.at(dl - 1, r);
        const Vec3 start = g.reversed ? right.at(dr - 1, r) - right.at(dr, r) : right.at(1, r) - right.at(0, r);
        need.kink_u[i] = turns(end, start);
      }
    }
  }
  for (int j = 1; j < nv; ++j) {
    for (int i = 0; i < nu && !need.kink_v[j]; ++i) {
      if (!in_u[i]) continue;
      const BezierPatch& below = g.patches[static_cast<size_t>(i * nv + j - 1)];
      const BezierPatch& above = g.patches[static_cast<size_t>(i * nv + j)];
      const int db = below.degree_v;
      for (int r = 0; r <= std::min(below.degree_u, above.degree_u) && !need.kink_v[j]; ++r)
        need.kink_v[j] = turns(below.at(r, db) - below.at(r, db - 1), above.at(r, 1) - above.at(r, 0));
    }
  }
  return need;
}

// Grid lines over `breaks` (first and last included) that spread the spans' needs evenly: the
// density over span k is need[k] / width (cells per unit, constant inside the span); between two
// kinks (and the ends) the lines cut the run into ceil(sum of needs) cells of equal load (the
// integral of the density), each at most 1, so a span that needs 1.3 cells and its neighbour that
// needs 1.4 share 3 cells instead of 2 + 2, and spans that need little share cells. A kink's knot
// is always a line. Lines may fall inside spans: the certificate cuts triangles along the patch grid.
std::vector<double> graded_lines(const std::vector<double>& breaks, const std::vector<double>& need,
                                 const std::vector<bool>& kink) {
  std::vector<double> load_of(need.size(), 0.0);  // a span's need (0 where it has no width)
  for (size_t k = 0; k < need.size(); ++k) load_of[k] = breaks[k + 1] > breaks[k] ? std::max(need[k], 0.0) : 0.0;
  std::vector<double> lines = {breaks.front()};
  size_t first = 0;  // the run's first span
  for (size_t k = 0; k < need.size(); ++k) {
    if (k + 1 < need.size() && !kink[k + 1]) continue;
    // Spans first..k form a run between kinks (or the ends).
    double total = 0.0;
    for (size_t j = first; j <= k; ++j) total += load_of[j];
    const int cells = std::max(1, static_cast<int>(std::ceil(total - 1e-9)));
    const double load = total / cells;  // each cell's share, <= 1
    size_t j = first;
    double before = 0.0;  // the load of spans first..j-1
    for (int c = 1; c < cells; ++c) {
      const double goal = load * c;
      while (j < k && before + load_of[j] < goal) before += load_of[j], ++j;
      const double a = breaks[j], b = breaks[j + 1];
      const double fraction = load_of[j] > 0.0 ? std::clamp((goal - before) / load_of[j], 0.0, 1.0) : 1.0;
      lines.push_back(a + (b - a) * fraction);
    }
    lines.push_back(breaks[k + 1]);
    first = k + 1;
  }
  // A cell thinner than 1e-9 of the range (rounding at a span's end) joins its neighbour.
  const double tiny = 1e-9 * (breaks.back() - breaks.front());
  std::vector<double> kept = {lines.front()};
  for (size_t k = 1; k + 1 < lines.size(); ++k) {
    if (lines[k] - kept.back() > tiny && lines.back() - lines[k] > tiny) kept.push_back(lines[k]);
  }
  kept.push_back(lines.back());
  return kept;
}

// The face's graded grid into g.scheme / g.scheme_uv: vertices at the lines' crossings (on the
// face's Bézier surface), each cell cut along its shorter diagonal in space, counter-clockwise in
// (U, V) (clockwise on a reversed face, whose patches mirror U).
void tessellate_graded(FaceGeometry& g, std::vector<double> lines_u, std::vector<double> lines_v) {
  g.scheme = Tessellation{};
  g.scheme_uv.clear();
  g.scheme_sides.clear();
  const size_t nu = lines_u.size(), nv = lines_v.size();
  Tessellation& m = g.scheme;
  for (size_t a = 0; a < nu; ++a) {
    for (size_t b = 0; b < nv; ++b) {
      const Vec2 w(lines_u[a], lines_v[b]);
      const uint32_t id = static_cast<uint32_t>(m.positions.size());
      m.positions.push_back(eval_uv(g, w));
      g.scheme_uv.push_back(w);
      if (a == 0 || a + 1 == nu || b == 0 || b + 1 == nv) g.scheme_sides.emplace(std::make_pair(w.x, w.y), id);
    }
  }
  const auto id = [nv](size_t a, size_t b) { return static_cast<uint32_t>(a * nv + b); };
  for (size_t a = 0; a + 1 < nu; ++a) {
    for (size_t b = 0; b + 1 < nv; ++b) {
      const uint32_t p00 = id(a, b), p10 = id(a + 1, b), p11 = id(a + 1, b + 1), p01 = id(a, b + 1);
      const bool main_diagonal =
          glm::length(m.positions[p00] - m.positions[p11]) <= glm::length(m.positions[p10] - m.positions[p01]);
      std::array<Triangle, 2> cell = main_diagonal
                                         ? std::array<Triangle, 2>{Triangle{p00, p10, p11}, Triangle{p00, p11, p01}}
                                         : std::array<Triangle, 2>{Triangle{p00, p10, p01}, Triangle{p10, p11, p01}};
      for (Triangle& t : cell) {
        if (g.reversed) std::swap(t[1], t[2]);
        m.triangles.push_back(t);
      }
    }
  }
  g.grid_u = std::move(lines_u);
  g.grid_v = std::move(lines_v);
}

// The graded grid for `segments` N when it has at most 3/4 of the cells of the per-patch grid
// nu x nv; false (nothing changed) otherwise. A smaller saving is not worth what the face gives up:
// an untrimmed face on the per-patch grid keeps the scheme's triangles whole (certified on its own
// patches), a graded one is triangulated from its loops like a trimmed face.
bool try_graded_grid(FaceGeometry& g, double segments, int nu, int nv) {
  if (g.nu * g.nv <= 1) return false;
  // Only a face whose knot spans differ in size (by more than 2x in U or V) leaves the per-patch
  // grid: on equal spans (a torus's or a cylinder's quarter arcs) the scheme's own tessellation stays.
  const auto uneven = [](const std::vector<double>& breaks) {
    double shortest = std::numeric_limits<double>::infinity(), longest = 0.0;
    for (size_t k = 0; k + 1 < breaks.size(); ++k) {
      const double width = breaks[k + 1] - breaks[k];
      if (width > 0.0) shortest = std::min(shortest, width), longest = std::max(longest, width);
    }
    return longest > 2.0 * shortest;
  };
  if (!uneven(g.report.u_breaks) && !uneven(g.report.v_breaks)) return false;
  const SpanNeeds need = span_needs(g, segments);
  std::vector<double> lines_u = graded_lines(g.report.u_breaks, need.u, need.kink_u);
  std::vector<double> lines_v = graded_lines(g.report.v_breaks, need.v, need.kink_v);
  const size_t cells_u = lines_u.size() - 1, cells_v = lines_v.size() - 1;
  if (4 * cells_u * cells_v > 3 * static_cast<size_t>(nu) * g.nu * static_cast<size_t>(nv) * g.nv) return false;
  // The CDT's metric: the mean cell square, the coarser direction shrunk (as face_grid's cells).
  const double mean_u = g.su * (g.report.u_breaks.back() - g.report.u_breaks.front()) / cells_u;
  const double mean_v = g.sv * (g.report.v_breaks.back() - g.report.v_breaks.front()) / cells_v;
  g.cu = mean_u > mean_v ? g.su * mean_v / mean_u : g.su;
  g.cv = mean_v > mean_u ? g.sv * mean_u / mean_v : g.sv;
  tessellate_graded(g, std::move(lines_u), std::move(lines_v));
  return true;
}

void tessellate_face_patches(FaceGeometry& g, const SchemeSpec& scheme, bool graded) {
  g.segments_u = g.segments_v = g.segments;
  g.cu = g.su;
  g.cv = g.sv;
  if (g.patches.empty()) return;
  Model model;
  model.patches = g.patches;
  SchemeSpec spec = scheme;
  spec.surface_data = true;
  spec.vertex_normals = false;
  const Topology topology = build_topology(model);
  if (spec.scheme == Scheme::kUniform && spec.patch_levels.empty()) {
    const FaceBend bend = face_bend(g.patches);
    const auto [nu, nv] = face_grid(g.segments, bend);
    if (graded && !bend.flat && try_graded_grid(g, g.graded_segments, nu, nv)) {
      g.segments_u = nu, g.segments_v = nv;
      return;
    }
    SchemeSpec grid = spec;
    grid.level = -1;
    grid.segments = nu;
    grid.segments_v = nv;
    try {
      g.scheme = tessellate(model, topology, grid);
      g.segments_u = nu;
      g.segments_v = nv;
      // A flat face's cells keep the CDT's own metric (nothing to gain from stretching).
      if (nu != nv) g.cu = g.su * nu / g.segments, g.cv = g.sv * nv / g.segments;
    } catch (const InputError&) {  // a side shared along u by one patch and along v by another
      g.scheme = tessellate(model, topology, spec);
    }
  } else {
    g.scheme = tessellate(model, topology, spec);
  }
  g.scheme_uv.assign(g.scheme.positions.size(), Vec2(0.0));
  const std::vector<double>& ub = g.report.u_breaks;
  const std::vector<double>& vb = g.report.v_breaks;
  for (size_t t = 0; t < g.scheme.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const Vec2 w = patch_to_uv(g, g.scheme.triangle_patch[t], g.scheme.triangle_uv[t][k]);
      g.scheme_uv[g.scheme.triangles[t][k]] = w;
      if (w.x == ub.front() || w.x == ub.back() || w.y == vb.front() || w.y == vb.back())
        g.scheme_sides.emplace(std::make_pair(w.x, w.y), g.scheme.triangles[t][k]);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Edges: sampled once, shared by every face that uses them.
struct EdgeSamples {
  std::vector<double> t;         // edge parameters (BRep_Tool::Range), increasing
  std::vector<uint32_t> vertex;  // mesh vertex of each sample
  bool degenerated = false;
  bool free = false;  // used by one face only, not a seam: the model's boundary
  std::function<Vec3(double)> on_face;  // a free edge's points on its face (free_edge_on_face), else empty
};

// Segments per patch span the scheme puts on a patch side (the edge density's unit).
int scheme_segments(const SchemeSpec& spec) {
  if (spec.scheme == Scheme::kUniform) {
    if (spec.segments > 0) return spec.segments;
    return 1 << std::max(0, std::min(spec.level >= 0 ? spec.level : 2, 12));
  }
  return 1;
}

// The scheme on face f: PartOptions::face_segments[f] segments per patch side where given (uniform).
SchemeSpec face_scheme(const PartOptions& options, int f) {
  SchemeSpec scheme = options.scheme;
  if (scheme.scheme == Scheme::kUniform && f < static_cast<int>(options.face_segments.size()) &&
      options.face_segments[static_cast<size_t>(f)] > 0) {
    scheme.segments = options.face_segments[static_cast<size_t>(f)];
    scheme.level = -1;
    scheme.patch_levels.clear();
  }
  return scheme;
}

// The edge's p-curve on face g sampled at 33 points, in the face's grid cells (a patch span is
// segments_u cells along u and segments_v along v, or the graded grid's cells): how many grid cells
// of the face the edge runs along.
double grid_length(const FaceGeometry& g, const TopoDS_Edge& edge) {
  double f = 0.0, l = 0.0;
  const Handle(Geom2d_Curve) pc = BRep_Tool::CurveOnSurface(edge, g.face, f, l);
  if (pc.IsNull()) return 0.0;
  double length = 0.0;
  Vec2 prev(0.0);
  const Vec2 shift = pcurve_shift(g, pc, f, l);
  for (int k = 0; k <= 32; ++k) {
    const gp_Pnt2d q = pc->Value(f + (l - f) * k / 32.0);
    const Vec2 UV = face_to_uv(g, q.X() + shift.x, q.Y() + shift.y);
    Vec2 grid;
    if (!g.grid_u.empty()) {
      const auto [i, s] = locate_span(g.grid_u, UV.x);
      const auto [j, t] = locate_span(g.grid_v, UV.y);
      grid = Vec2(i + s, j + t);
    } else {
      const auto [i, s] = locate_span(g.report.u_breaks, UV.x);
      const auto [j, t] = locate_span(g.report.v_breaks, UV.y);
      grid = Vec2((i + s) * g.segments_u, (j + t) * g.segments_v);
    }
    if (k > 0) length += glm::length(grid - prev);
    prev = grid;
  }
  return length;
}

// Total turning of the edge's tangent (radians), from 64 chords.
double turning(const BRepAdaptor_Curve& c, double first, double last) {
  double total = 0.0;
  Vec3 prev_dir(0.0);
  Vec3 prev = to_vec(c.Value(first));
  for (int k = 1; k <= 64; ++k) {
    const Vec3 p = to_vec(c.Value(first + (last - first) * k / 64.0));
    const Vec3 d = p - prev;
    const double len = glm::length(d);
    if (len > 0.0) {
      const Vec3 dir = d / len;
      if (glm::length(prev_dir) > 0.0) total += std::acos(clamp(glm::dot(dir, prev_dir), -1.0, 1.0));
      prev_dir = dir;
    }
    prev = p;
  }
  return total;
}

double chord_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  const double t = len2 > 0.0 ? clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * ab));
}

// Splits the parameters t (sorted) until every chord is within tol of the curve at its quarter
// points; at most `cap` samples.
void refine_to_tolerance(const BRepAdaptor_Curve& c, std::vector<double>& t, double tol, size_t cap) {
  bool changed = true;
  while (changed && t.size() < cap) {
    changed = false;
    std::vector<double> out{t.front()};
    for (size_t k = 0; k + 1 < t.size(); ++k) {
      const Vec3 a = to_vec(c.Value(t[k])), b = to_vec(c.Value(t[k + 1]));
      double worst = 0.0;
      for (double w : {0.25, 0.5, 0.75}) {
        worst = std::max(worst, chord_distance(to_vec(c.Value(t[k] + w * (t[k + 1] - t[k]))), a, b));
      }
      if (worst > tol && out.size() + (t.size() - k) < cap) {
        // A chord's deviation grows like its length squared: m equal pieces with m^2 >= worst / tol
        // (2 % margin) should pass; halving instead could leave a curve with up to twice the chords.
        const double want = std::ceil(std::sqrt(worst / tol) * 1.02);
        const size_t room = cap - (out.size() + (t.size() - k));
        const int m = static_cast<int>(std::min<double>({std::max(2.0, want), 64.0, static_cast<double>(room + 1)}));
        for (int i = 1; i < m; ++i) out.push_back(t[k] + (t[k + 1] - t[k]) * i / m);
        changed = true;
      }
      out.push_back(t[k + 1]);
    }
    t.swap(out);
  }
}

struct EdgePlan;

struct PartBuilder {
  const PartOptions& options;
  const ShapeIndex& x;
  std::vector<FaceGeometry>& geometry;
  PartMesh& out;
  std::vector<EdgeSamples> edges;
  std::vector<bool> surface_point_set;
  // Per mesh vertex: how far apart two loop points of it may lie in a face's scaled (U, V) and still
  // be the same point (10 x the B-rep vertex's tolerance; edge samples: 1e-9 of the part's size).
  std::vector<double> vertex_tolerance;
  // Per edge: parameters added to its samples (chords that crossed another loop's chord in a face),
  // and those found in this pass.
  const std::vector<std::vector<double>>& extra;
  std::map<int, std::vector<double>> crossing;
  const std::vector<EdgePlan>& plans;
  // Ears to split (cdt_without_ears), by their corners' positions: the triangles two faces both
  // made in an earlier pass (a triangle's vertex ids change between passes, its corners do not).
  const std::set<std::array<double, 9>>* split_ears = nullptr;

  uint32_t add_vertex(const Vec3& p) {
    out.mesh.positions.push_back(p);
    out.mesh.surface_points.push_back({});
    surface_point_set.push_back(false);
    vertex_tolerance.push_back(0.0);
    return static_cast<uint32_t>(out.mesh.positions.size() - 1);
  }
};

// An edge's samples before any crossing split: parameters from the scheme's density on each face,
// the turning and the chord tolerance (computed once per part, see mesh_shape).
struct EdgePlan {
  std::vector<double> t;
  bool degenerated = false;
  bool free = false;
  // Where the edge runs along a side of an untrimmed face (its "owner", the first such face), its
  // samples are that face's scheme vertices on the side: their parameters and the scheme's
  // positions (by t), so the owner keeps its scheme triangles unchanged (mesh_face).
  std::map<double, Vec3> owner_positions;
};

// The owner face g's scheme vertices on the edge (strictly between its ends) as (edge parameter,
// scheme position); false when the edge is not an iso-line on a side of g's patch range. The
// parameter of a vertex at (U, V) is found by bisection on the p-curve (monotone along an iso-line).
bool owner_samples(const FaceGeometry& g, const TopoDS_Edge& edge, double first, double last,
                   std::map<double, Vec3>& samples) {
  const std::vector<double>& ub = g.report.u_breaks;
  const std::vector<double>& vb = g.report.v_breaks;
  const double eps_u = 1e-9 * (ub.back() - ub.front()), eps_v = 1e-9 * (vb.back() - vb.front());
  bool any = false;
  for (TopExp_Explorer it(g.face, TopAbs_EDGE); it.More(); it.Next()) {
    const TopoDS_Edge occurrence = TopoDS::Edge(it.Current());
    if (!occurrence.IsSame(edge)) continue;
    double f = 0.0, l = 0.0;
    const Handle(Geom2d_Curve) pc = BRep_Tool::CurveOnSurface(occurrence, g.face, f, l);
    if (pc.IsNull()) return false;
    const bool same = BRep_Tool::SameParameter(edge) && BRep_Tool::SameRange(edge);
    const Vec2 shift = pcurve_shift(g, pc, f, l);
    const auto uv_at = [&](double p) {
      const gp_Pnt2d q = pc->Value(p);
      return face_to_uv(g, q.X() + shift.x, q.Y() + shift.y);
    };
    const Vec2 a = uv_at(f), b = uv_at(l);
    int axis;  // the coordinate that is constant along the side
    if (std::abs(a.x - b.x) <= eps_u && (std::abs(a.x - ub.front()) <= eps_u || std::abs(a.x - ub.back()) <= eps_u)) {
      axis = 0;
    } else if (std::abs(a.y - b.y) <= eps_v &&
               (std::abs(a.y - vb.front()) <= eps_v || std::abs(a.y - vb.back()) <= eps_v)) {
      axis = 1;
    } else {
      return false;
    }
    const double side = axis == 0 ? (std::abs(a.x - ub.front()) <= eps_u ? ub.front() : ub.back())
                                  : (std::abs(a.y - vb.front()) <= eps_v ? vb.front() : vb.back());
    const double lo = std::min(a[1 - axis], b[1 - axis]), hi = std::max(a[1 - axis], b[1 - axis]);
    const double eps = axis == 0 ? eps_v : eps_u;
    for (const auto& [key, v] : g.scheme_sides) {
      const Vec2 w(key.first, key.second);
      if (w[axis] != side || w[1 - axis] <= lo + eps || w[1 - axis] >= hi - eps) continue;
      // Bisection for the p-curve parameter whose (U, V) has w's coordinate along the side.
      double p0 = f, p1 = l;
      const bool increasing = b[1 - axis] > a[1 - axis];
      for (int i = 0; i < 80; ++i) {
        const double pm = 0.5 * (p0 + p1);
        ((uv_at(pm)[1 - axis] < w[1 - axis]) == increasing ? p0 : p1) = pm;
      }
      const double p = 0.5 * (p0 + p1);
      const double t = same || l == f ? p : first + (p - f) * (last - first) / (l - f);
      samples.emplace(t, g.scheme.positions[v]);
      any = true;
    }
    break;  // a seam's second copy runs along the other side at the same parameters
  }
  (void)any;
  return true;
}

EdgePlan plan_edge(const PartOptions& options, const ShapeIndex& x, const std::vector<FaceGeometry>& geometry, int e) {
  const TopoDS_Edge edge = TopoDS::Edge(x.edges(e + 1).Oriented(TopAbs_FORWARD));
  EdgePlan plan;
  TopoDS_Vertex v_first, v_last;
  TopExp::Vertices(edge, v_first, v_last);
  double first = 0.0, last = 0.0;
  BRep_Tool::Range(edge, first, last);
  const std::vector<int> faces = faces_of_edge(x, edge);
  plan.degenerated = BRep_Tool::Degenerated(edge);
  bool seam = false;
  for (int f : faces) seam = seam || BRep_Tool::IsClosed(edge, geometry[f].face);
  plan.free = faces.size() == 1 && !seam && !plan.degenerated;
  std::unique_ptr<BRepAdaptor_Curve> curve;
  if (!plan.degenerated) curve = std::make_unique<BRepAdaptor_Curve>(edge);
  // The owner: of the untrimmed faces using the edge along a side of their patch range, the one
  // whose scheme puts the most vertices on it (the finer grid keeps its triangles; a coarser one,
  // a flat face's 1 x 1 grid say, is triangulated from the loops); its side vertices are the samples.
  bool owned = false;
  for (int f : faces) {
    const FaceGeometry& g = geometry[f];
    if (g.patches.empty() || g.report.status == "trimmed" || plan.degenerated) continue;
    std::map<double, Vec3> samples;
    if (!owner_samples(g, edge, first, last, samples)) continue;
    if (owned && samples.size() <= plan.owner_positions.size()) continue;
    plan.t = {first};
    for (const auto& [t, p] : samples) {
      if (t > first && t < last) plan.t.push_back(t);
    }
    plan.t.push_back(last);
    plan.owner_positions = std::move(samples);
    owned = true;
  }
  if (!owned) {  // the scheme's density on every face that uses the edge, and its turning
    int n = 1, segs = 1;
    for (int f : faces) {
      if (geometry[f].patches.empty()) continue;
      segs = std::max(segs, geometry[f].segments);
      n = std::max(n, static_cast<int>(std::ceil(grid_length(geometry[f], edge) - 1e-9)));
    }
    if (curve) {
      const double turn = turning(*curve, first, last);
      n = std::max(n, static_cast<int>(std::ceil(segs * turn / (kPi / 2) - 1e-9)));
      if (turn > 1e-3) n = std::max(n, 2);
    }
    if (!v_first.IsNull() && v_first.IsSame(v_last)) n = std::max(n, 3);  // a closed edge
    n = std::min(n, 1 << 16);
    for (int k = 0; k <= n; ++k) plan.t.push_back(k == n ? last : first + (last - first) * k / n);
  }
  // A closed edge bounds a loop by itself: with fewer than 3 chords its polygon has no area. An edge
  // sampled above already has 3 (n >= 3); an owner face's side vertices may give 2 (a pipe's grid
  // along its end circle), so there the widest intervals are split until it has 3.
  if (owned && !v_first.IsNull() && v_first.IsSame(v_last)) {
    while (plan.t.size() >= 2 && plan.t.size() < 4) {
      size_t widest = 0;
      for (size_t k = 1; k + 1 < plan.t.size(); ++k) {
        if (plan.t[k + 1] - plan.t[k] > plan.t[widest + 1] - plan.t[widest]) widest = k;
      }
      plan.t.insert(plan.t.begin() + static_cast<std::ptrdiff_t>(widest) + 1,
                    0.5 * (plan.t[widest] + plan.t[widest + 1]));
    }
  }
  double tol = options.edge_tolerance;
  for (int f : faces) {
    const double face_tol = f < static_cast<int>(options.face_edge_tolerance.size())
                                ? options.face_edge_tolerance[static_cast<size_t>(f)]
                                : 0.0;
    if (face_tol > 0.0) tol = tol > 0.0 ? std::min(tol, face_tol) : face_tol;
  }
  // ESC's threshold refines the edges it did not sample itself; an owned edge keeps the owner's ESC
  // side vertices (refining them would take the owner off its own triangles, into the loops route).
  if (options.scheme.scheme == Scheme::kEsc && options.scheme.threshold > 0.0 && !owned)
    tol = tol > 0.0 ? std::min(tol, options.scheme.threshold) : options.scheme.threshold;
  if (curve && tol > 0.0) refine_to_tolerance(*curve, plan.t, tol, size_t(1) << 16);
  return plan;
}

// A free edge (used by one face, not a seam) evaluated on its face: t -> S(p-curve(t)), the edge's
// parameter mapped linearly onto the p-curve's range unless the edge is same-parameter. Empty for
// any other edge, or when the face has no p-curve for it. Nothing else shares a free edge's
// samples, so they can lie on the face itself even where the B-rep's 3D curve is off it by its
// tolerance (bearing.iges, an IGES part of 213 free faces: up to 0.0019 on a part 0.16 across).
std::function<Vec3(double)> free_edge_on_face(const PartBuilder& b, int e) {
  if (!b.plans[e].free) return {};
  const TopoDS_Edge edge = TopoDS::Edge(b.x.edges(e + 1).Oriented(TopAbs_FORWARD));
  const std::vector<int> faces = faces_of_edge(b.x, edge);
  if (faces.size() != 1) return {};
  const TopoDS_Face& face = b.geometry[faces.front()].face;
  double f = 0.0, l = 0.0, first = 0.0, last = 0.0;
  const Handle(Geom2d_Curve) pc = BRep_Tool::CurveOnSurface(edge, face, f, l);
  const Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
  if (pc.IsNull() || surface.IsNull()) return {};
  BRep_Tool::Range(edge, first, last);
  const bool same = (BRep_Tool::SameParameter(edge) && BRep_Tool::SameRange(edge)) || last == first;
  return [=](double t) {
    const gp_Pnt2d q = pc->Value(same ? t : f + (t - first) * (l - f) / (last - first));
    return to_vec(surface->Value(q.X(), q.Y()));
  };
}

// The edge's samples (its plan and the splits in b.extra) as mesh vertices; its ends are the B-rep
// vertices' mesh vertices, a degenerated edge is its one vertex. A free edge's samples lie on its
// face (free_edge_on_face), the others on the edge's 3D curve (or the owner face's scheme vertices).
void sample_edge(PartBuilder& b, int e) {
  const TopoDS_Edge edge = TopoDS::Edge(b.x.edges(e + 1).Oriented(TopAbs_FORWARD));
  EdgeSamples& s = b.edges[e];
  const EdgePlan& plan = b.plans[e];
  TopoDS_Vertex v_first, v_last;
  TopExp::Vertices(edge, v_first, v_last);
  s.degenerated = plan.degenerated;
  s.free = plan.free;
  s.t = plan.t;
  if (!b.extra[e].empty()) {
    s.t.insert(s.t.end(), b.extra[e].begin(), b.extra[e].end());
    std::sort(s.t.begin(), s.t.end());
    s.t.erase(std::unique(s.t.begin(), s.t.end()), s.t.end());
  }
  std::unique_ptr<BRepAdaptor_Curve> curve;
  if (!s.degenerated) curve = std::make_unique<BRepAdaptor_Curve>(edge);
  s.on_face = free_edge_on_face(b, e);
  const std::function<Vec3(double)>& on_face = s.on_face;
  const auto vertex_id = [&](const TopoDS_Vertex& v) { return static_cast<uint32_t>(b.x.vertices.FindIndex(v) - 1); };
  for (size_t k = 0; k < s.t.size(); ++k) {
    if (s.degenerated) {
      s.vertex.push_back(vertex_id(v_first));
    } else if (k == 0 && !v_first.IsNull()) {
      s.vertex.push_back(vertex_id(v_first));
    } else if (k + 1 == s.t.size() && !v_last.IsNull()) {
      s.vertex.push_back(vertex_id(v_last));
    } else {
      const auto owned = plan.owner_positions.find(s.t[k]);
      s.vertex.push_back(b.add_vertex(owned != plan.owner_positions.end() ? owned->second
                                      : on_face                           ? on_face(s.t[k])
                                                                          : to_vec(curve->Value(s.t[k]))));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// One face: its loops' chords in the CDT's plane (scaled (U, V)), the scheme's triangles kept inside.

struct LoopPoint {
  Vec2 q;           // (U su, V sv)
  uint32_t vertex;  // mesh vertex
  double t = 0.0;   // the edge's parameter
};

// Boundary segments in a bucket grid over the face's plane, for "is anything near this box" and
// "is this point inside" (even-odd crossings of a ray towards +x).
class SegmentGrid {
 public:
  SegmentGrid(const std::vector<LoopPoint>& points, const std::vector<std::array<uint32_t, 2>>& segments)
      : points_(points), segments_(segments) {
    lo_ = Vec2(std::numeric_limits<double>::max()), hi_ = Vec2(-std::numeric_limits<double>::max());
    for (const LoopPoint& p : points) lo_ = glm::min(lo_, p.q), hi_ = glm::max(hi_, p.q);
    cells_ = std::max(1, std::min(512, static_cast<int>(std::sqrt(double(segments.size())))));
    size_ = glm::max((hi_ - lo_) / double(cells_), Vec2(1e-300));
    grid_.resize(size_t(cells_) * cells_);
    rows_.resize(cells_);
    for (uint32_t k = 0; k < segments.size(); ++k) {
      const Vec2 a = points[segments[k][0]].q, b = points[segments[k][1]].q;
      const auto [i0, j0] = cell(glm::min(a, b));
      const auto [i1, j1] = cell(glm::max(a, b));
      for (int j = j0; j <= j1; ++j) {
        rows_[j].push_back(k);
        for (int i = i0; i <= i1; ++i) grid_[size_t(j) * cells_ + i].push_back(k);
      }
    }
  }

  // True when a segment's box meets the box [lo, hi].
  bool any_near(const Vec2& lo, const Vec2& hi) const {
    const auto [i0, j0] = cell(lo);
    const auto [i1, j1] = cell(hi);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        for (uint32_t k : grid_[size_t(j) * cells_ + i]) {
          const Vec2 a = points_[segments_[k][0]].q, b = points_[segments_[k][1]].q;
          if (std::max(a.x, b.x) >= lo.x && std::min(a.x, b.x) <= hi.x && std::max(a.y, b.y) >= lo.y &&
              std::min(a.y, b.y) <= hi.y)
            return true;
        }
      }
    }
    return false;
  }

  // Even-odd: inside the loops.
  bool inside(const Vec2& p) const {
    if (p.x < lo_.x || p.x > hi_.x || p.y < lo_.y || p.y > hi_.y) return false;
    bool in = false;
    for (uint32_t k : rows_[cell(p).second]) {
      const Vec2 a = points_[segments_[k][0]].q, b = points_[segments_[k][1]].q;
      if ((a.y > p.y) != (b.y > p.y)) {
        const double x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
        if (x > p.x) in = !in;
      }
    }
    return in;
  }

 private:
  std::pair<int, int> cell(const Vec2& p) const {
    const auto c = [&](double v, double lo, double size) {
      return std::max(0, std::min(cells_ - 1, static_cast<int>(std::floor((v - lo) / size))));
    };
    return {c(p.x, lo_.x, size_.x), c(p.y, lo_.y, size_.y)};
  }
  const std::vector<LoopPoint>& points_;
  const std::vector<std::array<uint32_t, 2>>& segments_;
  Vec2 lo_, hi_, size_;
  int cells_ = 1;
  std::vector<std::vector<uint32_t>> grid_, rows_;
};

// The face's loops as chords between shared edge samples, in the (U, V) plane scaled by (su, sv).
// Each wire is walked in order (BRepTools_WireExplorer) and each edge's p-curve is moved by whole
// periods so that it starts where the previous one ended: a loop around a periodic surface stays
// in one piece, and a seam's two copies land on the two sides of the domain. Returns false (with
// a reason) when an edge has no p-curve on the face.
// A degenerated edge's segment in (U, V) and its one mesh vertex.
struct PoleLine {
  Vec2 a, b;
  uint32_t vertex = 0;
};

// An edge's p-curve as the loop walk used it: OCCT's parameters [f, l] of the p-curve, the edge's
// [first, last], whether they coincide, and the whole periods added to the curve's (u, v).
struct RangeCurve {
  Handle(Geom2d_Curve) pc;
  double f = 0.0, l = 0.0, first = 0.0, last = 0.0;
  bool same = true;
  Vec2 shift{0.0};
  bool reversed = false;  // the edge runs against its parameter in the loop
  // The p-curve's parameter at edge parameter t.
  double param(double t) const { return same || last == first ? t : f + (t - first) * (l - f) / (last - first); }
};

// The chord between loop points p and q of one edge, with its proven deviation from the p-curve.
BoundaryChord bound_chord(const FaceGeometry& g, const RangeCurve& rc, const LoopPoint& p, const LoopPoint& q) {
  BoundaryChord c;
  c.a = p.vertex, c.b = q.vertex;
  c.uv_a = Vec2(p.q.x / g.cu, p.q.y / g.cv), c.uv_b = Vec2(q.q.x / g.cu, q.q.y / g.cv);
  detail::ParameterMap map;
  map.identity = g.identity_map;
  map.shift = rc.shift;
  map.metric = Vec2(g.su, g.sv);
  if (!map.identity) {
    map.to_uv = [&g](const Vec2& uv) { return face_to_uv(g, uv.x, uv.y); };
    const std::vector<double>& ub = g.report.u_breaks;
    const std::vector<double>& vb = g.report.v_breaks;
    map.to_uv_error = 1e-12 * std::max(ub.back() - ub.front(), vb.back() - vb.front());
  }
  detail::ChordTrace trace;
  detail::ChordSides sides;
  c.deviation =
      detail::chord_deviation(rc.pc, rc.param(p.t), rc.param(q.t), map, c.uv_a, c.uv_b, &trace, &c.overshoot, &sides);
  c.left = sides.left, c.right = sides.right;
  c.trace = std::move(trace.points);
  c.trace_deviation = trace.deviation;
  for (int k = 0; k < 3; ++k) {
    const double t = p.t + 0.25 * (k + 1) * (q.t - p.t);
    const gp_Pnt2d r = rc.pc->Value(rc.param(t));
    c.curve_points[k] = eval_uv(g, face_to_uv(g, r.X() + rc.shift.x, r.Y() + rc.shift.y));
    const double size = std::max({std::abs(c.curve_points[k].x), std::abs(c.curve_points[k].y),
                                  std::abs(c.curve_points[k].z)});
    c.curve_point_error = std::max(c.curve_point_error, 1e-12 * size);
  }
  if (rc.reversed) {  // along the loop
    std::swap(c.a, c.b), std::swap(c.uv_a, c.uv_b), std::swap(c.left, c.right);
    std::reverse(c.trace.begin(), c.trace.end());
  }
  return c;
}

bool face_loops(PartBuilder& b, const FaceGeometry& g, std::vector<LoopPoint>& points,
                std::vector<std::array<uint32_t, 2>>& segments, std::vector<int>& segment_edge, PartFace& pf,
                std::vector<PoleLine>* pole_lines = nullptr, std::vector<BoundaryChord>* chords = nullptr) {
  // A degenerated edge (pole, apex) is one mesh vertex but a segment in (U, V): its samples stay
  // apart in (U, V), all at that vertex. The CDT's triangles with two corners on the segment collapse
  // onto an edge in space and are left out (emit_triangle records them in PartFace::collapsed).
  std::vector<std::pair<uint32_t, uint32_t>> ranges;  // per edge: [first, last) in points
  std::vector<int> range_edge;
  std::vector<RangeCurve> range_curve;
  std::set<std::pair<int, int>> done;                 // (edge, orientation) already walked
  bool missing_pcurve = false;
  const auto walk = [&](const TopoDS_Edge& edge, bool first_in_wire, Vec2& previous_end) {
    if (edge.Orientation() == TopAbs_INTERNAL || edge.Orientation() == TopAbs_EXTERNAL) return;
    const int e = b.x.edges.FindIndex(edge) - 1;
    if (e < 0 || !done.insert({e, int(edge.Orientation())}).second) return;
    const EdgeSamples& s = b.edges[e];
    double f = 0.0, l = 0.0;
    const Handle(Geom2d_Curve) pc = BRep_Tool::CurveOnSurface(edge, g.face, f, l);
    if (pc.IsNull()) {
      pf.reason = "edge " + std::to_string(e + 1) + " has no curve on the face's surface";
      missing_pcurve = true;
      return;
    }
    const double first = s.t.front(), last = s.t.back();
    RangeCurve rc{pc, f, l, first, last, BRep_Tool::SameParameter(edge) && BRep_Tool::SameRange(edge)};
    const auto raw = [&](double t) {
      const gp_Pnt2d uv = pc->Value(rc.param(t));
      return Vec2(uv.X(), uv.Y());
    };
    const bool reversed = edge.Orientation() == TopAbs_REVERSED;
    Vec2 shift = pcurve_shift(g, pc, f, l);
    if (!first_in_wire) {
      const Vec2 start = raw(reversed ? last : first);
      if (g.u_period > 0.0) shift.x = std::round((previous_end.x - start.x) / g.u_period) * g.u_period;
      if (g.v_period > 0.0) shift.y = std::round((previous_end.y - start.y) / g.v_period) * g.v_period;
    }
    const auto uv_at = [&](double t) {
      const Vec2 r = raw(t);
      return face_to_uv(g, r.x + shift.x, r.y + shift.y);
    };
    const Vec2 end = raw(reversed ? first : last);
    previous_end = Vec2(end.x + shift.x, end.y + shift.y);
    if (s.degenerated && pole_lines) pole_lines->push_back({uv_at(first), uv_at(last), s.vertex.front()});
    const uint32_t start = static_cast<uint32_t>(points.size());
    for (size_t k = 0; k < s.t.size(); ++k) {
      const Vec2 UV = uv_at(s.t[k]);
      points.push_back({Vec2(UV.x * g.cu, UV.y * g.cv), s.vertex[k], s.t[k]});
      const double offset = glm::length(b.out.mesh.positions[s.vertex[k]] - eval_uv(g, UV));
      pf.max_boundary_offset = std::max(pf.max_boundary_offset, offset);
      if (!b.surface_point_set[s.vertex[k]]) {
        const Vec2 w = wrap_uv(g, UV).first;
        const auto [patch, st] = locate_patch(g, w.x, w.y);
        b.out.mesh.surface_points[s.vertex[k]] = {static_cast<uint32_t>(pf.first_patch + patch), st.x, st.y};
        b.surface_point_set[s.vertex[k]] = true;
      }
    }
    ranges.push_back({start, static_cast<uint32_t>(points.size())});
    range_edge.push_back(e);
    rc.shift = shift;
    rc.reversed = reversed;
    range_curve.push_back(rc);
  };
  for (TopExp_Explorer w(g.face, TopAbs_WIRE); w.More(); w.Next()) {
    Vec2 previous_end(0.0);
    bool first_in_wire = true;
    for (BRepTools_WireExplorer it(TopoDS::Wire(w.Current()), g.face); it.More(); it.Next()) {
      walk(it.Current(), first_in_wire, previous_end);
      first_in_wire = false;
    }
  }
  // Edges the wire explorer does not reach (a wire that is not a simple chain) on their own.
  for (TopExp_Explorer it(g.face, TopAbs_EDGE); it.More(); it.Next()) {
    Vec2 unused(0.0);
    walk(TopoDS::Edge(it.Current()), true, unused);
  }
  if (missing_pcurve) return false;
  // Two loop points of one vertex (an edge's end and the next edge's start, both ends of a closed
  // edge) come from different p-curves and differ by rounding or the B-rep's tolerance; left apart
  // they would open the loop. Copies further apart than the vertex's tolerance (a seam's two sides)
  // stay apart.
  std::map<uint32_t, std::vector<Vec2>> copies;
  for (LoopPoint& p : points) {
    std::vector<Vec2>& seen = copies[p.vertex];
    const double tol = b.vertex_tolerance[p.vertex];
    bool merged = false;
    for (const Vec2& q : seen) {
      if (glm::length(q - p.q) <= tol) {
        p.q = q;
        merged = true;
        break;
      }
    }
    if (!merged) seen.push_back(p.q);
  }
  std::vector<size_t> segment_range;  // per new segment: its range
  const size_t first_segment = segments.size();
  for (size_t r = 0; r < ranges.size(); ++r) {
    for (uint32_t k = ranges[r].first + 1; k < ranges[r].second; ++k) {
      if (points[k].q != points[k - 1].q) {
        segments.push_back({k - 1, k});
        segment_edge.push_back(range_edge[r]);
        segment_range.push_back(r);
      }
    }
  }
  if (chords) {
    // Each chord's bound is a function of the face, the curve and its two points alone: in parallel
    // (through a re-parametrised surface's map it is most of the part's meshing time).
    const size_t first = chords->size();
    chords->resize(first + segment_range.size());
    tbb::parallel_for(size_t(0), segment_range.size(), [&](size_t s) {
      const auto [i, k] = segments[first_segment + s];
      (*chords)[first + s] = bound_chord(g, range_curve[segment_range[s]], points[i], points[k]);
    });
  }
  pf.boundary_vertices = points.size();
  return true;
}

// Appends triangle (a, b, c) of face g to the part. uv are the corners' (U, V). One whose corners
// are not distinct vertices (two on a pole's segment) is not emitted but kept in pf.collapsed.
void emit_triangle(PartBuilder& b, const FaceGeometry& g, PartFace& pf, std::array<uint32_t, 3> tri,
                   std::array<Vec2, 3> uv) {
  const auto [centre, shift] = wrap_uv(g, (uv[0] + uv[1] + uv[2]) / 3.0);
  for (Vec2& c : uv) c -= shift;
  if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) {
    ++b.out.mesh.degenerate_triangles;
    pf.collapsed.push_back({tri, uv});
    return;
  }
  const int patch = locate_patch(g, centre.x, centre.y).first;
  const int i = patch / g.nv, j = patch % g.nv;
  std::array<Vec2, 3> st;
  for (int k = 0; k < 3; ++k) {
    const double s = (uv[k].x - g.report.u_breaks[i]) / (g.report.u_breaks[i + 1] - g.report.u_breaks[i]);
    const double t = (uv[k].y - g.report.v_breaks[j]) / (g.report.v_breaks[j + 1] - g.report.v_breaks[j]);
    st[k] = Vec2(g.reversed ? 1.0 - s : s, t);
  }
  b.out.mesh.triangles.push_back(tri);
  b.out.mesh.triangle_patch.push_back(static_cast<uint32_t>(pf.first_patch + patch));
  b.out.mesh.triangle_uv.push_back(st);
  b.out.triangle_face.push_back(static_cast<uint32_t>(g.report.face_index));
  b.out.triangle_solid.push_back(g.solid);
  ++pf.triangles;
}

struct KeyHash {
  size_t operator()(const std::array<uint32_t, 3>& k) const {
    return (size_t(k[0]) * 73856093u) ^ (size_t(k[1]) * 19349663u) ^ (size_t(k[2]) * 83492791u);
  }
};

// The scheme's triangles of the face (in the face's own patch numbering) and which are kept.
struct SchemeMesh {
  Tessellation mesh;
  std::vector<Vec2> vertex_uv;      // per scheme vertex: (U, V)
  std::vector<bool> kept;           // per triangle
  std::vector<uint32_t> mesh_vertex;  // per scheme vertex: part mesh vertex (created when used)
};

SchemeMesh scheme_mesh(const FaceGeometry& g, const SegmentGrid& grid) {
  SchemeMesh sm;
  sm.mesh = g.scheme;
  const Tessellation& m = sm.mesh;
  sm.vertex_uv = g.scheme_uv;
  sm.kept.assign(m.triangles.size(), false);
  sm.mesh_vertex.assign(m.positions.size(), std::numeric_limits<uint32_t>::max());
  const Vec2 scale(g.cu, g.cv);
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    std::array<Vec2, 3> q;
    for (int k = 0; k < 3; ++k) q[k] = sm.vertex_uv[m.triangles[t][k]] * scale;
    // Clear of the loops by half the triangle's extent along each axis (cells may be long and thin).
    const Vec2 box_lo = glm::min(q[0], glm::min(q[1], q[2])), box_hi = glm::max(q[0], glm::max(q[1], q[2]));
    const Vec2 lo = box_lo - 0.5 * (box_hi - box_lo), hi = box_hi + 0.5 * (box_hi - box_lo);
    if (grid.any_near(lo, hi)) continue;
    sm.kept[t] = grid.inside((q[0] + q[1] + q[2]) / 3.0);
  }
  return sm;
}

// The scheme's vertices that no kept triangle uses but that lie inside the loops, clear of them by
// a third of their shortest scheme edge, become free points of the CDT: the region between the kept
// triangles and the loops keeps the scheme's density (without them a half cylinder with only its
// boundary points would be cut by chords through its axis). Where the loops run whole periods past
// the patches (a face winding around a seam) the copies one period away are used too.
void add_free_points(PartBuilder& b, const FaceGeometry& g, const SegmentGrid& grid, const SchemeMesh& sm,
                     PartFace& pf, std::vector<Vec2>& points, std::vector<uint32_t>& vertex) {
  const Tessellation& m = sm.mesh;
  const Vec2 scale(g.cu, g.cv);
  std::vector<double> spacing(m.positions.size(), std::numeric_limits<double>::max());
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = m.triangles[t][k], c = m.triangles[t][(k + 1) % 3];
      const double len = glm::length((sm.vertex_uv[a] - sm.vertex_uv[c]) * scale);
      spacing[a] = std::min(spacing[a], len);
      spacing[c] = std::min(spacing[c], len);
    }
  }
  Vec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (size_t k = 0; k < points.size(); ++k) lo = glm::min(lo, points[k] / scale), hi = glm::max(hi, points[k] / scale);
  const auto copies = [](double lo_loop, double hi_loop, double lo, double hi, double period) {
    if (period <= 0.0) return std::pair<int, int>(0, 0);
    return std::pair<int, int>(static_cast<int>(std::floor((lo_loop - lo) / period)),
                               static_cast<int>(std::ceil((hi_loop - hi) / period)));
  };
  const auto [ku0, ku1] = copies(lo.x, hi.x, g.report.u_breaks.front(), g.report.u_breaks.back(), g.u_period);
  const auto [kv0, kv1] = copies(lo.y, hi.y, g.report.v_breaks.front(), g.report.v_breaks.back(), g.v_period);
  std::set<std::pair<int64_t, int64_t>> seen;
  const Vec2 extent = glm::max(hi - lo, Vec2(1e-300));
  for (uint32_t v = 0; v < m.positions.size(); ++v) {
    if (sm.mesh_vertex[v] != std::numeric_limits<uint32_t>::max() || spacing[v] == std::numeric_limits<double>::max())
      continue;
    for (int ku = std::min(ku0, 0); ku <= std::max(ku1, 0); ++ku) {
      for (int kv = std::min(kv0, 0); kv <= std::max(kv1, 0); ++kv) {
        const Vec2 UV = sm.vertex_uv[v] + Vec2(ku * g.u_period, kv * g.v_period);
        const Vec2 q = UV * scale;
        const double margin = spacing[v] / 3.0;
        if (!grid.inside(q) || grid.any_near(q - Vec2(margin), q + Vec2(margin))) continue;
        const Vec2 key = (UV - lo) / extent * 1e9;
        if (!seen.insert({std::llround(key.x), std::llround(key.y)}).second) continue;
        const uint32_t id = b.add_vertex(m.positions[v]);
        const Vec2 w = wrap_uv(g, UV).first;
        const auto [patch, st] = locate_patch(g, w.x, w.y);
        b.out.mesh.surface_points[id] = {static_cast<uint32_t>(pf.first_patch + patch), st.x, st.y};
        b.surface_point_set[id] = true;
        points.push_back(q);
        vertex.push_back(id);
      }
    }
  }
}

// An untrimmed face whose loop points are exactly its scheme's side vertices (its edges' owner, or
// a neighbour sampled alike) keeps the scheme's tessellation unchanged: side vertices become the
// edges' vertices, the rest new vertices. False (nothing emitted) when any side vertex or loop point
// has no partner; mesh_face then takes the general path.
bool try_keep_whole_face(PartBuilder& b, const FaceGeometry& g, PartFace& pf, const std::vector<LoopPoint>& loop,
                         const std::vector<PoleLine>& poles) {
  // A graded grid's cells span several patches: the face is certified from its loops.
  if (g.report.status == "trimmed" || g.scheme.triangles.empty() || !g.grid_u.empty()) return false;
  const std::vector<double>& ub = g.report.u_breaks;
  const std::vector<double>& vb = g.report.v_breaks;
  const Vec2 eps(1e-9 * (ub.back() - ub.front()), 1e-9 * (vb.back() - vb.front()));
  const Vec2 scale(g.cu, g.cv);
  const auto near = [&](const Vec2& p, const Vec2& q) {
    return std::abs(p.x - q.x) <= eps.x && std::abs(p.y - q.y) <= eps.y;
  };
  const Tessellation& m = g.scheme;
  constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> vertex(m.positions.size(), kNone);
  std::vector<bool> matched(loop.size(), false);
  for (const auto& [key, v] : g.scheme_sides) {
    const Vec2 w(key.first, key.second);
    bool found = false;
    for (const PoleLine& pole : poles) {
      const Vec2 lo = glm::min(pole.a, pole.b) - eps, hi = glm::max(pole.a, pole.b) + eps;
      if (w.x < lo.x || w.x > hi.x || w.y < lo.y || w.y > hi.y) continue;
      if (vertex[v] != kNone && vertex[v] != pole.vertex) return false;
      vertex[v] = pole.vertex;
      found = true;
    }
    for (size_t k = 0; k < loop.size(); ++k) {
      if (!near(loop[k].q / scale, w)) continue;
      if (vertex[v] != kNone && vertex[v] != loop[k].vertex) return false;
      vertex[v] = loop[k].vertex;
      matched[k] = true;
      found = true;
    }
    if (!found) vertex[v] = kNone;
    if (vertex[v] == kNone) return false;
  }
  for (size_t k = 0; k < loop.size(); ++k) {
    // A pole's samples (one vertex) need no partner: the scheme's side there collapses to it too.
    const bool at_pole = std::any_of(poles.begin(), poles.end(), [&](const PoleLine& p) { return p.vertex == loop[k].vertex; });
    if (!matched[k] && !at_pole) return false;
  }
  for (size_t v = 0; v < m.positions.size(); ++v) {
    if (vertex[v] != kNone) continue;
    vertex[v] = b.add_vertex(m.positions[v]);
    const auto [patch, st] = locate_patch(g, g.scheme_uv[v].x, g.scheme_uv[v].y);
    b.out.mesh.surface_points[vertex[v]] = {static_cast<uint32_t>(pf.first_patch + patch), st.x, st.y};
    b.surface_point_set[vertex[v]] = true;
  }
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const std::array<uint32_t, 3> tri = {vertex[m.triangles[t][0]], vertex[m.triangles[t][1]], vertex[m.triangles[t][2]]};
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) {
      ++b.out.mesh.degenerate_triangles;
      continue;
    }
    b.out.mesh.triangles.push_back(tri);
    b.out.mesh.triangle_patch.push_back(static_cast<uint32_t>(pf.first_patch) + m.triangle_patch[t]);
    b.out.mesh.triangle_uv.push_back(m.triangle_uv[t]);
    b.out.triangle_face.push_back(static_cast<uint32_t>(g.report.face_index));
    b.out.triangle_solid.push_back(g.solid);
    ++pf.triangles;
    ++pf.scheme_triangles;
  }
  pf.kept_whole = true;
  return true;
}

// The corners' positions of a triangle, sorted: the key of PartBuilder::split_ears.
std::array<double, 9> corner_key(const PartBuilder& b, std::array<uint32_t, 3> tri) {
  std::sort(tri.begin(), tri.end(), [&](uint32_t x, uint32_t y) {
    const Vec3 &p = b.out.mesh.positions[x], &q = b.out.mesh.positions[y];
    return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
  });
  std::array<double, 9> key;
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c)
      key[static_cast<size_t>(3 * k + c)] = b.out.mesh.positions[tri[static_cast<size_t>(k)]][c];
  return key;
}

// How far x lies from the surface point e along the surface's normal there (the whole distance
// where the normal is not defined): a chord cutting through the surface counts, the slide of a
// rational parametrisation's (U, V) midpoint along the surface does not.
double across_surface(const SurfacePointEval& e, const Vec3& x) {
  const Vec3 n = glm::cross(e.du, e.dv), d = x - e.position;
  const double length = glm::length(n);
  return length > 0.0 ? std::abs(glm::dot(d, n)) / length : glm::length(d);
}

// The surface point of the face at (U, V) with its patch's derivatives (eval_uv's point).
SurfacePointEval eval_uv_with_derivatives(const FaceGeometry& g, const Vec2& unwrapped) {
  const Vec2 UV = wrap_uv(g, unwrapped).first;
  const auto [p, st] = locate_patch(g, UV.x, UV.y);
  return evaluate_with_derivatives(g.patches[p], clamp(st.x, 0.0, 1.0), clamp(st.y, 0.0, 1.0));
}

// The largest distance (across the surface) between the midpoint of an edge of the scheme's
// tessellation of the face's patches and the surface at the edge's (U, V) midpoint: the density
// the scheme chose for the face.
double scheme_edge_deviation(const FaceGeometry& g) {
  const Tessellation& m = g.scheme;
  if (m.triangle_patch.size() != m.triangles.size() || m.triangle_uv.size() != m.triangles.size()) return 0.0;
  double worst = 0.0;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const BezierPatch& patch = g.patches[m.triangle_patch[t]];
    for (int k = 0; k < 3; ++k) {
      // In the patch's own (s, t): a vertex shared across a seam has one (U, V) for both sides.
      const Vec2 st = 0.5 * (m.triangle_uv[t][k] + m.triangle_uv[t][(k + 1) % 3]);
      const Vec3 mid = 0.5 * (m.positions[m.triangles[t][k]] + m.positions[m.triangles[t][(k + 1) % 3]]);
      worst = std::max(worst, across_surface(evaluate_with_derivatives(patch, st.x, st.y), mid));
    }
  }
  return worst;
}

// Adds the (U, V) midpoint of every unconstrained edge between input points of a CDT triangle inside
// the loops whose midpoint is farther than `limit` across the surface there (see cdt_without_ears).
void split_deviating_edges(PartBuilder& b, const FaceGeometry& g,
                           const std::vector<std::array<uint32_t, 2>>& constraints, const detail::CdtResult& cdt,
                           double limit, std::vector<Vec2>& points, std::vector<uint32_t>& vertex) {
  const Vec2 scale(g.cu, g.cv);
  const size_t inputs = points.size();
  std::set<std::pair<uint32_t, uint32_t>> fixed, done;
  for (const auto& c : constraints) {
    const uint32_t a = cdt.merged[c[0]], e = cdt.merged[c[1]];
    fixed.insert({std::min(a, e), std::max(a, e)});
  }
  std::vector<uint32_t> point_vertex(cdt.points.size(), std::numeric_limits<uint32_t>::max());
  for (size_t k = 0; k < inputs; ++k) point_vertex[cdt.merged[k]] = vertex[k];
  for (size_t c = 0; c < cdt.triangles.size(); ++c) {
    if (!cdt.inside[c]) continue;
    const auto& t = cdt.triangles[c];
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = std::min(t[k], t[(k + 1) % 3]), e = std::max(t[k], t[(k + 1) % 3]);
      if (point_vertex[a] == std::numeric_limits<uint32_t>::max() ||
          point_vertex[e] == std::numeric_limits<uint32_t>::max() || fixed.count({a, e}) || !done.insert({a, e}).second)
        continue;
      const Vec2 q = 0.5 * (cdt.points[a] + cdt.points[e]);
      const SurfacePointEval on_surface = eval_uv_with_derivatives(g, q / scale);
      const Vec3 mid = 0.5 * (b.out.mesh.positions[point_vertex[a]] + b.out.mesh.positions[point_vertex[e]]);
      if (!(across_surface(on_surface, mid) > limit)) continue;
      points.push_back(q);
      vertex.push_back(b.add_vertex(on_surface.position));
    }
  }
}

// The CDT of the face's points and constraints (the first segments.size() are the loop chords).
// An "ear": a CDT triangle whose three corners are samples of one edge. Both faces of a tangent edge
// (a fillet meeting a plane) may make the same ear, and their triangles would then coincide: an ear
// that did so in an earlier pass (b.split_ears) gets a point at its centre (on the surface), and
// the CDT is made again (at most 4 times). Other ears stay (splitting every ear of a plane's outer
// arcs cost UKI60998 a third more triangles).
//
// An unconstrained CDT edge whose midpoint is farther across the surface (along its normal) at its
// (U, V) midpoint than `deviation_limit` gets that midpoint (on the surface) as a new point, and the CDT is made again
// (at most kDeviationRounds times): where no scheme vertex lies inside the loops (a long rod's
// cylinder, one cell along its length, around a cross hole in its middle) the CDT would otherwise
// join loop points on opposite sides by chords through the axis.
detail::CdtResult cdt_without_ears(PartBuilder& b, const FaceGeometry& g,
                                   const std::vector<std::array<uint32_t, 2>>& segments,
                                   const std::vector<int>& segment_edge,
                                   const std::vector<std::array<uint32_t, 2>>& constraints, std::vector<Vec2>& points,
                                   std::vector<uint32_t>& vertex, double deviation_limit) {
  constexpr int kEarRounds = 4, kDeviationRounds = 12;
  const Vec2 scale(g.cu, g.cv);
  const size_t point_budget = 4 * points.size() + 4096;
  detail::CdtResult cdt;
  for (int round = 0;; ++round) {
    cdt = detail::constrained_delaunay(points, constraints, segments.size());
    if (round == kDeviationRounds) break;
    const size_t before_deviation = points.size();
    if (points.size() < point_budget) split_deviating_edges(b, g, constraints, cdt, deviation_limit, points, vertex);
    if (round >= kEarRounds) {
      if (points.size() == before_deviation) break;
      continue;
    }
    std::vector<std::vector<int>> point_edges(cdt.points.size());
    for (size_t c = 0; c < segments.size(); ++c) {
      for (uint32_t end : segments[c]) point_edges[cdt.merged[end]].push_back(segment_edge[c]);
    }
    const auto has = [&](uint32_t p, int e) {
      return std::find(point_edges[p].begin(), point_edges[p].end(), e) != point_edges[p].end();
    };
    const size_t before = points.size();
    for (size_t c = 0; c < cdt.triangles.size(); ++c) {
      if (!cdt.inside[c]) continue;
      const auto& t = cdt.triangles[c];
      for (int e : point_edges[t[0]]) {
        if (!has(t[1], e) || !has(t[2], e)) continue;
        if (!b.split_ears || !b.split_ears->count(corner_key(b, {vertex[t[0]], vertex[t[1]], vertex[t[2]]}))) break;
        const Vec2 centre = (cdt.points[t[0]] + cdt.points[t[1]] + cdt.points[t[2]]) / 3.0;
        points.push_back(centre);
        vertex.push_back(b.add_vertex(eval_uv(g, centre / scale)));
        break;
      }
    }
    if (points.size() == before && points.size() == before_deviation) break;
  }
  return cdt;
}

// A point CGAL made (index >= inputs) lies where two loop chords cross; it would be a T-junction.
// The longest chord through it is split at its middle (b.crossing) and the part is tessellated again
// (mesh_shape). Near a vertex where two curves are tangent (concentric-like arcs) the outer curve's
// first chord must become shorter than the inner's, so only one of the two is split each time.
void record_crossings(PartBuilder& b, const std::vector<LoopPoint>& loop,
                      const std::vector<std::array<uint32_t, 2>>& segments, const std::vector<int>& segment_edge,
                      const detail::CdtResult& cdt, size_t inputs) {
  for (size_t k = inputs; k < cdt.points.size(); ++k) {
    const Vec2 q = cdt.points[k];
    double longest = -1.0;
    size_t split = 0;
    for (size_t c = 0; c < segments.size(); ++c) {
      const Vec2 a = loop[segments[c][0]].q, d = loop[segments[c][1]].q;
      const Vec2 ad = d - a;
      const double t = clamp(glm::dot(q - a, ad) / std::max(glm::dot(ad, ad), 1e-300), 0.0, 1.0);
      if (glm::length(q - (a + t * ad)) <= 1e-9 * (glm::length(ad) + glm::length(q)) && glm::length(ad) > longest) {
        longest = glm::length(ad);
        split = c;
      }
    }
    if (longest > 0.0) {
      b.crossing[segment_edge[split]].push_back(0.5 * (loop[segments[split][0]].t + loop[segments[split][1]].t));
    }
  }
}

// Tessellates one face into the part; false (pf.reason set) when it cannot.
bool mesh_face(PartBuilder& b, const FaceGeometry& g, PartFace& pf) {
  std::vector<LoopPoint> loop;
  std::vector<std::array<uint32_t, 2>> segments;
  std::vector<int> segment_edge;
  std::vector<PoleLine> poles;
  std::vector<BoundaryChord> chords;
  if (!face_loops(b, g, loop, segments, segment_edge, pf, &poles, &chords)) return false;
  if (try_keep_whole_face(b, g, pf, loop, poles)) return true;
  pf.chords = std::move(chords);
  pf.chord_metric = Vec2(g.su, g.sv);
  if (segments.size() < 2) {
    pf.reason = "the face's boundary has no extent in its parameters";
    return false;
  }
  const SegmentGrid grid(loop, segments);
  SchemeMesh sm = scheme_mesh(g, grid);
  const Tessellation& m = sm.mesh;
  const Vec2 scale(g.cu, g.cv);

  // CDT input: the loop points, then the kept triangles' vertices; constraints: the loop chords and
  // the kept triangles' edges (so each kept triangle is a face of the CDT).
  std::vector<Vec2> points;
  std::vector<uint32_t> vertex;  // per CDT input point: its mesh vertex
  for (const LoopPoint& p : loop) points.push_back(p.q), vertex.push_back(p.vertex);
  std::vector<std::array<uint32_t, 2>> constraints = segments;
  std::vector<uint32_t> scheme_point(m.positions.size(), std::numeric_limits<uint32_t>::max());
  std::unordered_set<std::array<uint32_t, 3>, KeyHash> kept_keys;
  std::set<std::pair<uint32_t, uint32_t>> kept_edges;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    if (!sm.kept[t]) continue;
    std::array<uint32_t, 3> key;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = m.triangles[t][k];
      if (sm.mesh_vertex[v] == std::numeric_limits<uint32_t>::max()) {
        sm.mesh_vertex[v] = b.add_vertex(m.positions[v]);
        const auto [patch, st] = locate_patch(g, sm.vertex_uv[v].x, sm.vertex_uv[v].y);
        b.out.mesh.surface_points[sm.mesh_vertex[v]] = {static_cast<uint32_t>(pf.first_patch + patch), st.x, st.y};
        b.surface_point_set[sm.mesh_vertex[v]] = true;
        scheme_point[v] = static_cast<uint32_t>(points.size());
        points.push_back(sm.vertex_uv[v] * scale);
        vertex.push_back(sm.mesh_vertex[v]);
      }
      key[k] = sm.mesh_vertex[v];
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = m.triangles[t][k], c = m.triangles[t][(k + 1) % 3];
      if (kept_edges.insert({std::min(a, c), std::max(a, c)}).second) constraints.push_back({scheme_point[a], scheme_point[c]});
    }
    std::sort(key.begin(), key.end());
    kept_keys.insert(key);
  }
  add_free_points(b, g, grid, sm, pf, points, vertex);
  // A CDT edge is split only where it cuts across the surface by more than four times what the
  // scheme's own edges or the loops' chords do (measured alike: midpoint against the surface at the
  // (U, V) midpoint, along its normal), or the edges' chord tolerance (the fit sets it near its
  // target), and 1e-9 of the face's extent (planes): a chord across the face, not a cell's chord
  // (1.5 times split so many edges near the loops that the fit's per-face densities and the
  // slivers' bounds on bug24595 came out worse).
  double extent = 0.0, chord_deviation = 0.0;
  for (uint32_t v : vertex)
    extent = std::max(extent, glm::length(b.out.mesh.positions[v] - b.out.mesh.positions[vertex[0]]));
  for (const auto& [i, k] : segments) {
    const Vec3 mid = 0.5 * (b.out.mesh.positions[vertex[i]] + b.out.mesh.positions[vertex[k]]);
    chord_deviation = std::max(chord_deviation,
                               across_surface(eval_uv_with_derivatives(g, 0.5 * (points[i] + points[k]) / scale), mid));
  }
  const double deviation_limit =
      std::max({4.0 * scheme_edge_deviation(g), 4.0 * chord_deviation, b.options.edge_tolerance, 1e-9 * extent});
  const detail::CdtResult cdt =
      cdt_without_ears(b, g, segments, segment_edge, constraints, points, vertex, deviation_limit);
  for (size_t k = points.size(); k < cdt.points.size(); ++k) vertex.push_back(b.add_vertex(eval_uv(g, cdt.points[k] / scale)));
  record_crossings(b, loop, segments, segment_edge, cdt, points.size());
  // The scheme's kept triangles as the scheme made them, then the CDT's faces inside the loops
  // that are not kept triangles.
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    if (!sm.kept[t]) continue;
    std::array<uint32_t, 3> tri;
    std::array<Vec2, 3> uv;
    for (int k = 0; k < 3; ++k) tri[k] = sm.mesh_vertex[m.triangles[t][k]], uv[k] = sm.vertex_uv[m.triangles[t][k]];
    emit_triangle(b, g, pf, tri, uv);
    ++pf.scheme_triangles;
  }
  for (size_t c = 0; c < cdt.triangles.size(); ++c) {
    if (!cdt.inside[c]) continue;
    const auto& face = cdt.triangles[c];
    std::array<Vec2, 3> q;
    for (int k = 0; k < 3; ++k) q[k] = cdt.points[face[k]];
    std::array<uint32_t, 3> tri;
    std::array<Vec2, 3> uv;
    for (int k = 0; k < 3; ++k) tri[k] = vertex[face[k]], uv[k] = q[k] / scale;
    std::array<uint32_t, 3> key = tri;
    std::sort(key.begin(), key.end());
    if (kept_keys.count(key)) continue;
    if (g.reversed) std::swap(tri[1], tri[2]), std::swap(uv[1], uv[2]);
    emit_triangle(b, g, pf, tri, uv);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------

std::vector<PartSolid> solid_facts(const ShapeIndex& x, bool occt_checks) {
  std::vector<PartSolid> solids;
  for (int s = 1; s <= x.solids.Extent(); ++s) {
    PartSolid ps;
    ps.index = s - 1;
    const TopoDS_Shape& solid = x.solids(s);
    ps.closed = true;
    bool any_shell = false;
    for (TopExp_Explorer it(solid, TopAbs_SHELL); it.More(); it.Next()) {
      any_shell = true;
      ps.closed = ps.closed && BRep_Tool::IsClosed(it.Current());
    }
    ps.closed = ps.closed && any_shell;
    if (!occt_checks) {
      solids.push_back(ps);
      continue;
    }
    try {
      ps.valid = BRepCheck_Analyzer(solid).IsValid();
      GProp_GProps props;
      BRepGProp::VolumeProperties(solid, props);
      ps.volume = props.Mass();
    } catch (const Standard_Failure&) {
      ps.valid = false;
    }
    solids.push_back(ps);
  }
  return solids;
}

void check_scheme(const PartOptions& options, const std::string& name) {
  if (options.scheme.scheme == Scheme::kPn) {
    throw InputError(name + ": pn is a scheme for triangle meshes; tessellate the part with uniform or esc");
  }
  for (int n : options.face_segments) {
    if (n < 0 || n > 4096) throw InputError(name + ": segments per face must be in 0..4096, got " + std::to_string(n));
  }
  for (double n : options.face_graded_segments) {
    if (!(n >= 0.0) || !(n <= 4096.0))
      throw InputError(name + ": a face's graded segments must be in 0..4096, got " + std::to_string(n));
  }
  for (double tol : options.face_edge_tolerance) {
    if (!(tol >= 0.0) || !std::isfinite(tol))
      throw InputError(name + ": a face's edge tolerance must be a finite number >= 0, got " + std::to_string(tol));
  }
}

// The B-rep's vertices and every edge's samples into b.out (the first mesh vertices).
void build_edges(PartBuilder& b) {
  const ShapeIndex& x = b.x;
  for (int v = 1; v <= x.vertices.Extent(); ++v) b.add_vertex(to_vec(BRep_Tool::Pnt(TopoDS::Vertex(x.vertices(v)))));
  b.edges.resize(x.edges.Extent());
  for (int e = 0; e < x.edges.Extent(); ++e) sample_edge(b, e);
  // A B-rep vertex whose (non-degenerated) edges are all free edges of one face moves onto the face
  // with them: to the mean of those edges' ends S(p-curve(end)) (one point but for the loop's gaps).
  std::vector<int> vertex_face(x.vertices.Extent(), -1);  // -1: none yet, -2: stays on the B-rep
  std::vector<Vec3> sum(x.vertices.Extent(), Vec3(0.0));
  std::vector<int> count(x.vertices.Extent(), 0);
  for (int e = 0; e < x.edges.Extent(); ++e) {
    if (b.edges[e].degenerated) continue;
    const TopoDS_Edge edge = TopoDS::Edge(x.edges(e + 1).Oriented(TopAbs_FORWARD));
    TopoDS_Vertex v_first, v_last;
    TopExp::Vertices(edge, v_first, v_last);
    const std::function<Vec3(double)>& on_face = b.edges[e].on_face;
    const int face = on_face ? faces_of_edge(x, edge).front() : -2;
    for (const auto& [v, t] : {std::pair{v_first, b.edges[e].t.front()}, std::pair{v_last, b.edges[e].t.back()}}) {
      if (v.IsNull()) continue;
      const int k = x.vertices.FindIndex(v) - 1;
      if (vertex_face[k] == -2) continue;
      if (face < 0 || (vertex_face[k] >= 0 && vertex_face[k] != face)) {
        vertex_face[k] = -2;
        continue;
      }
      vertex_face[k] = face;
      sum[k] += on_face(t);
      ++count[k];
    }
  }
  for (int k = 0; k < x.vertices.Extent(); ++k) {
    if (vertex_face[k] >= 0 && count[k] > 0) b.out.mesh.positions[k] = sum[k] / double(count[k]);
  }
  Vec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const Vec3& p : b.out.mesh.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
  const double size = b.out.mesh.positions.empty() ? 0.0 : glm::length(hi - lo);
  for (double& tol : b.vertex_tolerance) tol = 1e-9 * size;
  for (int v = 1; v <= x.vertices.Extent(); ++v)
    b.vertex_tolerance[v - 1] = std::max(1e-9 * size, 10.0 * BRep_Tool::Tolerance(TopoDS::Vertex(x.vertices(v))));
  b.out.edges = x.edges.Extent();
  b.out.edge_vertices = b.out.mesh.positions.size();
  for (const EdgeSamples& s : b.edges) {
    if (!s.free) continue;
    for (size_t k = 0; k + 1 < s.vertex.size(); ++k) b.out.boundary_edges.push_back({s.vertex[k], s.vertex[k + 1]});
  }
}

// True when segments (a, b) and (c, d) share a point other than a common end (orientation tests
// in double; the CDT's exact predicates are the backstop).
bool segments_cross(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  if (a == c || a == d || b == c || b == d) return false;
  const auto orient = [](const Vec2& p, const Vec2& q, const Vec2& r) {
    const double o = (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
    return o > 0.0 ? 1 : (o < 0.0 ? -1 : 0);
  };
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 * o2 > 0 || o3 * o4 > 0) return false;
  if (o1 == 0 && o2 == 0) {  // collinear: overlapping extents
    const Vec2 lo1 = glm::min(a, b), hi1 = glm::max(a, b), lo2 = glm::min(c, d), hi2 = glm::max(c, d);
    return lo1.x <= hi2.x && lo2.x <= hi1.x && lo1.y <= hi2.y && lo2.y <= hi1.y;
  }
  return true;
}

// True when c and d both lie on the line through a and b (orientation tests in double). Such chords
// are not split: where they overlap, the loops run along themselves (a face whose p-curves leave its
// surface's range, clamped onto one line) and halving them never separates them (an IGES face did
// so for ever); the CDT's exact predicates decide.
bool collinear(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const auto orient = [](const Vec2& p, const Vec2& q, const Vec2& r) {
    return (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
  };
  return orient(a, b, c) == 0.0 && orient(a, b, d) == 0.0;
}

// Loop chords of different edges (or far apart on one edge) that cross in some face's (U, V): the
// longer of each crossing pair gets its middle added to its edge's samples (`extra`). Returns
// whether any was found. Cheap (loops only), so the part is meshed once the loops are clean.
bool split_crossing_chords(PartBuilder& b, std::vector<std::vector<double>>& extra, std::set<int>& faces) {
  std::set<int> next;
  for (int f : faces) {
    const FaceGeometry& g = b.geometry[f];
    if (g.patches.empty()) continue;
    PartFace pf;
    std::vector<LoopPoint> loop;
    std::vector<std::array<uint32_t, 2>> segments;
    std::vector<int> segment_edge;
    if (!face_loops(b, g, loop, segments, segment_edge, pf) || segments.size() < 2) continue;
    Vec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (const LoopPoint& p : loop) lo = glm::min(lo, p.q), hi = glm::max(hi, p.q);
    const int cells = std::max(1, std::min(256, static_cast<int>(std::sqrt(double(segments.size())))));
    const Vec2 size = glm::max((hi - lo) / double(cells), Vec2(1e-300));
    std::vector<std::vector<uint32_t>> grid(size_t(cells) * cells);
    const auto cell = [&](const Vec2& p, int axis) {
      const double v = axis == 0 ? (p.x - lo.x) / size.x : (p.y - lo.y) / size.y;
      return std::max(0, std::min(cells - 1, static_cast<int>(std::floor(v))));
    };
    std::set<std::pair<uint32_t, uint32_t>> tested;
    std::map<int, std::set<double>> split;
    for (uint32_t k = 0; k < segments.size(); ++k) {
      const Vec2 a = loop[segments[k][0]].q, c = loop[segments[k][1]].q;
      const Vec2 s0 = glm::min(a, c), s1 = glm::max(a, c);
      for (int j = cell(s0, 1); j <= cell(s1, 1); ++j) {
        for (int i = cell(s0, 0); i <= cell(s1, 0); ++i) {
          for (uint32_t other : grid[size_t(j) * cells + i]) {
            if (!tested.insert({other, k}).second) continue;
            const Vec2 p = loop[segments[other][0]].q, q = loop[segments[other][1]].q;
            if (!segments_cross(a, c, p, q) || collinear(a, c, p, q)) continue;
            const uint32_t longer = glm::length(c - a) >= glm::length(q - p) ? k : other;
            split[segment_edge[longer]].insert(0.5 * (loop[segments[longer][0]].t + loop[segments[longer][1]].t));
          }
          grid[size_t(j) * cells + i].push_back(k);
        }
      }
    }
    for (const auto& [e, ts] : split) {
      extra[e].insert(extra[e].end(), ts.begin(), ts.end());
      for (int other : faces_of_edge(b.x, b.x.edges(e + 1))) next.insert(other);
    }
  }
  faces.swap(next);
  return !faces.empty();
}

// Face g of the part: its report fields and patches into a new PartFace, `mesh` fills its triangles
// (false and pf.reason when it cannot); then the part's face, solid and skip counts. OCCT failures on
// the face become its reason.
void add_face(PartBuilder& b, const FaceGeometry& g, const std::function<bool(PartFace&)>& mesh) {
  PartFace pf;
  pf.face_index = g.report.face_index;
  pf.name = g.report.name;
  pf.surface_type = g.report.surface_type;
  pf.trimmed = g.report.status == "trimmed";
  // Our own uniform tessellation only (a foreign mesh's faces have no scheme).
  const bool uniform = b.options.scheme.scheme == Scheme::kUniform && !g.scheme.triangles.empty();
  pf.segments = uniform ? g.segments : 0;
  pf.segments_u = uniform ? g.segments_u : 0;
  pf.segments_v = uniform ? g.segments_v : 0;
  if (uniform && !g.grid_u.empty()) {
    pf.graded_u = static_cast<int>(g.grid_u.size()) - 1;
    pf.graded_v = static_cast<int>(g.grid_v.size()) - 1;
    pf.graded_segments = g.graded_segments;
  }
  pf.solid = g.solid;
  pf.status = "skipped";
  if (g.patches.empty()) {
    pf.reason = g.report.reason;
  } else {
    pf.first_patch = static_cast<int>(b.out.model.patches.size());
    pf.patch_count = static_cast<int>(g.patches.size());
    pf.u_breaks = g.report.u_breaks, pf.v_breaks = g.report.v_breaks;
    pf.reversed = g.reversed;
    pf.u_period = g.u_period, pf.v_period = g.v_period;
    b.out.model.patches.insert(b.out.model.patches.end(), g.patches.begin(), g.patches.end());
    try {
      if (mesh(pf)) pf.status = "tessellated";
    } catch (const Standard_Failure& e) {
      pf.reason = std::string("OCCT failed on the face (") + e.GetMessageString() + ")";
    }
  }
  if (pf.status == "skipped" && pf.reason.empty()) pf.reason = "no triangles";
  b.out.faces_tessellated += pf.status == "tessellated";
  b.out.faces_skipped += pf.status == "skipped";
  b.out.faces_trimmed += pf.trimmed;
  if (pf.solid >= 0) {
    ++b.out.solids[pf.solid].faces;
    b.out.solids[pf.solid].triangles += pf.triangles;
  }
  b.out.faces.push_back(pf);
}

// One pass over the part: vertices, edges, then every face (mesh_shape repeats it with refined
// edges while chords cross).
void build_part(PartBuilder& b) {
  std::vector<FaceGeometry>& geometry = b.geometry;
  build_edges(b);
  for (FaceGeometry& g : geometry) {
    budget::check("meshing the part");  // per face: a cancel waits for one face's mesh at most
    add_face(b, g, [&](PartFace& pf) { return mesh_face(b, g, pf); });
  }
}

// Bytes of meshing a part into `triangles` triangles: every face's scheme mesh (with surface data)
// is kept until the part is assembled, and the part's mesh copies it with per-triangle face, solid
// and (u, v). Generous: measured about 360 bytes per triangle (a cylinder at level 8), this gives 408.
double part_bytes(double triangles) { return 3.0 * tessellation_bytes(triangles, triangles); }

// Throws MemoryLimitExceeded (budget::check_memory) before any face is meshed when the whole part
// (every face's scheme estimate, untrimmed: trimming only removes triangles) would exceed the limit.
// Each face's scheme also guards its own size; this guards their sum.
void check_part_memory(const std::vector<FaceGeometry>& geometry, const PartOptions& options, const std::string& name) {
  if (budget::max_bytes() <= 0.0) return;
  double triangles = 0.0;
  for (const FaceGeometry& g : geometry) {
    if (g.patches.empty()) continue;
    Model face;
    face.patches = g.patches;
    triangles += estimated_triangles(face, face_scheme(options, g.report.face_index));
  }
  if (!(triangles > 0.0)) return;
  budget::check_memory(part_bytes(triangles),
                       name + ": meshing the part (about " + std::to_string(static_cast<uint64_t>(std::min(triangles, 1e19))) +
                           " triangles)",
                       "lower --level or --segments, or raise --max-memory");
}

// Every face's geometry (face_geometry); throws InputError when the shape has no face.
std::vector<FaceGeometry> faces_geometry(const ShapeIndex& x, const std::string& name, const CadOptions& cad) {
  if (x.faces.Extent() == 0) throw InputError(name + ": the shape has no faces");
  std::vector<FaceGeometry> geometry;
  for (int f = 0; f < x.faces.Extent(); ++f) {
    budget::check("converting the part's faces");
    geometry.push_back(face_geometry(x, f, name, cad));
  }
  return geometry;
}

PartMesh mesh_shape(const TopoDS_Shape& shape, const std::string& name, const PartOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  check_scheme(options, name);
  PartMesh out;
  out.name = name;
  out.model.name = name;
  const ShapeIndex x = index_shape(shape);
  std::vector<FaceGeometry> geometry = faces_geometry(x, name, options.cad);
  check_part_memory(geometry, options, name);
  for (FaceGeometry& g : geometry) {
    budget::check("tessellating the part's faces");
    const SchemeSpec scheme = face_scheme(options, g.report.face_index);
    g.segments = scheme_segments(scheme);
    const size_t fi = static_cast<size_t>(g.report.face_index);
    const double real_n = scheme.scheme == Scheme::kUniform && fi < options.face_graded_segments.size()
                              ? options.face_graded_segments[fi]
                              : 0.0;
    g.graded_segments = real_n > 0.0 ? std::min(real_n, double(g.segments)) : g.segments;
    tessellate_face_patches(g, scheme, options.graded_grids);
  }
  // OCCT's checks of the solids (validity, volume) read the shape only: beside the meshing.
  const std::vector<PartSolid> shells = solid_facts(x, false);  // closed or not: counted per pass
  std::vector<PartSolid> solids;
  tbb::task_group solid_checks;
  struct WaitOnExit {
    tbb::task_group& group;
    ~WaitOnExit() {
      try {
        group.wait();
      } catch (...) {  // unwinding already: the meshing's exception is the one reported
      }
    }
  } wait_on_exit{solid_checks};
  solid_checks.run([&] { solids = solid_facts(x, options.solid_facts); });
  std::vector<EdgePlan> plans;
  for (int e = 0; e < x.edges.Extent(); ++e) {
    budget::check("planning the part's edges");
    plans.push_back(plan_edge(options, x, geometry, e));
  }
  // Chords that cross are split first on the loops alone (each pass re-checks only the faces of the
  // edges just split); near a vertex where two curves are tangent this takes a pass per chord.
  std::vector<std::vector<double>> extra(x.edges.Extent());
  std::set<int> faces;
  for (int f = 0; f < x.faces.Extent(); ++f) faces.insert(f);
  for (int pass = 0; pass < 64; ++pass) {
    budget::check("splitting crossing chords");
    PartMesh scratch;
    PartBuilder b{options, x, geometry, scratch, {}, {}, {}, extra, {}, plans};
    build_edges(b);
    if (!split_crossing_chords(b, extra, faces)) break;
  }
  std::set<std::array<double, 9>> split_ears;
  for (int pass = 0;; ++pass) {
    out = PartMesh();
    out.name = name;
    out.model.name = name;
    out.solids = shells;
    PartBuilder b{options, x, geometry, out, {}, {}, {}, extra, {}, plans};
    b.split_ears = &split_ears;
    build_part(b);
    // Triangles that two faces both made (ears of one edge on both sides): split next pass.
    bool new_ears = false;
    std::map<std::array<uint32_t, 3>, uint32_t> first_face;
    for (size_t t = 0; t < out.mesh.triangles.size(); ++t) {
      std::array<uint32_t, 3> key = out.mesh.triangles[t];
      std::sort(key.begin(), key.end());
      const auto [it, inserted] = first_face.emplace(key, out.triangle_face[t]);
      if (!inserted && it->second != out.triangle_face[t])
        new_ears = split_ears.insert(corner_key(b, out.mesh.triangles[t])).second || new_ears;
    }
    if ((b.crossing.empty() && !new_ears) || pass == 8) break;
    for (const auto& [e, ts] : b.crossing) extra[e].insert(extra[e].end(), ts.begin(), ts.end());
  }
  solid_checks.wait();
  for (size_t k = 0; k < out.solids.size(); ++k)
    out.solids[k].valid = solids[k].valid, out.solids[k].volume = solids[k].volume;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

// ---------------------------------------------------------------------------------------------
// Another mesher's triangulation of the part (BRepMesh's: the Poly_Triangulation OCCT leaves on each
// face, nodes with the face's (u, v), edges as Poly_PolygonOnTriangulation with their parameters), in
// the same PartMesh form as our own, so that certify_part's loops route certifies it face by face.

// Mesh vertices of the triangulations' nodes: by B-rep vertex (at_corner), by an edge's sample
// (brepmesh_face), else by bit-identical position (a seam's two copies, a pole's nodes, and a shared
// edge's nodes where BRepMesh gives both faces the same 3D points).
class NodeIndex {
 public:
  static constexpr uint32_t kUnset = std::numeric_limits<uint32_t>::max();
  explicit NodeIndex(PartBuilder& b) : b_(b), corners_(static_cast<size_t>(b.x.vertices.Extent()), kUnset) {}
  uint32_t vertex(const Vec3& p) {
    const auto it = index_.find(key(p));
    if (it != index_.end()) return it->second;
    const uint32_t v = b_.add_vertex(p);
    index_.emplace(key(p), v);
    return v;
  }
  // Nodes at p are vertex v from now on, unless p already has a vertex (a node taken by another
  // face's sample of its edge: the other nodes of this face at the same point, a pole's, follow it).
  void alias(const Vec3& p, uint32_t v) { index_.emplace(key(p), v); }
  // The mesh vertex of the B-rep's vertex c (an index of ShapeIndex::vertices), or kUnset.
  uint32_t at_corner(int c) const { return corners_[static_cast<size_t>(c)]; }
  void set_corner(int c, uint32_t v) { corners_[static_cast<size_t>(c)] = v; }

 private:
  using Key = std::array<uint64_t, 3>;
  static Key key(const Vec3& p) {
    Key k;
    std::memcpy(&k[0], &p.x, 8), std::memcpy(&k[1], &p.y, 8), std::memcpy(&k[2], &p.z, 8);
    return k;
  }
  PartBuilder& b_;
  std::vector<uint32_t> corners_;  // per B-rep vertex
  std::map<Key, uint32_t> index_;
};

// One face of a foreign mesh, once b.edges holds the samples of the face's edges (edge parameters
// and mesh vertices): its loops, then its triangles with (U, V) corners. raw_uv are the corners' (u, v)
// in the face's own parameters (OCCT's, before face_to_uv). The loops were moved whole periods towards
// the patches' range (pcurve_shift), the corners were not: the shift between them, the most frequent
// at the corners on the loops, moves every corner into the loops' frame; each triangle's corners are
// then (`unwrap`: corners projected into one period, not continuous across a seam) unwrapped whole
// periods towards a corner off the loops (or on them but not on a seam or pole), and corners on the loops take
// the nearest of their vertex's loop points (a seam's or a pole's copies lie apart). False (pf.reason)
// when the face cannot be taken.
bool take_face(PartBuilder& b, const FaceGeometry& g, PartFace& pf, const std::vector<std::array<uint32_t, 3>>& tris,
               const std::vector<std::array<Vec2, 3>>& raw_uv, bool unwrap) {
  std::vector<LoopPoint> loop;
  std::vector<std::array<uint32_t, 2>> segments;
  std::vector<int> segment_edge;
  std::vector<BoundaryChord> chords;
  if (!face_loops(b, g, loop, segments, segment_edge, pf, nullptr, &chords)) return false;
  pf.chords = std::move(chords);
  pf.chord_metric = Vec2(g.su, g.sv);
  std::unordered_map<uint32_t, std::vector<Vec2>> loop_uv;
  for (const LoopPoint& p : loop) loop_uv[p.vertex].push_back(Vec2(p.q.x / g.cu, p.q.y / g.cv));
  // Seam vertices: copies at least a quarter of the loops' extent apart in U or in V (a seam's two
  // sides; not a corner's copies from two p-curves, nor a pole's, whose copies run along its segment).
  std::set<uint32_t> seams;
  {
    Vec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (const LoopPoint& p : loop) lo = glm::min(lo, p.q), hi = glm::max(hi, p.q);
    const Vec2 extent = hi - lo;
    std::set<uint32_t> poles;
    for (TopExp_Explorer it(g.face, TopAbs_EDGE); it.More(); it.Next()) {
      const int e = b.x.edges.FindIndex(it.Current()) - 1;
      if (e >= 0 && BRep_Tool::Degenerated(TopoDS::Edge(it.Current())) && !b.edges[e].vertex.empty())
        poles.insert(b.edges[e].vertex.front());
    }
    for (const auto& [v, copies] : loop_uv) {
      if (copies.size() < 2 || poles.count(v)) continue;
      bool apart = false;
      for (const Vec2& q : copies) {
        const Vec2 d = glm::abs((q - copies.front()) * Vec2(g.cu, g.cv));
        apart = apart || d.x > 0.25 * extent.x || d.y > 0.25 * extent.y;
      }
      if (apart) seams.insert(v);
    }
  }
  const auto period_steps = [&](const Vec2& d) {
    return std::make_pair(g.u_period > 0.0 ? std::round(d.x / g.u_period) : 0.0, g.v_period > 0.0 ? std::round(d.y / g.v_period) : 0.0);
  };
  const auto remove_periods = [&](const Vec2& d) {
    const auto [ku, kv] = period_steps(d);
    return Vec2(d.x - ku * g.u_period, d.y - kv * g.v_period);
  };
  // face_to_uv of each distinct (vertex, raw (u, v)): a Gauss-Newton solve on analytic faces.
  std::map<std::tuple<uint32_t, double, double>, Vec2> mapped;
  std::vector<std::array<Vec2, 3>> uv(tris.size());
  std::map<std::pair<double, double>, int> shifts;
  for (size_t t = 0; t < tris.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const Vec2 r = raw_uv[t][c];
      auto [it, fresh] = mapped.try_emplace({tris[t][c], r.x, r.y}, Vec2(0.0));
      if (fresh) {
        it->second = face_to_uv(g, r.x, r.y);
        const auto on_loop = loop_uv.find(tris[t][c]);
        if (on_loop != loop_uv.end()) {
          double best = std::numeric_limits<double>::infinity();
          std::pair<double, double> steps{0.0, 0.0};
          for (const Vec2& q : on_loop->second) {
            const double d = glm::length(remove_periods(q - it->second) * Vec2(g.su, g.sv));
            if (d < best) best = d, steps = period_steps(it->second - q);
          }
          ++shifts[steps];
        }
      }
      uv[t][c] = it->second;
    }
  }
  Vec2 shift(0.0);
  int votes = 0;
  for (const auto& [k, count] : shifts) {
    if (count > votes) shift = Vec2(k.first * g.u_period, k.second * g.v_period), votes = count;
  }
  for (size_t t = 0; t < tris.size(); ++t) {
    // The reference corner: one off the loops, else one with a single loop point (not on a seam or
    // a pole, whose copies lie apart), else the first.
    int reference = 0, rank = 0;
    for (int c = 0; c < 3; ++c) {
      const auto on_loop = loop_uv.find(tris[t][c]);
      const int r = on_loop == loop_uv.end() ? 2 : on_loop->second.size() == 1 ? 1 : 0;
      if (r > rank) reference = c, rank = r;
    }
    const auto single = loop_uv.find(tris[t][reference]);
    const Vec2 ref = rank == 1 ? single->second.front() : uv[t][reference] - shift;
    for (int c = 0; c < 3; ++c) {
      Vec2 w = uv[t][c] - shift;
      if (unwrap) w = ref + remove_periods(w - ref);
      const auto on_loop = loop_uv.find(tris[t][c]);
      if (on_loop != loop_uv.end()) {
        double best = std::numeric_limits<double>::infinity();
        const Vec2 own = w;
        for (const Vec2& q : on_loop->second) {
          // Unwrapped (a foreign mesh's projected (u, v)): the copy whole periods next to the corner.
          const Vec2 near = unwrap ? own + remove_periods(q - own) : q;
          const double d = glm::length((near - own) * Vec2(g.su, g.sv));
          if (d < best) best = d, w = near;
        }
      } else if (!b.surface_point_set[tris[t][c]]) {
        const Vec2 inside = wrap_uv(g, w).first;
        const auto [patch, st] = locate_patch(g, inside.x, inside.y);
        b.out.mesh.surface_points[tris[t][c]] = {static_cast<uint32_t>(pf.first_patch + patch), st.x, st.y};
        b.surface_point_set[tris[t][c]] = true;
      }
      uv[t][c] = w;
    }
    // Seam vertices of a foreign mesh get their (u, v) by projection, on either side of the seam, and
    // on a surface closed but not periodic (an extrusion of a closed B-spline) no period brings them
    // across; where all three corners lie on seams (a torus's corner vertex) no corner is a safe
    // reference either. The seam corners take the copies that make the triangle smallest in (U, V)
    // (its perimeter, the corners off seams fixed).
    if (unwrap) {
      std::array<const std::vector<Vec2>*, 3> choices{};
      size_t combinations = 1;
      for (int c = 0; c < 3; ++c) {
        if (!seams.count(tris[t][c])) continue;
        choices[c] = &loop_uv.at(tris[t][c]);
        combinations *= choices[c]->size();
      }
      if (combinations > 1 && combinations <= 512) {
        const Vec2 metric(g.su, g.sv), anchor = uv[t][reference];
        double best = std::numeric_limits<double>::infinity();
        std::array<Vec2, 3> pick = uv[t], trial = uv[t];
        for (size_t k = 0; k < combinations; ++k) {
          size_t rest = k;
          for (int c = 0; c < 3; ++c) {
            if (!choices[c]) continue;
            const Vec2 q = (*choices[c])[rest % choices[c]->size()];
            trial[c] = anchor + remove_periods(q - anchor);  // whole periods next to the reference
            rest /= choices[c]->size();
          }
          const double perimeter = glm::length((trial[1] - trial[0]) * metric) +
                                   glm::length((trial[2] - trial[1]) * metric) +
                                   glm::length((trial[0] - trial[2]) * metric);
          if (perimeter < best) best = perimeter, pick = trial;
        }
        uv[t] = pick;
      }
    }
    emit_triangle(b, g, pf, tris[t], uv[t]);
  }
  return true;
}

// The vertex tolerance of an edge's end vertices: 10x the B-rep vertices' tolerance, at least 1e-9 of
// the part (how far apart two loop points of one vertex may lie and still be that vertex).
void set_end_tolerance(PartBuilder& b, const TopoDS_Edge& edge, const EdgeSamples& s, double part_size) {
  double tol = 1e-9 * part_size;
  for (TopExp_Explorer ve(edge, TopAbs_VERTEX); ve.More(); ve.Next())
    tol = std::max(tol, 10.0 * BRep_Tool::Tolerance(TopoDS::Vertex(ve.Current())));
  for (const uint32_t v : {s.vertex.front(), s.vertex.back()}) b.vertex_tolerance[v] = std::max(b.vertex_tolerance[v], tol);
}

// A pole (a degenerated edge) in a foreign mesh: the mesh has one vertex P there (s.vertex all P),
// the face a segment of (u, v) (the edge's p-curve, a line). Each triangle (P, a, b) becomes (P at
// a', a, b) and the collapsed (P at a', b, P at b'), a' and b' the projections of a and b onto the
// segment: together they tile the quadrilateral a', a, b, b' of (u, v), and the fan's collapsed
// triangles meet along the segment at the pole's samples (every a', b' becomes an edge parameter of
// the pole, s.t). raw: the corners' (u, v) in the face's own parameters. Without this, a fan corner
// at one (u, v) of the segment (a mesher's node at the pole) makes the triangle's (u, v) map sweep
// across the meridians and its bound first-order. Where a' and b' lie within `tolerance` of each
// other in the loops' metric ((U, V) scaled by cu, cv: face_loops merges such samples of one vertex
// into one loop point), the collapsed triangle would have no area and is left out.
void tile_pole(const FaceGeometry& g, const TopoDS_Edge& edge, double tolerance, EdgeSamples& s,
               std::vector<std::array<uint32_t, 3>>& triangles, std::vector<std::array<Vec2, 3>>& raw) {
  double f = 0.0, l = 0.0;
  const Handle(Geom2d_Curve) pc = BRep_Tool::CurveOnSurface(edge, g.face, f, l);
  if (pc.IsNull()) return;
  const gp_Pnt2d p0 = pc->Value(f), p1 = pc->Value(l);
  const Vec2 A(p0.X(), p0.Y()), B(p1.X(), p1.Y());
  const double len2 = glm::dot(B - A, B - A);
  if (!(len2 > 0.0)) return;
  const uint32_t pole = s.vertex.front();
  const auto along = [&](const Vec2& q) { return std::clamp(glm::dot(q - A, B - A) / len2, 0.0, 1.0); };
  const auto loop_point = [&](const Vec2& q) {  // as face_loops places it
    const Vec2 UV = face_to_uv(g, q.x, q.y);
    return Vec2(UV.x * g.cu, UV.y * g.cv);
  };
  std::vector<double> t = s.t;
  std::vector<size_t> dropped;
  const size_t count = triangles.size();
  for (size_t k = 0; k < count; ++k) {
    int c = 0;
    while (c < 3 && triangles[k][c] != pole) ++c;
    if (c == 3) continue;
    const int a = (c + 1) % 3, bb = (c + 2) % 3;
    // Two corners at the pole (a mesher's nodes at both ends of the segment, one vertex in space): a
    // triangle without area, whose (u, v) the tiling of its neighbours' fans covers; dropped.
    if (triangles[k][a] == pole || triangles[k][bb] == pole) {
      dropped.push_back(k);
      continue;
    }
    const double sa = along(raw[k][a]), sb = along(raw[k][bb]);
    const Vec2 qa = A + sa * (B - A), qb = A + sb * (B - A);
    t.push_back(f + sa * (l - f)), t.push_back(f + sb * (l - f));
    raw[k][c] = qa;
    if (sa != sb && glm::length(loop_point(qa) - loop_point(qb)) > tolerance) {
      triangles.push_back({pole, triangles[k][bb], pole});
      raw.push_back({qa, raw[k][bb], qb});
    }
  }
  for (auto k = dropped.rbegin(); k != dropped.rend(); ++k) {
    triangles.erase(triangles.begin() + static_cast<std::ptrdiff_t>(*k));
    raw.erase(raw.begin() + static_cast<std::ptrdiff_t>(*k));
  }
  std::sort(t.begin(), t.end());
  t.erase(std::unique(t.begin(), t.end()), t.end());
  s.t = std::move(t);
  s.vertex.assign(s.t.size(), pole);
}

// One face of BRepMesh's mesh: the edges' samples from their Poly_PolygonOnTriangulation on the face's
// triangulation, the nodes' (u, v) from the triangulation.
bool brepmesh_face(PartBuilder& b, NodeIndex& nodes, const FaceGeometry& g, PartFace& pf, double part_size) {
  TopLoc_Location loc;
  const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(g.face, loc);
  std::vector<TopoDS_Edge> poles;  // degenerated edges whose nodes are one mesh vertex
  if (tri.IsNull() || tri->NbTriangles() == 0) {
    pf.reason = "the mesher left no triangles on the face";
    return false;
  }
  if (!tri->HasUVNodes()) {
    pf.reason = "the face's triangulation has no (u, v) nodes";
    return false;
  }
  const gp_Trsf trsf = loc.Transformation();
  constexpr uint32_t kUnset = NodeIndex::kUnset;
  std::vector<uint32_t> id(static_cast<size_t>(tri->NbNodes()) + 1, kUnset);
  // BRepMesh evaluates each face's nodes itself: on faces sewn from an IGES file the two sides' points
  // of one edge differ in their last bits (FreeCAD's IGES exports: "cracks 132" on a closed mesh), so
  // nodes are merged by topology before position. A node at a B-rep vertex (an edge's end, every node
  // of a degenerated edge) is that vertex's mesh vertex, whichever face met it first; a node inside an
  // edge that a face before this one (or this face's other side of a seam) sampled at the same
  // parameter is that sample's vertex; each within the vertex's or edge's tolerance.
  for (TopExp_Explorer it(g.face, TopAbs_EDGE); it.More(); it.Next()) {
    const TopoDS_Edge edge = TopoDS::Edge(it.Current());
    const int e = b.x.edges.FindIndex(edge) - 1;
    if (e < 0) continue;
    const Handle(Poly_PolygonOnTriangulation) poly = BRep_Tool::PolygonOnTriangulation(edge, tri, loc);
    if (poly.IsNull() || !poly->HasParameters()) continue;
    TopoDS_Vertex first_vertex, last_vertex;
    TopExp::Vertices(edge, first_vertex, last_vertex);
    double first = 0.0, last = 0.0;
    BRep_Tool::Range(edge, first, last);
    const bool degenerated = BRep_Tool::Degenerated(edge);
    const EdgeSamples& before = b.edges[e];
    for (int k = 1; k <= poly->NbNodes(); ++k) {
      const int n = poly->Node(k);
      if (id[n] != kUnset) continue;
      const double t = poly->Parameter(k);
      const Vec3 p = to_vec(tri->Node(n).Transformed(trsf));
      const TopoDS_Vertex& corner = degenerated || t == first ? first_vertex
                                    : t == last               ? last_vertex
                                                              : TopoDS_Vertex();
      const int c = corner.IsNull() ? -1 : b.x.vertices.FindIndex(corner) - 1;
      if (c >= 0) {
        const uint32_t v = nodes.at_corner(c);
        if (v == kUnset) {
          id[n] = nodes.vertex(p);
          nodes.set_corner(c, id[n]);
        } else if (glm::length(b.out.mesh.positions[v] - p) <=
                   std::max(BRep_Tool::Tolerance(corner), BRep_Tool::Tolerance(edge))) {
          id[n] = v, nodes.alias(p, v);
        }
        continue;
      }
      const auto at = std::lower_bound(before.t.begin(), before.t.end(), t);
      if (at == before.t.end() || *at != t) continue;
      const uint32_t v = before.vertex[static_cast<size_t>(at - before.t.begin())];
      if (glm::length(b.out.mesh.positions[v] - p) <= BRep_Tool::Tolerance(edge)) id[n] = v, nodes.alias(p, v);
    }
  }
  for (int n = 1; n <= tri->NbNodes(); ++n) {
    if (id[n] == kUnset) id[n] = nodes.vertex(to_vec(tri->Node(n).Transformed(trsf)));
  }
  for (TopExp_Explorer it(g.face, TopAbs_EDGE); it.More(); it.Next()) {
    const TopoDS_Edge edge = TopoDS::Edge(it.Current());
    const int e = b.x.edges.FindIndex(edge) - 1;
    if (e < 0) continue;
    const Handle(Poly_PolygonOnTriangulation) poly = BRep_Tool::PolygonOnTriangulation(edge, tri, loc);
    if (poly.IsNull() || !poly->HasParameters() || poly->NbNodes() < 2) {
      pf.reason = "edge " + std::to_string(e + 1) + " has no polygon with parameters on the face's triangulation";
      return false;
    }
    EdgeSamples s;
    s.degenerated = BRep_Tool::Degenerated(edge);
    s.free = faces_of_edge(b.x, edge).size() == 1 && !BRep_Tool::IsClosed(edge, g.face);
    std::vector<std::pair<double, uint32_t>> samples;
    for (int k = 1; k <= poly->NbNodes(); ++k) samples.push_back({poly->Parameter(k), id[poly->Node(k)]});
    std::sort(samples.begin(), samples.end());
    for (const auto& [t, v] : samples) s.t.push_back(t), s.vertex.push_back(v);
    set_end_tolerance(b, edge, s, part_size);
    if (s.free) {
      for (size_t k = 0; k + 1 < s.vertex.size(); ++k) b.out.boundary_edges.push_back({s.vertex[k], s.vertex[k + 1]});
    }
    if (s.degenerated &&
        std::all_of(s.vertex.begin(), s.vertex.end(), [&](uint32_t v) { return v == s.vertex.front(); }))
      poles.push_back(edge);
    b.edges[e] = std::move(s);
  }
  for (int n = 1; n <= tri->NbNodes(); ++n) {
    if (b.vertex_tolerance[id[n]] == 0.0) b.vertex_tolerance[id[n]] = 1e-9 * part_size;
  }
  std::vector<std::array<uint32_t, 3>> tris;
  std::vector<std::array<Vec2, 3>> raw;
  const bool reversed = g.face.Orientation() == TopAbs_REVERSED;
  for (int t = 1; t <= tri->NbTriangles(); ++t) {
    int n[3];
    tri->Triangle(t).Get(n[0], n[1], n[2]);
    if (reversed) std::swap(n[1], n[2]);
    std::array<Vec2, 3> q;
    for (int c = 0; c < 3; ++c) q[c] = Vec2(tri->UVNode(n[c]).X(), tri->UVNode(n[c]).Y());
    tris.push_back({id[n[0]], id[n[1]], id[n[2]]});
    raw.push_back(q);
  }
  if (!poles.empty()) {
    // The tiling is kept only when every triangle at a pole keeps the face's orientation in (u, v)
    // with an area (the majority's of the triangles off the poles); otherwise (a fan corner on the
    // pole's meridian, a fold) the mesher's own (u, v) stay.
    std::vector<std::array<uint32_t, 3>> tiled = tris;
    std::vector<std::array<Vec2, 3>> tiled_raw = raw;
    std::vector<std::pair<size_t, EdgeSamples>> saved;
    std::set<uint32_t> pole_vertices;
    for (const TopoDS_Edge& edge : poles) {
      const size_t e = static_cast<size_t>(b.x.edges.FindIndex(edge) - 1);
      saved.emplace_back(e, b.edges[e]);
      pole_vertices.insert(b.edges[e].vertex.front());
      tile_pole(g, edge, b.vertex_tolerance[b.edges[e].vertex.front()], b.edges[e], tiled, tiled_raw);
    }
    const auto sign = [](const std::array<Vec2, 3>& q) {
      const double area = (q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y);
      return area > 0.0 ? 1 : area < 0.0 ? -1 : 0;
    };
    const auto at_pole = [&](const std::array<uint32_t, 3>& t) {
      return pole_vertices.count(t[0]) || pole_vertices.count(t[1]) || pole_vertices.count(t[2]);
    };
    int majority = 0;
    for (size_t t = 0; t < tris.size(); ++t) majority += at_pole(tris[t]) ? 0 : sign(raw[t]);
    bool consistent = majority != 0;
    for (size_t t = 0; t < tiled.size() && consistent; ++t)
      consistent = !at_pole(tiled[t]) || sign(tiled_raw[t]) == (majority > 0 ? 1 : -1);
    if (consistent) {
      tris = std::move(tiled), raw = std::move(tiled_raw);
    } else {
      for (auto& [e, samples] : saved) b.edges[e] = std::move(samples);
    }
  }
  return take_face(b, g, pf, tris, raw, false);
}

// The shape's faces taken from a foreign mesh one by one: `take` fills a face's triangles (false and
// pf.reason when it cannot). Faces with no Bézier form are listed as skipped with their reason.
PartMesh foreign_part(const TopoDS_Shape& shape, const std::string& name, bool occt_solid_facts,
                      const std::function<void(PartBuilder&, double)>& prepare,
                      const std::function<bool(PartBuilder&, const FaceGeometry&, PartFace&, double)>& take) {
  PartMesh out;
  out.name = name;
  out.model.name = name;
  const ShapeIndex x = index_shape(shape);
  std::vector<FaceGeometry> geometry = faces_geometry(x, name, CadOptions{});
  out.solids = solid_facts(x, occt_solid_facts);
  const PartOptions options;
  const std::vector<std::vector<double>> extra(x.edges.Extent());
  const std::vector<EdgePlan> plans;
  PartBuilder b{options, x, geometry, out, {}, {}, {}, extra, {}, plans};
  b.edges.resize(x.edges.Extent());
  Bnd_Box box;
  BRepBndLib::Add(shape, box);
  const double part_size = box.IsVoid() ? 1.0 : std::sqrt(box.SquareExtent());
  prepare(b, part_size);
  for (FaceGeometry& g : geometry) {
    budget::check("reading the mesh's faces");
    add_face(b, g, [&](PartFace& pf) { return take(b, g, pf, part_size); });
  }
  out.edges = x.edges.Extent();
  std::sort(out.boundary_edges.begin(), out.boundary_edges.end());
  out.boundary_edges.erase(std::unique(out.boundary_edges.begin(), out.boundary_edges.end()), out.boundary_edges.end());
  return out;
}

PartMesh brepmesh_shape(const TopoDS_Shape& shape, const std::string& name, const BRepMeshOptions& o) {
  if (!(o.deflection > 0.0) || !std::isfinite(o.deflection)) throw InputError("--deflection must be a positive number");
  if (!(o.angle > 0.0) || !std::isfinite(o.angle)) throw InputError("--angle must be a positive number (radians)");
  BRepTools::Clean(shape);  // a BREP file may carry a triangulation of its own
  const auto start = std::chrono::steady_clock::now();
  try {
    BRepMesh_IncrementalMesh mesher(shape, o.deflection, o.relative, o.angle, o.parallel ? Standard_True : Standard_False);
  } catch (const Standard_Failure& e) {
    throw InputError(name + ": BRepMesh failed (" + std::string(e.GetMessageString()) + ")");
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::unique_ptr<NodeIndex> nodes;
  PartMesh out = foreign_part(
      shape, name, o.solid_facts, [&](PartBuilder& b, double) { nodes = std::make_unique<NodeIndex>(b); },
      [&](PartBuilder& b, const FaceGeometry& g, PartFace& pf, double size) { return brepmesh_face(b, *nodes, g, pf, size); });
  out.seconds = seconds;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Any mesh of the part (an STL, OBJ or PLY with no (u, v) and no face ids): each vertex is found on
// the B-rep's edges (within tolerance of the 3D curve: its edge parameter) and faces (projected on the
// surface, classified inside the face: its (u, v)); a triangle belongs to the face all three corners
// lie on. Then each face goes through take_face like BRepMesh's.

// How close a mesh vertex must be to a curve or surface to lie on it: 1e-6 of the part's size (a
// float STL's rounding is about 1e-7 of its coordinates), or twice the B-rep entity's tolerance.
double on_tolerance(double part_size, double entity_tolerance) { return std::max(1e-6 * part_size, 2.0 * entity_tolerance); }

struct VertexOnFace {
  int face;
  Vec2 uv;  // the face's own (u, v)
};

struct MeshOnShape {
  std::vector<Vec3> position;                        // per mesh vertex (merged)
  std::vector<uint32_t> by_x;                        // vertices sorted by x
  std::vector<std::vector<VertexOnFace>> on_faces;   // per vertex
  std::vector<std::vector<std::array<uint32_t, 3>>> face_triangles;  // per face
  uint64_t unassigned = 0;  // triangles whose corners share no face
  // How far the positions may lie from the mesher's points by rounding to float (an STL): 0 when a
  // coordinate is not a float. Added to every tolerance for finding vertices on edges and faces.
  double rounding = 0.0;

  // Vertices inside the box [lo, hi].
  template <typename F>
  void in_box(const Vec3& lo, const Vec3& hi, F&& f) const {
    auto it = std::lower_bound(by_x.begin(), by_x.end(), lo.x, [&](uint32_t v, double x) { return position[v].x < x; });
    for (; it != by_x.end() && position[*it].x <= hi.x; ++it) {
      const Vec3& p = position[*it];
      if (p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z) f(*it);
    }
  }
};

std::pair<Vec3, Vec3> box_corners(const Bnd_Box& box) {
  double x0, y0, z0, x1, y1, z1;
  box.Get(x0, y0, z0, x1, y1, z1);
  return {Vec3(x0, y0, z0), Vec3(x1, y1, z1)};
}

// The edges' samples (b.edges) from the mesh vertices that lie on them.
void edges_from_vertices(PartBuilder& b, const MeshOnShape& m, double part_size) {
  for (int e = 0; e < b.x.edges.Extent(); ++e) {
    budget::check("finding the mesh's vertices on the part's edges");
    const TopoDS_Edge edge = TopoDS::Edge(b.x.edges(e + 1).Oriented(TopAbs_FORWARD));
    EdgeSamples& s = b.edges[e];
    s.degenerated = BRep_Tool::Degenerated(edge);
    const std::vector<int> faces = faces_of_edge(b.x, edge);
    s.free = faces.size() == 1 && !BRep_Tool::IsClosed(edge, TopoDS::Face(b.x.faces(faces.front() + 1)));
    if (s.degenerated) {
      // A pole: its one mesh vertex, at both ends (take_mesh_face adds the parameters its fan needs).
      TopoDS_Vertex v0, v1;
      TopExp::Vertices(edge, v0, v1);
      if (v0.IsNull()) continue;
      const gp_Pnt pole = BRep_Tool::Pnt(v0);
      const double tol = on_tolerance(part_size, BRep_Tool::Tolerance(v0)) + m.rounding;
      double first = 0.0, last = 0.0, nearest = tol;
      BRep_Tool::Range(edge, first, last);
      m.in_box(Vec3(pole.X(), pole.Y(), pole.Z()) - Vec3(tol), Vec3(pole.X(), pole.Y(), pole.Z()) + Vec3(tol), [&](uint32_t v) {
        const double d = pole.Distance(gp_Pnt(m.position[v].x, m.position[v].y, m.position[v].z));
        if (d <= nearest) nearest = d, s.t = {first, last}, s.vertex = {v, v};
      });
      continue;
    }
    double first = 0.0, last = 0.0;
    const Handle(Geom_Curve) curve = BRep_Tool::Curve(edge, first, last);  // location applied
    if (curve.IsNull()) continue;
    const double tol = on_tolerance(part_size, BRep_Tool::Tolerance(edge)) + m.rounding;
    Bnd_Box box;
    BRepBndLib::Add(edge, box);
    box.Enlarge(tol);
    const auto [lo, hi] = box_corners(box);
    std::vector<std::pair<double, uint32_t>> samples;
    const gp_Pnt p_first = curve->Value(first), p_last = curve->Value(last);
    GeomAPI_ProjectPointOnCurve projector;
    // An end vertex (both ends of a closed edge) takes the end parameters exactly: the vertex nearest
    // to each end, within tol. Others that near an end are samples like any (bug24595's MeshPart STL:
    // an edge of tolerance 0.028 had two more vertices within 2x that of its end, taken as the end
    // and dropped, so they lay on no face).
    uint32_t at_first = std::numeric_limits<uint32_t>::max(), at_last = at_first;
    double to_first = tol, to_last = tol;
    m.in_box(lo, hi, [&](uint32_t v) {
      const gp_Pnt p(m.position[v].x, m.position[v].y, m.position[v].z);
      if (p.Distance(p_first) <= to_first) to_first = p.Distance(p_first), at_first = v;
      if (p.Distance(p_last) <= to_last) to_last = p.Distance(p_last), at_last = v;
    });
    m.in_box(lo, hi, [&](uint32_t v) {
      const gp_Pnt p(m.position[v].x, m.position[v].y, m.position[v].z);
      if (v == at_first) samples.push_back({first, v});
      if (v == at_last) samples.push_back({last, v});
      if (v == at_first || v == at_last) return;
      projector.Init(p, curve, first, last);
      if (projector.NbPoints() > 0 && projector.LowerDistance() <= tol)
        samples.push_back({projector.LowerDistanceParameter(), v});
    });
    std::sort(samples.begin(), samples.end());
    for (const auto& [t, v] : samples) {
      if (!s.t.empty() && t == s.t.back()) continue;
      s.t.push_back(t), s.vertex.push_back(v);
    }
    if (s.t.size() >= 2) set_end_tolerance(b, edge, s, part_size);
    if (s.free) {
      for (size_t k = 0; k + 1 < s.vertex.size(); ++k) b.out.boundary_edges.push_back({s.vertex[k], s.vertex[k + 1]});
    }
  }
}

// The vertices on face f and their (u, v) (m.on_faces): on an edge of the face, the p-curve at its
// edge parameter; else the projection on the face's surface, when within tolerance and inside the
// face. With `orphans`, only those vertices, projected by ShapeAnalysis_Surface instead of
// GeomAPI_ProjectPointOnSurf.
void vertices_on_face(PartBuilder& b, MeshOnShape& m, double part_size, int f, const std::vector<char>* orphans) {
  const FaceGeometry& g = b.geometry[static_cast<size_t>(f)];
  if (g.patches.empty()) return;
  const TopoDS_Face& face = g.face;
  std::unordered_map<uint32_t, Vec2> on_edges;
  for (TopExp_Explorer it(face, TopAbs_EDGE); it.More(); it.Next()) {
    const TopoDS_Edge edge = TopoDS::Edge(it.Current());
    const int e = b.x.edges.FindIndex(edge) - 1;
    if (e < 0 || b.edges[static_cast<size_t>(e)].t.size() < 2) continue;
    const EdgeSamples& s = b.edges[static_cast<size_t>(e)];
    RangeCurve rc;
    rc.pc = BRep_Tool::CurveOnSurface(edge, face, rc.f, rc.l);
    if (rc.pc.IsNull()) continue;
    rc.same = BRep_Tool::SameParameter(edge) && BRep_Tool::SameRange(edge);
    BRep_Tool::Range(edge, rc.first, rc.last);
    for (size_t k = 0; k < s.t.size(); ++k) {
      const gp_Pnt2d q = rc.pc->Value(rc.param(s.t[k]));
      on_edges.emplace(s.vertex[k], Vec2(q.X(), q.Y()));
    }
  }
  double u0, u1, v0, v1;
  BRepTools::UVBounds(face, u0, u1, v0, v1);
  const double tol = on_tolerance(part_size, BRep_Tool::Tolerance(face)) + m.rounding;
  Vec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const BezierPatch& p : g.patches) {
    const Box box = control_box(p);
    lo = glm::min(lo, box.lo), hi = glm::max(hi, box.hi);
  }
  lo -= Vec3(tol), hi += Vec3(tol);
  const Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
  GeomAPI_ProjectPointOnSurf projector;
  Handle(ShapeAnalysis_Surface) analysis;
  BRepTopAdaptor_FClass2d classifier(face, 1e-9 * std::max(u1 - u0, v1 - v0));
  const auto into_range = [](double x, double lo_, double period) {
    return period > 0.0 ? lo_ + std::fmod(std::fmod(x - lo_, period) + period, period) : x;
  };
  m.in_box(lo, hi, [&](uint32_t v) {
    if (orphans && !(*orphans)[v]) return;
    const auto edge_uv = on_edges.find(v);
    if (edge_uv != on_edges.end()) return m.on_faces[v].push_back({f, edge_uv->second});
    const gp_Pnt p(m.position[v].x, m.position[v].y, m.position[v].z);
    double u = 0.0, w = 0.0;
    if (orphans) {
      if (analysis.IsNull()) {
        analysis = new ShapeAnalysis_Surface(surface);
        analysis->SetDomain(u0, u1, v0, v1);
      }
      const gp_Pnt2d q = analysis->ValueOfUV(p, tol);
      if (!(analysis->Gap() <= tol)) return;
      u = q.X(), w = q.Y();
    } else {
      projector.Init(p, surface, u0, u1, v0, v1);
      if (projector.NbPoints() == 0 || !(projector.LowerDistance() <= tol)) return;
      projector.LowerDistanceParameters(u, w);
    }
    u = into_range(u, u0 - 1e-9 * g.u_period, g.u_period), w = into_range(w, v0 - 1e-9 * g.v_period, g.v_period);
    if (classifier.Perform(gp_Pnt2d(u, w)) == TopAbs_IN) m.on_faces[v].push_back({f, Vec2(u, w)});
  });
}

// Each vertex's faces and (u, v) (vertices_on_face). OCCT's extrema can miss the nearest point of a
// B-spline surface (bottle.brep's Face 4: a mesh vertex 4.5e-7 off it, well inside the face, whose
// nearest point found was 0.0147 away), so a vertex left on no face is projected again by
// ShapeAnalysis_Surface, which starts from its own sampling of the surface.
void faces_from_vertices(PartBuilder& b, MeshOnShape& m, double part_size) {
  m.on_faces.assign(m.position.size(), {});
  for (int f = 0; f < b.x.faces.Extent(); ++f) {
    budget::check("finding the mesh's vertices on the part's faces");
    vertices_on_face(b, m, part_size, f, nullptr);
  }
  std::vector<char> orphans(m.position.size(), 0);
  bool any = false;
  for (size_t v = 0; v < orphans.size(); ++v) any = (orphans[v] = m.on_faces[v].empty() ? 1 : 0) || any;
  if (!any) return;
  for (int f = 0; f < b.x.faces.Extent(); ++f) {
    budget::check("finding the mesh's vertices on the part's faces");
    vertices_on_face(b, m, part_size, f, &orphans);
  }
}

// The faces' triangles: the face shared by all three corners. When several are: first a face whose
// domain holds the projection of the triangle's centroid, then one whose outward normal there agrees
// with the triangle's winding, then the nearest surface. Coincident faces of two solids (tr10's pins
// in their holes: the same cylinder, normals opposite) are equally near and both hold every corner;
// the first took both meshes, which then overlapped in (U, V).
void triangles_to_faces(const PartBuilder& b, MeshOnShape& m, const std::vector<Triangle>& triangles) {
  m.face_triangles.assign(static_cast<size_t>(b.x.faces.Extent()), {});
  GeomAPI_ProjectPointOnSurf projector;
  std::map<int, std::unique_ptr<BRepTopAdaptor_FClass2d>> classifiers;
  // Whether the surface point at (u, v) lies inside face f (whole periods tried in periodic directions).
  const auto inside = [&](int f, double u, double v) {
    const FaceGeometry& g = b.geometry[static_cast<size_t>(f)];
    auto& classifier = classifiers[f];
    if (!classifier) {
      double u0, u1, v0, v1;
      BRepTools::UVBounds(g.face, u0, u1, v0, v1);
      classifier = std::make_unique<BRepTopAdaptor_FClass2d>(g.face, 1e-9 * std::max(u1 - u0, v1 - v0));
    }
    for (const int i : {0, -1, 1}) {
      for (const int j : {0, -1, 1}) {
        if ((i != 0 && !(g.u_period > 0.0)) || (j != 0 && !(g.v_period > 0.0))) continue;
        if (classifier->Perform(gp_Pnt2d(u + i * g.u_period, v + j * g.v_period)) == TopAbs_IN) return true;
      }
    }
    return false;
  };
  for (const Triangle& t : triangles) {
    std::vector<int> common;
    for (const VertexOnFace& a : m.on_faces[t[0]]) {
      const auto has = [&](uint32_t v) {
        return std::any_of(m.on_faces[v].begin(), m.on_faces[v].end(), [&](const VertexOnFace& o) { return o.face == a.face; });
      };
      if (has(t[1]) && has(t[2]) && std::find(common.begin(), common.end(), a.face) == common.end()) common.push_back(a.face);
    }
    if (common.empty()) {
      ++m.unassigned;
      continue;
    }
    int best = common.front();
    if (common.size() > 1) {
      const Vec3 c = (m.position[t[0]] + m.position[t[1]] + m.position[t[2]]) / 3.0;
      const Vec3 winding = glm::cross(m.position[t[1]] - m.position[t[0]], m.position[t[2]] - m.position[t[0]]);
      // (outside the domain, normal against the winding, distance): the smallest wins.
      std::tuple<bool, bool, double> nearest{true, true, std::numeric_limits<double>::infinity()};
      for (const int f : common) {
        const TopoDS_Face& face = b.geometry[static_cast<size_t>(f)].face;
        const Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
        projector.Init(gp_Pnt(c.x, c.y, c.z), surface);
        if (projector.NbPoints() == 0) continue;
        double u = 0.0, v = 0.0;
        projector.LowerDistanceParameters(u, v);
        gp_Pnt p;
        gp_Vec du, dv;
        surface->D1(u, v, p, du, dv);
        const gp_Vec n = du.Crossed(dv) * (face.Orientation() == TopAbs_REVERSED ? -1.0 : 1.0);
        const bool against = !(n.X() * winding.x + n.Y() * winding.y + n.Z() * winding.z > 0.0);
        const std::tuple<bool, bool, double> key{!inside(f, u, v), against, projector.LowerDistance()};
        if (key < nearest) nearest = key, best = f;
      }
    }
    m.face_triangles[static_cast<size_t>(best)].push_back(t);
  }
}

bool take_mesh_face(PartBuilder& b, const MeshOnShape& m, const FaceGeometry& g, PartFace& pf, double part_size) {
  const std::vector<std::array<uint32_t, 3>>& tris = m.face_triangles[static_cast<size_t>(g.report.face_index)];
  if (tris.empty()) {
    pf.reason = "no triangle of the mesh lies on the face";
    return false;
  }
  std::vector<std::array<uint32_t, 3>> triangles = tris;
  std::vector<std::array<Vec2, 3>> raw(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      for (const VertexOnFace& o : m.on_faces[tris[t][c]]) {
        if (o.face == g.report.face_index) raw[t][c] = o.uv;
      }
    }
  }
  for (TopExp_Explorer it(g.face, TopAbs_EDGE); it.More(); it.Next()) {
    const TopoDS_Edge edge = TopoDS::Edge(it.Current());
    const int e = b.x.edges.FindIndex(edge) - 1;
    EdgeSamples& s = b.edges[static_cast<size_t>(e)];
    if (BRep_Tool::Degenerated(edge) && s.vertex.size() == 2) {
      tile_pole(g, edge, b.vertex_tolerance[s.vertex.front()], s, triangles, raw);
      continue;
    }
    double first = 0.0, last = 0.0;
    BRep_Tool::Range(edge, first, last);
    if (s.t.size() < 2 || s.t.front() != first || s.t.back() != last) {
      pf.reason = "edge " + std::to_string(e + 1) + " has no mesh vertex at one of its ends (within " +
                  std::to_string(on_tolerance(part_size, BRep_Tool::Tolerance(edge)) + m.rounding) + " of the edge)";
      return false;
    }
  }
  // An edge's samples are the mesh vertices on it, whichever triangles use them: on an edge that
  // another solid's face touches (tr10's pins in their holes) the pin's vertices lie on the hole's
  // edge too, and the hole face's triangles, which do not use them, no longer matched its loops.
  // The face's loops take the samples its triangles use (and the edge's ends); the others are
  // restored for the next face.
  std::unordered_set<uint32_t> used;
  for (const auto& tri : triangles) used.insert(tri.begin(), tri.end());
  std::vector<std::pair<size_t, EdgeSamples>> saved;
  for (TopExp_Explorer it(g.face, TopAbs_EDGE); it.More(); it.Next()) {
    const int e = b.x.edges.FindIndex(it.Current()) - 1;
    if (e < 0 || BRep_Tool::Degenerated(TopoDS::Edge(it.Current()))) continue;
    EdgeSamples& s = b.edges[static_cast<size_t>(e)];
    EdgeSamples kept = s;
    kept.t.clear(), kept.vertex.clear();
    for (size_t k = 0; k < s.t.size(); ++k) {
      if (k == 0 || k + 1 == s.t.size() || used.count(s.vertex[k]))
        kept.t.push_back(s.t[k]), kept.vertex.push_back(s.vertex[k]);
    }
    if (kept.t.size() == s.t.size()) continue;
    saved.emplace_back(static_cast<size_t>(e), s);
    s = std::move(kept);
  }
  const bool taken = take_face(b, g, pf, triangles, raw, true);
  for (auto& [e, samples] : saved) b.edges[e] = std::move(samples);
  return taken;
}

PartMesh mesh_on_shape(const TopoDS_Shape& shape, const std::string& name, const Tessellation& mesh) {
  if (mesh.triangles.empty()) throw InputError(name + ": the mesh has no triangles");
  MeshOnShape m;
  std::vector<Triangle> triangles;
  uint64_t dropped = 0;
  double welded = 0.0;
  PartMesh out = foreign_part(
      shape, name, true,
      [&](PartBuilder& b, double part_size) {
        // Vertices closer than 1e-9 of the part are welded (one mesher's faces may compute a shared
        // vertex twice, 8e-11 apart in FreeCAD's mesh of pr1ct.stp): clusters of vertices within that
        // distance of each other become their first vertex; the largest move is added to every bound (PartMesh::welded).
        const double weld = 1e-9 * part_size;
        std::vector<uint32_t> rep(mesh.positions.size());
        for (uint32_t v = 0; v < rep.size(); ++v) rep[v] = v;
        const auto find = [&](uint32_t v) {
          while (rep[v] != v) v = rep[v] = rep[rep[v]];
          return v;
        };
        // Cells of the weld distance: two vertices within it lie in neighbouring cells (a sort along
        // one axis would scan a whole plane of equal x).
        const auto cell = [&](const Vec3& p) {
          return std::array<int64_t, 3>{static_cast<int64_t>(std::floor(p.x / weld)), static_cast<int64_t>(std::floor(p.y / weld)),
                                        static_cast<int64_t>(std::floor(p.z / weld))};
        };
        std::map<std::array<int64_t, 3>, std::vector<uint32_t>> cells;
        for (uint32_t v = 0; v < rep.size(); ++v) {
          const std::array<int64_t, 3> c = cell(mesh.positions[v]);
          for (int64_t dx = -1; dx <= 1; ++dx)
            for (int64_t dy = -1; dy <= 1; ++dy)
              for (int64_t dz = -1; dz <= 1; ++dz) {
                const auto near = cells.find({c[0] + dx, c[1] + dy, c[2] + dz});
                if (near == cells.end()) continue;
                for (const uint32_t u : near->second) {
                  if (glm::length(mesh.positions[v] - mesh.positions[u]) > weld) continue;
                  const uint32_t a = find(v), r = find(u);
                  if (a != r) rep[std::max(a, r)] = std::min(a, r);
                }
              }
          cells[c].push_back(v);
        }
        for (uint32_t v = 0; v < rep.size(); ++v) rep[v] = find(v);
        NodeIndex nodes(b);
        std::vector<uint32_t> id(mesh.positions.size());
        for (size_t v = 0; v < mesh.positions.size(); ++v) {
          welded = std::max(welded, glm::length(mesh.positions[v] - mesh.positions[rep[v]]));
          id[v] = nodes.vertex(mesh.positions[rep[v]]);
        }
        for (const Triangle& t : mesh.triangles) {
          const Triangle u = {id[t[0]], id[t[1]], id[t[2]]};
          if (u[0] == u[1] || u[1] == u[2] || u[2] == u[0]) {
            ++dropped;
            continue;
          }
          triangles.push_back(u);
        }
        for (uint32_t v = 0; v < b.out.mesh.positions.size(); ++v) b.vertex_tolerance[v] = 1e-9 * part_size;
        m.position = b.out.mesh.positions;
        // Float coordinates (an STL): each is within half the gap to the next float above it of the
        // mesher's (0.03 at 1e6: far_filleted's vertices were off their faces by more than the faces'
        // tolerance). Rounded to nearest, a float f came from within half the larger of its two gaps,
        // which is the gap above |f|.
        bool floats = true;
        double largest = 0.0;
        for (const Vec3& p : m.position) {
          double squared = 0.0;
          for (int k = 0; k < 3; ++k) {
            const float f = std::abs(static_cast<float>(p[k]));
            floats = floats && static_cast<double>(static_cast<float>(p[k])) == p[k];
            const double half_gap =
                0.5 * (static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity())) - f);
            squared += half_gap * half_gap;
          }
          largest = std::max(largest, std::sqrt(squared));
        }
        // Only where vertices are looked for: the certificate measures each vertex's own distance.
        m.rounding = floats && std::isfinite(largest) ? largest * (1.0 + 1e-6) : 0.0;
        m.by_x.resize(m.position.size());
        for (uint32_t v = 0; v < m.by_x.size(); ++v) m.by_x[v] = v;
        std::sort(m.by_x.begin(), m.by_x.end(), [&](uint32_t a, uint32_t c) { return m.position[a].x < m.position[c].x; });
        edges_from_vertices(b, m, part_size);
        faces_from_vertices(b, m, part_size);
        triangles_to_faces(b, m, triangles);
      },
      [&](PartBuilder& b, const FaceGeometry& g, PartFace& pf, double part_size) { return take_mesh_face(b, m, g, pf, part_size); });
  out.mesh.degenerate_triangles += dropped;
  out.unassigned_triangles = m.unassigned;
  out.welded = welded;
  return out;
}

}  // namespace

PartMesh mesh_part_shape(const TopoDS_Shape& shape, const std::string& name, const PartOptions& options) {
  return mesh_shape(shape, name, options);
}

PartMesh mesh_part_file(const std::string& path, const PartOptions& options) {
  check_scheme(options, path);
  return mesh_shape(read_cad_shape(path), path, options);
}

PartMesh mesh_part_brep_string(const std::string& brep_text, const std::string& name, const PartOptions& options) {
  check_scheme(options, name);
  return mesh_shape(read_brep_shape(brep_text, name), name, options);
}

std::string sew_free_faces_brep_string(const std::string& brep_text, const std::string& name) {
  const TopoDS_Shape shape = read_brep_shape(brep_text, name);
  TopTools_IndexedDataMapOfShapeListOfShape edge_faces;
  TopExp::MapShapesAndAncestors(shape, TopAbs_EDGE, TopAbs_FACE, edge_faces);
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  if (faces.Extent() < 2) return brep_text;
  for (int e = 1; e <= edge_faces.Extent(); ++e) {
    // A seam lists its one face twice: only another face makes the edge shared.
    for (const TopoDS_Shape& f : edge_faces(e)) {
      if (!f.IsSame(edge_faces(e).First())) return brep_text;
    }
  }
  const TopoDS_Shape sewn = sew_free_faces(shape);  // unchanged where the shape has a shell
  if (sewn.IsSame(shape)) return brep_text;
  std::ostringstream out;
  BRepTools::Write(sewn, out);
  return out.str();
}

PartMesh brepmesh_part_file(const std::string& path, const BRepMeshOptions& options) {
  return brepmesh_shape(read_cad_shape(path), path, options);
}

PartMesh brepmesh_part_brep_string(const std::string& brep_text, const std::string& name, const BRepMeshOptions& options) {
  return brepmesh_shape(read_brep_shape(brep_text, name), name, options);
}

PartMesh mesh_on_part_file(const std::string& path, const Tessellation& mesh, const std::string& mesh_name) {
  return mesh_on_shape(read_cad_shape(path), path + " with " + mesh_name, mesh);
}

PartMesh mesh_on_part_brep_string(const std::string& brep_text, const std::string& name, const Tessellation& mesh) {
  return mesh_on_shape(read_brep_shape(brep_text, name), name, mesh);
}

}  // namespace sagitta::occt
