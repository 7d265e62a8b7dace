// Trimmed faces: OCCT's triangles of a face measured against the face's surface restricted to its
// trimmed domain D (docs/CAD.md, "Trimmed faces"). OCCT decides what lies in D (BRepTopAdaptor_FClass2d,
// Geom2dAPI_InterCurveCurve); the validator gets plain data: split triangles and a domain predicate.
#include "occt_shape.hpp"

#include "sagitta/evaluate.hpp"
#include "sagitta/grid_cut.hpp"

#include <glm/geometric.hpp>

#include <BRepTopAdaptor_FClass2d.hxx>
#include <BRep_Tool.hxx>
#include <BndLib_Add2dCurve.hxx>
#include <Bnd_Box2d.hxx>
#include <Geom2dAPI_InterCurveCurve.hxx>
#include <Geom2d_Line.hxx>
#include <Geom2d_TrimmedCurve.hxx>
#include <Poly_Triangulation.hxx>
#include <Precision.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Vertex.hxx>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>

namespace sagitta::occt {

namespace {

struct PCurve {
  Handle(Geom2d_Curve) curve;
  double first = 0.0, last = 0.0;
  bool reversed = false;
  std::vector<std::pair<double, double>> pieces;  // parameter sub-ranges
  std::vector<Bnd_Box2d> boxes;                   // OCCT's box of each piece
  std::vector<Vec2> samples;                      // points of the curve (hole test)
};

bool is_line(Handle(Geom2d_Curve) c) {
  while (c->IsKind(STANDARD_TYPE(Geom2d_TrimmedCurve))) c = Handle(Geom2d_TrimmedCurve)::DownCast(c)->BasisCurve();
  return c->IsKind(STANDARD_TYPE(Geom2d_Line));
}

double cross(const Vec2& a, const Vec2& b) { return a.x * b.y - a.y * b.x; }

size_t cell_of(const std::vector<double>& breaks, double x) {
  const auto it = std::upper_bound(breaks.begin(), breaks.end(), x);
  const size_t k = it == breaks.begin() ? 0 : static_cast<size_t>(it - breaks.begin()) - 1;
  return std::min(k, breaks.size() - 2);
}

// The face's grid of Bézier patches: face (u, v) in cell (i, j) -> that patch's local (u, v) (u
// mirrored for reversed faces, like the patches themselves).
struct PatchGrid {
  const std::vector<double>& ub;
  const std::vector<double>& vb;
  size_t nv = 0;
  bool reversed = false;
  Vec2 local(size_t i, size_t j, Vec2 uv) const {
    double s = (uv.x - ub[i]) / (ub[i + 1] - ub[i]);
    const double t = (uv.y - vb[j]) / (vb[j + 1] - vb[j]);
    s = std::clamp(s, 0.0, 1.0);
    return Vec2(reversed ? 1.0 - s : s, std::clamp(t, 0.0, 1.0));
  }
};

// OCCT's nodes (1-based, like OCCT): face (u, v) and position.
struct Nodes {
  std::vector<Vec2> uv;
  std::vector<Vec3> X;
};

// The nodes read from the triangulation; sets out.max_node_offset, the largest distance of a node
// from the patch point its (u, v) maps to.
Nodes read_nodes(const opencascade::handle<Poly_Triangulation>& tri, const TopLoc_Location& loc, const PatchGrid& grid,
                 const Model& model, TrimmedFacePeer& out) {
  const gp_Trsf trsf = loc.Transformation();
  const int nodes = tri->NbNodes();
  Nodes nd;
  nd.uv.resize(static_cast<size_t>(nodes) + 1);
  nd.X.resize(nd.uv.size());
  for (int n = 1; n <= nodes; ++n) {
    const gp_Pnt q = tri->Node(n).Transformed(trsf);
    const gp_Pnt2d t = tri->UVNode(n);
    nd.X[n] = {q.X(), q.Y(), q.Z()};
    nd.uv[n] = {t.X(), t.Y()};
    // The mapping must reproduce OCCT's node: S_face(u, v) = S_patch(local u, v).
    const size_t i = cell_of(grid.ub, t.X()), j = cell_of(grid.vb, t.Y());
    const Vec2 l = grid.local(i, j, nd.uv[n]);
    const auto s = de_casteljau<long double>(model.patches[i * grid.nv + j], l.x, l.y);
    const Vec3 exact{static_cast<double>(s[0]), static_cast<double>(s[1]), static_cast<double>(s[2])};
    out.max_node_offset = std::max(out.max_node_offset, glm::length(exact - nd.X[n]));
  }
  return nd;
}

// The largest tolerance of the face's edges and vertices.
double edge_tolerance(const TopoDS_Face& face) {
  double tolerance = 0.0;
  for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next())
    tolerance = std::max(tolerance, BRep_Tool::Tolerance(TopoDS::Edge(e.Current())));
  for (TopExp_Explorer e(face, TopAbs_VERTEX); e.More(); e.Next())
    tolerance = std::max(tolerance, BRep_Tool::Tolerance(TopoDS::Vertex(e.Current())));
  return tolerance;
}

// The integral of u dv along the p-curve (parameter order), 64 intervals of 5-point Gauss-Legendre
// each: exact for polynomial p-curves of degree <= 4, an approximation otherwise.
double integral_u_dv(const PCurve& pc) {
  static const double gx[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640};
  static const double gw[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                               0.2369268850561891};
  double integral = 0.0;
  for (int k = 0; k < 64; ++k) {
    const double a = pc.first + (pc.last - pc.first) * k / 64.0, b = pc.first + (pc.last - pc.first) * (k + 1) / 64.0;
    for (int g = 0; g < 5; ++g) {
      gp_Pnt2d p;
      gp_Vec2d d;
      pc.curve->D1(0.5 * (a + b) + 0.5 * (b - a) * gx[g], p, d);
      integral += 0.5 * (b - a) * gw[g] * p.X() * d.Y();
    }
  }
  return integral;
}

// The p-curve of an edge on the forward face, cut into pieces with OCCT's boxes, and sampled.
PCurve make_pcurve(const TopoDS_Edge& edge, const TopoDS_Face& forward) {
  PCurve pc;
  pc.curve = BRep_Tool::CurveOnSurface(edge, forward, pc.first, pc.last);
  if (pc.curve.IsNull()) return pc;
  pc.reversed = edge.Orientation() == TopAbs_REVERSED;
  constexpr int kPieces = 16;
  for (int k = 0; k < kPieces; ++k) {
    const double a = pc.first + (pc.last - pc.first) * k / kPieces,
                 b = pc.first + (pc.last - pc.first) * (k + 1) / kPieces;
    Bnd_Box2d box;
    BndLib_Add2dCurve::Add(pc.curve, a, b, Precision::PConfusion(), box);
    pc.pieces.push_back({a, b});
    pc.boxes.push_back(box);
  }
  for (int k = 1; k < 32; ++k) {
    const gp_Pnt2d p = pc.curve->Value(pc.first + (pc.last - pc.first) * k / 32.0);
    pc.samples.push_back({p.X(), p.Y()});
  }
  return pc;
}

// The p-curves of the face's edges; sets out.straight_boundary and out.domain_area (the area of D
// by Green's theorem: the sum of the integral of u dv along each p-curve, oriented with the edge).
// False (a reason given) when an edge has no p-curve.
bool read_pcurves(const TopoDS_Face& face, std::vector<PCurve>& pcurves, TrimmedFacePeer& out) {
  out.straight_boundary = true;
  const TopoDS_Face forward = TopoDS::Face(face.Oriented(TopAbs_FORWARD));
  for (TopExp_Explorer e(forward, TopAbs_EDGE); e.More(); e.Next()) {
    PCurve pc = make_pcurve(TopoDS::Edge(e.Current()), forward);
    if (pc.curve.IsNull()) {
      out.reasons.push_back("an edge of the face has no p-curve");
      return false;
    }
    out.straight_boundary = out.straight_boundary && is_line(pc.curve);
    const double integral = integral_u_dv(pc);
    out.domain_area += pc.reversed ? -integral : integral;
    pcurves.push_back(std::move(pc));
  }
  out.domain_area = std::abs(out.domain_area);
  return true;
}

// The trimmed domain D: OCCT's classifier (one caller at a time) and the p-curves of the face's edges.
struct TrimmedDomain {
  BRepTopAdaptor_FClass2d classifier;
  std::mutex classifier_mutex;
  std::vector<PCurve> pcurves;
  double uv_scale = 0.0;  // the largest cell of the patch grid in u or v
  explicit TrimmedDomain(const TopoDS_Face& face) : classifier(face, Precision::PConfusion()) {}
  // q is not OUT of D.
  bool inside(const Vec2& q) {
    std::lock_guard<std::mutex> lock(classifier_mutex);
    return classifier.Perform(gp_Pnt2d(q.x, q.y)) != TopAbs_OUT;
  }
  // The segment (a, b) crosses a p-curve away from its own end points.
  bool edge_crosses(const Vec2& a, const Vec2& b) const {
    const double len = glm::length(b - a);
    if (!(len > 0.0)) return false;
    Bnd_Box2d seg_box;
    seg_box.Update(std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.x, b.x), std::max(a.y, b.y));
    Handle(Geom2d_TrimmedCurve) seg;
    const double end_tol = 1e-7 * len;
    for (const PCurve& pc : pcurves) {
      for (size_t k = 0; k < pc.pieces.size(); ++k) {
        if (pc.boxes[k].IsOut(seg_box)) continue;
        if (seg.IsNull()) {
          seg = new Geom2d_TrimmedCurve(new Geom2d_Line(gp_Pnt2d(a.x, a.y), gp_Dir2d(b.x - a.x, b.y - a.y)), 0.0, len);
        }
        Handle(Geom2d_TrimmedCurve) piece = new Geom2d_TrimmedCurve(pc.curve, pc.pieces[k].first, pc.pieces[k].second);
        Geom2dAPI_InterCurveCurve inter(seg, piece, 1e-12 * std::max(uv_scale, 1.0));
        for (int p = 1; p <= inter.NbPoints(); ++p) {
          const double t = inter.Intersector().Point(p).ParamOnFirst();
          if (t > end_tol && t < len - end_tol) return true;
        }
        // Overlapping segments (a chord along a straight p-curve) run on the boundary: not a crossing.
      }
    }
    return false;
  }
  // A p-curve sample lies strictly inside the (u, v) triangle q (a hole or a bay of the boundary).
  bool sample_inside(const Vec2 q[3]) const {
    bool found = false;
    const Vec2 lo = glm::min(glm::min(q[0], q[1]), q[2]), hi = glm::max(glm::max(q[0], q[1]), q[2]);
    const double twice = cross(q[1] - q[0], q[2] - q[0]);
    for (const PCurve& pc : pcurves) {
      for (const Vec2& s : pc.samples) {
        if (s.x <= lo.x || s.y <= lo.y || s.x >= hi.x || s.y >= hi.y) continue;
        const double l0 = cross(q[1] - s, q[2] - s) / twice, l1 = cross(q[2] - s, q[0] - s) / twice;
        if (l0 > 1e-9 && l1 > 1e-9 && 1.0 - l0 - l1 > 1e-9) found = true;
      }
    }
    return found;
  }
};

// OCCT's triangles as node triples (wound like the face) and whether all have one orientation in
// (u, v).
struct FaceTriangles {
  std::vector<std::array<int, 3>> tris;
  bool one_orientation = false;
};

// Each (u, v) triangle is shown inside D when: its corners and edge midpoints are not OUT, no edge
// crosses a p-curve away from its own end points, and no p-curve sample lies strictly inside it
// (a hole or a bay of the boundary inside the triangle). Sets out.uv_area and out.triangles_outside.
FaceTriangles classify_triangles(const opencascade::handle<Poly_Triangulation>& tri, const Nodes& nd, bool reversed,
                                 TrimmedDomain& domain, TrimmedFacePeer& out) {
  FaceTriangles ft;
  double signed_min = 0.0, signed_max = 0.0;
  for (int t = 1; t <= tri->NbTriangles(); ++t) {
    int a, b, c;
    tri->Triangle(t).Get(a, b, c);
    if (reversed) std::swap(b, c);
    ft.tris.push_back({a, b, c});
    const Vec2 q[3] = {nd.uv[a], nd.uv[b], nd.uv[c]};
    const double area = 0.5 * cross(q[1] - q[0], q[2] - q[0]);
    out.uv_area += std::abs(area);
    signed_min = std::min(signed_min, area);
    signed_max = std::max(signed_max, area);
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) {
      ok = domain.inside(q[k]) && domain.inside(0.5 * (q[k] + q[(k + 1) % 3])) &&
           !domain.edge_crosses(q[k], q[(k + 1) % 3]);
    }
    if (ok && domain.sample_inside(q)) ok = false;
    if (!ok) ++out.triangles_outside;
  }
  ft.one_orientation = signed_min == 0.0 || signed_max == 0.0;
  return ft;
}

// Split every (u, v) triangle along the patch grid; the pieces keep the triangle's positions
// (X is affine in the barycentric coordinates, like (u, v)), so they tile the same mesh triangle.
Tessellation split_along_grid(const FaceTriangles& ft, const Nodes& nd, const PatchGrid& grid) {
  const sagitta::PatchGrid cells{grid.ub, grid.vb, 0.0, 0.0, grid.reversed};
  Tessellation mesh;
  for (const auto& c : ft.tris) {
    for (const GridPiece& piece : cut_along_grid({nd.uv[c[0]], nd.uv[c[1]], nd.uv[c[2]]}, cells)) {
      const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
      for (const Vec3& w : piece.barycentric) mesh.positions.push_back(w.x * nd.X[c[0]] + w.y * nd.X[c[1]] + w.z * nd.X[c[2]]);
      mesh.triangles.push_back({base, base + 1, base + 2});
      mesh.triangle_patch.push_back(piece.patch);
      mesh.triangle_uv.push_back(piece.st);
    }
  }
  return mesh;
}

// What the certificate against S over the (u, v) triangles says about the face: the upper bounds
// kept only where the triangles are shown to lie in D (mesh->face) and to cover it (face->mesh).
void restrict_to_face(bool one_orientation, TrimmedFacePeer& out) {
  DistanceReport& d = out.distance;
  // Mesh -> face: the Bernstein bound measures against S over each (u, v) triangle, so it bounds the
  // distance to the face only when every triangle lies in D.
  if (out.triangles_outside > 0) {
    d.mesh_to_surface.upper = std::numeric_limits<double>::infinity();
    d.mesh_to_surface.certified = false;
    out.reasons.push_back(std::to_string(out.triangles_outside) + " of " + std::to_string(out.triangles) +
                          " (u, v) triangles are not shown inside the trimmed domain (chords of concave trimming "
                          "curves, or crossings): mesh->face upper bound not certified");
  }
  // Face -> mesh: needs the triangles to cover D. Shown only for straight trimming curves, triangles
  // inside D of one orientation, and equal areas; chords of curved p-curves leave slivers uncovered.
  const double rel = out.domain_area > 0.0 ? std::abs(out.uv_area - out.domain_area) / out.domain_area : 1.0;
  const bool covered = out.triangles_outside == 0 && out.straight_boundary && one_orientation && rel <= 1e-9;
  if (covered) {
    d.surface_to_mesh.upper = d.surface_to_mesh_over_triangles;
    d.surface_to_mesh.certified = true;
    d.coverage_ok = true;
    d.coverage_note.clear();
  } else {
    d.surface_to_mesh.upper = std::numeric_limits<double>::infinity();
    d.surface_to_mesh.certified = false;
    char buf[200];
    std::snprintf(buf, sizeof buf, "the triangles' (u, v) area is %.9g of the trimmed domain's (%s)",
                  out.domain_area > 0.0 ? out.uv_area / out.domain_area : 0.0,
                  !out.straight_boundary ? "curved trimming curves: chords leave slivers uncovered"
                  : !one_orientation     ? "triangles of both orientations"
                                         : "not all triangles inside the domain, or areas differ");
    out.reasons.push_back(std::string(buf) + ": face->mesh upper bound not certified");
  }
}

}  // namespace

TrimmedFacePeer measure_trimmed_face(const TopoDS_Face& face, const FaceReport& report,
                                     const std::vector<BezierPatch>& trimmed_patches, const CertifyOptions& certify) {
  TrimmedFacePeer out;
  out.name = report.name;
  TopLoc_Location loc;
  const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(face, loc);
  if (tri.IsNull() || tri->NbTriangles() == 0) {
    out.reasons.push_back("OCCT made no triangulation of the face");
    return out;
  }
  out.triangles = static_cast<size_t>(tri->NbTriangles());
  if (!tri->HasUVNodes()) {
    out.reasons.push_back("the triangulation has no (u, v) nodes");
    return out;
  }
  const std::vector<double>& ub = report.u_breaks;
  const std::vector<double>& vb = report.v_breaks;
  const size_t nu = ub.size() < 2 ? 0 : ub.size() - 1, nv = vb.size() < 2 ? 0 : vb.size() - 1;
  if (nu * nv == 0 || static_cast<int>(nu * nv) != report.patch_count) {
    out.reasons.push_back("the Bézier patch grid of the face is unknown");
    return out;
  }
  const bool reversed = face.Orientation() == TopAbs_REVERSED;
  Model model;
  model.name = report.name;
  model.patches.assign(trimmed_patches.begin() + report.first_patch,
                       trimmed_patches.begin() + report.first_patch + report.patch_count);
  const PatchGrid grid{ub, vb, nv, reversed};
  const double diag = model_box(model).diagonal();
  const Nodes nd = read_nodes(tri, loc, grid, model, out);
  // Nodes on the face's edges come from the edges' 3D curves, off the surface by up to the edge
  // tolerance; a re-parametrised surface (cylinder -> rational form) is off by far more.
  const double node_limit = std::max(1e-7 * std::max(diag, 1.0), 10.0 * edge_tolerance(face));
  if (!(out.max_node_offset <= node_limit)) {
    out.reasons.push_back("the Bézier form re-parametrises the surface (node offset " +
                          std::to_string(out.max_node_offset) +
                          "): OCCT's (u, v) do not map affinely onto the patches");
    return out;
  }

  // The trimmed domain: OCCT's classifier and the p-curves of the face's edges.
  TrimmedDomain domain(face);
  if (!read_pcurves(face, domain.pcurves, out)) return out;
  for (size_t k = 0; k + 1 < ub.size(); ++k) domain.uv_scale = std::max(domain.uv_scale, ub[k + 1] - ub[k]);
  for (size_t k = 0; k + 1 < vb.size(); ++k) domain.uv_scale = std::max(domain.uv_scale, vb[k + 1] - vb[k]);
  const FaceTriangles ft = classify_triangles(tri, nd, reversed, domain, out);
  const Tessellation mesh = split_along_grid(ft, nd, grid);
  out.pieces = mesh.triangles.size();
  if (mesh.triangles.empty()) {
    out.reasons.push_back("no triangle of the face has a non-degenerate (u, v) image");
    return out;
  }

  CertifyOptions options = certify;
  options.in_domain = [&](uint32_t patch, Vec2 l) {
    const size_t i = patch / nv, j = patch % nv;
    const double s = reversed ? 1.0 - l.x : l.x;
    return domain.inside(Vec2(ub[i] + s * (ub[i + 1] - ub[i]), vb[j] + l.y * (vb[j + 1] - vb[j])));
  };
  out.distance = certify_distance(model, mesh, options);
  out.validated = true;
  restrict_to_face(ft.one_orientation, out);
  check_distance_report(out.distance);
  return out;
}

}  // namespace sagitta::occt
