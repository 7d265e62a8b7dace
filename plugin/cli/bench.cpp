// `sagitta bench`: the performance numbers of issue 10 in one run (docs/BENCHMARKS.md).
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

void run_bench(const BenchOptions& o) {
  // Line-buffered, so each row appears when measured, also when stdout is a pipe or a file.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  if (!o.json.empty()) {
    std::vector<std::string> inputs;
    for (const char* file : {"teapot.bpt", "teacup.bpt", "teaspoon.bpt"}) {
      try {
        inputs.push_back(data_path(o, file));
      } catch (const InputError&) {  // a missing file is reported where it is read
      }
    }
    check_outputs({{"--json", o.json}}, inputs);
  }
  const Stopwatch total;
  const int all = tbb::info::default_concurrency();
  const int repeats = o.quick ? 2 : 5;
  nlohmann::json doc;
  doc["quick"] = o.quick;
  doc["threads_all"] = all;
  doc["repeats"] = repeats;

  // 1. Store bandwidth.
  const size_t buffer = o.quick ? (size_t{64} << 20) : (size_t{512} << 20);
  std::printf("store bandwidth (%zu MiB buffers, best of %d)\n", buffer >> 20, repeats);
  double memset_bw[2] = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    const int threads = k == 0 ? 1 : all;
    nlohmann::json j = bandwidth(buffer, repeats, threads);
    memset_bw[k] = j["memset_bytes_per_s"].get<double>();
    std::printf("  %2d thr  memset %6.2f GB/s  copy %6.2f GB/s\n", threads, memset_bw[k] * 1e-9,
                j["copy_bytes_per_s"].get<double>() * 1e-9);
    doc["bandwidth"].push_back(j);
  }

  // 2. Throughput per scheme on 100 teacups (2600 bicubic patches).
  const Model cup = io::read_bpt(data_path(o, "teacup.bpt"));
  const Model cups = replicate(cup, o.quick ? 10 : 100);
  const Topology cups_topo = build_topology(cups);
  const int grid_level = o.quick ? 4 : 6;
  const int esc_level = o.quick ? 3 : 7;
  const int pn_factor = 8;
  std::printf("throughput (%zu patches; uniform L = %d, ESC L = %d rho = 0, PN k = %d on uniform L = 2)\n",
              cups.patches.size(), grid_level, esc_level, pn_factor);
  const int n = segments_for_level(grid_level);
  const size_t vertices = uniform_grid_vertices(cups, n);
  const double grid_triangles = 2.0 * n * n * static_cast<double>(cups.patches.size());
  std::vector<float> xyz32(3 * vertices, 0.0f);
  std::vector<double> xyz64(3 * vertices, 0.0);
  SchemeSpec uniform = unguarded(Scheme::kUniform);
  uniform.segments = n;
  uniform.vertex_normals = false;
  uniform.surface_data = false;
  SchemeSpec esc = unguarded(Scheme::kEsc);
  esc.level = esc_level;
  esc.vertex_normals = false;
  esc.surface_data = false;
  SchemeSpec pn_base_spec = unguarded(Scheme::kUniform);
  pn_base_spec.segments = 4;
  pn_base_spec.surface_data = false;
  const Tessellation pn_base = tessellate(cups, cups_topo, pn_base_spec);
  SchemeSpec pn = unguarded(Scheme::kPn);
  pn.level = pn_factor;
  nlohmann::json& tp = doc["throughput"];
  tp["patches"] = cups.patches.size();
  tp["uniform_level"] = grid_level;
  tp["esc_level"] = esc_level;
  tp["pn_factor"] = pn_factor;
  double per_triangle[2][2] = {{0, 0}, {0, 0}};  // [uniform, esc][threads]
  for (int k = 0; k < 2; ++k) {
    const int threads = k == 0 ? 1 : all;
    const std::string key = k == 0 ? "single_thread" : "all_threads";
    const double s32 = timed_with_threads(threads, repeats, [&] { tessellate_uniform_grid(cups, n, xyz32.data()); });
    const double s64 = timed_with_threads(threads, repeats, [&] { tessellate_uniform_grid(cups, n, xyz64.data()); });
    nlohmann::json g32 = rate_json(s32, grid_triangles, 12.0 * vertices);
    nlohmann::json g64 = rate_json(s64, grid_triangles, 24.0 * vertices);
    g32["fraction_of_memset"] = g32["output_bytes_per_s"].get<double>() / memset_bw[k];
    g64["fraction_of_memset"] = g64["output_bytes_per_s"].get<double>() / memset_bw[k];
    Tessellation t;
    const double su = timed_with_threads(threads, repeats, [&] { t = tessellate(cups, cups_topo, uniform); });
    const nlohmann::json ju = rate_json(su, static_cast<double>(t.triangles.size()), mesh_bytes(t));
    const double se = timed_with_threads(threads, repeats, [&] { t = tessellate(cups, cups_topo, esc); });
    const nlohmann::json je = rate_json(se, static_cast<double>(t.triangles.size()), mesh_bytes(t));
    const double sp = timed_with_threads(threads, repeats, [&] { t = tessellate_mesh(pn_base, pn); });
    const nlohmann::json jp = rate_json(sp, static_cast<double>(t.triangles.size()), mesh_bytes(t));
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
  xyz64 = {};

  // 3. The Teacups scene (100 cups) at L = 3.
  {
    const Model scene = replicate(cup, 100);
    const Topology topo = build_topology(scene);
    SchemeSpec u3 = unguarded(Scheme::kUniform);
    u3.level = 3;
    u3.surface_data = false;
    SchemeSpec e3 = unguarded(Scheme::kEsc);
    e3.level = 3;
    e3.surface_data = false;
    std::vector<float> buf(3 * uniform_grid_vertices(scene, 8));
    nlohmann::json& sc = doc["teacups_scene"];
    sc["patches"] = scene.patches.size();
    std::printf("Teacups scene (%zu patches) at L = 3, normals on, tessellations per second\n", scene.patches.size());
    for (int k = 0; k < 2; ++k) {
      const int threads = k == 0 ? 1 : all;
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
          {"uniform_grid_float32", {{"seconds", sg}, {"triangles", 2.0 * 64 * scene.patches.size()}, {"per_s", 1.0 / sg}}},
          {"uniform_grid_float32_prepared",
           {{"seconds", sgp}, {"triangles", 2.0 * 64 * scene.patches.size()}, {"per_s", 1.0 / sgp}}}};
      std::printf("  %2d thr  uniform %7.1f/s  esc %7.1f/s  grid float32 %7.1f/s  prepared grid float32 %7.1f/s\n",
                  threads, 1.0 / su, 1.0 / se, 1.0 / sg, 1.0 / sgp);
    }
  }

  // 4. The tea set against OCCT at equal certified error, and 5. validation / tessellation time.
  std::vector<std::string> files = {"teapot.bpt", "teacup.bpt", "teaspoon.bpt"};
  std::vector<double> targets = {1e-2, 1e-3, 1e-4};
  if (o.quick) {
    files = {"teacup.bpt"};
    targets = {1e-2};
  }
  std::printf("tea set vs BRepMesh_IncrementalMesh (OCCT %s) at equal certified error\n", occt::occt_version().c_str());
  std::printf("  %-13s %7s  %-18s %9s %10s %10s | %9s %9s %10s | %7s %7s | %6s\n", "model", "target", "ours",
              "triangles", "ms (1 thr)", "ms (all)", "occt tri", "occt defl", "occt ms", "speedup", "tri",
              "val/tes");
  for (const std::string& file : files) {
    const Model model = io::read_bpt(data_path(o, file));
    const Topology topo = build_topology(model);
    for (double target : targets) {
      nlohmann::json row = {{"model", file}, {"target", target}};
      app::FittedSetting ours;
      if (!app::fit_fewest_triangles(model, topo, target, ours)) {
        row["ours"] = nullptr;
        doc["tea_set"].push_back(row);
        continue;
      }
      Tessellation mesh;
      const double t1 = timed_with_threads(1, repeats, [&] { mesh = tessellate(model, topo, ours.spec); });
      const double tall = timed_with_threads(all, repeats, [&] { mesh = tessellate(model, topo, ours.spec); });
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
      const bool occt_ok = !o.skip_occt && app::fit_occt_deflection(model, target, peer, deflection);
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
      doc["tea_set"].push_back(row);
    }
  }
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
