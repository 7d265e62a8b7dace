// Uniform-scheme throughput: triangles per second on the teapot at level 6 and on 100 teacups at
// level 5, on one thread and on all cores. Run: build/tests/bench/sagitta_bench
#include "sagitta/io/model_io.hpp"
#include "sagitta/uniform.hpp"

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <thread>

namespace {

using namespace sagitta;

// `level` < 0: state.range(1) segments per patch side instead of 2^level; `full`: the full
// Tessellation the tea-set rows of `sagitta bench` time (normals, (u, v), patch ids).
void run_uniform(benchmark::State& state, const char* file, int copies, int level, bool full = false) {
  const std::string path = std::string(SAGITTA_SHARED_DATA) + "/" + file;
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared data absent");
    return;
  }
  const Model model = replicate(io::read_bpt(path), copies);
  const Topology topo = build_topology(model);
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(state.range(0)));
  UniformParams params;
  params.segments = level >= 0 ? segments_for_level(level) : static_cast<int>(state.range(1));
  params.surface_data = full;
  size_t triangles = 0;
  for (auto _ : state) {
    const Tessellation t = tessellate_uniform(model, topo, params);
    triangles = t.triangles.size();
    benchmark::DoNotOptimize(t.positions.data());
  }
  state.counters["triangles"] = static_cast<double>(triangles);
  state.counters["triangles_per_s"] =
      benchmark::Counter(static_cast<double>(triangles), benchmark::Counter::kIsIterationInvariantRate);
}

const int kAllCores = static_cast<int>(std::thread::hardware_concurrency());

void BM_UniformTeapotLevel6(benchmark::State& s) { run_uniform(s, "teapot.bpt", 1, 6); }
void BM_UniformTeacups100Level5(benchmark::State& s) { run_uniform(s, "teacup.bpt", 100, 5); }
void BM_TessellateTeapotFull(benchmark::State& s) { run_uniform(s, "teapot.bpt", 1, -1, true); }
BENCHMARK(BM_UniformTeapotLevel6)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_UniformTeacups100Level5)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
// One thread, N = 13 and 42 (the teapot's fits at 1e-2 and 1e-3).
BENCHMARK(BM_TessellateTeapotFull)->Args({1, 13})->Args({1, 42})->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
