// Certified validation of small meshes (the tea-set rows of `sagitta bench`, issue 17): the time of
// certify_distance on the uniform meshes of the teaspoon, teacup and teapot at a few segments per
// patch side, on one thread (BM_TessellateTeapotFull in bench_uniform.cpp times such a tessellation).
// Run: build/tests/bench/sagitta_bench --benchmark_filter=Certify
#include "sagitta/certify.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/uniform.hpp"

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <filesystem>

namespace {

using namespace sagitta;

void run_certify(benchmark::State& state, const char* file) {
  const std::string path = std::string(SAGITTA_SHARED_DATA) + "/" + file;
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared data absent");
    return;
  }
  const Model model = io::read_bpt(path);
  const Topology topo = build_topology(model);
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
  UniformParams params;
  params.segments = static_cast<int>(state.range(0));
  params.surface_data = true;
  const Tessellation mesh = tessellate_uniform(model, topo, params);
  DistanceReport report;
  for (auto _ : state) {
    report = certify_distance(model, mesh);
    benchmark::DoNotOptimize(report.triangle_upper.data());
  }
  state.counters["triangles"] = static_cast<double>(mesh.triangles.size());
  state.counters["upper"] = report.hausdorff.upper;
}

void BM_CertifyTeaspoon(benchmark::State& s) { run_certify(s, "teaspoon.bpt"); }
void BM_CertifyTeacup(benchmark::State& s) { run_certify(s, "teacup.bpt"); }
void BM_CertifyTeapot(benchmark::State& s) { run_certify(s, "teapot.bpt"); }
BENCHMARK(BM_CertifyTeaspoon)->Arg(4)->Arg(13)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CertifyTeacup)->Arg(7)->Arg(22)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CertifyTeapot)->Arg(13)->Arg(42)->Unit(benchmark::kMillisecond);

}  // namespace
