// --max-seconds and --max-memory on every subcommand, and Ctrl-C: they set the run's budget
// (sagitta/budget.hpp), which the long loops and the memory guard check.
#pragma once

#include <CLI/CLI.hpp>

namespace sagitta::cli {

struct BudgetOptions {
  double max_seconds = 0.0;     // 0: no time limit
  double max_memory_gib = -1.0; // < 0: the default (80 % of physical memory); 0: no limit
};

// Adds --max-seconds and --max-memory to a subcommand.
void add_budget_options(CLI::App* command, BudgetOptions& options);

// Starts the budget (the clock runs from here) and makes SIGINT request cancellation: the work stops
// at its next budget check with one line and exit code 2; a second SIGINT ends the process at once.
void start_budget(const BudgetOptions& options);

// 80 % of the physical memory, in bytes (0 when unknown).
double default_max_memory_bytes();

}  // namespace sagitta::cli
