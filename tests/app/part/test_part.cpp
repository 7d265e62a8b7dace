// The application layer on whole CAD parts (issue 14 item 5): the certificate covers exactly the
// faces it can prove and its bound holds against brute-force distances; the per-solid summary
// agrees with volumes and open edges recomputed here from the triangles.
#include "sagitta/app/part.hpp"
#include "sagitta/evaluate.hpp"

#include "brute_force.hpp"
#include "part_points.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

namespace sagitta {
namespace {

using test::shared_data;

// The faces of `part` with the given names (as FreeCAD numbers them) and their certificates, in face order.
std::vector<std::pair<const occt::PartFace*, const app::FaceCertificate*>> named_faces(
    const occt::PartMesh& part, const app::PartCertificate& cert, const std::vector<std::string>& names) {
  std::vector<std::pair<const occt::PartFace*, const app::FaceCertificate*>> out;
  for (const app::FaceCertificate& f : cert.faces) {
    const occt::PartFace& face = part.faces[static_cast<size_t>(f.face)];
    if (std::find(names.begin(), names.end(), face.name) != names.end()) out.push_back({&face, &f});
  }
  return out;
}

occt::PartMesh mesh_part(const std::string& path, int level) {
  SchemeSpec spec;
  spec.level = level;
  return occt::mesh_part_file(path, app::part_options(spec, 0.0));
}

// 1e-3 of the part's diagonal (the box of a level-0 mesh), as the fit tests ask for.
double fit_target(const std::string& path) { return 1e-3 * model_box(mesh_part(path, 0).model).diagonal(); }

// app::fit_part on the file (tighten: the tightness pass, as `sagitta fit` without --fewest).
app::PartFit fit_file(const std::string& path, double target, bool tighten = true) {
  return app::fit_part([&](const occt::PartOptions& options) { return occt::mesh_part_file(path, options); }, target,
                       CertifyOptions{}, {}, tighten);
}

// The fit met E: every face certified, the part's certified bound at most E.
testing::AssertionResult fit_meets(const app::PartFit& fit, double target) {
  if (!fit.met) return testing::AssertionFailure() << "not met: " << fit.reason;
  if (!fit.run.certificate.all_certified) return testing::AssertionFailure() << "not every face certified";
  if (!(fit.run.certificate.distance.hausdorff.upper <= target))
    return testing::AssertionFailure() << "certified " << fit.run.certificate.distance.hausdorff.upper << " > "
                                       << target;
  return testing::AssertionSuccess();
}

using test::face_point_uv;

// The exact surface point of face f at a point w of patch `patch`'s (s, t) frame (w may lie outside
// [0, 1]^2, in a neighbouring patch of the face's grid): located in the grid, evaluated in long double.
Vec3 face_point(const occt::PartMesh& part, const occt::PartFace& f, uint32_t patch, Vec2 w) {
  const size_t nv = f.v_breaks.size() - 1, local = patch - static_cast<uint32_t>(f.first_patch);
  const size_t i = local / nv, j = local % nv;
  const double s = f.reversed ? 1.0 - w.x : w.x;
  const double U = f.u_breaks[i] + s * (f.u_breaks[i + 1] - f.u_breaks[i]);
  const double V = f.v_breaks[j] + w.y * (f.v_breaks[j + 1] - f.v_breaks[j]);
  return face_point_uv(part, f, U, V);
}

constexpr std::array<Vec3, 10> kSampleBarycentrics = {Vec3(1, 0, 0),       Vec3(0, 1, 0),       Vec3(0, 0, 1),
                                                      Vec3(1, 1, 1) / 3.0, Vec3(0.5, 0.5, 0),   Vec3(0, 0.5, 0.5),
                                                      Vec3(0.5, 0, 0.5),   Vec3(0.6, 0.2, 0.2), Vec3(0.2, 0.6, 0.2),
                                                      Vec3(0.2, 0.2, 0.6)};

// The largest exact distance from surface points x to the face's triangles, given a starting
// maximum: each point's scan starts at its own triangle `t` (or any) and stops once it is at most
// the running maximum.
struct FaceDistance {
  const occt::PartMesh& part;
  const std::vector<size_t>& triangles;
  double worst = 0.0;
  void add(const Vec3& x, size_t t) {
    const auto distance_to = [&](size_t u) {
      const Triangle& tri = part.mesh.triangles[u];
      return test::point_triangle_distance(x, part.mesh.positions[tri[0]], part.mesh.positions[tri[1]],
                                           part.mesh.positions[tri[2]]);
    };
    double d = distance_to(t);
    for (const size_t u : triangles) {
      if (d <= worst) break;
      d = std::min(d, distance_to(u));
    }
    worst = std::max(worst, d);
  }
};

// Every certified face's bound holds against brute force: surface points S(w) at 10 barycentric
// points of each of the face's triangles' (U, V) (trimmed faces included), and of its (U, V)
// triangles collapsed at a pole, against the face's own triangles; triangle_upper is finite exactly
// on the certified faces' triangles; lower <= upper. `only` (when not empty): the faces checked.
void expect_face_bounds_hold(const occt::PartMesh& part, const app::PartCertificate& cert,
                             const std::vector<int>& only = {}) {
  ASSERT_EQ(cert.faces.size(), part.faces.size());
  std::vector<std::vector<size_t>> face_triangles(part.faces.size());
  for (size_t t = 0; t < part.mesh.triangles.size(); ++t) face_triangles[part.triangle_face[t]].push_back(t);
  int certified = 0;
  for (const app::FaceCertificate& f : cert.faces) {
    certified += f.certified ? 1 : 0;
    for (const size_t t : face_triangles[static_cast<size_t>(f.face)])
      EXPECT_EQ(std::isfinite(cert.triangle_upper[t]), f.certified) << "triangle " << t;
    if (!f.certified) {
      EXPECT_FALSE(f.reason.empty());
      continue;
    }
    EXPECT_LE(f.hausdorff.lower, f.hausdorff.upper);
    if (!only.empty() && std::find(only.begin(), only.end(), f.face) == only.end()) continue;
    const occt::PartFace& face = part.faces[static_cast<size_t>(f.face)];
    const std::vector<size_t>& own = face_triangles[static_cast<size_t>(f.face)];
    ASSERT_FALSE(own.empty()) << face.name;
    FaceDistance distance{part, own};
    for (const size_t t : own) {
      const auto& q = part.mesh.triangle_uv[t];
      for (const Vec3 b : kSampleBarycentrics) {
        const Vec2 w = b.x * q[0] + b.y * q[1] + b.z * q[2];
        distance.add(face.kept_whole ? face_point(part, face, part.mesh.triangle_patch[t], glm::clamp(w, 0.0, 1.0))
                                     : face_point(part, face, part.mesh.triangle_patch[t], w),
                     t);
      }
    }
    for (const occt::PartFace::CollapsedTriangle& c : face.collapsed) {
      for (const Vec3 b : kSampleBarycentrics) {
        const Vec2 w = b.x * c.uv[0] + b.y * c.uv[1] + b.z * c.uv[2];
        distance.add(face_point_uv(part, face, w.x, w.y), own.front());
      }
    }
    EXPECT_LE(distance.worst, f.hausdorff.upper * (1 + 1e-9) + 1e-12) << face.name;
  }
  EXPECT_EQ(certified, cert.faces_certified);
  EXPECT_EQ(cert.all_certified, cert.faces_certified == static_cast<int>(part.faces.size()));
  if (cert.all_certified) {
    for (const app::FaceCertificate& f : cert.faces) EXPECT_LE(f.hausdorff.lower, cert.distance.hausdorff.upper);
  } else {
    EXPECT_FALSE(std::isfinite(cert.distance.hausdorff.upper));
  }
}

TEST(AppPart, FaceBoundsHoldOnShell1) {
  const std::string path = shared_data("cad/shell1.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 1);
  const app::PartCertificate cert = app::certify_part(part);
  // Every face, the B-spline faces closing at a degenerated edge within the B-rep's tolerance
  // included (their side is snapped collapsed, the move added to the bounds).
  EXPECT_TRUE(cert.all_certified);
  expect_face_bounds_hold(part, cert);
}

// shell1's untrimmed B-spline faces whose control nets are far from uniform: the triangles' (u, v)
// drift along the surface from their positions, and the surface->mesh bound matched leaf corners to
// one triangle each, which falls only with the leaf's size where the surface is nearest to two
// (at level 1 before: Face 42 [2.58e-4, 2.98e-3], 11.6x; Face 38 2.7x; Face 5 2.0x). The tiling by
// projected leaves (validation/src/certify.cpp) bounds them within 1.1 of the lower bound.
TEST(AppPart, DriftingBSplineFacesOfShell1AreTight) {
  const std::string path = shared_data("cad/shell1.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 1);
  const app::PartCertificate cert = app::certify_part(part);
  for (const int number : {5, 9, 30, 38, 42}) {
    const app::FaceCertificate& f = cert.faces[static_cast<size_t>(number - 1)];
    ASSERT_EQ(part.faces[static_cast<size_t>(number - 1)].name, "Face " + std::to_string(number));
    EXPECT_FALSE(part.faces[static_cast<size_t>(number - 1)].trimmed);
    ASSERT_TRUE(f.certified) << number << ": " << f.reason;
    EXPECT_GT(f.hausdorff.lower, 0.0) << number;
    EXPECT_LE(f.hausdorff.upper, 1.1 * f.hausdorff.lower)
        << "Face " << number << " [" << f.hausdorff.lower << ", " << f.hausdorff.upper << "] (" << f.route << ")";
  }
}

// Trimmed cones and cylinders over part of a turn (their patch grid spans less than the period), tori
// and planes with holes: every face certified, and every bound holds against brute force.
TEST(AppPart, FaceBoundsHoldOnStepParts) {
  for (const char* name : {"cad/step/bug32745_pmi1.stp", "cad/step/OCC2368.stp", "cad/step/pr1ct.stp"}) {
    const std::string path = shared_data(name);
    SAGITTA_REQUIRE_DATA(path);
    const occt::PartMesh part = mesh_part(path, 2);
    const app::PartCertificate cert = app::certify_part(part);
    EXPECT_TRUE(cert.all_certified) << name;
    expect_face_bounds_hold(part, cert);
  }
}

// Trimmed faces with a pole (a sphere or a cone's apex cut by other faces: a degenerated edge in
// their loops) go through the loops route; the (U, V) triangles that collapse onto the pole's
// edges tile the domain with the emitted ones, and the surface above them is certified too.
TEST(AppPart, PoleFacesInTheLoopsRouteAreCertified) {
  const std::string path = shared_data("cad/step/trj10_b2-oc-214.stp");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 2);
  std::vector<int> poles;
  for (const occt::PartFace& f : part.faces) {
    if (!f.collapsed.empty()) poles.push_back(f.face_index);
  }
  ASSERT_GE(poles.size(), 2u);
  const app::PartCertificate cert = app::certify_part(part);
  for (const int face : poles) {
    const app::FaceCertificate& f = cert.faces[static_cast<size_t>(face)];
    EXPECT_EQ(f.route, "loops") << part.faces[static_cast<size_t>(face)].name;
    EXPECT_TRUE(f.certified) << part.faces[static_cast<size_t>(face)].name << ": " << f.reason;
  }
  expect_face_bounds_hold(part, cert, poles);
}

// Trimmed faces are certified by the loops route (most of the bottle's), or say why they are not.
TEST(AppPart, TrimmedFacesAreCertifiedOrSayWhy) {
  const std::string path = shared_data("cad/bottle.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 2);
  ASSERT_GT(part.faces_trimmed, 0);
  const app::PartCertificate cert = app::certify_part(part);
  int trimmed = 0, trimmed_certified = 0;
  for (const app::FaceCertificate& f : cert.faces) {
    if (!part.faces[static_cast<size_t>(f.face)].trimmed) continue;
    ++trimmed;
    trimmed_certified += f.certified ? 1 : 0;
    EXPECT_EQ(f.route, "loops");
  }
  EXPECT_GE(2 * trimmed_certified, trimmed);
  expect_face_bounds_hold(part, cert);
  const nlohmann::json json = app::part_certificate_json(part, cert);
  EXPECT_EQ(json["certified"], cert.all_certified);
  // Each face's lower bounds with their witnesses: the mesh -> face witness is a point of the mesh
  // (on one of the face's triangles), and its lower bound positive and at most the face's upper bound.
  int witnesses = 0;
  for (const nlohmann::json& row : json["faces"]) {
    if (!row.contains("mesh_to_surface")) continue;
    const nlohmann::json& w = row["mesh_to_surface"]["witness"];
    const Vec3 x(w[0].get<double>(), w[1].get<double>(), w[2].get<double>());
    double nearest = std::numeric_limits<double>::infinity();
    for (const Triangle& t : part.mesh.triangles)
      nearest = std::min(nearest, test::point_triangle_distance(x, part.mesh.positions[t[0]], part.mesh.positions[t[1]],
                                                                part.mesh.positions[t[2]]));
    EXPECT_LE(nearest, 1e-9 * model_box(part.model).diagonal()) << row["face"];
    EXPECT_GT(row["mesh_to_surface"]["lower"].get<double>(), 0.0) << row["face"];
    if (row["upper"].is_number()) {
      EXPECT_LE(row["mesh_to_surface"]["lower"].get<double>(), row["upper"].get<double>());
    }
    ++witnesses;
  }
  EXPECT_GT(witnesses, 0);
}

// Planes with holes: the mesh covers the slivers between a hole's circle and its chords, outside the
// face, so the error sits there; the upper bound is the sliver's width and the lower bound must prove
// that the face keeps away from the chord's midpoint (raise_lower_in_slivers). Before it, the lower
// bound of these faces was 0 (the untrimmed plane passes through the midpoint). tr10 has 46 such faces.
TEST(AppPart, PlanesWithHolesHaveTightIntervals) {
  const std::string path = shared_data("cad/step/tr10_r0901_ec.stp");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 2);
  const app::PartCertificate cert = app::certify_part(part);
  const double exact = 1e-9 * model_box(part.model).diagonal();  // exact up to rounding below this
  int planes = 0;
  for (const app::FaceCertificate& f : cert.faces) {
    const occt::PartFace& face = part.faces[static_cast<size_t>(f.face)];
    if (!face.trimmed || face.surface_type != "Plane") continue;
    ASSERT_TRUE(f.certified) << face.name << ": " << f.reason;
    if (!(f.hausdorff.upper > exact)) continue;
    ++planes;
    EXPECT_LE(f.hausdorff.upper, 1.5 * f.hausdorff.lower)
        << face.name << " [" << f.hausdorff.lower << ", " << f.hausdorff.upper << "]";
  }
  EXPECT_GE(planes, 40);
  expect_face_bounds_hold(part, cert);
}

// bearing.iges's small B-spline faces with a collapsed side (16 of them, 88 triangles each at level
// 3): the mesh lies on the surface at every estimate point (~1e-17) while the surface leaves the mesh
// by 1.7e-5 elsewhere, so the refinement's target sat at the rounding floor and every triangle was
// refined to the first pass's full depth (341 leaves each, 60 % of the part's certificate). A shallow
// look first raises the target to what it sees: far fewer leaves, and the interval stays within 1.1.
TEST(AppPart, FacesWhoseEstimatesSeeNothingAreNotRefinedToTheFloor) {
  const std::string path = shared_data("cad/step/bearing.iges");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 3);
  const occt::PartFace& face = part.faces[154];
  ASSERT_EQ(face.name, "Face 155");
  ASSERT_EQ(face.patch_count, 1);
  // The face alone: its patch and its triangles (shared vertices kept shared).
  Model model;
  model.patches.push_back(part.model.patches[static_cast<size_t>(face.first_patch)]);
  Tessellation mesh;
  std::vector<int64_t> local(part.mesh.positions.size(), -1);
  for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
    if (part.triangle_face[t] != 154) continue;
    Triangle tri;
    for (int i = 0; i < 3; ++i) {
      const uint32_t v = part.mesh.triangles[t][i];
      if (local[v] < 0)
        local[v] = static_cast<int64_t>(mesh.positions.size()), mesh.positions.push_back(part.mesh.positions[v]);
      tri[i] = static_cast<uint32_t>(local[v]);
    }
    mesh.triangles.push_back(tri);
    mesh.triangle_patch.push_back(0);
    mesh.triangle_uv.push_back(part.mesh.triangle_uv[t]);
  }
  ASSERT_EQ(mesh.triangles.size(), 88u);
  const DistanceReport report = certify_distance(model, mesh);
  ASSERT_TRUE(report.hausdorff.certified) << report.not_certified_reason;
  EXPECT_GT(report.hausdorff.lower, 1.7e-5);
  EXPECT_LE(report.hausdorff.upper, 1.1 * report.hausdorff.lower);
  // Leaves evaluated over all passes: 35,544 before (30,008 of them the first pass's), 4,824 now.
  EXPECT_LT(report.leaves, 8000u);
  std::cout << "bearing Face 155: [" << report.hausdorff.lower << ", " << report.hausdorff.upper << "], "
            << report.leaves << " leaves\n";
}

// Free edges lie on their face: bearing.iges is 213 free faces (no edge shared) whose edges' 3D
// curves lie up to 0.0019 off the faces (1.2 % of the part; the B-rep's tolerance says so). A free
// edge's samples and vertices are taken on the face, S(p-curve(t)), so the mesh's boundary is on
// the face and the certificate is the tessellation's own error: at level 3 the whole-part interval
// was [0.000238, 0.0019] with the samples on the 3D curves, now within 1.1 of its lower bound.
TEST(AppPart, FreeEdgesAreSampledOnTheirFace) {
  const std::string path = shared_data("cad/step/bearing.iges");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 3);
  const double size = model_box(part.model).diagonal();
  // Every boundary vertex lies on its face: within 1e-6 of the part's size of S(p-curve) (a B-rep
  // vertex is the mean of its edges' p-curve ends, which meet within the wire's tolerance, 1e-7);
  // checked through the faces' loop chords, whose ends carry their (U, V).
  int checked = 0;
  for (const occt::PartFace& face : part.faces) {
    for (const occt::BoundaryChord& c : face.chords) {
      for (const auto& [vertex, uv] : {std::pair{c.a, c.uv_a}, std::pair{c.b, c.uv_b}}) {
        const Vec3 on_face = face_point_uv(part, face, uv.x, uv.y);
        EXPECT_LE(glm::length(part.mesh.positions[vertex] - on_face), 1e-6 * size) << face.name;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 1000);
  const app::PartCertificate cert = app::certify_part(part);
  ASSERT_TRUE(cert.all_certified);
  EXPECT_LE(cert.distance.hausdorff.upper, 1.1 * cert.distance.hausdorff.lower)
      << "[" << cert.distance.hausdorff.lower << ", " << cert.distance.hausdorff.upper << "]";
  expect_face_bounds_hold(part, cert);
}

// The untrimmed faces certified by the loops route, each expected certified with upper <= 1.07 x
// lower; returns how many there are.
int tight_untrimmed_loop_faces(const occt::PartMesh& part, const app::PartCertificate& cert) {
  int faces = 0;
  for (const app::FaceCertificate& f : cert.faces) {
    const occt::PartFace& face = part.faces[static_cast<size_t>(f.face)];
    if (face.trimmed || f.route != "loops") continue;
    EXPECT_TRUE(f.certified) << face.name << ": " << f.reason;
    ++faces;
    EXPECT_LE(f.hausdorff.upper, 1.07 * f.hausdorff.lower)
        << face.name << " (" << face.surface_type << ") [" << f.hausdorff.lower << ", " << f.hausdorff.upper << "]";
  }
  return faces;
}

// Untrimmed cylinders and cones re-triangulated inside their loops (OCC2368: the edges carry other
// samples than the scheme's): the face is its patches whole, so a triangle is matched to its
// corners' projections (CertifyOptions::domain_contains_patches). Matched by its own (u, v) only, the
// rational parametrisation's tangential drift kept the upper bound 8-13 % above the lower.
TEST(AppPart, UntrimmedFacesInTheLoopsRouteAreTight) {
  const std::string path = shared_data("cad/step/OCC2368.stp");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 2);
  const app::PartCertificate cert = app::certify_part(part);
  EXPECT_GE(tight_untrimmed_loop_faces(part, cert), 5);
  expect_face_bounds_hold(part, cert);
}

// The same at the fit's coarsest density: one segment per patch side with edges split to E / 2
// (E = 1e-3 of the diagonal), so a few long triangles span a cone's re-parametrised circle and a
// surface point over one lies nearest to a triangle beyond its ring. Before the tree search the
// cones' surface->mesh bounds stayed at 2.2-3.0 times the lower bound.
TEST(AppPart, CoarseUntrimmedFacesInTheLoopsRouteAreTight) {
  const std::string path = shared_data("cad/step/OCC2368.stp");
  SAGITTA_REQUIRE_DATA(path);
  SchemeSpec spec;
  spec.segments = 1;
  const double target = 1e-3 * model_box(mesh_part(path, 0).model).diagonal();
  const occt::PartMesh part = occt::mesh_part_file(path, app::part_options(spec, 0.5 * target));
  const app::PartCertificate cert = app::certify_part(part);
  EXPECT_GE(tight_untrimmed_loop_faces(part, cert), 10);
  expect_face_bounds_hold(part, cert);
}

// fit_part when a face is not certified (planted: a trimmed face's first chord deviation made
// unproven). Only at one segment per side: the search goes on and meets the target with every face
// certified. At every density: it stops after the second step (the same face twice), met = false,
// naming the face and why.
TEST(AppPart, FitGoesOnPastAFaceNotCertifiedAtOneDensityOnly) {
  const std::string path = shared_data("cad/step/OCC2368.stp");
  SAGITTA_REQUIRE_DATA(path);
  const double target = 2e-3 * model_box(mesh_part(path, 0).model).diagonal();
  int planted = -1;
  const auto mesher = [&](bool always) {
    return [&, always](const occt::PartOptions& options) {
      occt::PartMesh part = occt::mesh_part_file(path, options);
      if (!always && options.scheme.segments != 1) return part;
      for (occt::PartFace& f : part.faces) {
        if (!f.trimmed || f.chords.empty()) continue;
        f.chords[0].deviation = std::numeric_limits<double>::infinity();
        planted = f.face_index;
        break;
      }
      return part;
    };
  };
  const app::PartFit once = app::fit_part(mesher(false), target, CertifyOptions{});
  ASSERT_GE(planted, 0);
  ASSERT_FALSE(once.steps.empty());
  EXPECT_FALSE(once.steps.front().certified);
  EXPECT_TRUE(once.met) << once.reason;
  EXPECT_GT(once.steps.size(), 2u);
  EXPECT_TRUE(once.run.certificate.all_certified);
  EXPECT_LE(once.run.certificate.distance.hausdorff.upper, target);
  // The smallest N: one segment fewer misses the target.
  for (const app::PartFit::Step& step : once.steps) {
    if (!step.per_face && step.segments < once.segments) {
      EXPECT_GT(step.faces_upper, target) << step.segments;
    }
  }

  const app::PartFit always = app::fit_part(mesher(true), target, CertifyOptions{});
  EXPECT_FALSE(always.met);
  EXPECT_EQ(always.steps.size(), 2u);
  EXPECT_FALSE(always.run.certificate.faces[static_cast<size_t>(planted)].certified);
  const std::string& name = always.run.part.faces[static_cast<size_t>(planted)].name;
  EXPECT_NE(always.reason.find(name + ":"), std::string::npos) << always.reason;
  EXPECT_NE(always.reason.find("not proven"), std::string::npos) << always.reason;
}

// fit_part when a face's mesh does not tile its domain at the first two densities (planted: one of
// its triangles flipped in (U, V) at 1 and 2 segments): such a face may tile at a finer N (a helical
// sweep's coarse rows beside its seam), so the search goes on past two doublings and meets the
// target with every face certified. Before, the same face uncertified twice stopped it.
TEST(AppPart, FitGoesOnPastFacesWhoseMeshDoesNotTileThem) {
  const std::string path = shared_data("cad/step/OCC2368.stp");
  SAGITTA_REQUIRE_DATA(path);
  const double target = 2e-3 * model_box(mesh_part(path, 0).model).diagonal();
  int planted = -1;
  const auto mesher = [&](const occt::PartOptions& options) {
    occt::PartMesh part = occt::mesh_part_file(path, options);
    if (options.scheme.segments > 2 || !options.face_segments.empty()) return part;
    for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
      const occt::PartFace& f = part.faces[part.triangle_face[t]];
      if (!f.trimmed || f.kept_whole || (planted >= 0 && f.face_index != planted)) continue;
      std::swap(part.mesh.triangles[t][1], part.mesh.triangles[t][2]);
      std::swap(part.mesh.triangle_uv[t][1], part.mesh.triangle_uv[t][2]);
      planted = f.face_index;
      break;
    }
    return part;
  };
  const app::PartFit fit = app::fit_part(mesher, target, CertifyOptions{});
  ASSERT_GE(planted, 0);
  ASSERT_GE(fit.steps.size(), 3u);
  EXPECT_FALSE(fit.steps[0].certified);
  EXPECT_FALSE(fit.steps[1].certified);
  EXPECT_TRUE(fit.met) << fit.reason;
  EXPECT_TRUE(fit.run.certificate.all_certified);
  EXPECT_LE(fit.run.certificate.distance.hausdorff.upper, target);
}

// fit_part on a B-rep whose edges lie farther from a face than the target (planted: a boundary
// vertex of a plane moved off it by 10x the target, and that face's measured boundary offset set to
// it): the face's certified lower bound stays above the target at 1 and 2 segments, so the fit
// stops after two steps and says the B-rep cannot meet the target, naming the face. With the offset
// alone (no vertex moved) the lower bounds fall as N grows and the fit meets the target.
TEST(AppPart, FitStopsWhenTheBRepsEdgesLieFartherThanTheTarget) {
  const std::string path = shared_data("cad/step/OCC2368.stp");
  SAGITTA_REQUIRE_DATA(path);
  const double target = 2e-3 * model_box(mesh_part(path, 0).model).diagonal();
  std::string planted;
  const auto mesher = [&](bool move) {
    return [&, move](const occt::PartOptions& options) {
      occt::PartMesh part = occt::mesh_part_file(path, options);
      for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
        occt::PartFace& f = part.faces[part.triangle_face[t]];
        if (f.surface_type != "Plane" || f.chords.empty()) continue;
        f.max_boundary_offset = 10.0 * target;
        planted = f.name;
        if (!move) break;
        const auto& tri = part.mesh.triangles[t];
        const Vec3 normal = glm::normalize(glm::cross(part.mesh.positions[tri[1]] - part.mesh.positions[tri[0]],
                                                      part.mesh.positions[tri[2]] - part.mesh.positions[tri[0]]));
        part.mesh.positions[f.chords.front().a] += 10.0 * target * normal;
        break;
      }
      return part;
    };
  };
  const app::PartFit stuck = app::fit_part(mesher(true), target, CertifyOptions{});
  ASSERT_FALSE(planted.empty());
  EXPECT_FALSE(stuck.met);
  EXPECT_EQ(stuck.steps.size(), 2u);
  EXPECT_NE(stuck.reason.find("cannot be met with this B-rep: " + planted + "'s edges"), std::string::npos)
      << stuck.reason;

  const app::PartFit fine = app::fit_part(mesher(false), target, CertifyOptions{});
  EXPECT_TRUE(fine.met) << fine.reason;
  EXPECT_GT(fine.steps.size(), 2u);
}

// fit_part gives each face its own density: on OCC2368 (a plane with holes, cylinders, cones) the
// faces end at different segment counts, the part meets the target with every face certified and
// with fewer triangles than the smallest uniform N that meets, and the bounds hold against brute force.
TEST(AppPart, FitGivesEachFaceItsOwnDensity) {
  const std::string path = shared_data("cad/step/OCC2368.stp");
  SAGITTA_REQUIRE_DATA(path);
  const double target = fit_target(path);
  const app::PartFit fit = fit_file(path, target);
  ASSERT_TRUE(fit_meets(fit, target));
  const occt::PartMesh& part = fit.run.part;
  ASSERT_EQ(fit.face_segments.size(), part.faces.size());
  const auto [fewest, most] = std::minmax_element(fit.face_segments.begin(), fit.face_segments.end());
  EXPECT_LT(*fewest, *most);
  EXPECT_EQ(fit.segments, *most);
  for (const occt::PartFace& f : part.faces)
    EXPECT_EQ(f.segments, fit.face_segments[static_cast<size_t>(f.face_index)]);
  uint64_t uniform_triangles = 0;  // the uniform doubling's run that met
  for (const app::PartFit::Step& step : fit.steps) {
    if (!step.per_face && step.certified && step.upper <= target) uniform_triangles = step.triangles;
  }
  ASSERT_GT(uniform_triangles, 0u);
  EXPECT_LT(part.mesh.triangles.size(), uniform_triangles / 2);
  expect_face_bounds_hold(part, fit.run.certificate);
}

// The fit's tightness pass (issue 15: upper / lower <= 1.5 on trimmed faces, 1.1 on untrimmed ones):
// on occ22470 three trimmed B-spline faces came out at 1.8-2.0 after the density search, their
// slivers between trimming curve and chords adding as much as the triangles' own bound. Their
// edges get a tighter tolerance (and only theirs): every face within the limits, target still met,
// and the mesh is what the options the fit reports make of the part (the FreeCAD Fit re-meshes so).
TEST(AppPart, FitTightensTheEdgesOfFacesOverTheRatioLimits) {
  const std::string path = shared_data("cad/step/occ22470.igs");
  SAGITTA_REQUIRE_DATA(path);
  const double target = fit_target(path);
  const app::PartFit fit = fit_file(path, target);
  ASSERT_TRUE(fit_meets(fit, target));
  const occt::PartMesh& part = fit.run.part;
  ASSERT_EQ(fit.face_edge_tolerance.size(), part.faces.size());
  int tightened = 0;
  for (size_t f = 0; f < part.faces.size(); ++f) {
    const app::FaceCertificate& c = fit.run.certificate.faces[f];
    ASSERT_TRUE(c.certified) << part.faces[f].name << ": " << c.reason;
    const double limit = part.faces[f].trimmed ? app::kFitRatioTrimmed : app::kFitRatioUntrimmed;
    EXPECT_LE(c.upper, limit * c.hausdorff.lower)
        << part.faces[f].name << " [" << c.hausdorff.lower << ", " << c.upper << "] sliver " << c.sliver;
    if (fit.face_edge_tolerance[f] > 0.0) {
      ++tightened;
      EXPECT_LT(fit.face_edge_tolerance[f], fit.edge_tolerance);
    }
  }
  EXPECT_GE(tightened, 1);
  EXPECT_LE(tightened, 6);
  occt::PartOptions again = app::part_options(SchemeSpec{}, fit.edge_tolerance);
  again.scheme.segments = fit.segments;
  again.face_segments = fit.face_segments;
  again.face_edge_tolerance = fit.face_edge_tolerance;
  again.face_graded_segments = fit.face_graded_segments;
  EXPECT_EQ(occt::mesh_part_file(path, again).mesh.positions, part.mesh.positions);
  expect_face_bounds_hold(part, fit.run.certificate);
  // Without the pass (`sagitta fit --fewest`): fewer triangles, the same target met, faces over.
  const app::PartFit fewest = fit_file(path, target, false);
  ASSERT_TRUE(fewest.met) << fewest.reason;
  EXPECT_LT(fewest.run.part.mesh.triangles.size(), part.mesh.triangles.size());
  int over = 0;
  for (size_t f = 0; f < fewest.run.part.faces.size(); ++f) {
    const app::FaceCertificate& c = fewest.run.certificate.faces[f];
    over += c.upper >
            (fewest.run.part.faces[f].trimmed ? app::kFitRatioTrimmed : app::kFitRatioUntrimmed) * c.hausdorff.lower;
  }
  EXPECT_GE(over, 1);
  // The fit's JSON lists those faces by name, worst first, with their intervals.
  const nlohmann::json listed = app::part_fit_json(fewest)["faces_over_ratio_limits_detail"];
  ASSERT_EQ(listed.size(), static_cast<size_t>(app::faces_over_ratio_limits(fewest.run)));
  ASSERT_GE(listed.size(), 1u);
  double previous = std::numeric_limits<double>::infinity();
  for (const nlohmann::json& row : listed) {
    size_t f = 0;
    while (f < fewest.run.part.faces.size() && fewest.run.part.faces[f].name != row["face"].get<std::string>()) ++f;
    ASSERT_LT(f, fewest.run.part.faces.size()) << row.dump();
    EXPECT_TRUE(app::face_over_ratio_limit(fewest.run, f)) << row.dump();
    EXPECT_EQ(row["upper"].get<double>(), fewest.run.certificate.faces[f].upper);
    const double ratio =
        row["ratio"].is_number() ? row["ratio"].get<double>() : std::numeric_limits<double>::infinity();
    EXPECT_LE(ratio, previous);
    previous = ratio;
  }
}

// Graded grids (docs/CAD.md): bug24595's four fillets are B-spline faces of 10 x 59 bicubic knot
// spans, 0.1 to 4.5 mm long side by side (the per-patch grid gave each of them the same N x N
// cells: 2,000 triangles a fillet at N = 3, 2.7x BRepMesh's whole part at the same certified error).
// With one grid of lines per face, short spans sharing cells, each fillet takes under half the
// triangles of the per-patch grid at the same N; with the trimming curves' chords equally fine (an
// edge tolerance of 0.02 mm, so that the slivers between curve and chords do not decide) its
// certified bound stays within 1.5x (the cells follow each span's own bending, and the per-patch
// grid's bound is that of its worst span too); the part stays closed; every face's bound holds
// against brute force (cells now span several patches).
TEST(AppPart, GradedGridsMergeShortKnotSpans) {
  const std::string path = shared_data("cad/step/bug24595_281390.stp");
  SAGITTA_REQUIRE_DATA(path);
  for (int segments : {2, 4}) {
    SchemeSpec spec;
    spec.segments = segments;
    occt::PartOptions options = app::part_options(spec, 0.02);
    const occt::PartMesh graded = occt::mesh_part_file(path, options);
    options.graded_grids = false;
    const occt::PartMesh patchwise = occt::mesh_part_file(path, options);
    ASSERT_EQ(graded.faces.size(), patchwise.faces.size());
    const app::PartCertificate cert = app::certify_part(graded);
    const app::PartCertificate cert_patchwise = app::certify_part(patchwise);
    ASSERT_TRUE(cert.all_certified);
    ASSERT_TRUE(cert_patchwise.all_certified);
    int fillets = 0;
    for (size_t f = 0; f < graded.faces.size(); ++f) {
      const occt::PartFace& g = graded.faces[f];
      EXPECT_EQ(patchwise.faces[f].graded_u, 0);
      if (g.graded_u == 0) continue;
      EXPECT_GT(g.graded_v, 0);
      if (g.patch_count < 100) continue;  // a face of a few patches
      ++fillets;
      std::printf("N = %d %s: graded %d x %d, %llu triangles, certified %.4g; per-patch %d x %d, %llu, %.4g\n",
                  segments, g.name.c_str(), g.graded_u, g.graded_v, static_cast<unsigned long long>(g.triangles),
                  cert.faces[f].hausdorff.upper, patchwise.faces[f].segments_u, patchwise.faces[f].segments_v,
                  static_cast<unsigned long long>(patchwise.faces[f].triangles),
                  cert_patchwise.faces[f].hausdorff.upper);
      EXPECT_LT(2 * g.triangles, patchwise.faces[f].triangles) << g.name;
      EXPECT_LE(cert.faces[f].hausdorff.upper, 1.5 * cert_patchwise.faces[f].hausdorff.upper) << g.name;
    }
    EXPECT_EQ(fillets, 4) << "N = " << segments;
    const app::PartValidation v = app::validate_part(graded);
    EXPECT_TRUE(v.watertight);
    EXPECT_EQ(v.crack_edges, 0u);
    for (const app::SolidVolume& s : v.volumes) EXPECT_TRUE(s.mesh_closed) << "solid " << s.solid;
    expect_face_bounds_hold(graded, cert);
  }
}

// A real N on graded faces (PartOptions::face_graded_segments, the fit's step 2b): bug24595's four
// fillets at N = 2 with real N 1.5 take fewer triangles than at 2 and more than at 1 (the lines
// spread the spans' needs, so the cells follow N continuously), their certified bounds fall in the
// same order, the faces on the per-patch grid and the other faces ignore it, the part stays closed,
// and every face's bound holds against brute force. A real N above the face's integer N is capped
// at it; a negative one is refused.
TEST(AppPart, GradedFacesTakeARealNBetweenIntegers) {
  const std::string path = shared_data("cad/step/bug24595_281390.stp");
  SAGITTA_REQUIRE_DATA(path);
  const auto mesh = [&](int segments, double real) {
    SchemeSpec spec;
    spec.segments = segments;
    occt::PartOptions options = app::part_options(spec, 0.05);
    if (real > 0.0) options.face_graded_segments.assign(64, real);
    return occt::mesh_part_file(path, options);
  };
  const occt::PartMesh one = mesh(1, 0.0), between = mesh(2, 1.5), two = mesh(2, 0.0), capped = mesh(2, 3.0);
  const app::PartCertificate c_one = app::certify_part(one), c_between = app::certify_part(between),
                             c_two = app::certify_part(two);
  ASSERT_TRUE(c_between.all_certified);
  int fillets = 0;
  for (size_t f = 0; f < between.faces.size(); ++f) {
    const occt::PartFace& g = between.faces[f];
    EXPECT_EQ(capped.faces[f].triangles, two.faces[f].triangles) << g.name;
    if (g.graded_u == 0) {
      EXPECT_EQ(g.graded_segments, 0.0) << g.name;
      continue;
    }
    EXPECT_EQ(g.graded_segments, 1.5) << g.name;
    if (g.patch_count < 100) continue;  // the fillets
    ++fillets;
    EXPECT_LT(g.triangles, two.faces[f].triangles) << g.name;
    EXPECT_GT(g.triangles, one.faces[f].triangles) << g.name;
    EXPECT_GT(c_between.faces[f].hausdorff.upper, c_two.faces[f].hausdorff.upper) << g.name;
    EXPECT_LT(c_between.faces[f].hausdorff.upper, c_one.faces[f].hausdorff.upper) << g.name;
  }
  EXPECT_EQ(fillets, 4);
  const app::PartValidation v = app::validate_part(between);
  EXPECT_TRUE(v.watertight);
  EXPECT_EQ(v.crack_edges, 0u);
  expect_face_bounds_hold(between, c_between);
  SchemeSpec spec;
  spec.segments = 2;
  occt::PartOptions refused = app::part_options(spec, 0.05);
  refused.face_graded_segments = {-1.0};
  EXPECT_THROW(occt::mesh_part_file(path, refused), InputError);
}

// Issue 15's fit acceptance on the part where it failed: bug24595's fit took 2.7x the triangles of
// BRepMesh's mesh at the largest deflection whose certified error meets E (9,206 against 3,372:
// its fillets' per-patch grids), and 1.30x once the certificate's tighter slivers let BRepMesh's
// mesh at D = E meet E (2,550 against 1,964). With graded grids whose lines spread the spans' needs
// evenly and the fit's real N on graded faces (docs/FITTING.md step 2b), the fitted mesh has no
// more triangles than that BRepMesh mesh, found here by certifying BRepMesh at 4E, 2E, ... E/32
// (the benchmark's sweep). E is the acceptance's: 1e-3 of the diagonal `sagitta fit --relative`
// takes (the box of a coarse mesh's vertices, which lie on the part).
TEST(AppPart, FitNeedsNoMoreTrianglesThanBRepMeshOnBug24595) {
  const std::string path = shared_data("cad/step/bug24595_281390.stp");
  SAGITTA_REQUIRE_DATA(path);
  const double target = 1e-3 * points_box_diagonal(mesh_part(path, 0).mesh.positions);
  const app::PartFit fit = fit_file(path, target);
  ASSERT_TRUE(fit_meets(fit, target));
  if (!fit.face_edge_tolerance.empty()) {
    ASSERT_EQ(fit.face_edge_tolerance.size(), fit.run.part.faces.size());
  }
  size_t brepmesh = 0;
  double deflection = 4.0 * target;
  for (; deflection >= target / 32.0 && brepmesh == 0; deflection /= 2.0) {
    occt::BRepMeshOptions options;
    options.deflection = deflection;
    options.solid_facts = false;
    const occt::PartMesh peer = occt::brepmesh_part_file(path, options);
    const app::PartCertificate cert = app::certify_part(peer);
    if (cert.all_certified && cert.distance.hausdorff.upper <= target) brepmesh = peer.mesh.triangles.size();
  }
  ASSERT_GT(brepmesh, 0u) << "BRepMesh did not meet E down to E/32";
  std::printf("bug24595 at E = %.4g: fit %zu triangles (certified %.4g), BRepMesh %zu at deflection %.4g\n", target,
              fit.run.part.mesh.triangles.size(), fit.run.certificate.distance.hausdorff.upper, brepmesh,
              2.0 * deflection);
  EXPECT_LE(fit.run.part.mesh.triangles.size(), brepmesh);
}

// The chords' overshoot (BoundaryChord::overshoot: how far the trimming curve projects beyond the
// chord's ends along it, which with the deviation bounds the slivers' term, docs/VALIDATION.md)
// holds against the curve's own points: the trace points of every chord of bug24595's and
// occ22470's trimmed B-spline faces (points of the curve, from de Casteljau halvings) lie within
// the deviation of the chord, project onto it within the overshoot of its ends, and lie within its
// proven sides (BoundaryChord::left / right) of the chord's line.
TEST(AppPart, ChordOvershootHoldsOnTheTrimmingCurves) {
  for (const char* name : {"cad/step/bug24595_281390.stp", "cad/step/occ22470.igs"}) {
    const std::string path = shared_data(name);
    SAGITTA_REQUIRE_DATA(path);
    const occt::PartMesh part = mesh_part(path, 2);
    size_t checked = 0, with_overshoot = 0, one_sided = 0;
    for (const occt::PartFace& f : part.faces) {
      const Vec2 m = f.chord_metric;
      for (const occt::BoundaryChord& c : f.chords) {
        const Vec2 a = m * c.uv_a, b = m * c.uv_b;
        const double length = glm::length(b - a);
        if (!(length > 0.0) || c.trace.size() < 3 || !std::isfinite(c.overshoot)) continue;
        ++checked;
        with_overshoot += c.overshoot > 1e-9 * length ? 1 : 0;
        const Vec2 along = (b - a) / length, left(-along.y, along.x);
        ASSERT_TRUE(std::isfinite(c.left) && std::isfinite(c.right)) << name << " " << f.name;
        EXPECT_LE(std::max(c.left, c.right), c.deviation * (1 + 1e-9) + 1e-12 * length) << name << " " << f.name;
        one_sided += std::min(c.left, c.right) <= 1e-9 * length ? 1 : 0;
        for (const Vec2& q : c.trace) {
          const Vec2 x = m * q;
          const double t = glm::dot(x - a, along);
          EXPECT_LE(glm::dot(x - a, left), c.left + 1e-12 * length) << name << " " << f.name;
          EXPECT_GE(glm::dot(x - a, left), -c.right - 1e-12 * length) << name << " " << f.name;
          EXPECT_GE(t, -c.overshoot - 1e-9 * length) << name << " " << f.name;
          EXPECT_LE(t, length + c.overshoot + 1e-9 * length) << name << " " << f.name;
          const double s = std::clamp(t / length, 0.0, 1.0);
          EXPECT_LE(glm::length(x - (a + s * (b - a))), c.deviation * (1 + 1e-9) + 1e-12 * length)
              << name << " " << f.name;
        }
      }
    }
    EXPECT_GT(checked, 50u) << name;
    // Most curves bulge to one side of their chord (C-shaped between two samples).
    EXPECT_GT(one_sided, checked / 2) << name;
    std::printf("%s: %zu traced chords checked, %zu with an overshoot above rounding, %zu on one side\n", name, checked,
                with_overshoot, one_sided);
  }
}

// The slivers' bounds against the chord's triangle (docs/VALIDATION.md, "the slivers' two sides"):
// four of bug33398's trimmed spheres at level 2 have curves that bulge away from their triangles
// (0 on the triangle's side, BoundaryChord::left / right), so the mesh covers nothing outside the
// face there and the face points in the slivers are bounded by the slices against the triangle:
// upper / lower 1.05 where the first-order term (deviation x speed added to the triangle's own
// bound) gave 1.59. The brute-force suite checks that the bounds hold.
TEST(AppPart, SliverSlicesTightenTrimmedSpheres) {
  const std::string path = shared_data("cad/step/bug33398.step");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 2);
  const app::PartCertificate cert = app::certify_part(part);
  const auto spheres = named_faces(part, cert, {"Face 303", "Face 308", "Face 328", "Face 334"});
  ASSERT_EQ(spheres.size(), 4u);
  for (const auto& [face, f] : spheres) {
    ASSERT_EQ(face->surface_type, "Sphere");
    ASSERT_TRUE(face->trimmed) << face->name;
    ASSERT_TRUE(f->certified) << face->name;
    EXPECT_LE(f->hausdorff.upper, 1.1 * f->hausdorff.lower) << face->name << " sliver " << f->sliver;
  }
}

// The slices' mesh -> face bound across a chord (part_certify.cpp, across_to_curve) compares each
// sub-net control point with the triangle's affine map at the point's Greville (U, V). On a reversed
// face (U runs against the patch's s) that point used to be turned twice, so it sat mirrored in the
// patch's cell and the slices ended at the first-order term: on bug33398 at level 1 the reversed
// trimmed cylinders Face 102 [0.0379, 0.0566] (now 0.0383) and Face 232 [0.0437, 0.0511] (now 0.0442).
TEST(AppPart, AcrossChordBoundsOnReversedFacesUseThePatchFrame) {
  const std::string path = shared_data("cad/step/bug33398.step");
  SAGITTA_REQUIRE_DATA(path);
  const occt::PartMesh part = mesh_part(path, 1);
  const app::PartCertificate cert = app::certify_part(part);
  const auto cylinders = named_faces(part, cert, {"Face 102", "Face 232"});
  ASSERT_EQ(cylinders.size(), 2u);
  for (const auto& [face, f] : cylinders) {
    ASSERT_TRUE(face->reversed && face->trimmed && face->surface_type == "Cylinder") << face->name;
    ASSERT_EQ(f->route, "loops") << face->name;
    ASSERT_TRUE(f->certified) << face->name << ": " << f->reason;
    EXPECT_LE(f->hausdorff.upper, 1.05 * f->hausdorff.lower) << face->name << " sliver " << f->sliver;
  }
}

// The mesh -> face term over a chord's sliver applies to every triangle meeting the chord's rectangle;
// the slices across the chord (across_to_curve) run over the part of that triangle inside the
// rectangle's strip. They used to run over the triangle's whole s-range, so for a neighbour that
// only touches the strip near a chord's end the slices compared its affine map, extended along
// the whole chord, with the curve and ended at the first-order term: on bug33398 at level 2 only 204
// of its 228 trimmed faces with a non-zero bound were within 1.5x (now all 228). Per-patch grids,
// as when this was measured: since the graded grids' lines spread the spans' needs (2026-12-04) ten
// of its B-spline faces take a graded grid at level 2 (134 triangles each instead of 190) whose
// interior triangles bound at 1.52-1.55x (max-depth 10 alike), which is not what this test is about.
TEST(AppPart, NeighboursOfAChordAreBoundedWhereTheyMeetItsStrip) {
  const std::string path = shared_data("cad/step/bug33398.step");
  SAGITTA_REQUIRE_DATA(path);
  SchemeSpec spec;
  spec.level = 2;
  occt::PartOptions options = app::part_options(spec, 0.0);
  options.graded_grids = false;
  const occt::PartMesh part = occt::mesh_part_file(path, options);
  const app::PartCertificate cert = app::certify_part(part);
  int trimmed = 0, within = 0;
  for (const app::FaceCertificate& f : cert.faces) {
    const occt::PartFace& face = part.faces[static_cast<size_t>(f.face)];
    if (!face.trimmed || !f.certified || !(f.hausdorff.upper > 1e-9)) continue;
    ++trimmed;
    within += f.hausdorff.upper <= 1.5 * f.hausdorff.lower ? 1 : 0;
  }
  std::cout << "bug33398 level 2: " << within << " of " << trimmed << " trimmed faces within 1.5x\n";
  EXPECT_GE(trimmed, 220);
  EXPECT_GE(within, trimmed - 4);
}

// BRepMesh at a pole (docs/VALIDATION.md, foreign meshes): its fan round a sphere's pole uses the
// pole's nodes at the two ends of the degenerated edge's segment in (u, v) (one vertex in space), so
// a fan triangle's (u, v) map swept across the meridians and its bound was first-order (the fixture
// sphere at D = 0.1 certified [0.049, 1.78]). The fan is now tiled as our own meshes of a pole are
// (each pole corner at its neighbours' projections onto the segment, plus the collapsed triangles,
// the area-less triangle spanning the segment dropped): tight, and the bound holds against brute
// force.
TEST(AppPart, BRepMeshFansAtAPoleAreBoundedTightly) {
  const std::string dir = SAGITTA_CAD_FIXTURE_DIR;
  if (dir.empty()) GTEST_SKIP() << "no FreeCAD fixtures (freecadcmd missing)";
  for (double deflection : {0.1, 0.02}) {
    occt::BRepMeshOptions options;
    options.deflection = deflection;
    options.solid_facts = false;
    const occt::PartMesh peer = occt::brepmesh_part_file(dir + "/sphere.brep", options);
    const app::PartCertificate cert = app::certify_part(peer);
    ASSERT_TRUE(cert.all_certified) << "D = " << deflection;
    for (const app::FaceCertificate& f : cert.faces) {
      EXPECT_LE(f.hausdorff.upper, 1.1 * f.hausdorff.lower)
          << "D = " << deflection << " [" << f.hausdorff.lower << ", " << f.hausdorff.upper << "]";
      EXPECT_GE(f.hausdorff.upper, 0.5 * deflection) << "D = " << deflection;
    }
    const app::PartValidation v = app::validate_part(peer);
    EXPECT_EQ(v.crack_edges, 0u);
    expect_face_bounds_hold(peer, cert);
  }
}

// A whole torus (FreeCAD fixture): its one face is periodic both ways, so at 1 segment per side with
// the fit's fine edges its triangles do not tile its domain (the four corners of (U, V) are one
// vertex). The fit stopped there ("cannot be certified": no face was certified at the first step);
// such a reason depends on the mesh, and the fit now goes on to the N that meets the target. The
// first mesh also has one triangle turned over (the same kind of reason), so that the test keeps
// checking this should the torus's first step come to tile.
TEST(AppPart, FitOfAWholeTorusGoesPastAnUntiledFirstStep) {
  const std::string dir = SAGITTA_CAD_FIXTURE_DIR;
  if (dir.empty()) GTEST_SKIP() << "no FreeCAD fixtures (freecadcmd missing)";
  const std::string path = dir + "/torus.brep";
  const double target = fit_target(path);
  bool first = true;
  const app::PartFit fit = app::fit_part(
      [&](const occt::PartOptions& options) {
        occt::PartMesh part = occt::mesh_part_file(path, options);
        if (first && !part.mesh.triangles.empty()) {
          std::swap(part.mesh.triangles[0][1], part.mesh.triangles[0][2]);
          if (!part.mesh.triangle_uv.empty()) std::swap(part.mesh.triangle_uv[0][1], part.mesh.triangle_uv[0][2]);
          first = false;
        }
        return part;
      },
      target, CertifyOptions{}, {}, true);
  EXPECT_TRUE(fit_meets(fit, target));
  ASSERT_GE(fit.steps.size(), 2u);
  EXPECT_FALSE(fit.steps.front().certified) << "the first step is expected not to tile (else this test checks nothing)";
  EXPECT_TRUE(fit.steps[1].certified);
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
