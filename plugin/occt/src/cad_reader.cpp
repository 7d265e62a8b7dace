// Reading STEP / IGES / BREP with OCCT and turning faces into Bézier patches (see docs/CAD.md).
#include "sagitta/occt/cad.hpp"

#include "occt_shape.hpp"

#include "sagitta/io/model_io.hpp"

#include <glm/geometric.hpp>

#include <BRepBndLib.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepClass3d_SolidClassifier.hxx>
#include <BRepTools.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <Geom2d_Curve.hxx>
#include <GeomConvert.hxx>
#include <GeomConvert_BSplineSurfaceToBezierSurface.hxx>
#include <Geom_BSplineSurface.hxx>
#include <Geom_BezierSurface.hxx>
#include <Geom_ConicalSurface.hxx>
#include <Geom_Curve.hxx>
#include <Geom_CylindricalSurface.hxx>
#include <Geom_OffsetSurface.hxx>
#include <Geom_Plane.hxx>
#include <Geom_RectangularTrimmedSurface.hxx>
#include <Geom_SphericalSurface.hxx>
#include <Geom_SurfaceOfLinearExtrusion.hxx>
#include <Geom_SurfaceOfRevolution.hxx>
#include <Geom_ToroidalSurface.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Precision.hxx>
#include <STEPControl_Reader.hxx>
#include <Standard_Failure.hxx>
#include <Standard_Version.hxx>
#include <TColGeom_Array2OfBezierSurface.hxx>
#include <TColStd_Array1OfReal.hxx>
#include <TColStd_Array2OfReal.hxx>
#include <TColgp_Array2OfPnt.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Solid.hxx>
#include <TopoDS_Vertex.hxx>
#include <TopoDS_Wire.hxx>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <unordered_map>

namespace sagitta::occt {

namespace {

// One Bézier patch from an OCCT Bézier surface: poles (i, j) with i the U index become row i.
BezierPatch to_patch(const Handle(Geom_BezierSurface)& b) {
  BezierPatch p;
  p.degree_u = b->UDegree();
  p.degree_v = b->VDegree();
  const bool rational = b->IsURational() || b->IsVRational();
  for (int i = 1; i <= b->NbUPoles(); ++i) {
    for (int j = 1; j <= b->NbVPoles(); ++j) {
      const gp_Pnt q = b->Pole(i, j);
      p.points.push_back({q.X(), q.Y(), q.Z()});
      if (rational) p.weights.push_back(b->Weight(i, j));
    }
  }
  return p;
}

const char* surface_type_name(const Handle(Geom_Surface)& s) {
  if (s->IsKind(STANDARD_TYPE(Geom_BSplineSurface))) return "BSplineSurface";
  if (s->IsKind(STANDARD_TYPE(Geom_BezierSurface))) return "BezierSurface";
  if (s->IsKind(STANDARD_TYPE(Geom_Plane))) return "Plane";
  if (s->IsKind(STANDARD_TYPE(Geom_CylindricalSurface))) return "Cylinder";
  if (s->IsKind(STANDARD_TYPE(Geom_ConicalSurface))) return "Cone";
  if (s->IsKind(STANDARD_TYPE(Geom_SphericalSurface))) return "Sphere";
  if (s->IsKind(STANDARD_TYPE(Geom_ToroidalSurface))) return "Torus";
  if (s->IsKind(STANDARD_TYPE(Geom_SurfaceOfRevolution))) return "SurfaceOfRevolution";
  if (s->IsKind(STANDARD_TYPE(Geom_SurfaceOfLinearExtrusion))) return "SurfaceOfExtrusion";
  if (s->IsKind(STANDARD_TYPE(Geom_OffsetSurface))) return "OffsetSurface";
  return s->DynamicType()->Name();
}

}  // namespace

Handle(Geom_Surface) untrimmed(Handle(Geom_Surface) surface) {
  while (!surface.IsNull() && surface->IsKind(STANDARD_TYPE(Geom_RectangularTrimmedSurface)))
    surface = Handle(Geom_RectangularTrimmedSurface)::DownCast(surface)->BasisSurface();
  return surface;
}

Handle(Geom_Surface) exact_surface(const TopoDS_Face& face) {
  const Handle(Geom_Surface) surface = BRep_Tool::Surface(face);  // location applied
  const Handle(Geom_Surface) basis = untrimmed(surface);
  if (basis.IsNull() || !basis->IsKind(STANDARD_TYPE(Geom_OffsetSurface))) return surface;
  const Handle(Geom_OffsetSurface) offset = Handle(Geom_OffsetSurface)::DownCast(basis);
  double u0 = 0.0, u1 = 0.0, v0 = 0.0, v1 = 0.0;
  BRepTools::UVBounds(face, u0, u1, v0, v1);
  Handle(Geom_Surface) equivalent;
  try {
    equivalent = offset->Surface();
  } catch (const Standard_Failure&) {
    return surface;
  }
  if (equivalent.IsNull() || !std::isfinite(u0) || !std::isfinite(u1) || !std::isfinite(v0) || !std::isfinite(v1))
    return surface;
  // OCCT builds the equivalent surface with the offset's parametrisation (a cylinder of radius r + d
  // on the same axis, angle and height); anything else would move the face's p-curves, so it is
  // checked on a 5 x 5 grid of the face's bounds to 1e-9 of the coordinates and the offset.
  try {
    for (int i = 0; i <= 4; ++i) {
      for (int j = 0; j <= 4; ++j) {
        const double u = u0 + (u1 - u0) * i / 4.0, v = v0 + (v1 - v0) * j / 4.0;
        const gp_Pnt a = offset->Value(u, v), b = equivalent->Value(u, v);
        const double scale = std::abs(a.X()) + std::abs(a.Y()) + std::abs(a.Z()) + std::abs(offset->Offset());
        if (!(a.Distance(b) <= 1e-9 * scale)) return surface;
      }
    }
  } catch (const Standard_Failure&) {
    return surface;
  }
  return equivalent;
}

namespace {

// True when the face's domain is the whole rectangle of its UV bounds: one wire whose p-curves all
// run along that rectangle's border (checked at 9 points per edge, relative tolerance 1e-9).
bool domain_is_rectangle(const TopoDS_Face& face, double u0, double u1, double v0, double v1) {
  int wires = 0;
  for (TopExp_Explorer w(face, TopAbs_WIRE); w.More(); w.Next()) ++wires;
  if (wires != 1) return false;
  const double tu = 1e-9 * std::max(1.0, u1 - u0), tv = 1e-9 * std::max(1.0, v1 - v0);
  for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next()) {
    const TopoDS_Edge& edge = TopoDS::Edge(e.Current());
    double first = 0.0, last = 0.0;
    const Handle(Geom2d_Curve) pc = BRep_Tool::CurveOnSurface(edge, face, first, last);
    if (pc.IsNull()) return false;
    for (int k = 0; k <= 8; ++k) {
      const gp_Pnt2d q = pc->Value(first + (last - first) * k / 8.0);
      const bool on_border = std::abs(q.X() - u0) <= tu || std::abs(q.X() - u1) <= tu || std::abs(q.Y() - v0) <= tv ||
                             std::abs(q.Y() - v1) <= tv;
      if (!on_border) return false;
    }
  }
  return true;
}

// The same polynomial (rational) patch over [lo, hi] of its u (axis 0) or v (axis 1) parameter, lo <= 0,
// hi >= 1: a face whose trimming curves run past the end of its B-spline surface's knot range lies on
// the surface's extrapolation there (OCCT evaluates the first / last span's polynomial beyond the
// range), so the end patches are extended to cover it. de Casteljau in homogeneous long double at hi
// (keep [0, hi]), then at lo / hi (keep [lo / hi, 1]): exact for any parameter. False when a weight
// of the extended patch is not positive.
bool extend_patch(BezierPatch& p, int axis, double lo, double hi) {
  const int n = axis == 0 ? p.degree_u : p.degree_v, lines = axis == 0 ? p.cols() : p.rows();
  const bool rational = p.rational();
  for (int line = 0; line < lines; ++line) {
    std::vector<std::array<long double, 4>> h(static_cast<size_t>(n) + 1);
    const auto index = [&](int k) { return axis == 0 ? k * p.cols() + line : line * p.cols() + k; };
    for (int k = 0; k <= n; ++k) {
      const long double w = rational ? p.weights[static_cast<size_t>(index(k))] : 1.0L;
      const Vec3& x = p.points[static_cast<size_t>(index(k))];
      h[static_cast<size_t>(k)] = {w * x.x, w * x.y, w * x.z, w};
    }
    const auto split = [&](long double t, bool keep_left) {
      std::vector<std::array<long double, 4>> work = h, left(h.size()), right(h.size());
      for (int level = 0; level <= n; ++level) {
        left[static_cast<size_t>(level)] = work[0];
        right[static_cast<size_t>(n - level)] = work[static_cast<size_t>(n - level)];
        for (int k = 0; k + 1 <= n - level; ++k) {
          for (int c = 0; c < 4; ++c) work[k][c] = (1.0L - t) * work[k][c] + t * work[k + 1][c];
        }
      }
      h = keep_left ? left : right;
    };
    if (hi != 1.0) split(hi, true);
    if (lo != 0.0) split(static_cast<long double>(lo) / hi, false);
    for (int k = 0; k <= n; ++k) {
      const auto& q = h[static_cast<size_t>(k)];
      if (!(q[3] > 0.0L) || (!rational && std::abs(q[3] - 1.0L) > 1e-12L)) return false;
      p.points[static_cast<size_t>(index(k))] = Vec3(static_cast<double>(q[0] / q[3]), static_cast<double>(q[1] / q[3]),
                                                     static_cast<double>(q[2] / q[3]));
      if (rational) p.weights[static_cast<size_t>(index(k))] = static_cast<double>(q[3]);
    }
  }
  return true;
}

// How far, in 3D, the face's boundary reaches past its surface's parameter bounds in a non-periodic
// direction: the largest distance between S(p) and S(p clamped to the bounds) over 33 points of each
// edge's p-curve (0 when every p-curve stays inside, +infinity when OCCT fails there). The patches
// stop at the bounds and the face's (U, V) are clamped onto them; past the B-rep's own tolerance the
// face lies partly on OCCT's extrapolation of the surface (an IGES round trip of a revolved periodic
// B-spline gave a profile over [0, 18.7] and a face down to -1.75, 4.2 away), which its patches miss.
double reach_past_bounds(const TopoDS_Face& face, const Handle(Geom_Surface) & basis) {
  double a, b, c, d;
  basis->Bounds(a, b, c, d);
  if (basis->IsUPeriodic()) a = -std::numeric_limits<double>::infinity(), b = std::numeric_limits<double>::infinity();
  if (basis->IsVPeriodic()) c = -std::numeric_limits<double>::infinity(), d = std::numeric_limits<double>::infinity();
  double worst = 0.0;
  try {
    for (TopExp_Explorer it(face, TopAbs_EDGE); it.More(); it.Next()) {
      double f = 0.0, l = 0.0;
      const Handle(Geom2d_Curve) pcurve = BRep_Tool::CurveOnSurface(TopoDS::Edge(it.Current()), face, f, l);
      if (pcurve.IsNull()) continue;
      for (int k = 0; k <= 32; ++k) {
        const gp_Pnt2d p = pcurve->Value(f + (l - f) * k / 32.0);
        const double u = std::clamp(p.X(), a, b), v = std::clamp(p.Y(), c, d);
        if (u == p.X() && v == p.Y()) continue;
        const double gap = basis->Value(p.X(), p.Y()).Distance(basis->Value(u, v));
        worst = std::max(worst, std::isfinite(gap) ? gap : std::numeric_limits<double>::infinity());
      }
    }
  } catch (const Standard_Failure&) {
    return std::numeric_limits<double>::infinity();
  }
  return worst;
}

// The largest tolerance of the face, its edges and its vertices.
double face_tolerance(const TopoDS_Face& face) {
  double t = BRep_Tool::Tolerance(face);
  for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next())
    t = std::max(t, BRep_Tool::Tolerance(TopoDS::Edge(e.Current())));
  for (TopExp_Explorer e(face, TopAbs_VERTEX); e.More(); e.Next())
    t = std::max(t, BRep_Tool::Tolerance(TopoDS::Vertex(e.Current())));
  return t;
}

// The face's surface over [u0, u1] x [v0, v1] as Bézier patches (exact), or a reason why not.
// u_breaks / v_breaks receive the patch grid's lines in the converted surface's parameters (these
// equal the face's (u, v) only where the conversion keeps the parametrisation: B-splines, Béziers,
// planes; peer.cpp checks this at the mesh nodes before using them).
// `converted` (when given) receives the B-spline surface the patches split (null for a whole Bézier surface,
// whose patch is the surface itself).
std::vector<BezierPatch> decompose(Handle(Geom_Surface) s, double u0, double u1, double v0, double v1, std::string& reason,
                                   std::vector<double>& u_breaks, std::vector<double>& v_breaks,
                                   Handle(Geom_BSplineSurface)* converted = nullptr) {
  s = untrimmed(s);
  if (!std::isfinite(u0) || !std::isfinite(u1) || !std::isfinite(v0) || !std::isfinite(v1) || !(u0 < u1) || !(v0 < v1)) {
    reason = "the face has no finite, non-empty parameter range";
    return {};
  }
  Handle(Geom_BSplineSurface) bs;
  bool analytic_surface = false;
  if (s->IsKind(STANDARD_TYPE(Geom_BezierSurface))) {
    const Handle(Geom_BezierSurface) b = Handle(Geom_BezierSurface)::DownCast(s);
    if (b->UDegree() > kMaxDegree || b->VDegree() > kMaxDegree) {
      reason = "degree above 25";
      return {};
    }
    if (u0 <= 0.0 + 1e-12 && u1 >= 1.0 - 1e-12 && v0 <= 1e-12 && v1 >= 1.0 - 1e-12) {
      u_breaks = {0.0, 1.0};
      v_breaks = {0.0, 1.0};
      return {to_patch(b)};
    }
    bs = GeomConvert::SurfaceToBSplineSurface(b);
  } else if (s->IsKind(STANDARD_TYPE(Geom_BSplineSurface))) {
    bs = Handle(Geom_BSplineSurface)::DownCast(s->Copy());
  } else if (s->IsKind(STANDARD_TYPE(Geom_OffsetSurface))) {
    reason = "offset surface: no exact rational form";
    return {};
  } else {
    analytic_surface = true;
    // Elementary surfaces, revolutions and extrusions of conics or splines: OCCT's conversion is exact
    // (rational B-spline, parametrised by tan(theta/2) for the circular directions). The face's UV
    // bounds may exceed a period or the surface's own bounds by a tolerance; clamp them first.
    double a, b, c, d;
    s->Bounds(a, b, c, d);
    // A start a rounding error below a period's start (-4e-13 on a full cylinder) makes OCCT's
    // conversion fail; it is snapped to the multiple of the period.
    const auto snap = [](double& x, double period) {
      const double k = std::round(x / period) * period;
      if (std::abs(x - k) <= 1e-9 * period) x = k;
    };
    if (s->IsUPeriodic()) snap(u0, s->UPeriod());
    if (s->IsVPeriodic()) snap(v0, s->VPeriod());
    if (s->IsUPeriodic()) u1 = std::min(u1, u0 + s->UPeriod());
    else u0 = std::max(u0, a), u1 = std::min(u1, b);
    if (s->IsVPeriodic()) v1 = std::min(v1, v0 + s->VPeriod());
    else v0 = std::max(v0, c), v1 = std::min(v1, d);
    bs = GeomConvert::SurfaceToBSplineSurface(new Geom_RectangularTrimmedSurface(s, u0, u1, v0, v1));
    if (!bs.IsNull()) bs->Bounds(u0, u1, v0, v1);
  }
  if (bs.IsNull()) {
    reason = "OCCT could not convert the surface to B-spline form";
    return {};
  }
  if (bs->UDegree() > kMaxDegree || bs->VDegree() > kMaxDegree) {
    reason = "degree above 25";
    return {};
  }
  const bool u_periodic = bs->IsUPeriodic(), v_periodic = bs->IsVPeriodic();
  // A face of a periodic B-spline may run across the surface's seam (v in [0.70, 1.08] of a surface
  // periodic over [0, 1]): the surface's origin moves to the last knot at or below the face's start
  // (SetUOrigin / SetVOrigin: the same surface, its period starting there), the face's range shifted
  // by whole periods into it, and the breaks shifted back afterwards, so that they are in the face's
  // own (u, v).
  double u_shift = 0.0, v_shift = 0.0;
  const auto reorigin = [&](bool u_dir, double& lo, double& hi) {
    double first, last, c0, c1;
    bs->Bounds(first, last, c0, c1);
    if (!u_dir) first = c0, last = c1;
    const double period = last - first, slack = 1e-9 * period;
    // Within rounding of the surface's own window (a face from 0 on a surface whose first knot is
    // 1.4e-15): kept there. Shifted by a period, such a face was cut at the last knot instead.
    if (lo >= first - slack && hi <= last + slack) {
      lo = std::max(lo, first), hi = std::min(hi, last);
      return 0.0;
    }
    if (hi - lo > period * (1.0 + 1e-9)) return 0.0;  // clamped below
    const double shift = std::floor((lo - first) / period) * period;
    lo -= shift, hi -= shift;
    const int k0 = u_dir ? bs->FirstUKnotIndex() : bs->FirstVKnotIndex();
    const int k1 = u_dir ? bs->LastUKnotIndex() : bs->LastVKnotIndex();
    const auto knot = [&](int k) { return u_dir ? bs->UKnot(k) : bs->VKnot(k); };
    int origin = k0;
    for (int k = k0; k < k1; ++k) {
      if (knot(k) <= lo) origin = k;
    }
    // The new window [knot, knot + period] must hold [lo, hi]: where the face reaches past it (it
    // spans nearly a whole period from a point inside a knot span), a knot is inserted at lo (exact:
    // the same surface) and the window starts there.
    if (hi > knot(origin) + period + slack) {
      if (u_dir)
        bs->InsertUKnot(lo, 1, 0.0, true);
      else
        bs->InsertVKnot(lo, 1, 0.0, true);
      const int n0 = u_dir ? bs->FirstUKnotIndex() : bs->FirstVKnotIndex();
      const int n1 = u_dir ? bs->LastUKnotIndex() : bs->LastVKnotIndex();
      for (int k = n0; k < n1; ++k) {
        if (knot(k) <= lo) origin = k;
      }
    }
    if (u_dir) bs->SetUOrigin(origin);
    else bs->SetVOrigin(origin);
    return shift;
  };
  if (u_periodic) u_shift = reorigin(true, u0, u1);
  if (v_periodic) v_shift = reorigin(false, v0, v1);
  if (bs->IsUPeriodic()) bs->SetUNotPeriodic();
  if (bs->IsVPeriodic()) bs->SetVNotPeriodic();
  double a, b, c, d;
  bs->Bounds(a, b, c, d);
  const double face_u0 = u0, face_u1 = u1, face_v0 = v0, face_v1 = v1;
  // In a periodic direction the window holds the face's range (reorigin); past it by more than
  // rounding, the patches would cover only part of the face, and its mesh would be certified against
  // a surface that lacks the rest.
  const auto outside = [](double lo, double hi, double first, double last) {
    const double slack = 1e-9 * (last - first);
    return lo < first - slack || hi > last + slack;
  };
  if ((u_periodic && outside(u0, u1, a, b)) || (v_periodic && outside(v0, v1, c, d))) {
    reason = "the face's range in a periodic direction does not fit one period of its surface";
    return {};
  }
  u0 = std::max(u0, a), u1 = std::min(u1, b), v0 = std::max(v0, c), v1 = std::min(v1, d);
  const bool whole = u0 == a && u1 == b && v0 == c && v1 == d;
  GeomConvert_BSplineSurfaceToBezierSurface split =
      whole ? GeomConvert_BSplineSurfaceToBezierSurface(bs)
            : GeomConvert_BSplineSurfaceToBezierSurface(bs, u0, u1, v0, v1, 1e-12 * std::max(1.0, std::max(u1 - u0, v1 - v0)));
  TColGeom_Array2OfBezierSurface patches(1, split.NbUPatches(), 1, split.NbVPatches());
  split.Patches(patches);
  TColStd_Array1OfReal uk(1, split.NbUPatches() + 1), vk(1, split.NbVPatches() + 1);
  split.UKnots(uk);
  split.VKnots(vk);
  u_breaks.clear();
  v_breaks.clear();
  for (int i = uk.Lower(); i <= uk.Upper(); ++i) u_breaks.push_back(uk(i) + u_shift);
  for (int j = vk.Lower(); j <= vk.Upper(); ++j) v_breaks.push_back(vk(j) + v_shift);
  if (converted) *converted = bs;
  std::vector<BezierPatch> out;
  for (int i = patches.LowerRow(); i <= patches.UpperRow(); ++i) {
    for (int j = patches.LowerCol(); j <= patches.UpperCol(); ++j) out.push_back(to_patch(patches(i, j)));
  }
  // The face's trimming curves past the surface's range in a direction that is not periodic: the end
  // patches extended onto the surface's extrapolation (extend_patch), at most one span's length.
  if (!analytic_surface) {
    const int nu = static_cast<int>(u_breaks.size()) - 1, nv = static_cast<int>(v_breaks.size()) - 1;
    const auto extend = [&](int axis, bool at_start, double to) {
      std::vector<double>& breaks = axis == 0 ? u_breaks : v_breaks;
      const int span = at_start ? 0 : static_cast<int>(breaks.size()) - 2;
      const double a0 = breaks[span], a1 = breaks[span + 1];
      const double x = (to - a0) / (a1 - a0);
      if (!(x >= -1.0 && x <= 2.0)) {
        reason = "the face's trimming curves run past its surface's parameter range by more than a knot span";
        return false;
      }
      const int count = axis == 0 ? nv : nu;
      for (int k = 0; k < count; ++k) {
        BezierPatch& p = out[static_cast<size_t>(axis == 0 ? span * nv + k : k * nv + span)];
        if (!extend_patch(p, axis, at_start ? x : 0.0, at_start ? 1.0 : x)) {
          reason = "the surface's extrapolation past its parameter range, where the face's trimming curves run, has a weight that is not positive";
          return false;
        }
      }
      (at_start ? breaks.front() : breaks.back()) = to;
      return true;
    };
    if (!u_periodic && face_u0 < a && !extend(0, true, face_u0)) return {};
    if (!u_periodic && face_u1 > b && !extend(0, false, face_u1)) return {};
    if (!v_periodic && face_v0 < c && !extend(1, true, face_v0)) return {};
    if (!v_periodic && face_v1 > d && !extend(1, false, face_v1)) return {};
  }
  return out;
}

// Reverses the u direction of a patch (row i becomes row degree_u - i): same surface, opposite normal.
void reverse_u(BezierPatch& p) {
  for (int i = 0; i < p.rows() / 2; ++i) {
    for (int j = 0; j < p.cols(); ++j) {
      const size_t a = static_cast<size_t>(i * p.cols() + j), b = static_cast<size_t>((p.degree_u - i) * p.cols() + j);
      std::swap(p.points[a], p.points[b]);
      if (p.rational()) std::swap(p.weights[a], p.weights[b]);
    }
  }
}

// Makes boundary control points of patches from different faces bit-identical when they agree within
// `tol`: each point joins the first representative found within tol (grid hash), and every point of a
// cluster that spans two or more faces is replaced by the representative. Interior points are untouched.
void snap_shared_sides(CadModel& cad, double tol) {
  struct Ref { size_t patch, index; };
  std::vector<Vec3> reps;
  std::vector<int> rep_face;           // the first face seen, or -1 once a second face joined
  std::vector<std::vector<Ref>> members;
  std::unordered_map<int64_t, std::vector<size_t>> grid;
  auto cell_key = [](int64_t x, int64_t y, int64_t z) { return (x * 73856093) ^ (y * 19349663) ^ (z * 83492791); };
  auto cell = [&](double c) { return static_cast<int64_t>(std::floor(c / tol)); };
  for (size_t p = 0; p < cad.model.patches.size(); ++p) {
    BezierPatch& patch = cad.model.patches[p];
    const int face = cad.patch_face[p];
    for (int i = 0; i < patch.rows(); ++i) {
      for (int j = 0; j < patch.cols(); ++j) {
        if (i != 0 && i != patch.degree_u && j != 0 && j != patch.degree_v) continue;
        const Vec3 x = patch.at(i, j);
        const int64_t cx = cell(x.x), cy = cell(x.y), cz = cell(x.z);
        size_t found = SIZE_MAX;
        for (int64_t dx = -1; dx <= 1 && found == SIZE_MAX; ++dx)
          for (int64_t dy = -1; dy <= 1 && found == SIZE_MAX; ++dy)
            for (int64_t dz = -1; dz <= 1 && found == SIZE_MAX; ++dz) {
              auto it = grid.find(cell_key(cx + dx, cy + dy, cz + dz));
              if (it == grid.end()) continue;
              for (size_t r : it->second) {
                const Vec3 d = reps[r] - x;
                if (std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}) <= tol) { found = r; break; }
              }
            }
        if (found == SIZE_MAX) {
          found = reps.size();
          reps.push_back(x);
          rep_face.push_back(face);
          members.emplace_back();
          grid[cell_key(cx, cy, cz)].push_back(found);
        } else if (rep_face[found] != face) {
          rep_face[found] = -1;
        }
        members[found].push_back({p, static_cast<size_t>(i * patch.cols() + j)});
      }
    }
  }
  std::vector<char> touched(cad.model.patches.size(), 0);
  for (size_t r = 0; r < reps.size(); ++r) {
    if (rep_face[r] != -1) continue;
    for (const Ref& m : members[r]) {
      Vec3& x = cad.model.patches[m.patch].points[m.index];
      if (x == reps[r]) continue;
      cad.max_snap = std::max(cad.max_snap, glm::length(x - reps[r]));
      x = reps[r];
      touched[m.patch] = 1;
    }
  }
  cad.snapped_patches = static_cast<int>(std::count(touched.begin(), touched.end(), 1));
}

// The largest tolerance OCCT records on an edge of the shape: the B-rep's own claim of how far the
// two faces' copies of an edge may differ.
double max_edge_tolerance(const TopoDS_Shape& shape) {
  double tol = 0.0;
  for (TopExp_Explorer e(shape, TopAbs_EDGE); e.More(); e.Next()) tol = std::max(tol, BRep_Tool::Tolerance(TopoDS::Edge(e.Current())));
  return tol;
}

void silence_occt_messages() {
  static const bool done = [] {
    Message::DefaultMessenger()->ChangePrinters().Clear();
    return true;
  }();
  (void)done;
}

}  // namespace

std::string occt_version() { return OCC_VERSION_COMPLETE; }

namespace {

// The largest distance, at 17 points of each edge, between the edge's 3D curve and the face's surface
// along the edge's p-curve (+infinity when either curve is missing).
double edges_off_face(const TopoDS_Face& face) {
  const Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
  if (surface.IsNull()) return std::numeric_limits<double>::infinity();
  double worst = 0.0;
  for (TopExp_Explorer it(face, TopAbs_EDGE); it.More(); it.Next()) {
    const TopoDS_Edge edge = TopoDS::Edge(it.Current());
    if (BRep_Tool::Degenerated(edge)) continue;
    double f = 0.0, l = 0.0, pf = 0.0, pl = 0.0;
    const Handle(Geom_Curve) curve = BRep_Tool::Curve(edge, f, l);  // location applied
    const Handle(Geom2d_Curve) pcurve = BRep_Tool::CurveOnSurface(edge, face, pf, pl);
    if (curve.IsNull() || pcurve.IsNull()) return std::numeric_limits<double>::infinity();
    for (int k = 0; k <= 16; ++k) {
      const gp_Pnt2d uv = pcurve->Value(pf + (pl - pf) * k / 16.0);
      const double d = curve->Value(f + (l - f) * k / 16.0).Distance(surface->Value(uv.X(), uv.Y()));
      worst = std::max(worst, std::isfinite(d) ? d : std::numeric_limits<double>::infinity());
    }
  }
  return worst;
}

}  // namespace

TopoDS_Shape sew_free_faces(const TopoDS_Shape& shape) {
  if (TopExp_Explorer(shape, TopAbs_SHELL).More()) return shape;
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  if (faces.Extent() < 1) return shape;
  try {
    Bnd_Box box;
    BRepBndLib::Add(shape, box);
    if (box.IsVoid()) return shape;
    const double tolerance = 1e-6 * std::sqrt(box.SquareExtent());
    if (!(tolerance > 0.0) || !std::isfinite(tolerance)) return shape;
    BRepBuilderAPI_Sewing sewing(tolerance);
    std::vector<bool> sewn(static_cast<size_t>(faces.Extent()) + 1, false);
    int added = 0;
    for (int f = 1; f <= faces.Extent(); ++f) {
      if (edges_off_face(TopoDS::Face(faces(f))) <= tolerance) sewing.Add(faces(f)), sewn[f] = true, ++added;
    }
    if (added < 1) return shape;
    sewing.Perform();
    const TopoDS_Shape result = sewing.SewedShape();
    // Each sewn face as the result holds it (its orientation in its shell), found by its TShape.
    std::unordered_map<const TopoDS_TShape*, TopoDS_Shape> in_result;
    for (TopExp_Explorer it(result, TopAbs_FACE); it.More(); it.Next())
      in_result.emplace(it.Current().TShape().get(), it.Current());
    const auto oriented = [&](const TopoDS_Shape& face) {
      const auto found = in_result.find(face.TShape().get());
      return found == in_result.end() ? TopoDS_Shape() : found->second;
    };
    BRep_Builder builder;
    TopoDS_Shell shell;
    builder.MakeShell(shell);
    for (int f = 1; f <= faces.Extent(); ++f) {
      TopoDS_Shape face = faces(f);
      if (sewn[f]) {
        const TopoDS_Shape modified = sewing.IsModified(face) ? sewing.Modified(face) : face;
        face = oriented(modified);
        if (face.IsNull() || face.ShapeType() != TopAbs_FACE) return shape;
      }
      builder.Add(shell, face);
    }
    // Every face sewn into one closed, manifold shell (each edge used twice: touching boxes' IGES
    // sews into edges of four faces): a solid, turned outward (a point far outside is OUT).
    std::map<const TopoDS_TShape*, int> uses;
    for (TopExp_Explorer it(shell, TopAbs_EDGE); it.More(); it.Next()) {
      if (!BRep_Tool::Degenerated(TopoDS::Edge(it.Current()))) ++uses[it.Current().TShape().get()];
    }
    const bool manifold = std::all_of(uses.begin(), uses.end(), [](const auto& u) { return u.second == 2; });
    if (added == faces.Extent() && manifold && BRep_Tool::IsClosed(shell)) {
      int shells = 0;  // connected pieces (sewing one face returns the face)
      for (TopExp_Explorer it(result, TopAbs_SHELL); it.More(); it.Next()) ++shells;
      if (shells == 1 || (shells == 0 && added == 1)) {
        shell.Closed(true);
        TopoDS_Solid solid;
        builder.MakeSolid(solid);
        builder.Add(solid, shell);
        BRepClass3d_SolidClassifier classifier(solid);
        classifier.PerformInfinitePoint(Precision::Confusion());
        if (classifier.State() == TopAbs_IN) {
          builder.MakeSolid(solid);
          builder.Add(solid, shell.Reversed());
        }
        return solid;
      }
    }
    return shell;
  } catch (const Standard_Failure&) {
    return shape;
  }
}

bool is_whole_part(const CadModel& cad) { return cad.solids > 0 || cad.shells > 0 || cad.faces_trimmed > 0; }

bool is_cad_file(const std::string& path) {
  const std::string ext = io::file_extension(path);
  return ext == ".step" || ext == ".stp" || ext == ".iges" || ext == ".igs" || ext == ".brep" || ext == ".brp";
}

TopoDS_Shape read_cad_shape(const std::string& path) {
  silence_occt_messages();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path + ": no such file");
  if (std::filesystem::file_size(path, ec) == 0) throw InputError(path + ": empty file");
  const std::string ext = io::file_extension(path);
  TopoDS_Shape shape;
  try {
    if (ext == ".step" || ext == ".stp") {
      STEPControl_Reader reader;
      if (reader.ReadFile(path.c_str()) != IFSelect_RetDone) throw InputError(path + ": not a readable STEP file");
      if (reader.TransferRoots() == 0) throw InputError(path + ": the STEP file holds no transferable shape");
      shape = reader.OneShape();
    } else if (ext == ".iges" || ext == ".igs") {
      IGESControl_Reader reader;
      if (reader.ReadFile(path.c_str()) != IFSelect_RetDone) throw InputError(path + ": not a readable IGES file");
      if (reader.TransferRoots() == 0) throw InputError(path + ": the IGES file holds no transferable shape");
      // IGES files often hold free faces (trimmed surfaces, no shell): sewn where their edges meet.
      shape = sew_free_faces(reader.OneShape());
    } else if (ext == ".brep" || ext == ".brp") {
      BRep_Builder builder;
      if (!BRepTools::Read(shape, path.c_str(), builder)) throw InputError(path + ": not a readable OCCT BREP file");
    } else {
      throw InputError(path + ": unknown CAD extension '" + ext + "' (expected .step, .stp, .iges, .igs, .brep, .brp)");
    }
  } catch (const Standard_Failure& e) {
    throw InputError(path + ": OCCT could not read it (" + std::string(e.GetMessageString()) + ")");
  }
  if (shape.IsNull()) throw InputError(path + ": no shape in the file");
  return shape;
}

TopoDS_Shape read_brep_shape(const std::string& text, const std::string& name) {
  silence_occt_messages();
  if (text.empty()) throw InputError(name + ": empty BREP text");
  TopoDS_Shape shape;
  try {
    std::istringstream in(text);
    BRep_Builder builder;
    BRepTools::Read(shape, in, builder);
  } catch (const Standard_Failure& e) {
    throw InputError(name + ": OCCT could not read the BREP text (" + std::string(e.GetMessageString()) + ")");
  }
  if (shape.IsNull()) throw InputError(name + ": not a readable OCCT BREP text");
  return shape;
}

std::vector<BezierPatch> face_patches(const TopoDS_Face& face, const std::string& name, const CadOptions& options,
                                      FaceReport& r, Handle(Geom_BSplineSurface)* converted) {
  std::vector<BezierPatch> patches;
  try {
    const Handle(Geom_Surface) given = BRep_Tool::Surface(face);  // location applied
    if (given.IsNull()) {
      r.surface_type = "none";
      r.reason = "the face has no surface";
    } else {
      double u0, u1, v0, v1;
      BRepTools::UVBounds(face, u0, u1, v0, v1);
      const Handle(Geom_Surface) surface = exact_surface(face);
      const Handle(Geom_Surface) basis = untrimmed(surface);
      r.surface_type = surface_type_name(basis);
      // An offset replaced by the elementary surface it equals is named as both.
      if (untrimmed(given)->IsKind(STANDARD_TYPE(Geom_OffsetSurface)) &&
          !basis->IsKind(STANDARD_TYPE(Geom_OffsetSurface)))
        r.surface_type = "OffsetSurface (" + r.surface_type + ")";
      const bool analytic =
          !basis->IsKind(STANDARD_TYPE(Geom_BSplineSurface)) && !basis->IsKind(STANDARD_TYPE(Geom_BezierSurface));
      const double reach = analytic && !options.convert_analytic ? 0.0 : reach_past_bounds(face, basis);
      const double tolerance = face_tolerance(face);
      if (analytic && !options.convert_analytic) {
        r.reason = "analytic surface and convert_analytic is off";
      } else if (!(reach <= 10.0 * tolerance)) {
        std::ostringstream why;
        why << "the face reaches " << reach << " past its surface's parameter bounds (10x its tolerance " << tolerance
            << "): it lies partly on an extrapolation of the surface";
        r.reason = why.str();
      } else {
        patches = decompose(surface, u0, u1, v0, v1, r.reason, r.u_breaks, r.v_breaks, converted);
        for (size_t i = 0; i < patches.size() && r.reason.empty(); ++i) {
          try {
            validate_patch(patches[i], name + " " + r.name);
            normalize_weights(patches[i]);
          } catch (const InputError& e) {
            r.reason = e.what();
          }
        }
        if (!r.reason.empty()) patches.clear();
      }
      if (r.reason.empty() && !domain_is_rectangle(face, u0, u1, v0, v1)) {
        r.status = "trimmed";
        r.reason = "trimmed: the face's boundary is not its parameter rectangle";
      }
    }
  } catch (const Standard_Failure& e) {
    r.reason = std::string("OCCT failed on the face (") + e.GetMessageString() + ")";
    patches.clear();
  }
  // A reversed face's outward normal is -dS/du x dS/dv: reverse the u direction so that every
  // patch's normal (and so every triangle's winding) follows the B-rep's orientation.
  if (face.Orientation() == TopAbs_REVERSED) {
    for (BezierPatch& p : patches) reverse_u(p);
  }
  return patches;
}

CadModel cad_model_from_shape(const TopoDS_Shape& shape, const std::string& name, const CadOptions& options) {
  CadModel cad;
  cad.model.name = name;
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  if (faces.Extent() == 0) throw InputError(name + ": the shape has no faces");
  for (int k = 1; k <= faces.Extent(); ++k) {
    const TopoDS_Face& face = TopoDS::Face(faces(k));
    FaceReport r;
    r.face_index = k - 1;
    r.name = "Face " + std::to_string(k);
    std::vector<BezierPatch> patches = face_patches(face, name, options, r);
    if (patches.empty()) {
      r.status = "skipped";
    } else if (r.status == "trimmed") {
      r.first_patch = static_cast<int>(cad.trimmed_patches.size());
      r.patch_count = static_cast<int>(patches.size());
      cad.trimmed_patches.insert(cad.trimmed_patches.end(), patches.begin(), patches.end());
    } else {
      r.status = "tessellated";
      r.first_patch = static_cast<int>(cad.model.patches.size());
      r.patch_count = static_cast<int>(patches.size());
      cad.model.patches.insert(cad.model.patches.end(), patches.begin(), patches.end());
      cad.patch_face.insert(cad.patch_face.end(), patches.size(), r.face_index);
    }
    cad.faces.push_back(r);
  }
  for (const FaceReport& r : cad.faces) {
    cad.faces_tessellated += r.status == "tessellated";
    cad.faces_trimmed += r.status == "trimmed";
    cad.faces_skipped += r.status == "skipped";
  }
  cad.bezier_patches = static_cast<int>(cad.model.patches.size() + cad.trimmed_patches.size());
  TopTools_IndexedMapOfShape solids, shells;
  TopExp::MapShapes(shape, TopAbs_SOLID, solids);
  TopExp::MapShapes(shape, TopAbs_SHELL, shells);
  cad.solids = solids.Extent();
  cad.shells = shells.Extent();
  if (!cad.model.patches.empty()) {
    const double diagonal = model_box(cad.model).diagonal();
    const double tol = options.snap_tolerance > 0.0 ? options.snap_tolerance
                                                    : std::max(1e-6 * diagonal, std::min(max_edge_tolerance(shape), 1e-5 * diagonal));
    cad.snap_tolerance = tol;
    if (tol > 0.0) snap_shared_sides(cad, tol);
  }
  return cad;
}

namespace {

// The ids ("#14") of the face entities of a STEP text: instances "#N = ADVANCED_FACE(" or
// "#N = FACE_SURFACE(".
std::vector<std::string> step_face_ids(const std::string& text) {
  std::vector<std::string> ids;
  auto blank = [&](size_t p) { return p < text.size() && std::isspace(static_cast<unsigned char>(text[p])); };
  for (size_t pos = text.find('#'); pos != std::string::npos; pos = text.find('#', pos + 1)) {
    size_t p = pos + 1;
    while (p < text.size() && std::isdigit(static_cast<unsigned char>(text[p]))) ++p;
    if (p == pos + 1) continue;
    const std::string id = text.substr(pos, p - pos);
    while (blank(p)) ++p;
    if (p >= text.size() || text[p] != '=') continue;
    ++p;
    while (blank(p)) ++p;
    for (const char* type : {"ADVANCED_FACE", "FACE_SURFACE"}) {
      const size_t n = std::char_traits<char>::length(type);
      size_t q = p + n;
      while (blank(q)) ++q;
      if (text.compare(p, n, type) == 0 && q < text.size() && text[q] == '(') ids.push_back(id);
    }
  }
  return ids;
}

// OCCT's STEP reader drops a face it cannot build (a dangling or broken reference) without a
// trace in the shape: every face entity of the file beyond the faces transferred is listed as
// skipped, so that faces_tessellated + faces_trimmed + faces_skipped = faces = the file's faces.
void list_dropped_step_faces(CadModel& cad, const std::string& text) {
  const std::vector<std::string> ids = step_face_ids(text);
  const size_t transferred = cad.faces.size();
  for (size_t k = transferred; k < ids.size(); ++k) {
    FaceReport r;
    r.face_index = static_cast<int>(k);
    r.name = "STEP face not transferred " + std::to_string(k - transferred + 1);
    r.surface_type = "unknown";
    r.status = "skipped";
    r.reason = "OCCT's STEP reader dropped it (a broken or dangling reference): the file has " + std::to_string(ids.size()) +
               " face entities, " + std::to_string(transferred) + " became faces";
    cad.faces.push_back(r);
    ++cad.faces_skipped;
  }
}

}  // namespace

CadModel read_cad_file(const std::string& path, const CadOptions& options) {
  CadModel cad = cad_model_from_shape(read_cad_shape(path), path, options);
  const std::string ext = io::file_extension(path);
  if (ext == ".step" || ext == ".stp") list_dropped_step_faces(cad, io::read_text_file(path));
  return cad;
}

CadModel read_brep_string(const std::string& brep_text, const std::string& name, const CadOptions& options) {
  return cad_model_from_shape(read_brep_shape(brep_text, name), name, options);
}

}  // namespace sagitta::occt
