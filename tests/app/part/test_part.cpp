// The application layer on whole CAD parts (issue 14 item 5): the certificate covers exactly the
// faces it can prove and its bound holds against brute-force distances; the per-solid summary
// agrees with volumes and open edges recomputed here from the triangles.
#include "sagitta/app/part.hpp"
#include "sagitta/evaluate.hpp"

#include "brute_force.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sagitta {
namespace {

using test::shared_data;

occt::PartMesh mesh_part(const std::string& path, int level) {
  SchemeSpec spec;
  spec.level = level;
  return occt::mesh_part_file(path, app::part_options(spec, 0.0));
}

// shell1.brep: the certificate's upper bound is at least every sampled surface->mesh distance of
// the faces it covers, and triangle_upper is finite exactly on the covered faces' triangles.
TEST(AppPart, CertificateBoundHoldsOnCoveredFaces) {
  const std::string path = shared_data("cad/shell1.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 1);
  const app::PartCertificate cert = app::certify_part(part);
  ASSERT_EQ(cert.faces.size(), part.faces.size());
  ASSERT_GT(cert.faces_certified, 0);
  ASSERT_TRUE(cert.distance.hausdorff.certified);
  std::vector<bool> covered(part.faces.size());
  int certified = 0;
  for (const app::FaceCertificate& f : cert.faces) {
    covered[static_cast<size_t>(f.face)] = f.reason.empty();
    certified += f.certified ? 1 : 0;
    const occt::PartFace& face = part.faces[static_cast<size_t>(f.face)];
    if (face.trimmed) {
      EXPECT_EQ(f.reason, app::kTrimmedNotCertified) << face.name;
    }
  }
  EXPECT_EQ(certified, cert.faces_certified);
  EXPECT_EQ(cert.all_certified, cert.faces_certified == static_cast<int>(part.faces.size()));
  uint64_t covered_triangles = 0;
  std::vector<size_t> sub;
  for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
    const bool in = covered[part.triangle_face[t]];
    EXPECT_EQ(std::isfinite(cert.triangle_upper[t]), in) << "triangle " << t;
    if (in) sub.push_back(t);
    covered_triangles += in ? 1 : 0;
  }
  EXPECT_EQ(cert.triangles, covered_triangles);
  // Surface points of the covered faces' patches against the covered triangles, brute force.
  const double upper = cert.distance.hausdorff.upper;
  double worst = 0.0;
  for (const occt::PartFace& f : part.faces) {
    if (!covered[static_cast<size_t>(f.face_index)]) continue;
    for (int p = f.first_patch; p < f.first_patch + f.patch_count; ++p) {
      for (int i = 0; i <= 4; ++i) {
        for (int j = 0; j <= 4; ++j) {
          const auto s = de_casteljau<double>(part.model.patches[static_cast<size_t>(p)], i / 4.0, j / 4.0);
          const Vec3 x(s[0], s[1], s[2]);
          double d = std::numeric_limits<double>::infinity();
          for (const size_t t : sub) {
            const Triangle& tri = part.mesh.triangles[t];
            d = std::min(d, test::point_triangle_distance(x, part.mesh.positions[tri[0]], part.mesh.positions[tri[1]],
                                                    part.mesh.positions[tri[2]]));
          }
          worst = std::max(worst, d);
        }
      }
    }
  }
  EXPECT_LE(worst, upper * (1 + 1e-12) + 1e-15);
  EXPECT_LE(cert.distance.hausdorff.lower, upper);
}

// An open shell of untrimmed planes (FreeCAD fixture): every face covered, the part certified as a
// whole, and its rim (the B-rep's free edges) is model boundary, not a crack.
TEST(AppPart, UntrimmedOpenShellIsCertifiedWhole) {
  const std::string dir = SAGITTA_CAD_FIXTURE_DIR;
  if (dir.empty()) GTEST_SKIP() << "no FreeCAD fixtures (freecadcmd missing)";
  const occt::PartMesh part = mesh_part(dir + "/open_box_shell.brep", 2);
  ASSERT_EQ(part.faces_trimmed, 0);
  const app::PartCertificate cert = app::certify_part(part);
  EXPECT_TRUE(cert.all_certified);
  EXPECT_EQ(cert.faces_certified, static_cast<int>(part.faces.size()));
  EXPECT_EQ(cert.triangles, part.mesh.triangles.size());
  const app::PartValidation v = app::validate_part(part);
  EXPECT_EQ(v.crack_edges, 0u);
  EXPECT_EQ(v.model_boundary_edges, test::count_topology(part.mesh).open_edges);
  EXPECT_GT(v.model_boundary_edges, 0u);
  EXPECT_TRUE(v.watertight);
}

// A part with trimmed faces is never certified as a whole, and each trimmed face says why.
TEST(AppPart, TrimmedFacesAreNeverCertified) {
  const std::string path = shared_data("cad/bottle.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 2);
  ASSERT_GT(part.faces_trimmed, 0);
  const app::PartCertificate cert = app::certify_part(part);
  EXPECT_FALSE(cert.all_certified);
  int trimmed_listed = 0;
  for (const app::FaceCertificate& f : cert.faces) {
    if (!part.faces[static_cast<size_t>(f.face)].trimmed) continue;
    EXPECT_FALSE(f.certified);
    trimmed_listed += f.reason == app::kTrimmedNotCertified ? 1 : 0;
  }
  EXPECT_EQ(trimmed_listed, part.faces_trimmed);
  EXPECT_EQ(app::part_certificate_json(part, cert)["certified"], false);
}

// The per-solid summary against the triangles: open edges counted here, and the enclosed volume by
// the divergence theorem about the origin (the checker uses the box centre: a different sum).
TEST(AppPart, SolidSummaryMatchesTheTriangles) {
  const std::string path = shared_data("cad/bottle.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 3);
  const app::PartValidation v = app::validate_part(part);
  for (const app::SolidVolume& s : v.volumes) {
    Tessellation solid;
    solid.positions = part.mesh.positions;
    double volume = 0.0;
    for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
      if (part.triangle_solid[t] != s.solid) continue;
      const Triangle& tri = part.mesh.triangles[t];
      solid.triangles.push_back(tri);
      volume +=
          glm::dot(part.mesh.positions[tri[0]], glm::cross(part.mesh.positions[tri[1]], part.mesh.positions[tri[2]])) /
          6.0;
    }
    const test::MeshCounts counts = test::count_topology(solid);
    EXPECT_EQ(s.mesh_closed, counts.open_edges == 0 && counts.nonmanifold_edges == 0 && counts.misoriented_edges == 0);
    if (!s.mesh_closed) continue;
    EXPECT_NEAR(s.mesh_volume, volume, 1e-9 * std::abs(volume));
    EXPECT_NEAR(s.relative_error, std::abs(volume - s.occt_volume) / std::abs(s.occt_volume), 1e-9);
    // A level-3 mesh of a bottle encloses nearly its volume (chords cut inside convex parts).
    EXPECT_LT(s.relative_error, 0.05);
  }
  EXPECT_EQ(v.watertight, v.crack_edges == 0 && v.t_junctions == 0 && v.non_manifold_edges == 0);
}

}  // namespace
}  // namespace sagitta
