#include "sagitta/uniform.hpp"

#include "sagitta/boundary.hpp"
#include "sagitta/evaluate.hpp"

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <cmath>

namespace sagitta {

int segments_for_level(int level) {
  if (level < 0 || level > kMaxUniformLevel) {
    throw InputError("--level " + std::to_string(level) + " is outside 0.." + std::to_string(kMaxUniformLevel) +
                     " (level L gives 2^L segments per side; 2^" + std::to_string(kMaxUniformLevel) +
                     " already makes 33.5 million triangles per patch)");
  }
  return 1 << level;
}

int segments_for_paper_level(int level) {
  if (level < 1 || level > kMaxUniformLevel) {
    throw InputError("paper level " + std::to_string(level) + " is outside 1.." + std::to_string(kMaxUniformLevel));
  }
  return (1 << (level + 1)) - 1;
}

uint64_t uniform_triangle_count(const Model& model, int segments) {
  return 2ull * static_cast<uint64_t>(segments) * static_cast<uint64_t>(segments) * model.patches.size();
}

Tessellation tessellate_uniform(const Model& model, const Topology& topology, const UniformParams& params) {
  const int n = params.segments;
  if (n < 1) throw InputError("--segments must be >= 1, got " + std::to_string(n));
  const size_t np = model.patches.size();
  const BoundaryLayout layout = layout_boundary(topology, [n](size_t) { return n; }, 0);
  const uint64_t interior_per_patch = static_cast<uint64_t>(n - 1) * static_cast<uint64_t>(n - 1);
  const uint64_t vertex_count = layout.end + interior_per_patch * np;
  if (vertex_count > UINT32_MAX) throw InputError("the tessellation needs more than 2^32 vertices; lower the level");

  Tessellation out;
  out.positions.resize(vertex_count);
  if (params.normals) out.normals.resize(vertex_count);
  if (params.surface_data) out.surface_points.resize(vertex_count);
  fill_boundary(model, topology, layout, out);

  const uint64_t cells = static_cast<uint64_t>(n) * static_cast<uint64_t>(n);
  std::vector<Triangle> slots(2 * cells * np);
  constexpr uint32_t kSkip = UINT32_MAX;

  tbb::parallel_for(size_t{0}, np, [&](size_t p) {
    const BezierPatch& patch = model.patches[p];
    const uint32_t pid = static_cast<uint32_t>(p);
    const uint64_t interior_base = layout.end + interior_per_patch * p;
    auto vertex = [&](int a, int b) -> uint32_t {
      if (a == 0) return side_vertex(layout, topology, pid, Side::kU0, b);
      if (a == n) return side_vertex(layout, topology, pid, Side::kU1, b);
      if (b == 0) return side_vertex(layout, topology, pid, Side::kV0, a);
      if (b == n) return side_vertex(layout, topology, pid, Side::kV1, a);
      return static_cast<uint32_t>(interior_base + static_cast<uint64_t>(a - 1) * (n - 1) + (b - 1));
    };

    // Interior samples: the matrix form, one u-contraction per grid row.
    if (n > 1) {
      const PatchEvaluator eval(patch);
      const int du = patch.degree_u, dv = patch.degree_v;
      std::vector<double> bv(static_cast<size_t>((n + 1) * (dv + 1))), dbv(bv.size());
      for (int b = 1; b < n; ++b) {
        eval.basis_row(dv, static_cast<double>(b) / n, &bv[static_cast<size_t>(b * (dv + 1))],
                       &dbv[static_cast<size_t>(b * (dv + 1))]);
      }
      double a_row[kMaxDegree + 1], da_row[kMaxDegree + 1];
      std::array<double, 4> row[kMaxDegree + 1], drow[kMaxDegree + 1];
      for (int a = 1; a < n; ++a) {
        const double u = static_cast<double>(a) / n;
        eval.basis_row(du, u, a_row, da_row);
        eval.contract_u(a_row, da_row, row, drow);
        for (int b = 1; b < n; ++b) {
          const double v = static_cast<double>(b) / n;
          const SurfacePointEval e = eval.finish(row, drow, &bv[static_cast<size_t>(b * (dv + 1))],
                                                 &dbv[static_cast<size_t>(b * (dv + 1))]);
          const uint32_t id = vertex(a, b);
          out.positions[id] = e.position;
          if (params.normals) {
            const Vec3 cr = glm::cross(e.du, e.dv);
            const double len = glm::length(cr);
            out.normals[id] = (len > 0.0 && std::isfinite(len)) ? cr / len : surface_normal(patch, u, v);
          }
          if (params.surface_data) out.surface_points[id] = {pid, u, v};
        }
      }
    }

    // Two triangles per cell, oriented like the (u, v) square.
    Triangle* t = &slots[2 * cells * p];
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b, t += 2) {
        const uint32_t v00 = vertex(a, b), v10 = vertex(a + 1, b), v01 = vertex(a, b + 1), v11 = vertex(a + 1, b + 1);
        t[0] = {v00, v10, v11};
        t[1] = {v00, v11, v01};
        for (int k = 0; k < 2; ++k) {
          const Triangle& tri = t[k];
          if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) t[k][0] = kSkip;
        }
      }
    }
  });

  // Compact in patch order, so the output is independent of scheduling.
  out.triangles.reserve(slots.size());
  if (params.surface_data) {
    out.triangle_patch.reserve(slots.size());
    out.triangle_uv.reserve(slots.size());
  }
  const double nd = static_cast<double>(n);
  for (size_t s = 0; s < slots.size(); ++s) {
    if (slots[s][0] == kSkip) {
      ++out.degenerate_triangles;
      continue;
    }
    out.triangles.push_back(slots[s]);
    if (params.surface_data) {
      const size_t p = s / (2 * cells);
      const size_t cell = (s % (2 * cells)) / 2;
      const double a = static_cast<double>(cell / n), b = static_cast<double>(cell % n);
      const Vec2 uv00(a / nd, b / nd), uv10((a + 1) / nd, b / nd), uv01(a / nd, (b + 1) / nd),
          uv11((a + 1) / nd, (b + 1) / nd);
      out.triangle_patch.push_back(static_cast<uint32_t>(p));
      if (s % 2 == 0) {
        out.triangle_uv.push_back({uv00, uv10, uv11});
      } else {
        out.triangle_uv.push_back({uv00, uv11, uv01});
      }
    }
  }
  return out;
}

}  // namespace sagitta
