// The `sagitta` command line: one register function per subcommand, and the helpers they share.
#pragma once

#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"

#include <CLI/CLI.hpp>

#include <functional>

namespace sagitta::cli {

// A subcommand and the action to run when it was given on the command line.
struct Command {
  CLI::App* app = nullptr;
  std::function<void()> run;
};

Command register_tessellate(CLI::App& app);
Command register_run(CLI::App& app);
Command register_validate(CLI::App& app);
Command register_scene(CLI::App& app);
Command register_fit(CLI::App& app);
Command register_report(CLI::App& app);
Command register_peer(CLI::App& app);
Command register_bench(CLI::App& app);
Command register_batch(CLI::App& app);  // takes no budget options: its arguments go to Python

// The application layer's shared pieces, as the subcommands use them.
using app::cad_json;
using app::check_outputs;
using app::fit_result_json;
using app::interval_json;
using app::load_model;
using app::NamedPath;
using app::Stopwatch;
using app::topology_json;
using app::topology_report_json;
using app::vec_json;
using app::write_json;

}  // namespace sagitta::cli
