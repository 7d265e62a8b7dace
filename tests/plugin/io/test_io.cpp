// Readers reject malformed input with "FILE:LINE: problem"; writers round-trip and are atomic.
#include "sagitta/fixtures.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/io/scene_io.hpp"
#include "sagitta/uniform.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>

#include <filesystem>
#include <fstream>

namespace sagitta {
namespace {

namespace fs = std::filesystem;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no error>";
}

const char* kTwoPatches =
    "2\n1 1\n0 0 0\n0 1 0\n1 0 0\n1 1 0\n"
    "1 2\n0 0 1\n0 1 1\n0 2 1\n1 0 1\n1 1 1\n1 2 1.5\n";

TEST(Bpt, ParsesPatchesRowMajor) {
  const Model m = io::parse_bpt(kTwoPatches, "two.bpt");
  ASSERT_EQ(m.patches.size(), 2u);
  EXPECT_EQ(m.patches[1].degree_u, 1);
  EXPECT_EQ(m.patches[1].degree_v, 2);
  EXPECT_EQ(m.patches[1].at(1, 2), Vec3(1, 2, 1.5));
  EXPECT_FALSE(m.patches[0].rational());
}

TEST(Bpt, RationalPointsCarryWeights) {
  const Model m = io::parse_bpt("1\n1 1\n0 0 0 1\n0 1 0 2\n1 0 0 0.5\n1 1 0 1\n", "w.bpt");
  ASSERT_TRUE(m.patches[0].rational());
  EXPECT_EQ(m.patches[0].weight(0, 1), 2.0);
}

// Weights far outside 2^+-100 are rescaled by a power of two (the same surface); ratios are exact.
TEST(Bpt, ExtremeWeightsAreRescaledExactly) {
  for (const char* w : {"1e-300", "1e300", "1e-200"}) {
    const std::string text = std::string("1\n1 1\n0 0 0 ") + w + "\n0 1 0 " + w + "\n1 0 0 " + w + "\n1 1 1 " + w + "\n";
    const Model m = io::parse_bpt(text, "w.bpt");
    ASSERT_TRUE(m.patches[0].rational());
    const double w0 = m.patches[0].weight(0, 0);
    EXPECT_GE(w0, 1.0) << w;
    EXPECT_LT(w0, 2.0) << w;
    EXPECT_EQ(w0, std::ldexp(std::stod(w), -std::ilogb(std::stod(w)))) << w;
    EXPECT_EQ(m.patches[0].weight(1, 1), w0);
  }
}

struct BadInput {
  const char* text;
  const char* expected;  // substring of the one-line message
};

class BptRejects : public ::testing::TestWithParam<BadInput> {};

TEST_P(BptRejects, WithFileLineAndProblem) {
  const std::string msg = error_of([&] { io::parse_bpt(GetParam().text, "bad.bpt"); });
  EXPECT_NE(msg.find(GetParam().expected), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind("bad.bpt:", 0), 0u) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
}

INSTANTIATE_TEST_SUITE_P(
    Malformed, BptRejects,
    ::testing::Values(BadInput{"", "bad.bpt:0: file ends early: expected the patch count"},
                      BadInput{"0\n", "bad.bpt:1: the model is empty"},
                      BadInput{"2\n1 1\n0 0 0\n0 1 0\n1 0 0\n1 1 0\n", "file ends early: expected the degree line"},
                      BadInput{"1\n1 1\n0 0 0\n0 1 0\n1 0 0\n", "file ends early: expected control point 3"},
                      BadInput{"1\n1 1\n0 0 0\n0 nan 0\n1 0 0\n1 1 0\n", "bad.bpt:4: 'nan' is not a finite number"},
                      BadInput{"1\n1 1\n0 0 0\n0 1 inf\n1 0 0\n1 1 0\n", "'inf' is not a finite number"},
                      BadInput{"1\n26 1\n", "bad.bpt:2: patch 0 of 1 has degree 26x1, outside 1..25"},
                      BadInput{"1\n1 1\n0 0 0\n0 1\n1 0 0\n1 1 0\n", "bad.bpt:4: control point 1 of patch 0 of 1 needs 3"},
                      BadInput{"1\n1 1\n0 0 0\n0 1 0\n1 0 0\n1 1 0\n7\n", "bad.bpt:7: unexpected content after the last"},
                      BadInput{"x\n", "bad.bpt:1: first line must be the patch count"},
                      BadInput{"1\n1 1\n0 0 0 1\n0 1 0 -1\n1 0 0 1\n1 1 0 1\n", "weight -1 must be > 0"},
                      BadInput{"1\n1 1\n0 0 0\n0 1e999 0\n1 0 0\n1 1 0\n", "is not a number"}),
    [](const ::testing::TestParamInfo<BadInput>& info) { return "case" + std::to_string(info.index); });

TEST(Bpt, ReadsTheTeapotAndNamesMissingFiles) {
  const std::string path = test::shared_data("teapot.bpt");
  SAGITTA_REQUIRE_DATA(path);
  EXPECT_EQ(io::read_bpt(path).patches.size(), 32u);
  EXPECT_NE(error_of([] { io::read_bpt("/nonexistent/x.bpt"); }).find("/nonexistent/x.bpt: cannot open"),
            std::string::npos);
}

TEST(Rib, BicubicPatchesWithTransforms) {
  const std::string rib =
      "# a test scene\n"
      "AttributeBegin\n"
      "  Translate 10 0 0\n"
      "  TransformBegin\n"
      "    Scale 2 2 2\n"
      "    Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n"
      "  TransformEnd\n"
      "  Rotate 90 0 0 1\n"
      "  Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n"
      "AttributeEnd\n"
      "Color [1 0 0]\n"
      "Patch \"bicubic\" \"P\" [" +
      [] {
        std::string s;
        for (int k = 0; k < 16; ++k) s += std::to_string(k % 4) + " " + std::to_string(k / 4) + " 0 ";
        return s;
      }() + "]\n";
  const Model m = io::detail::parse_rib(rib, "scene.rib");
  ASSERT_EQ(m.patches.size(), 3u);
  // RIB varies u fastest: its second point (1 0 0) is our (u=1, v=0).
  EXPECT_EQ(m.patches[0].at(1, 0), Vec3(12, 0, 0));   // scaled by 2, then translated
  EXPECT_NEAR(m.patches[1].at(1, 0).x, 10.0, 1e-12);  // rotated 90 degrees about z, then translated
  EXPECT_NEAR(m.patches[1].at(1, 0).y, 1.0, 1e-12);
  EXPECT_EQ(m.patches[2].degree_u, 3);
  EXPECT_EQ(m.patches[2].at(3, 1), Vec3(3, 1, 0));
}

TEST(Rib, RejectsMalformedInput) {
  EXPECT_NE(error_of([] {
              io::detail::parse_rib("Patch \"bicubic\" \"P\" [1 2 3]\n", "a.rib");
            }).find("a.rib:1: Patch \"bicubic\" needs 48 numbers, got 3"),
            std::string::npos);
  EXPECT_NE(
      error_of([] { io::detail::parse_rib("\n\nTransformEnd\n", "b.rib"); }).find("b.rib:3: TransformEnd without"),
      std::string::npos);
  EXPECT_NE(error_of([] { io::detail::parse_rib("WorldBegin\nWorldEnd\n", "c.rib"); }).find("the model is empty"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              io::detail::parse_rib("Patch \"bilinear\" \"P\" [0 0 0 1 0 nan 0 1 0 1 1 0]", "d.rib");
            }).find("not a finite number"),
            std::string::npos);
  EXPECT_NE(error_of([] { io::detail::parse_rib("Basis \"bspline\" 1 \"bspline\" 1\n", "e.rib"); }).find("only Basis"),
            std::string::npos);
}

// A unit cube around the origin as six bilinear RIB patches, each written (u fastest) so that
// RenderMan's default orientation makes its outside face away from the cube.
std::string rib_cube(const std::string& prefix) {
  // Per face: P00, P10, P01, P11 with (P10 - P00) x (P01 - P00) pointing out.
  const char* faces[] = {
      "1 0 0  1 1 0  1 0 1  1 1 1",  // +x
      "0 0 0  0 0 1  0 1 0  0 1 1",  // -x
      "0 1 0  0 1 1  1 1 0  1 1 1",  // +y
      "0 0 0  1 0 0  0 0 1  1 0 1",  // -y
      "0 0 1  1 0 1  0 1 1  1 1 1",  // +z
      "0 0 0  0 1 0  1 0 0  1 1 0",  // -z
  };
  std::string rib = prefix + "\nTranslate -0.5 -0.5 -0.5\n";
  for (const char* f : faces) rib += std::string("Patch \"bilinear\" \"P\" [") + f + "]\n";
  return rib;
}

// +1 when every patch's du x dv at its centre points away from the model's centre, -1 when every
// one points towards it, 0 otherwise.
int patch_orientation(const Model& m) {
  Vec3 centre(0.0);
  for (const BezierPatch& p : m.patches) centre += (p.at(0, 0) + p.at(1, 1)) * 0.5;
  centre /= static_cast<double>(m.patches.size());
  int out = 0, in = 0;
  for (const BezierPatch& p : m.patches) {
    const Vec3 du = (p.at(1, 0) + p.at(1, 1)) - (p.at(0, 0) + p.at(0, 1));
    const Vec3 dv = (p.at(0, 1) + p.at(1, 1)) - (p.at(0, 0) + p.at(1, 0));
    const double d = glm::dot(glm::cross(glm::normalize(du), glm::normalize(dv)),
                              glm::normalize((p.at(0, 0) + p.at(1, 1)) * 0.5 - centre));
    out += d > 0.0;
    in += d < 0.0;
  }
  return out == static_cast<int>(m.patches.size()) ? 1 : in == static_cast<int>(m.patches.size()) ? -1 : 0;
}

// RenderMan (RISpec 3.2, 4.2.14): the default orientation is outside = dPdu x dPdv with RIB's u
// the fastest index; a mirroring transform flips the coordinate system and the orientation
// together (the surface stays outward); ReverseOrientation and Orientation "inside" turn it in.
TEST(Rib, OrientationFollowsRenderMan) {
  EXPECT_EQ(patch_orientation(io::detail::parse_rib(rib_cube(""), "cube.rib")), 1);
  EXPECT_EQ(patch_orientation(io::detail::parse_rib(rib_cube("Scale 1 1 -1"), "mirrored.rib")), 1);
  EXPECT_EQ(
      patch_orientation(io::detail::parse_rib(rib_cube("ConcatTransform [-2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]"), "m.rib")),
      1);
  EXPECT_EQ(patch_orientation(io::detail::parse_rib(rib_cube("ReverseOrientation"), "reversed.rib")), -1);
  EXPECT_EQ(patch_orientation(io::detail::parse_rib(rib_cube("Orientation \"inside\""), "inside.rib")), -1);
  EXPECT_EQ(patch_orientation(io::detail::parse_rib(rib_cube("Orientation \"rh\""), "rh.rib")), -1);
  EXPECT_EQ(patch_orientation(io::detail::parse_rib(rib_cube("Scale 1 1 -1 Orientation \"rh\""), "mirrored_rh.rib")),
            1);
  // Tiny scales (determinant 1e-330, below the doubles) keep the sign of the determinant.
  EXPECT_EQ(patch_orientation(io::detail::parse_rib(rib_cube("Scale 1e-110 1e-110 -1e-110"), "tiny.rib")), 1);
  // ReverseOrientation is an attribute: AttributeEnd restores it, TransformEnd does not.
  EXPECT_EQ(
      patch_orientation(io::detail::parse_rib(rib_cube("AttributeBegin ReverseOrientation AttributeEnd"), "a.rib")), 1);
  EXPECT_EQ(
      patch_orientation(io::detail::parse_rib(rib_cube("TransformBegin ReverseOrientation TransformEnd"), "t.rib")),
      -1);
}

TEST(Rib, TransformReplacesAndSingularTransformsAreRefused) {
  const Model m = io::detail::parse_rib(
      "Translate 5 0 0\nTransform [2 0 0 0  0 2 0 0  0 0 2 0  0 0 1 1]\n"
      "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n",
      "t.rib");
  EXPECT_EQ(m.patches[0].at(1, 1), Vec3(2, 2, 1));
  const std::string patch = "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n";
  EXPECT_EQ(error_of([&] { io::detail::parse_rib("Scale 0 0 0\n" + patch, "s.rib"); }),
            "s.rib:1: Scale by zero makes the transformation singular");
  EXPECT_EQ(
      error_of([&] { io::detail::parse_rib("\nTransform [1 0 0 0 0 1 0 0 0 0 0 0 0 0 0 1]\n" + patch, "z.rib"); }),
      "z.rib:2: Transform matrix is singular");
  EXPECT_EQ(error_of([&] { io::detail::parse_rib("Scale 1e-200 1e-200 1e-200\nScale 1e-200 1 1\n" + patch, "u.rib"); }),
            "u.rib:2: Scale makes the transformation singular (or not finite)");
  for (const char* request : {"ObjectBegin 1", "ObjectInstance 1", "MotionBegin [0 1]", "Skew 45 0 1 0 1 0 0"}) {
    const std::string word = std::string(request).substr(0, std::string(request).find(' '));
    EXPECT_EQ(error_of([&] {
                io::detail::parse_rib(std::string(request) + "\n" + patch, "r.rib");
              }).rfind("r.rib:1: " + word + " is not supported", 0),
              0u)
        << request;
  }
  EXPECT_EQ(error_of([] { io::detail::parse_rib("Orientation \"sideways\"\n", "o.rib"); }),
            "o.rib:1: Orientation must be \"outside\", \"inside\", \"lh\" or \"rh\"");
  EXPECT_EQ(error_of([] { io::detail::parse_rib("Attribute \"" + std::string(5000, 'a') + "\"\n", "l.rib"); }),
            "l.rib:1: string longer than 4096 bytes");
}

// Text inputs are refused at the first NUL byte or over-long line, naming the line: devices such as
// /dev/zero cost one chunk, not all of memory.
TEST(TextInput, RefusesNulBytesAndOverlongLinesAsTheyAreRead) {
  const fs::path dir = fs::temp_directory_path() / ("sagitta_text_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string nul = (dir / "nul.bpt").string(), longline = (dir / "long.obj").string();
  std::ofstream(nul, std::ios::binary) << "1\n1 1\n0 0 0" << '\0' << "\n";
  std::ofstream(longline, std::ios::binary) << "v 0 0 0\n" << std::string(io::kMaxLineBytes + 1, '1') << "\n";
  EXPECT_EQ(error_of([&] { io::read_bpt(nul); }), nul + ":3: contains a NUL byte (binary data, not a text file)");
  EXPECT_EQ(error_of([&] { io::read_mesh(longline); }), longline + ":2: line longer than 65536 bytes (no valid line is that long)");
  if (fs::exists("/dev/zero")) {
    EXPECT_EQ(error_of([] { io::detail::read_text_input("/dev/zero"); }),
              "/dev/zero:1: contains a NUL byte (binary data, not a text file)");
    EXPECT_EQ(error_of([] { io::read_scene("/dev/zero"); }), "/dev/zero:1: contains a NUL byte (binary data, not a text file)");
  }
  fs::remove_all(dir);
}

class MeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("sagitta_io_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const Model model = fixtures::pillow_box();
    UniformParams p;
    p.segments = 3;
    mesh_ = tessellate_uniform(model, build_topology(model), p);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  Tessellation mesh_;
};

TEST_F(MeshFiles, RoundTripEveryFormat) {
  for (const char* ext : {".obj", ".ply", ".stl"}) {
    const std::string path = (dir_ / (std::string("m") + ext)).string();
    io::write_mesh(mesh_, path);
    const Tessellation back = io::read_mesh(path);
    ASSERT_EQ(back.triangles.size(), mesh_.triangles.size()) << ext;
    ASSERT_EQ(back.positions.size(), mesh_.positions.size()) << ext;
    const test::MeshCounts c = test::count_topology(back);
    EXPECT_EQ(c.open_edges, 0u) << ext;
    EXPECT_EQ(c.euler(), 2) << ext;
    if (std::string(ext) != ".stl") {  // STL stores float32; OBJ (17 digits) and PLY (double) are exact
      EXPECT_EQ(back.positions, mesh_.positions) << ext;
      EXPECT_EQ(back.triangles, mesh_.triangles) << ext;
      EXPECT_EQ(back.normals.size(), back.positions.size()) << ext;
    }
  }
  // Nothing but the outputs is left in the folder (the temporary files were renamed).
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 3u);
}

TEST_F(MeshFiles, PlyCarriesPerFaceError) {
  std::vector<float> error(mesh_.triangles.size(), 0.25f);
  io::MeshWriteOptions o;
  o.face_error = &error;
  const std::string path = (dir_ / "e.ply").string();
  io::write_ply(mesh_, path, o);
  const std::string text = io::read_text_file(path);
  EXPECT_NE(text.find("property float error"), std::string::npos);
  EXPECT_EQ(io::read_mesh(path).triangles.size(), mesh_.triangles.size());
}

TEST_F(MeshFiles, FailedWriteLeavesTargetUntouched) {
  const std::string path = (dir_ / "keep.obj").string();
  io::write_file_atomic(path, "original\n");
  EXPECT_THROW(io::write_mesh(mesh_, (dir_ / "no" / "such" / "dir.obj").string()), InputError);
  EXPECT_THROW(io::write_mesh(mesh_, (dir_ / "x.xyz").string()), InputError);
  EXPECT_EQ(io::read_text_file(path), "original\n");
}

TEST(MeshRead, RejectsMalformedMeshes) {
  EXPECT_NE(error_of([] {
              io::detail::parse_mesh("v 0 0 0\nv 1 0 0\nf 1 2 3\n", "a.obj", ".obj");
            }).find("a.obj:3: vertex index 3 is out of range"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              io::detail::parse_mesh("v 0 0 nan\n", "b.obj", ".obj");
            }).find("b.obj:1: 'v' needs 3 finite numbers"),
            std::string::npos);
  EXPECT_NE(error_of([] { io::detail::parse_mesh("v 0 0 0\n", "c.obj", ".obj"); }).find("c.obj: the mesh has no faces"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              io::detail::parse_mesh(
                  "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                  "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                  "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
                  "d.ply", ".ply");
            }).find("vertex index 7 out of range"),
            std::string::npos);
  EXPECT_NE(
      error_of([] { io::detail::parse_mesh(std::string(90, 'x'), "e.stl", ".stl"); }).find("e.stl: not an STL file"),
      std::string::npos);
  std::string truncated = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                          "property double z\nend_header\n";
  truncated += std::string(20, '\0');
  EXPECT_NE(error_of([&] { io::detail::parse_mesh(truncated, "f.ply", ".ply"); }).find("truncated"), std::string::npos);
}

TEST(MeshRead, ObjQuadsAreTriangulatedAndSplitNormalsSplitVertices) {
  const std::string path = test::shared_data("mesh/cube.obj");
  SAGITTA_REQUIRE_DATA(path);
  const Tessellation cube = io::read_mesh(path);
  EXPECT_EQ(cube.positions.size(), 8u);
  EXPECT_EQ(cube.triangles.size(), 12u);
  EXPECT_TRUE(cube.normals.empty());
  const Tessellation split = io::detail::parse_mesh(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\nf 1//2 3//2 2//2\n", "s.obj", ".obj");
  EXPECT_EQ(split.positions.size(), 6u);
  EXPECT_EQ(split.normals.size(), 6u);
}

}  // namespace
}  // namespace sagitta
