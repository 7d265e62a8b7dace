// `sagitta bench`: the performance numbers of docs/BENCHMARKS.md in one run.
// Sections: store bandwidth (memset, copy), scheme throughput (single thread and all threads),
// the Teacups scene at L = 3, the tea set against OCCT's BRepMesh at equal certified error, and
// certified validation time against tessellation time. Prints a table; --json writes the numbers.
#include "commands.hpp"

#include "sagitta/app/fit_search.hpp"

#include "sagitta/esc.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/uniform.hpp"
#include "sagitta/uniform_grid.hpp"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>

namespace sagitta::cli {

namespace {

struct BenchOptions {
  std::string json;
  std::string data;  // folder with teapot.bpt, teacup.bpt, teaspoon.bpt
  bool quick = false;
  bool skip_occt = false;
};

// Smallest wall time of `repeats` runs of f after one untimed warm-up run.
template <class F>
double best_seconds(int repeats, F&& f) {
  f();
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeats; ++r) {
    const Stopwatch w;
    f();
    best = std::min(best, w.seconds());
  }
  return best;
}

// Runs f() with at most `threads` TBB workers.
template <class F>
double timed_with_threads(int threads, int repeats, F&& f) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
  return best_seconds(repeats, f);
}

// Splits [0, bytes) into 1 MiB chunks over the TBB workers.
template <class F>
void over_chunks(size_t bytes, F&& f) {
  constexpr size_t kChunk = size_t{1} << 20;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, (bytes + kChunk - 1) / kChunk), [&](const tbb::blocked_range<size_t>& r) {
    const size_t begin = r.begin() * kChunk, end = std::min(bytes, r.end() * kChunk);
    f(begin, end - begin);
  });
}

nlohmann::json rate_json(double seconds, double triangles, double bytes) {
  return {{"seconds", seconds},
          {"triangles", triangles},
          {"triangles_per_s", triangles / seconds},
          {"output_bytes", bytes},
          {"output_bytes_per_s", bytes / seconds}};
}

double mesh_bytes(const Tessellation& t) {
  return static_cast<double>(t.positions.size() * sizeof(Vec3) + t.normals.size() * sizeof(Vec3) +
                             t.triangles.size() * sizeof(Triangle));
}

std::string data_path(const BenchOptions& o, const std::string& file) {
  std::string dir = o.data;
  if (dir.empty()) {
    if (const char* env = std::getenv("SAGITTA_SHARED_DATA"); env && *env) dir = env;
  }
  if (dir.empty()) throw InputError("sagitta bench needs the tea set: pass --data DIR or set SAGITTA_SHARED_DATA");
  const std::string path = (std::filesystem::path(dir) / file).string();
  if (!std::filesystem::exists(path)) throw InputError(path + ": not found (sagitta bench needs teapot, teacup, teaspoon .bpt)");
  return path;
}

// Store bandwidth: memset of a buffer far bigger than the caches, and memcpy between two such
// buffers (bytes written per second), best of `repeats`, on `threads` workers.
nlohmann::json bandwidth(size_t bytes, int repeats, int threads) {
  std::vector<char> a(bytes, 1), b(bytes, 2);  // touched: page faults stay out of the timing
  int value = 0;
  const double set = timed_with_threads(threads, repeats, [&] {
    ++value;
    over_chunks(bytes, [&](size_t at, size_t n) { std::memset(a.data() + at, value, n); });
  });
  const double copy = timed_with_threads(threads, repeats, [&] {
    over_chunks(bytes, [&](size_t at, size_t n) { std::memcpy(b.data() + at, a.data() + at, n); });
  });
  if (a[bytes / 2] != b[bytes / 3]) std::cerr << "";  // keeps the buffers observable
  return {{"threads", threads},
          {"buffer_bytes", bytes},
          {"memset_bytes_per_s", static_cast<double>(bytes) / set},
          {"copy_bytes_per_s", static_cast<double>(bytes) / copy}};
}

void print_rate(const std::string& name, int threads, const nlohmann::json& j, double store = 0.0) {
  std::printf("  %-28s %2d thr  %10.3f ms  %8.1f M tri/s  %7.2f GB/s", name.c_str(), threads,
              j["seconds"].get<double>() * 1e3, j["triangles_per_s"].get<double>() * 1e-6,
              j["output_bytes_per_s"].get<double>() * 1e-9);
  if (store > 0.0) std::printf("  (%.0f%% of memset)", 100.0 * j["output_bytes_per_s"].get<double>() / store);
  std::printf("\n");
}

// Bench times the kernels at sizes it chose: no front end's size guard.
SchemeSpec unguarded(Scheme scheme) {
  SchemeSpec spec;
  spec.scheme = scheme;
  spec.guard = false;
  return spec;
}

// Refuses a --json output that is one of the tea-set inputs (a missing file is reported where it is read).
void check_bench_outputs(const BenchOptions& o) {
  if (o.json.empty()) return;
  std::vector<std::string> inputs;
  for (const char* file : {"teapot.bpt", "teacup.bpt", "teaspoon.bpt"}) {
    try {
      inputs.push_back(data_path(o, file));
    } catch (const InputError&) {  // a missing file is reported where it is read
    }
  }
  check_outputs({{"--json", o.json}}, inputs);
}

// What every section needs: the thread counts, the repeats and the document being filled.
struct BenchRun {
  const BenchOptions& options;
  int all = 1;      // threads of "all threads"
  int repeats = 5;  // best of
  nlohmann::json& doc;
};

// 1. Store bandwidth, single thread and all threads; returns memset bytes per second of each.
std::array<double, 2> bench_bandwidth(BenchRun& run) {
  const size_t buffer = run.options.quick ? (size_t{64} << 20) : (size_t{512} << 20);
  std::printf("store bandwidth (%zu MiB buffers, best of %d)\n", buffer >> 20, run.repeats);
  std::array<double, 2> memset_bw = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    const int threads = k == 0 ? 1 : run.all;
    nlohmann::json j = bandwidth(buffer, run.repeats, threads);
    memset_bw[k] = j["memset_bytes_per_s"].get<double>();
    std::printf("  %2d thr  memset %6.2f GB/s  copy %6.2f GB/s\n", threads, memset_bw[k] * 1e-9,
                j["copy_bytes_per_s"].get<double>() * 1e-9);
    run.doc["bandwidth"].push_back(j);
  }
  return memset_bw;
}

// The settings section 2 times, on 100 teacups (10 with --quick).
struct ThroughputSetup {
  Model cups;
  Topology topology;
  int grid_level = 6, esc_level = 7, pn_factor = 8;
  int n = 0;  // uniform segments
  size_t vertices = 0;
  double grid_triangles = 0.0;
  SchemeSpec uniform, esc, pn;
  Tessellation pn_base;
};

ThroughputSetup throughput_setup(const BenchRun& run, const Model& cup) {
  const bool quick = run.options.quick;
  ThroughputSetup t;
  t.cups = replicate(cup, quick ? 10 : 100);
  t.topology = build_topology(t.cups);
  t.grid_level = quick ? 4 : 6;
  t.esc_level = quick ? 3 : 7;
  t.n = segments_for_level(t.grid_level);
  t.vertices = uniform_grid_vertices(t.cups, t.n);
  t.grid_triangles = 2.0 * t.n * t.n * static_cast<double>(t.cups.patches.size());
  t.uniform = unguarded(Scheme::kUniform);
  t.uniform.segments = t.n;
  t.uniform.vertex_normals = false;
  t.uniform.surface_data = false;
  t.esc = unguarded(Scheme::kEsc);
  t.esc.level = t.esc_level;
  t.esc.vertex_normals = false;
  t.esc.surface_data = false;
  SchemeSpec pn_base_spec = unguarded(Scheme::kUniform);
  pn_base_spec.segments = 4;
  pn_base_spec.surface_data = false;
  t.pn_base = tessellate(t.cups, t.topology, pn_base_spec);
  t.pn = unguarded(Scheme::kPn);
  t.pn.level = t.pn_factor;
  return t;
}

// 2. Throughput per scheme on 100 teacups (2600 bicubic patches), single thread and all threads.
void bench_throughput(BenchRun& run, const Model& cup, const std::array<double, 2>& memset_bw) {
  const ThroughputSetup t = throughput_setup(run, cup);
  std::printf("throughput (%zu patches; uniform L = %d, ESC L = %d rho = 0, PN k = %d on uniform L = 2)\n",
              t.cups.patches.size(), t.grid_level, t.esc_level, t.pn_factor);
  std::vector<float> xyz32(3 * t.vertices, 0.0f);
  std::vector<double> xyz64(3 * t.vertices, 0.0);
  nlohmann::json& tp = run.doc["throughput"];
  tp["patches"] = t.cups.patches.size();
  tp["uniform_level"] = t.grid_level;
  tp["esc_level"] = t.esc_level;
  tp["pn_factor"] = t.pn_factor;
  const int repeats = run.repeats;
  double per_triangle[2][2] = {{0, 0}, {0, 0}};  // [uniform, esc][threads]
  for (int k = 0; k < 2; ++k) {
    const int threads = k == 0 ? 1 : run.all;
    const std::string key = k == 0 ? "single_thread" : "all_threads";
    const double s32 =
        timed_with_threads(threads, repeats, [&] { tessellate_uniform_grid(t.cups, t.n, xyz32.data()); });
    const double s64 =
        timed_with_threads(threads, repeats, [&] { tessellate_uniform_grid(t.cups, t.n, xyz64.data()); });
    nlohmann::json g32 = rate_json(s32, t.grid_triangles, 12.0 * t.vertices);
    nlohmann::json g64 = rate_json(s64, t.grid_triangles, 24.0 * t.vertices);
    g32["fraction_of_memset"] = g32["output_bytes_per_s"].get<double>() / memset_bw[k];
    g64["fraction_of_memset"] = g64["output_bytes_per_s"].get<double>() / memset_bw[k];
    Tessellation m;
    const double su = timed_with_threads(threads, repeats, [&] { m = tessellate(t.cups, t.topology, t.uniform); });
    const nlohmann::json ju = rate_json(su, static_cast<double>(m.triangles.size()), mesh_bytes(m));
    const double se = timed_with_threads(threads, repeats, [&] { m = tessellate(t.cups, t.topology, t.esc); });
    const nlohmann::json je = rate_json(se, static_cast<double>(m.triangles.size()), mesh_bytes(m));
    const double sp = timed_with_threads(threads, repeats, [&] { m = tessellate_mesh(t.pn_base, t.pn); });
    const nlohmann::json jp = rate_json(sp, static_cast<double>(m.triangles.size()), mesh_bytes(m));
    per_triangle[0][k] = su / ju["triangles"].get<double>();
    per_triangle[1][k] = se / je["triangles"].get<double>();
    tp[key] = {{"threads", threads}, {"uniform_grid_float32", g32}, {"uniform_grid_double", g64},
               {"uniform", ju}, {"esc", je}, {"pn", jp},
               {"esc_over_uniform_time_per_triangle", per_triangle[1][k] / per_triangle[0][k]}};
    print_rate("uniform grid float32", threads, g32, memset_bw[k]);
    print_rate("uniform grid double", threads, g64, memset_bw[k]);
    print_rate("uniform (Tessellation)", threads, ju);
    print_rate("esc (Tessellation)", threads, je);
    print_rate("pn (Tessellation)", threads, jp);
    std::printf("  esc / uniform time per triangle: %.2f\n", per_triangle[1][k] / per_triangle[0][k]);
  }
}

// 3. The Teacups scene (100 cups) at L = 3.
void bench_teacups_scene(BenchRun& run, const Model& cup) {
  const Model scene = replicate(cup, 100);
  const Topology topo = build_topology(scene);
  SchemeSpec u3 = unguarded(Scheme::kUniform);
  u3.level = 3;
  u3.surface_data = false;
  SchemeSpec e3 = unguarded(Scheme::kEsc);
  e3.level = 3;
  e3.surface_data = false;
  std::vector<float> buf(3 * uniform_grid_vertices(scene, 8));
  nlohmann::json& sc = run.doc["teacups_scene"];
  sc["patches"] = scene.patches.size();
  std::printf("Teacups scene (%zu patches) at L = 3, normals on, tessellations per second\n", scene.patches.size());
  const int repeats = run.repeats;
  for (int k = 0; k < 2; ++k) {
    const int threads = k == 0 ? 1 : run.all;
    Tessellation t;
    const double su = timed_with_threads(threads, repeats * 4, [&] { t = tessellate(scene, topo, u3); });
    const double ut = static_cast<double>(t.triangles.size());
    const double se = timed_with_threads(threads, repeats * 4, [&] { t = tessellate(scene, topo, e3); });
    const double et = static_cast<double>(t.triangles.size());
    const double sg = timed_with_threads(threads, repeats * 4, [&] { tessellate_uniform_grid(scene, 8, buf.data()); });
    const UniformGridPlan plan(scene, 8);
    const double sgp = timed_with_threads(threads, repeats * 4, [&] { plan.run(buf.data()); });
    sc[k == 0 ? "single_thread" : "all_threads"] = {
        {"threads", threads},
        {"uniform", {{"seconds", su}, {"triangles", ut}, {"per_s", 1.0 / su}}},
        {"esc", {{"seconds", se}, {"triangles", et}, {"per_s", 1.0 / se}}},
        {"uniform_grid_float32",
         {{"seconds", sg}, {"triangles", 2.0 * 64 * scene.patches.size()}, {"per_s", 1.0 / sg}}},
        {"uniform_grid_float32_prepared",
         {{"seconds", sgp}, {"triangles", 2.0 * 64 * scene.patches.size()}, {"per_s", 1.0 / sgp}}}};
    std::printf("  %2d thr  uniform %7.1f/s  esc %7.1f/s  grid float32 %7.1f/s  prepared grid float32 %7.1f/s\n",
                threads, 1.0 / su, 1.0 / se, 1.0 / sg, 1.0 / sgp);
  }
}

// One row of section 4: our fewest-triangle fit for `target`, timed and certified, against OCCT's
// largest deflection that certifies the same target.
nlohmann::json tea_set_row(const BenchRun& run, const std::string& file, const Model& model, const Topology& topo,
                           double target) {
  nlohmann::json row = {{"model", file}, {"target", target}};
  app::FittedSetting ours;
  if (!app::fit_fewest_triangles(model, topo, target, ours)) {
    row["ours"] = nullptr;
    return row;
  }
  Tessellation mesh;
  const double t1 = timed_with_threads(1, run.repeats, [&] { mesh = tessellate(model, topo, ours.spec); });
  const double tall = timed_with_threads(run.all, run.repeats, [&] { mesh = tessellate(model, topo, ours.spec); });
  const DistanceReport cert = certify_distance(model, mesh);
  row["ours"] = {{"scheme", ours.scheme},
                 {"level", ours.fit.level},
                 {"threshold", ours.fit.threshold},
                 {"triangles", mesh.triangles.size()},
                 {"certified_error", cert.hausdorff.upper},
                 {"seconds_single_thread", t1},
                 {"seconds_all_threads", tall},
                 {"validation_seconds", cert.seconds},
                 {"validation_over_tessellation", cert.seconds / tall}};
  occt::PeerResult peer;
  double deflection = 0.0;
  const bool occt_ok = !run.options.skip_occt && app::fit_occt_deflection(model, target, peer, deflection);
  if (occt_ok) {
    row["occt"] = {{"deflection", deflection},
                   {"triangles", peer.triangles},
                   {"certified_error", peer.distance.hausdorff.upper},
                   {"seconds", peer.mesh_seconds}};
    row["speedup_single_thread"] = peer.mesh_seconds / t1;
    row["speedup_all_threads"] = peer.mesh_seconds / tall;
    row["triangle_ratio"] = static_cast<double>(mesh.triangles.size()) / static_cast<double>(peer.triangles);
  } else {
    row["occt"] = nullptr;
  }
  std::printf("  %-13s %7.0e  %-18s %9zu %10.3f %10.3f | %9zu %9.2e %10.3f | %7.0f %7.2f | %6.1f\n", file.c_str(),
              target, ours.scheme.c_str(), mesh.triangles.size(), t1 * 1e3, tall * 1e3,
              occt_ok ? peer.triangles : size_t{0}, deflection, occt_ok ? peer.mesh_seconds * 1e3 : 0.0,
              occt_ok ? peer.mesh_seconds / t1 : 0.0,
              occt_ok ? static_cast<double>(mesh.triangles.size()) / static_cast<double>(peer.triangles) : 0.0,
              cert.seconds / tall);
  return row;
}

// 4. The tea set against OCCT at equal certified error, and 5. validation / tessellation time.
void bench_tea_set(BenchRun& run) {
  std::vector<std::string> files = {"teapot.bpt", "teacup.bpt", "teaspoon.bpt"};
  std::vector<double> targets = {1e-2, 1e-3, 1e-4};
  if (run.options.quick) {
    files = {"teacup.bpt"};
    targets = {1e-2};
  }
  std::printf("tea set vs BRepMesh_IncrementalMesh (OCCT %s) at equal certified error\n", occt::occt_version().c_str());
  std::printf("  %-13s %7s  %-18s %9s %10s %10s | %9s %9s %10s | %7s %7s | %6s\n", "model", "target", "ours",
              "triangles", "ms (1 thr)", "ms (all)", "occt tri", "occt defl", "occt ms", "speedup", "tri",
              "val/tes");
  for (const std::string& file : files) {
    const Model model = io::read_bpt(data_path(run.options, file));
    const Topology topo = build_topology(model);
    for (double target : targets) run.doc["tea_set"].push_back(tea_set_row(run, file, model, topo, target));
  }
}

void run_bench(const BenchOptions& o) {
  // Line-buffered, so each row appears when measured, also when stdout is a pipe or a file.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  check_bench_outputs(o);
  const Stopwatch total;
  nlohmann::json doc;
  BenchRun run{o, tbb::info::default_concurrency(), o.quick ? 2 : 5, doc};
  doc["quick"] = o.quick;
  doc["threads_all"] = run.all;
  doc["repeats"] = run.repeats;
  const std::array<double, 2> memset_bw = bench_bandwidth(run);
  const Model cup = io::read_bpt(data_path(o, "teacup.bpt"));
  bench_throughput(run, cup, memset_bw);
  bench_teacups_scene(run, cup);
  bench_tea_set(run);
  doc["seconds"] = total.seconds();
  std::printf("total %.1f s\n", total.seconds());
  if (!o.json.empty()) write_json(o.json, doc);
}

}  // namespace

Command register_bench(CLI::App& app) {
  auto options = std::make_shared<BenchOptions>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Throughput, store bandwidth, the Teacups scene, the tea set against OCCT at equal certified error");
  cmd->add_option("--json", options->json, "Write the numbers to this JSON file");
  cmd->add_option("--data", options->data, "Folder with teapot.bpt, teacup.bpt, teaspoon.bpt (default: $SAGITTA_SHARED_DATA)");
  cmd->add_flag("--quick", options->quick, "Small sizes and one tea-set case (a smoke test, not a measurement)");
  cmd->add_flag("--skip-occt", options->skip_occt, "Leave out the OCCT comparison");
  Command command;
  command.app = cmd;
  command.run = [options]() { run_bench(*options); };
  return command;
}

}  // namespace sagitta::cli
