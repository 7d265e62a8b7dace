// sagitta batch: hands its arguments to the Python package sagitta_batch (Dask.distributed), which runs this
// executable once per file. Everything after `batch` is passed through, --help included.
#include "commands.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#ifndef SAGITTA_BATCH_PYTHONPATH
#define SAGITTA_BATCH_PYTHONPATH ""
#endif

namespace sagitta::cli {
namespace {

// The folder holding sagitta_batch/: $SAGITTA_BATCH_PYTHONPATH, then <bin>/../share/sagitta/python, then the
// source tree.
std::string find_package_dir(const std::filesystem::path& exe) {
  if (const char* env = std::getenv("SAGITTA_BATCH_PYTHONPATH"); env && *env) return env;
  std::error_code ec;
  const auto installed = exe.parent_path().parent_path() / "share" / "sagitta" / "python";
  if (std::filesystem::exists(installed / "sagitta_batch", ec)) return installed.string();
  if (std::filesystem::exists(std::filesystem::path(SAGITTA_BATCH_PYTHONPATH) / "sagitta_batch", ec))
    return SAGITTA_BATCH_PYTHONPATH;
  throw std::runtime_error("batch: the Python package sagitta_batch was not found (set SAGITTA_BATCH_PYTHONPATH)");
}

// Replaces this process with `python3 -m sagitta_batch ARGS...`; SAGITTA_EXE names this executable for the
// children. Returns only by throwing.
[[noreturn]] void exec_batch(const std::vector<std::string>& args) {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("batch: cannot locate the sagitta executable: " + ec.message());
  std::string path = find_package_dir(exe);
  if (const char* old = std::getenv("PYTHONPATH"); old && *old) path += std::string(":") + old;
  setenv("PYTHONPATH", path.c_str(), 1);
  setenv("SAGITTA_EXE", exe.c_str(), 1);
  const std::string python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  std::vector<std::string> argv_strings = {python, "-m", "sagitta_batch"};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  execvp(argv[0], argv.data());
  throw std::runtime_error("batch: cannot run " + python + ": " + std::strerror(errno));
}

}  // namespace

Command register_batch(CLI::App& app) {
  CLI::App* sub = app.add_subcommand(
      "batch",
      "Validate a library of CAD parts and patch models on Dask.distributed, one isolated child process "
      "per file, results in SQLite (sagitta batch --help; docs/BATCH.md)");
  sub->set_help_flag();  // --help goes to the Python side with every other argument
  sub->prefix_command();
  sub->allow_extras();
  return {sub, [sub] { exec_batch(sub->remaining()); }};
}

}  // namespace sagitta::cli
