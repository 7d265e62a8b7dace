// Prints the teapot table of docs/PN.md: a uniform base at level L refined by PN at k = 2..8,
// against the plain uniform tessellation with the same triangle count (N = 2^L * k segments).
// Distances are *sampled* (a lower estimate of the true maxima, not certified):
//   parametric: max over samples b of |S(u(b), v(b)) - T(b)|, (u, v)(b) = barycentric interpolation
//               of triangle_uv, T(b) the flat output triangle;
//   closest:    the same samples T(b) projected onto their patch by Gauss-Newton from (u, v)(b)
//               (the normal distance, what a viewer sees).
// Usage: sagitta_pn_bench [teapot.bpt] [samples_per_side]
#include "sagitta/evaluate.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/pn.hpp"
#include "sagitta/uniform.hpp"

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

namespace {

using namespace sagitta;
using sagitta::detail::PatchEvaluator;

struct Distances {
  double parametric = 0.0;
  double closest = 0.0;
  SurfacePoint worst_closest;  // where the closest-point distance is largest
};

Distances sampled_distance(const Model& model, const std::vector<PatchEvaluator>& evals, const Tessellation& mesh, int m) {
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mesh.triangles.size()), Distances{},
      [&](const tbb::blocked_range<size_t>& r, Distances d) {
        for (size_t t = r.begin(); t != r.end(); ++t) {
          const PatchEvaluator& eval = evals[mesh.triangle_patch[t]];
          const auto& uv = mesh.triangle_uv[t];
          const Triangle& tri = mesh.triangles[t];
          for (int i = 0; i <= m; ++i) {
            for (int j = 0; i + j <= m; ++j) {
              const double b1 = double(i) / m, b2 = double(j) / m, b0 = 1.0 - b1 - b2;
              const Vec3 x = b0 * mesh.positions[tri[0]] + b1 * mesh.positions[tri[1]] + b2 * mesh.positions[tri[2]];
              Vec2 p = b0 * uv[0] + b1 * uv[1] + b2 * uv[2];
              SurfacePointEval e = eval.evaluate(p.x, p.y);
              d.parametric = std::max(d.parametric, glm::length(e.position - x));
              for (int it = 0; it < 6; ++it) {  // Gauss-Newton towards the closest point, kept in [0,1]^2
                const Vec3 r0 = x - e.position;
                const double a = glm::dot(e.du, e.du), b = glm::dot(e.du, e.dv), c = glm::dot(e.dv, e.dv);
                const double det = a * c - b * b;
                if (!(det > 1e-30)) break;
                const double gu = glm::dot(e.du, r0), gv = glm::dot(e.dv, r0);
                p.x = std::clamp(p.x + (c * gu - b * gv) / det, 0.0, 1.0);
                p.y = std::clamp(p.y + (a * gv - b * gu) / det, 0.0, 1.0);
                e = eval.evaluate(p.x, p.y);
              }
              const double dc = glm::length(e.position - x);
              if (dc > d.closest) {
                d.closest = dc;
                d.worst_closest = {mesh.triangle_patch[t], p.x, p.y};
              }
            }
          }
        }
        return d;
      },
      [](Distances a, const Distances& b) {
        a.parametric = std::max(a.parametric, b.parametric);
        if (b.closest > a.closest) {
          a.closest = b.closest;
          a.worst_closest = b.worst_closest;
        }
        return a;
      });
  (void)model;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : std::string(SAGITTA_SHARED_DATA) + "/teapot.bpt";
  const int m = argc > 2 ? std::stoi(argv[2]) : 6;
  const Model model = io::read_patch_model(path);
  const Topology topology = build_topology(model);
  std::vector<PatchEvaluator> evals;
  for (const BezierPatch& p : model.patches) evals.emplace_back(p);
  const double diag = model_box(model).diagonal();
  std::printf("model %s: %zu patches, box diagonal %.4f; %d samples per triangle side\n\n", path.c_str(),
              model.patches.size(), diag, m);
  std::printf("| base L | k | PN triangles | PN parametric | PN closest | uniform N | uniform triangles | uniform parametric | uniform closest | PN ms | PN worst (patch u v) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int level = 1; level <= 2; ++level) {
    UniformParams up;
    up.segments = 1 << level;
    const Tessellation base = tessellate_uniform(model, topology, up);
    for (int k = 1; k <= 8; ++k) {
      PnParams params;
      params.factor = k;
      const auto t0 = std::chrono::steady_clock::now();
      const Tessellation pn = tessellate_pn(base, params);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const Distances dp = sampled_distance(model, evals, pn, m);
      UniformParams uq;
      uq.segments = up.segments * k;
      const Tessellation uni = tessellate_uniform(model, topology, uq);
      const Distances du = sampled_distance(model, evals, uni, m);
      std::printf("| %d | %d | %zu | %.3e | %.3e | %d | %zu | %.3e | %.3e | %.1f | %u %.2f %.2f |\n", level, k,
                  pn.triangles.size(), dp.parametric, dp.closest, uq.segments, uni.triangles.size(), du.parametric,
                  du.closest, ms, dp.worst_closest.patch, dp.worst_closest.u, dp.worst_closest.v);
      std::fflush(stdout);
    }
  }
  return 0;
}
