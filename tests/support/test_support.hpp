// Helpers shared by the unit tests: where the real models live, and mesh topology counts computed
// independently of the code under test.
#pragma once

#include "sagitta/tessellation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <utility>

namespace sagitta::test {

// Path of a file in ../shared/data; the test is skipped (saying so) when the folder is absent.
inline std::string shared_data(const std::string& relative) {
  const std::string path = std::string(SAGITTA_SHARED_DATA) + "/" + relative;
  return path;
}
#define SAGITTA_REQUIRE_DATA(path)                                                         \
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared data absent: " << (path)

struct MeshCounts {
  size_t open_edges = 0;           // undirected edges used by exactly one triangle
  size_t nonmanifold_edges = 0;    // used by more than two triangles
  size_t misoriented_edges = 0;    // a directed edge used twice (neighbours disagree on orientation)
  size_t edges = 0;
  size_t used_vertices = 0;
  long euler() const { return static_cast<long>(used_vertices) - static_cast<long>(edges) + static_cast<long>(faces); }
  size_t faces = 0;
};

inline MeshCounts count_topology(const Tessellation& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> undirected, directed;
  std::map<uint32_t, int> used;
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      ++undirected[{std::min(a, b), std::max(a, b)}];
      ++directed[{a, b}];
      used[a] = 1;
    }
  }
  MeshCounts c;
  c.faces = mesh.triangles.size();
  c.edges = undirected.size();
  c.used_vertices = used.size();
  for (const auto& [e, n] : undirected) {
    if (n == 1) ++c.open_edges;
    if (n > 2) ++c.nonmanifold_edges;
  }
  for (const auto& [e, n] : directed) {
    if (n > 1) ++c.misoriented_edges;
  }
  return c;
}

}  // namespace sagitta::test
