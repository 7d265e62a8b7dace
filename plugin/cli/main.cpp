// sagitta: certified tessellation of Bézier surfaces.
#include "budget_options.hpp"
#include "commands.hpp"

#include <tbb/global_control.h>

#include <iostream>
#include <memory>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <string>
#include <vector>

int main(int argc, char** argv) {
#if defined(__GLIBC__)
  // The schemes and the validator allocate and free arrays of up to hundreds of megabytes, and fit,
  // report and bench tessellate many times. By default glibc maps each block above 128 KiB-32 MiB
  // afresh and unmaps it on free, and hands a freed heap top back to the kernel, so every call pays
  // its page faults again: two thirds of the uniform scheme's time on 100 teacups at level 6 (21 M
  // triangles: 647 ms, 196 ms without) and half of ESC's. This process takes every block from the
  // heap, keeps up to 1 GiB of freed memory for the next call and grows the heap 64 MiB at a time
  // (only pages touched become resident).
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  mallopt(M_TOP_PAD, 64 << 20);
#endif
  CLI::App app{"sagitta: tessellate Bézier surfaces and certify how far the mesh is from the exact surface"};
  app.require_subcommand(1);
  int threads = 0;
  app.add_option("--threads", threads, "Worker threads (0: all cores)")->check(CLI::Range(0, 4096));
  const std::vector<sagitta::cli::Command> commands = {
      sagitta::cli::register_run(app),
      sagitta::cli::register_tessellate(app),
      sagitta::cli::register_validate(app),
      sagitta::cli::register_scene(app),
      sagitta::cli::register_fit(app),
      sagitta::cli::register_report(app),
      sagitta::cli::register_peer(app),
      sagitta::cli::register_bench(app),
  };
  sagitta::cli::BudgetOptions budget;
  for (const auto& command : commands) sagitta::cli::add_budget_options(command.app, budget);
  const sagitta::cli::Command batch = sagitta::cli::register_batch(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version print and exit 0; every other parse error is an input error: exit 2
    // with one line, like a malformed file (CLI11's own codes 101..120 are not used).
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    std::string what = e.what();
    for (char& c : what) {
      if (c == '\n' || c == '\r') c = ' ';
    }
    std::cerr << "sagitta: " << what << " (see sagitta --help)\n";
    return 2;
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  sagitta::cli::start_budget(budget);
  try {
    for (const auto& command : commands) {
      if (command.app->parsed()) command.run();
    }
    if (batch.app->parsed()) batch.run();
  } catch (const std::exception& e) {
    std::cerr << "sagitta: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
