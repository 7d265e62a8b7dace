// Certified companion of sagitta_pn_bench: the validator's Hausdorff interval for the teapot with a
// uniform base at level L refined by PN at k, and for plain uniform with N = 2^L * k segments.
// Usage: sagitta_pn_certify [teapot.bpt] [max_depth]
#include "sagitta/certify.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/pn.hpp"
#include "sagitta/uniform.hpp"

#include <cstdio>
#include <string>

int main(int argc, char** argv) {
  using namespace sagitta;
  const std::string path = argc > 1 ? argv[1] : std::string(SAGITTA_SHARED_DATA) + "/teapot.bpt";
  CertifyOptions options;
  if (argc > 2) options.max_depth = std::stoi(argv[2]);
  const Model model = io::read_patch_model(path);
  const Topology topology = build_topology(model);
  std::printf("| base L | k | mesh | triangles | mesh->surface [lower, upper] | Hausdorff [lower, upper] | certified | seconds |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (int level = 1; level <= 2; ++level) {
    UniformParams up;
    up.segments = 1 << level;
    const Tessellation base = tessellate_uniform(model, topology, up);
    for (int k : {2, 4, 8}) {
      PnParams params;
      params.factor = k;
      UniformParams uq;
      uq.segments = up.segments * k;
      const Tessellation meshes[2] = {tessellate_pn(base, params), tessellate_uniform(model, topology, uq)};
      const char* names[2] = {"PN", "uniform"};
      for (int i = 0; i < 2; ++i) {
        const DistanceReport r = certify_distance(model, meshes[i], options);
        std::printf("| %d | %d | %s | %zu | [%.3e, %.3e] | [%.3e, %.3e] | %s | %.1f |\n", level, k, names[i],
                    meshes[i].triangles.size(), r.mesh_to_surface.lower, r.mesh_to_surface.upper, r.hausdorff.lower,
                    r.hausdorff.upper, r.hausdorff.certified ? "yes" : "no", r.seconds);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
