#include "budget_options.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/io/mesh_io.hpp"

#include <unistd.h>

#include <csignal>
#include <cstring>

namespace sagitta::cli {

namespace {

// The first Ctrl-C cancels the work (it stops at the next budget check, one line, exit 2); a second
// one ends the process at once, after removing the temporary files of writes in progress (this
// handler replaces the one write_file_atomic would install for SIGINT).
extern "C" void on_interrupt(int) {
  static volatile std::sig_atomic_t interrupts = 0;
  if (interrupts++ == 0) {
    sagitta::budget::request_cancel();
    return;
  }
  sagitta::io::remove_temp_files();
  std::signal(SIGINT, SIG_DFL);
  std::raise(SIGINT);
}

}  // namespace

double default_max_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? 0.8 * static_cast<double>(pages) * static_cast<double>(page) : 0.0;
}

void add_budget_options(CLI::App* command, BudgetOptions& o) {
  command->add_option("--max-seconds", o.max_seconds,
                      "Stop (one line, exit code 2, no result) when the work takes longer than this; 0: no limit")
      ->check(CLI::NonNegativeNumber);
  command->add_option("--max-memory", o.max_memory_gib,
                      "Refuse work whose estimated memory exceeds this many GiB (default: 80% of physical memory; 0: no limit)")
      ->check(CLI::NonNegativeNumber);
}

void start_budget(const BudgetOptions& o) {
  budget::set_max_seconds(o.max_seconds);
  budget::set_max_bytes(o.max_memory_gib < 0.0 ? default_max_memory_bytes() : o.max_memory_gib * double(1ull << 30));
  struct sigaction action;
  std::memset(&action, 0, sizeof action);
  action.sa_handler = on_interrupt;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
}

}  // namespace sagitta::cli
