// Trimmed faces (issue 6): OCCT's triangles of each trimmed face get an interval against the face
// restricted to its trimmed domain; a brute force independent of the validator (OCCT's projection
// onto the surface, OCCT's classifier, exact point-triangle distances) must respect it.
#include "occt_shape.hpp"
#include "sagitta/occt/cad.hpp"
#include "test_support.hpp"

#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRepTopAdaptor_FClass2d.hxx>
#include <BRep_Tool.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Poly_Triangulation.hxx>
#include <Precision.hxx>
#include <TopExp.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

namespace sagitta {
namespace {

using test::shared_data;

// Distance from p to the triangle (a, b, c): minimum over a fine barycentric grid and the edges,
// computed by projection onto the plane when the foot falls inside.
double point_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = glm::cross(b - a, c - a);
  const double nn = glm::dot(n, n);
  if (nn > 0.0) {
    const double t = glm::dot(p - a, n) / nn;
    const Vec3 f = p - t * n;
    const double l0 = glm::dot(glm::cross(b - f, c - f), n) / nn, l1 = glm::dot(glm::cross(c - f, a - f), n) / nn;
    if (l0 >= 0 && l1 >= 0 && l0 + l1 <= 1) return glm::length(p - f);
  }
  double best = std::numeric_limits<double>::infinity();
  for (auto [u, v] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
    const Vec3 d = v - u;
    const double dd = glm::dot(d, d);
    const double t = dd > 0 ? std::clamp(glm::dot(p - u, d) / dd, 0.0, 1.0) : 0.0;
    best = std::min(best, glm::length(p - (u + t * d)));
  }
  return best;
}

struct Counts {
  int trimmed = 0, validated = 0, m2s_certified = 0, s2m_certified = 0;
};

Counts check_file(const char* name, double deflection) {
  Counts counts;
  const TopoDS_Shape shape = occt::read_cad_shape(shared_data(name));
  const occt::CadModel cad = occt::cad_model_from_shape(shape, name, {});
  BRepMesh_IncrementalMesh mesher(shape, deflection, false, 0.5, true);
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  CertifyOptions certify;
  certify.max_depth = 6;
  for (int k = 1; k <= faces.Extent(); ++k) {
    const occt::FaceReport& fr = cad.faces[k - 1];
    if (fr.status != "trimmed") continue;
    ++counts.trimmed;
    const TopoDS_Face face = TopoDS::Face(faces(k));
    const occt::TrimmedFacePeer t = occt::measure_trimmed_face(face, fr, cad.trimmed_patches, certify);
    EXPECT_EQ(t.name, fr.name);
    if (!t.validated) {
      EXPECT_FALSE(t.reasons.empty()) << name << " " << fr.name << ": not validated without a reason";
      std::printf("%s %s: not validated: %s\n", name, fr.name.c_str(), t.reasons.empty() ? "" : t.reasons[0].c_str());
      continue;
    }
    ++counts.validated;
    const DistanceReport& d = t.distance;
    EXPECT_LE(d.mesh_to_surface.lower, d.mesh_to_surface.upper);
    EXPECT_LE(d.surface_to_mesh.lower, d.surface_to_mesh.upper);
    EXPECT_EQ(d.hausdorff.certified, d.mesh_to_surface.certified && d.surface_to_mesh.certified);
    if (!d.hausdorff.certified) EXPECT_FALSE(t.reasons.empty());
    counts.m2s_certified += d.mesh_to_surface.certified;
    counts.s2m_certified += d.surface_to_mesh.certified;
    // Brute force with OCCT's own geometry.
    const Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
    const BRepTopAdaptor_FClass2d classifier(face, Precision::PConfusion());
    TopLoc_Location loc;
    const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(face, loc);
    std::vector<std::array<Vec3, 3>> tris;
    for (int i = 1; i <= tri->NbTriangles(); ++i) {
      int a, b, c;
      tri->Triangle(i).Get(a, b, c);
      std::array<Vec3, 3> T;
      int id[3] = {a, b, c};
      for (int m = 0; m < 3; ++m) {
        const gp_Pnt p = tri->Node(id[m]).Transformed(loc.Transformation());
        T[m] = {p.X(), p.Y(), p.Z()};
      }
      tris.push_back(T);
    }
    // Mesh -> face: points on the triangles whose nearest surface point (OCCT's projection) is in D:
    // there the distance to the surface is the distance to the face.
    double m2s = 0.0;
    const size_t stride = std::max<size_t>(1, tris.size() / 300);
    for (size_t i = 0; i < tris.size(); i += stride) {
      for (int a = 0; a <= 4; ++a) {
        for (int b = 0; a + b <= 4; ++b) {
          const Vec3 x = (double(a) * tris[i][0] + double(b) * tris[i][1] + double(4 - a - b) * tris[i][2]) / 4.0;
          GeomAPI_ProjectPointOnSurf proj(gp_Pnt(x.x, x.y, x.z), surface);
          if (proj.NbPoints() == 0) continue;
          double u, v;
          proj.LowerDistanceParameters(u, v);
          if (classifier.Perform(gp_Pnt2d(u, v)) != TopAbs_IN) continue;
          const double e = proj.LowerDistance();
          m2s = std::max(m2s, e);
          if (d.mesh_to_surface.certified) EXPECT_GE(d.mesh_to_surface.upper * (1 + 1e-9) + 1e-12, e) << name << " " << fr.name;
        }
      }
    }
    // Face -> mesh: surface points over a (u, v) grid classified inside D, against all the face's triangles.
    double u0, u1, v0, v1;
    BRepTools::UVBounds(face, u0, u1, v0, v1);
    double s2m = 0.0;
    for (int i = 0; i <= 16; ++i) {
      for (int j = 0; j <= 16; ++j) {
        const double u = u0 + (u1 - u0) * i / 16.0, v = v0 + (v1 - v0) * j / 16.0;
        if (classifier.Perform(gp_Pnt2d(u, v)) != TopAbs_IN) continue;
        const gp_Pnt p = surface->Value(u, v);
        const Vec3 y{p.X(), p.Y(), p.Z()};
        double e = std::numeric_limits<double>::infinity();
        for (const auto& T : tris) e = std::min(e, point_triangle(y, T[0], T[1], T[2]));
        s2m = std::max(s2m, e);
        if (d.surface_to_mesh.certified) EXPECT_GE(d.surface_to_mesh.upper * (1 + 1e-9) + 1e-12, e) << name << " " << fr.name;
      }
    }
    // Lower bounds are attained somewhere on the face; the samples may miss the worst point by at most
    // the mesh's deflection (the tolerance we give OCCT), so lower <= sampled max + deflection.
    EXPECT_LE(d.mesh_to_surface.lower, m2s + deflection) << name << " " << fr.name;
    EXPECT_LE(d.surface_to_mesh.lower, s2m + deflection) << name << " " << fr.name;
    std::printf("%s %s: %zu triangles (%zu outside D), m2s [%.3g, %.3g]%s, s2m [%.3g, %.3g]%s, samples m2s %.3g s2m %.3g\n", name,
                fr.name.c_str(), t.triangles, t.triangles_outside, d.mesh_to_surface.lower, d.mesh_to_surface.upper,
                d.mesh_to_surface.certified ? "" : " (n.c.)", d.surface_to_mesh.lower, d.surface_to_mesh.upper,
                d.surface_to_mesh.certified ? "" : " (n.c.)", m2s, s2m);
  }
  return counts;
}

TEST(OcctTrimmed, Shell1TrimmedFacesGetAnInterval) {
  const Counts c = check_file("cad/shell1.brep", 0.02);
  EXPECT_EQ(c.trimmed, 13);
  EXPECT_EQ(c.validated, 13);  // all B-spline faces: OCCT's (u, v) map affinely onto the patches
}

TEST(OcctTrimmed, BottleTrimmedFacesGetAnInterval) {
  const Counts c = check_file("cad/bottle.brep", 0.1);
  EXPECT_EQ(c.trimmed, 9);
  EXPECT_GE(c.validated, 1);
}

TEST(OcctTrimmed, ScrewTrimmedFacesAreValidatedOrExplained) {
  const Counts c = check_file("cad/screw.step", 0.05);
  EXPECT_EQ(c.trimmed, 8);
}

}  // namespace
}  // namespace sagitta
