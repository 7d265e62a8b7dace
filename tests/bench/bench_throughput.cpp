// Issue 10 throughput: the store bandwidth (memset of 512 MiB) and the positions-only uniform grid
// (float32 and double) on 100 teacups at level 6, on one thread and on all cores; the Teacups scene
// at L = 3 with the prepared plan; the full Tessellations of the uniform scheme (L = 6) and of ESC
// (L = 7, rho = 0) on the same 100 teacups, positions only, as `sagitta bench` times them (issue 17:
// ESC per triangle against uniform). Run: build/tests/bench/sagitta_bench --benchmark_filter=Grid|Store|Scheme
#include "sagitta/io/model_io.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/uniform_grid.hpp"

#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cstring>
#include <filesystem>
#include <thread>
#include <vector>

namespace {

using namespace sagitta;

void BM_StoreMemset(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(state.range(0)));
  const size_t bytes = size_t{512} << 20, chunk = size_t{1} << 20;
  std::vector<char> buffer(bytes, 1);
  int value = 0;
  for (auto _ : state) {
    ++value;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, bytes / chunk), [&](const tbb::blocked_range<size_t>& r) {
      std::memset(buffer.data() + r.begin() * chunk, value, (r.end() - r.begin()) * chunk);
    });
    benchmark::DoNotOptimize(buffer.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(bytes));
}

template <class T>
void run_grid(benchmark::State& state, int copies, int level, bool prepared) {
  const std::string path = std::string(SAGITTA_SHARED_DATA) + "/teacup.bpt";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared data absent");
    return;
  }
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(state.range(0)));
  const Model model = replicate(io::read_bpt(path), copies);
  const int n = 1 << level;
  const UniformGridPlan plan(model, n);
  std::vector<T> xyz(3 * plan.vertices(), T(0));
  for (auto _ : state) {
    if (prepared) {
      plan.run(xyz.data());
    } else {
      tessellate_uniform_grid(model, n, xyz.data());
    }
    benchmark::DoNotOptimize(xyz.data());
  }
  const double triangles = 2.0 * n * n * static_cast<double>(model.patches.size());
  state.counters["triangles_per_s"] = benchmark::Counter(triangles, benchmark::Counter::kIsIterationInvariantRate);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(xyz.size() * sizeof(T)));
}

// One scheme's full Tessellation (no normals, no surface data) on 100 teacups.
void run_scheme(benchmark::State& state, Scheme scheme, int level) {
  const std::string path = std::string(SAGITTA_SHARED_DATA) + "/teacup.bpt";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared data absent");
    return;
  }
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(state.range(0)));
  const Model model = replicate(io::read_bpt(path), 100);
  const Topology topology = build_topology(model);
  SchemeSpec spec;
  spec.scheme = scheme;
  spec.level = level;
  spec.vertex_normals = false;
  spec.surface_data = false;
  spec.guard = false;
  double triangles = 0.0;
  for (auto _ : state) {
    const Tessellation mesh = tessellate(model, topology, spec);
    triangles = static_cast<double>(mesh.triangles.size());
    benchmark::DoNotOptimize(mesh.triangles.data());
  }
  state.counters["triangles"] = triangles;
  state.counters["triangles_per_s"] = benchmark::Counter(triangles, benchmark::Counter::kIsIterationInvariantRate);
}

const int kAllCores = static_cast<int>(std::thread::hardware_concurrency());

void BM_GridFloat32Teacups100Level6(benchmark::State& s) { run_grid<float>(s, 100, 6, false); }
void BM_GridDoubleTeacups100Level6(benchmark::State& s) { run_grid<double>(s, 100, 6, false); }
void BM_GridFloat32TeacupsSceneLevel3Prepared(benchmark::State& s) { run_grid<float>(s, 100, 3, true); }
void BM_SchemeUniformTeacups100Level6(benchmark::State& s) { run_scheme(s, Scheme::kUniform, 6); }
void BM_SchemeEscTeacups100Level7(benchmark::State& s) { run_scheme(s, Scheme::kEsc, 7); }
BENCHMARK(BM_SchemeUniformTeacups100Level6)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SchemeEscTeacups100Level7)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_StoreMemset)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_GridFloat32Teacups100Level6)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_GridDoubleTeacups100Level6)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_GridFloat32TeacupsSceneLevel3Prepared)->Arg(1)->Arg(kAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
