// Topology verdict: planted defects in our own meshes (with (u, v)) and in OBJ files written to a
// temporary folder (no (u, v)); each is counted exactly and located.
#include "sagitta/fixtures.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/uniform.hpp"
#include "test_support.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>

#include <unistd.h>

namespace sagitta {
namespace {

Tessellation uniform(const Model& model, int segments) {
  UniformParams params;
  params.segments = segments;
  return tessellate_uniform(model, build_topology(model), params);
}

void erase_triangle(Tessellation& m, size_t t) {
  m.triangles.erase(m.triangles.begin() + static_cast<long>(t));
  m.triangle_patch.erase(m.triangle_patch.begin() + static_cast<long>(t));
  m.triangle_uv.erase(m.triangle_uv.begin() + static_cast<long>(t));
}

void append_triangle(Tessellation& m, const Triangle& tri, uint32_t patch, const std::array<Vec2, 3>& uv) {
  m.triangles.push_back(tri);
  m.triangle_patch.push_back(patch);
  m.triangle_uv.push_back(uv);
}

// A triangle sharing edge (t[0], t[1]) with triangle t, or -1.
long neighbour_across(const Tessellation& m, size_t t) {
  const Triangle& a = m.triangles[t];
  for (size_t s = 0; s < m.triangles.size(); ++s) {
    if (s == t) continue;
    const Triangle& b = m.triangles[s];
    for (int k = 0; k < 3; ++k) {
      if (b[k] == a[1] && b[(k + 1) % 3] == a[0]) return static_cast<long>(s);
    }
  }
  return -1;
}

struct Case {
  std::string name;
  std::function<void(Tessellation&)> plant;
  std::function<void(const TopologyReport&, const Tessellation&)> check;
};

const TopologyFinding* find(const TopologyReport& r, const std::string& kind) {
  for (const auto& f : r.findings) {
    if (f.kind == kind) return &f;
  }
  return nullptr;
}

// Planted defects on a closed pillow box at 4 segments (patch 2, an interior triangle).
std::vector<Case> cases() {
  const size_t t0 = 2 * 32 + 9;  // patch 2 (32 triangles per patch), away from the patch sides
  std::vector<Case> c;
  c.push_back({"removed triangle",
               [=](Tessellation& m) { erase_triangle(m, t0); },
               [=](const TopologyReport& r, const Tessellation&) {
                 EXPECT_EQ(r.open_edges, 3u);
                 EXPECT_EQ(r.crack_edges, 3u);
                 EXPECT_EQ(r.model_boundary_edges, 0u);
                 ASSERT_NE(find(r, "crack_edge"), nullptr);
               }});
  c.push_back({"nudged duplicate vertex",
               [=](Tessellation& m) {
                 const uint32_t v = m.triangles[t0][0];
                 m.positions.push_back(m.positions[v] + Vec3(1e-4, 0, 0));
                 if (!m.normals.empty()) m.normals.push_back(m.normals[v]);
                 if (!m.surface_points.empty()) m.surface_points.push_back(m.surface_points[v]);
                 m.triangles[t0][0] = static_cast<uint32_t>(m.positions.size() - 1);
               },
               [=](const TopologyReport& r, const Tessellation& m) {
                 EXPECT_EQ(r.crack_edges, 4u);
                 EXPECT_EQ(r.model_boundary_edges, 0u);
                 const TopologyFinding* f = find(r, "crack_edge");
                 ASSERT_NE(f, nullptr);
                 EXPECT_LT(glm::length(f->position - m.positions.back()), 1.0);
               }});
  c.push_back({"T-junction",
               [=](Tessellation& m) {
                 const Triangle t = m.triangles[t0];
                 const auto uv = m.triangle_uv[t0];
                 const uint32_t patch = m.triangle_patch[t0];
                 m.positions.push_back(0.5 * (m.positions[t[0]] + m.positions[t[1]]));
                 if (!m.normals.empty()) m.normals.push_back(m.normals[t[0]]);
                 if (!m.surface_points.empty()) m.surface_points.push_back(m.surface_points[t[0]]);
                 const uint32_t mid = static_cast<uint32_t>(m.positions.size() - 1);
                 const Vec2 muv = 0.5 * (uv[0] + uv[1]);
                 erase_triangle(m, t0);
                 append_triangle(m, {t[0], mid, t[2]}, patch, {uv[0], muv, uv[2]});
                 append_triangle(m, {mid, t[1], t[2]}, patch, {muv, uv[1], uv[2]});
               },
               [=](const TopologyReport& r, const Tessellation& m) {
                 EXPECT_EQ(r.t_junctions, 1u);
                 EXPECT_EQ(r.crack_edges, 3u);  // (a, m), (m, b) on one side, (a, b) on the other
                 const TopologyFinding* f = find(r, "t_junction");
                 ASSERT_NE(f, nullptr);
                 EXPECT_EQ(f->position, m.positions.back());
                 EXPECT_EQ(f->vertices[0], static_cast<int64_t>(m.positions.size() - 1));
               }});
  c.push_back({"flipped triangle",
               [=](Tessellation& m) { std::swap(m.triangles[t0][1], m.triangles[t0][2]); },
               [=](const TopologyReport& r, const Tessellation&) {
                 EXPECT_EQ(r.inconsistent_orientation_edges, 3u);
                 EXPECT_EQ(r.open_edges, 0u);
                 const TopologyFinding* f = find(r, "inconsistent_orientation_edge");
                 ASSERT_NE(f, nullptr);
                 if (f->patch >= 0) EXPECT_EQ(f->patch, 2);  // located in its patch when (u, v) are known
               }});
  c.push_back({"duplicated face",
               [=](Tessellation& m) { append_triangle(m, m.triangles[t0], m.triangle_patch[t0], m.triangle_uv[t0]); },
               [=](const TopologyReport& r, const Tessellation&) {
                 EXPECT_EQ(r.non_manifold_edges, 3u);
                 EXPECT_EQ(r.duplicated_faces, 1u);
                 EXPECT_EQ(r.open_edges, 0u);
                 ASSERT_NE(find(r, "non_manifold_edge"), nullptr);
               }});
  return c;
}

TEST(MeshCheck, CleanClosedMeshHasNoFindings) {
  const Model model = fixtures::pillow_box();
  const Topology topo = build_topology(model);
  const Tessellation mesh = uniform(model, 4);
  const TopologyReport r = check_mesh_topology(mesh, &model, &topo);
  EXPECT_EQ(r.open_edges + r.t_junctions + r.non_manifold_edges + r.inconsistent_orientation_edges + r.degenerate_triangles +
                r.duplicated_faces,
            0u);
  EXPECT_TRUE(r.watertight());
  EXPECT_TRUE(r.findings.empty());
  const test::MeshCounts counts = test::count_topology(mesh);  // independent reference
  EXPECT_EQ(r.edges, counts.edges);
}

TEST(MeshCheck, PlantedDefectsInOurMeshes) {
  const Model model = fixtures::pillow_box();
  const Topology topo = build_topology(model);
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    Tessellation mesh = uniform(model, 4);
    c.plant(mesh);
    const TopologyReport r = check_mesh_topology(mesh, &model, &topo);
    EXPECT_TRUE(r.classified_with_uv);
    EXPECT_FALSE(r.watertight() && r.inconsistent_orientation_edges == 0 && r.duplicated_faces == 0);
    c.check(r, mesh);
    // Counts agree with the independent counter of the unit tests.
    const test::MeshCounts counts = test::count_topology(mesh);
    EXPECT_EQ(r.open_edges, counts.open_edges);
    EXPECT_EQ(r.non_manifold_edges, counts.nonmanifold_edges);
  }
}

TEST(MeshCheck, PlantedDefectsInObjFiles) {
  const Model model = fixtures::pillow_box();
  const Topology topo = build_topology(model);
  const auto dir = std::filesystem::temp_directory_path() / ("sagitta_mesh_check_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    Tessellation mesh = uniform(model, 4);
    c.plant(mesh);
    const std::string path = (dir / "planted.obj").string();
    io::detail::write_obj(mesh, path);
    const Tessellation read = io::read_mesh(path);
    ASSERT_FALSE(read.has_surface());
    const TopologyReport r = check_mesh_topology(read, &model, &topo);
    EXPECT_FALSE(r.classified_with_uv);
    c.check(r, read);
  }
  std::filesystem::remove_all(dir);
}

// The cube [-1, 1]^3 as 6 bilinear patches, du x dv pointing outwards: enclosed volume exactly 8.
Model bilinear_cube() {
  struct Face {
    int fixed_axis, fixed_value, u_axis, v_axis;
  };
  const Face faces[] = {{0, 1, 1, 2}, {0, 0, 2, 1}, {1, 1, 2, 0}, {1, 0, 0, 2}, {2, 1, 0, 1}, {2, 0, 1, 0}};
  Model model;
  for (const Face& f : faces) {
    BezierPatch patch;
    patch.degree_u = patch.degree_v = 1;
    for (int a = 0; a <= 1; ++a) {
      for (int b = 0; b <= 1; ++b) {
        double c[3];
        c[f.fixed_axis] = 2.0 * f.fixed_value - 1.0;
        c[f.u_axis] = 2.0 * a - 1.0;
        c[f.v_axis] = 2.0 * b - 1.0;
        patch.points.push_back(Vec3(c[0], c[1], c[2]));
      }
    }
    model.patches.push_back(std::move(patch));
  }
  return model;
}

// x -> -x on the patches [first, last) (a determinant -1 placement), patch order and (u, v) unchanged.
Model mirrored(Model model, size_t first, size_t last) {
  for (size_t p = first; p < last; ++p) {
    for (Vec3& q : model.patches[p].points) q.x = -q.x;
  }
  return model;
}

TopologyReport topology_of(const Model& model, int segments) {
  const Topology topo = build_topology(model);
  return check_mesh_topology(uniform(model, segments), &model, &topo);
}

// Issue 20 item 9: a mirrored part is inside-out and used to go unreported.
TEST(MeshCheck, SignedVolumeOfClosedComponents) {
  const TopologyReport cube = topology_of(bilinear_cube(), 3);
  ASSERT_EQ(cube.components, 1u);
  ASSERT_EQ(cube.component_list.size(), 1u);
  EXPECT_TRUE(cube.component_list[0].closed);
  EXPECT_NEAR(cube.component_list[0].signed_volume, 8.0, 1e-12);
  EXPECT_EQ(cube.inside_out_components, 0u);
  EXPECT_EQ(find(cube, "inside_out_component"), nullptr);

  const TopologyReport flipped = topology_of(mirrored(bilinear_cube(), 0, 6), 3);
  ASSERT_EQ(flipped.component_list.size(), 1u);
  EXPECT_TRUE(flipped.component_list[0].closed);
  EXPECT_NEAR(flipped.component_list[0].signed_volume, -8.0, 1e-12);
  EXPECT_TRUE(flipped.component_list[0].inside_out);
  EXPECT_EQ(flipped.inside_out_components, 1u);
  ASSERT_NE(find(flipped, "inside_out_component"), nullptr);
  // The mirror image is consistently oriented within itself: only the volume tells.
  EXPECT_EQ(flipped.inconsistent_orientation_edges, 0u);
  EXPECT_TRUE(flipped.watertight());
}

TEST(MeshCheck, MirroredComponentReportedSeparately) {
  // Default model: the pillow box (patches 0..5) and the torus (6..21), two closed components.
  const Model model = fixtures::default_model();
  const TopologyReport plain = topology_of(model, 16);
  ASSERT_EQ(plain.components, 2u);
  EXPECT_EQ(plain.closed_components, 2u);
  EXPECT_EQ(plain.inside_out_components, 0u);
  ASSERT_EQ(plain.component_list.size(), 2u);
  const MeshComponent& box = plain.component_list[0];
  const MeshComponent& torus = plain.component_list[1];
  EXPECT_GT(box.signed_volume, 8.0);  // the cube [-1, 1]^3 bulged outwards
  EXPECT_NEAR(torus.signed_volume, 2.0 * M_PI * M_PI * 2.0 * 0.5 * 0.5, 0.01 * 9.87);  // 2 pi^2 R r^2
  EXPECT_EQ(box.patch, 0);
  EXPECT_EQ(torus.patch, 6);

  // Only the torus mirrored: it alone is inside-out, with the opposite volume.
  const TopologyReport one = topology_of(mirrored(model, 6, model.patches.size()), 16);
  ASSERT_EQ(one.component_list.size(), 2u);
  EXPECT_EQ(one.inside_out_components, 1u);
  EXPECT_FALSE(one.component_list[0].inside_out);
  EXPECT_NEAR(one.component_list[0].signed_volume, box.signed_volume, 1e-9 * box.signed_volume);
  EXPECT_TRUE(one.component_list[1].inside_out);
  EXPECT_NEAR(one.component_list[1].signed_volume, -torus.signed_volume, 1e-9 * torus.signed_volume);
  const TopologyFinding* f = find(one, "inside_out_component");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->patch, 6);
  EXPECT_LT(f->position.x, 0.0);  // the mirrored torus sits around x = -5
}

TEST(MeshCheck, OpenComponentHasNoVolume) {
  Model model;
  model.patches = {fixtures::random_patch(3, 3, 4)};
  const TopologyReport r = topology_of(model, 4);
  ASSERT_EQ(r.component_list.size(), 1u);
  EXPECT_FALSE(r.component_list[0].closed);
  EXPECT_EQ(r.component_list[0].signed_volume, 0.0);
  EXPECT_EQ(r.closed_components, 0u);
  EXPECT_EQ(r.inside_out_components, 0u);
}

TEST(MeshCheck, TeapotFreeBoundaryIsModelBoundary) {
  const std::string path = test::shared_data("teapot.bpt");
  SAGITTA_REQUIRE_DATA(path);
  const Model model = io::read_bpt(path);
  const Topology topo = build_topology(model);
  const Tessellation mesh = uniform(model, 8);
  const TopologyReport with_uv = check_mesh_topology(mesh, &model, &topo);
  // 16 free boundary curves (PROVENANCE.md) x 8 segments each.
  EXPECT_EQ(with_uv.model_boundary_edges, 16u * 8u);
  EXPECT_EQ(with_uv.crack_edges, 0u);
  EXPECT_EQ(with_uv.t_junctions, 0u);
  // The same mesh through an OBJ file (no (u, v)): classified by distance to the free curves.
  const auto file = std::filesystem::temp_directory_path() / ("sagitta_teapot_" + std::to_string(::getpid()) + ".obj");
  io::detail::write_obj(mesh, file.string());
  const TopologyReport without = check_mesh_topology(io::read_mesh(file.string()), &model, &topo);
  std::filesystem::remove(file);
  EXPECT_EQ(without.model_boundary_edges, 16u * 8u);
  EXPECT_EQ(without.crack_edges, 0u);
}

}  // namespace
}  // namespace sagitta
