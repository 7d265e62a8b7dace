// Whole parts (issue 14): every face of the shared CAD files tessellated into one mesh that is
// closed per closed, valid solid, with the solid's volume, checked by the project's mesh check.
#include "sagitta/mesh_check.hpp"
#include "sagitta/occt/part.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace sagitta::occt {
namespace {

const std::string kData = SAGITTA_SHARED_DATA;

std::vector<std::string> shared_cad_files() {
  std::vector<std::string> files;
  if (const char* probe = std::getenv("SAGITTA_PART_PROBE")) {
    std::string list = probe;
    for (size_t a = 0, b; a < list.size(); a = b + 1) {
      b = list.find(',', a);
      if (b == std::string::npos) b = list.size();
      files.push_back(list.substr(a, b - a));
    }
    return files;
  }
  for (const char* f : {"cad/bottle.brep", "cad/screw.step", "cad/shell1.brep", "cad/wing.brep", "cad/MAT.brep"})
    files.push_back(kData + "/" + f);
  for (const auto& e : std::filesystem::directory_iterator(kData + "/cad/step")) {
    const std::string ext = e.path().extension().string();
    if (ext == ".step" || ext == ".stp" || ext == ".igs" || ext == ".iges") files.push_back(e.path().string());
  }
  std::sort(files.begin() + 5, files.end());
  return files;
}

// The triangles of one solid as a mesh of their own (vertices renumbered), so that the topology
// check sees only that solid.
Tessellation solid_mesh(const PartMesh& part, int32_t solid) {
  Tessellation m;
  std::map<uint32_t, uint32_t> renumber;
  for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
    if (part.triangle_solid[t] != solid) continue;
    Triangle tri;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = part.mesh.triangles[t][k];
      auto [it, added] = renumber.emplace(v, static_cast<uint32_t>(m.positions.size()));
      if (added) m.positions.push_back(part.mesh.positions[v]);
      tri[k] = it->second;
    }
    m.triangles.push_back(tri);
  }
  return m;
}

TEST(Part, ProbeSharedFiles) {
  for (const std::string& file : shared_cad_files()) {
    PartOptions options;
    options.scheme.level = std::getenv("SAGITTA_PART_LEVEL") ? std::atoi(std::getenv("SAGITTA_PART_LEVEL")) : 2;
    const PartMesh part = mesh_part_file(file, options);
    std::printf("%s: faces %zu tessellated %d skipped %d triangles %zu edges %d %.2fs\n",
                std::filesystem::path(file).filename().c_str(), part.faces.size(), part.faces_tessellated,
                part.faces_skipped, part.mesh.triangles.size(), part.edges, part.seconds);
    for (const PartFace& f : part.faces) {
      if (f.status != "tessellated") std::printf("  %s %s: %s\n", f.name.c_str(), f.surface_type.c_str(), f.reason.c_str());
    }
    if (std::getenv("SAGITTA_PART_FACES")) {
      for (const PartFace& f : part.faces) {
        Tessellation fm;
        PartMesh one = part;
        for (size_t t = 0; t < part.mesh.triangles.size(); ++t) one.triangle_solid[t] = part.triangle_face[t] == uint32_t(f.face_index) ? 0 : -1;
        const Tessellation m = solid_mesh(one, 0);
        const TopologyReport r = check_mesh_topology(m, nullptr, nullptr);
        std::printf("   %s %s trimmed %d: tris %llu kept %llu open %llu nonmanifold %llu inconsistent %llu offset %.3g\n", f.name.c_str(), f.surface_type.c_str(), f.trimmed,
                    (unsigned long long)f.triangles, (unsigned long long)f.scheme_triangles, (unsigned long long)r.open_edges, (unsigned long long)r.non_manifold_edges, (unsigned long long)r.inconsistent_orientation_edges, f.max_boundary_offset);
      }
    }
    for (const PartSolid& s : part.solids) {
      const Tessellation m = solid_mesh(part, s.index);
      const TopologyReport r = check_mesh_topology(m, nullptr, nullptr);
      double volume = 0.0;
      for (const MeshComponent& c : r.component_list) volume += c.signed_volume;
      std::printf("  solid %d closed %d valid %d: open %llu nonmanifold %llu tj %llu inconsistent %llu comps %llu "
                  "volume %.6g occt %.6g\n",
                  s.index, s.closed, s.valid, (unsigned long long)r.open_edges, (unsigned long long)r.non_manifold_edges,
                  (unsigned long long)r.t_junctions, (unsigned long long)r.inconsistent_orientation_edges,
                  (unsigned long long)r.components, volume, s.volume);
      if (std::getenv("SAGITTA_PART_EDGES")) {
        std::map<std::pair<uint32_t, uint32_t>, std::vector<size_t>> uses;
        for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
          if (part.triangle_solid[t] != s.index) continue;
          for (int k = 0; k < 3; ++k) {
            uint32_t a = part.mesh.triangles[t][k], b = part.mesh.triangles[t][(k + 1) % 3];
            uses[{std::min(a, b), std::max(a, b)}].push_back(t);
          }
        }
        int shown = 0;
        for (const auto& [e, ts] : uses) {
          if (ts.size() == 2 || shown > 40) continue;
          ++shown;
          std::printf("    edge %u-%u:", e.first, e.second);
          for (size_t t : ts) std::printf(" t%zu(face %u)", t, part.triangle_face[t] + 1);
          std::printf("\n");
        }
      }
    }
  }
}

}  // namespace
}  // namespace sagitta::occt
