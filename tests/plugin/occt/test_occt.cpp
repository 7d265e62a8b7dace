// OCCT CAD input and the OCCT peer (issue 6). References are independent of the adapter: knot
// spans and surface points come straight from OCCT's Geom_BSplineSurface, distances from brute force.
#include "sagitta/evaluate.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/occt/cad.hpp"
#include "sagitta/uniform.hpp"
#include "brute_force.hpp"
#include "test_support.hpp"

#include <BRepTools.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Geom_BSplineSurface.hxx>
#include <TopExp.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>

#include <glm/geometric.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

namespace sagitta {
namespace {

using test::shared_data;

TopTools_IndexedMapOfShape brep_faces(const std::string& path) {
  TopoDS_Shape shape;
  BRep_Builder builder;
  EXPECT_TRUE(BRepTools::Read(shape, path.c_str(), builder));
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  return faces;
}

// Knot intervals of positive length inside [lo, hi] (the B-spline's domain), and over the whole knot vector.
int spans_inside(const TColStd_Array1OfReal& knots, double lo, double hi) {
  int n = 0;
  for (int i = knots.Lower(); i < knots.Upper(); ++i) n += knots(i + 1) > knots(i) && knots(i) >= lo && knots(i + 1) <= hi;
  return n;
}

TEST(OcctReader, Shell1FacesAndBezierPatches) {
  const std::string path = shared_data("cad/shell1.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::CadModel cad = occt::read_cad_file(path);
  ASSERT_EQ(cad.faces.size(), 99u);
  const TopTools_IndexedMapOfShape faces = brep_faces(path);
  int in_domain = 0, all_intervals = 0;
  for (int k = 1; k <= faces.Extent(); ++k) {
    const auto s = Handle(Geom_BSplineSurface)::DownCast(BRep_Tool::Surface(TopoDS::Face(faces(k))));
    ASSERT_FALSE(s.IsNull());
    double u0, u1, v0, v1;
    s->Bounds(u0, u1, v0, v1);
    TColStd_Array1OfReal uk(1, s->NbUKnots()), vk(1, s->NbVKnots());
    s->UKnots(uk);
    s->VKnots(vk);
    in_domain += spans_inside(uk, u0, u1) * spans_inside(vk, v0, v1);
    all_intervals += (s->NbUKnots() - 1) * (s->NbVKnots() - 1);
    EXPECT_EQ(cad.faces[k - 1].surface_type, "BSplineSurface");
    EXPECT_NE(cad.faces[k - 1].status, "skipped") << cad.faces[k - 1].reason;
  }
  // PROVENANCE.md's 4851 counts every interval of the knot vectors (-3..4, 8 knots each way); the
  // surfaces are uniform unclamped bicubics whose domain [0, 1]^2 is one span, so 99 patches.
  EXPECT_EQ(all_intervals, 4851);
  EXPECT_EQ(in_domain, 99);
  EXPECT_EQ(cad.bezier_patches, in_domain);
  EXPECT_EQ(cad.faces_tessellated + cad.faces_trimmed, 99);
  EXPECT_GE(cad.faces_trimmed, 1);
  for (const occt::FaceReport& f : cad.faces) {
    if (f.status == "trimmed") {
      EXPECT_FALSE(f.reason.empty()) << f.name;
    }
  }
}

// Our patches evaluate to OCCT's surface points: the decomposition is exact (up to rounding).
void expect_patches_match_occt(const std::string& path, int max_faces) {
  const occt::CadModel cad = occt::read_cad_file(path);
  const TopTools_IndexedMapOfShape faces = brep_faces(path);
  const double tol = 1e-9 * model_box(cad.model).diagonal() + cad.max_snap;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked = 0;
  for (const occt::FaceReport& f : cad.faces) {
    if (f.status != "tessellated" || f.patch_count != 1 || checked >= max_faces) continue;
    const TopoDS_Face& face = TopoDS::Face(faces(f.face_index + 1));
    const Handle(Geom_Surface) s = BRep_Tool::Surface(face);
    double u0, u1, v0, v1;
    BRepTools::UVBounds(face, u0, u1, v0, v1);
    const bool reversed = face.Orientation() == TopAbs_REVERSED;
    const BezierPatch& patch = cad.model.patches[static_cast<size_t>(f.first_patch)];
    for (int k = 0; k < 20; ++k) {
      const double a = unit(rng), b = unit(rng);
      const gp_Pnt q = s->Value(u0 + (reversed ? 1.0 - a : a) * (u1 - u0), v0 + b * (v1 - v0));
      const auto x = de_casteljau<long double>(patch, a, b);
      const Vec3 ours{static_cast<double>(x[0]), static_cast<double>(x[1]), static_cast<double>(x[2])};
      EXPECT_LE(glm::length(ours - Vec3{q.X(), q.Y(), q.Z()}), tol) << f.name;
    }
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

TEST(OcctReader, DecompositionMatchesOcctSurface) {
  for (const char* name : {"cad/shell1.brep", "cad/wing.brep"}) {
    const std::string path = shared_data(name);
    SAGITTA_REQUIRE_DATA(path);
    expect_patches_match_occt(path, 40);
  }
}

TEST(OcctReader, Shell1UntrimmedFacesAreCrackFree) {
  const std::string path = shared_data("cad/shell1.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::CadModel cad = occt::read_cad_file(path);
  EXPECT_LT(cad.max_snap, cad.snap_tolerance + 1e-300);
  const Topology topology = build_topology(cad.model);
  UniformParams params;
  params.segments = 4;
  const Tessellation mesh = tessellate_uniform(cad.model, topology, params);
  const TopologyReport report = check_mesh_topology(mesh, &cad.model, &topology);
  EXPECT_EQ(report.crack_edges, 0u);
  EXPECT_EQ(report.t_junctions, 0u);
  EXPECT_EQ(report.non_manifold_edges, 0u);
  EXPECT_EQ(report.inconsistent_orientation_edges, 0u);
  EXPECT_EQ(report.open_edges, report.model_boundary_edges);
  EXPECT_GT(report.open_edges, 0u);  // an open shell
}

TEST(OcctReader, WingAndMatDecompose) {
  const std::string wing = shared_data("cad/wing.brep"), mat = shared_data("cad/MAT.brep");
  SAGITTA_REQUIRE_DATA(wing);
  SAGITTA_REQUIRE_DATA(mat);
  const occt::CadModel w = occt::read_cad_file(wing);
  EXPECT_EQ(w.faces_tessellated, 4);
  EXPECT_EQ(w.model.patches.size(), 4u);
  for (const BezierPatch& p : w.model.patches) {
    EXPECT_EQ(p.degree_v, 1);
    EXPECT_TRUE(p.degree_u == 7 || p.degree_u == 8);
  }
  const occt::CadModel m = occt::read_cad_file(mat);
  EXPECT_EQ(m.faces_tessellated, 1);
  EXPECT_EQ(m.model.patches.size(), 6160u);  // PROVENANCE.md: 6160 knot spans
  const Topology topology = build_topology(m.model);
  EXPECT_EQ(topology.free_edges(), 2u * (77 + 80));  // the span grid's border (77 x 80 = 6160)
}

TEST(OcctReader, EveryFaceOfBottleAndScrewIsAccountedFor) {
  for (auto [name, count] : {std::pair<const char*, size_t>{"cad/bottle.brep", 71}, {"cad/screw.step", 10}}) {
    const std::string path = shared_data(name);
    SAGITTA_REQUIRE_DATA(path);
    const occt::CadModel cad = occt::read_cad_file(path);
    EXPECT_EQ(cad.faces.size(), count) << name;
    EXPECT_EQ(static_cast<size_t>(cad.faces_tessellated + cad.faces_trimmed + cad.faces_skipped), count) << name;
    EXPECT_GT(cad.faces_tessellated, 0) << name;
    for (const occt::FaceReport& f : cad.faces) {
      EXPECT_TRUE(f.status == "tessellated" || f.status == "trimmed" || f.status == "skipped") << f.name;
      if (f.status != "tessellated") {
        EXPECT_FALSE(f.reason.empty()) << name << " " << f.name;
      }
    }
  }
}

// A STEP face whose surface reference dangles is dropped by OCCT's reader: it is still listed as
// skipped (with a reason), so tessellated + trimmed + skipped = the file's 10 faces.
TEST(OcctReader, StepFaceWithADanglingReferenceIsListedAsSkipped) {
  const std::string screw = shared_data("cad/screw.step");
  SAGITTA_REQUIRE_DATA(screw);
  std::string text = io::read_text_file(screw);
  const std::string face = "#14 = ADVANCED_FACE('',(#15),#49,.F.);";
  const size_t at = text.find(face);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, face.size(), "#14 = ADVANCED_FACE('',(#15),#999999,.F.);");
  const std::filesystem::path path = std::filesystem::temp_directory_path() / ("sagitta_dangling_" + std::to_string(::getpid()) + ".step");
  std::ofstream(path, std::ios::binary) << text;
  const occt::CadModel cad = occt::read_cad_file(path.string());
  std::filesystem::remove(path);
  EXPECT_EQ(cad.faces.size(), 10u);
  EXPECT_EQ(cad.faces_tessellated + cad.faces_trimmed + cad.faces_skipped, 10);
  EXPECT_GE(cad.faces_skipped, 1);
  for (const occt::FaceReport& f : cad.faces) {
    if (f.status != "tessellated") {
      EXPECT_FALSE(f.reason.empty()) << f.name;
    }
  }
}

TEST(OcctReader, MalformedFilesAreRejectedWithTheirName) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("sagitta_occt_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string p = (dir / name).string();
    std::ofstream(p, std::ios::binary) << text;
    return p;
  };
  std::vector<std::string> bad = {write("empty.step", ""), write("text.step", "hello, not STEP\n"),
                                  write("text.iges", "not IGES either\n"), write("text.brep", "DBRep_DrawableShape\ngarbage\n"),
                                  write("empty.brep", "")};
  const std::string screw = shared_data("cad/screw.step");
  if (std::filesystem::exists(screw)) {
    const std::string text = io::read_text_file(screw);
    bad.push_back(write("truncated.step", text.substr(0, text.size() / 3)));
  }
  const std::string shell = shared_data("cad/shell1.brep");
  if (std::filesystem::exists(shell)) {
    const std::string text = io::read_text_file(shell);
    bad.push_back(write("truncated.brep", text.substr(0, text.size() / 2)));
  }
  for (const std::string& p : bad) {
    try {
      const occt::CadModel cad = occt::read_cad_file(p);
      ADD_FAILURE() << p << " was accepted with " << cad.faces.size() << " faces";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(occt::read_brep_string("", "empty"), InputError);
  EXPECT_THROW(occt::read_brep_string("not a brep", "junk"), InputError);
  std::filesystem::remove_all(dir);
}

TEST(OcctReader, BrepStringMatchesFile) {
  const std::string path = shared_data("cad/wing.brep");
  SAGITTA_REQUIRE_DATA(path);
  const occt::CadModel a = occt::read_cad_file(path);
  const occt::CadModel b = occt::read_brep_string(io::read_text_file(path), "wing");
  ASSERT_EQ(a.model.patches.size(), b.model.patches.size());
  for (size_t p = 0; p < a.model.patches.size(); ++p) EXPECT_EQ(a.model.patches[p].points, b.model.patches[p].points);
}

TEST(OcctPeer, TeapotIntervalContainsBruteForceSamples) {
  const std::string path = shared_data("teapot.bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model model = io::read_bpt(path);
  occt::PeerOptions options;
  options.deflection = 1e-2;
  const occt::PeerResult r = occt::peer_mesh_model(model, options);
  EXPECT_EQ(r.route, "bernstein");
  EXPECT_EQ(r.faces_meshed, 32);
  EXPECT_LT(r.max_node_offset, 1e-12);
  ASSERT_TRUE(r.distance.hausdorff.certified);
  EXPECT_TRUE(std::isfinite(r.distance.hausdorff.upper));
  EXPECT_LE(r.distance.hausdorff.lower, r.distance.hausdorff.upper);
  // BRepMesh honours the deflection up to its own sampling: the certified distance is near it.
  EXPECT_LT(r.distance.hausdorff.upper, 3.0 * options.deflection);
  // Surface -> mesh by brute force over all triangles, on an 8 x 8 grid per patch.
  double worst = 0.0;
  for (const BezierPatch& patch : model.patches) {
    for (int i = 0; i <= 7; ++i) {
      for (int j = 0; j <= 7; ++j) {
        const auto s = de_casteljau<long double>(patch, (i + 0.5) / 8.0, (j + 0.5) / 8.0);
        const Vec3 x{static_cast<double>(s[0]), static_cast<double>(s[1]), static_cast<double>(s[2])};
        double best = INFINITY;
        for (const Triangle& t : r.mesh.triangles) {
          best = std::min(best, test::point_triangle_distance(x, r.mesh.positions[t[0]], r.mesh.positions[t[1]], r.mesh.positions[t[2]]));
        }
        worst = std::max(worst, best);
      }
    }
  }
  EXPECT_LE(worst, r.distance.surface_to_mesh.upper * (1 + 1e-9));
  EXPECT_LE(worst, r.distance.hausdorff.upper * (1 + 1e-9));
}

}  // namespace
}  // namespace sagitta
