// Replays every file under tests/fuzz/regressions/<reader>/ (inputs that once crashed, leaked or
// hung a reader) and tests/fuzz/corpus/<reader>/ (the fuzzers' seeds) through its reader in the
// normal build: each must parse or be rejected with a one-line InputError naming the file.
#include "readers.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

namespace fs = std::filesystem;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs every file of tests/fuzz/<folder>/<reader>/ through the reader; returns how many it read.
size_t replay(const std::string& folder) {
  size_t files = 0;
  for (const std::string& reader : sagitta::fuzz::reader_names()) {
    const fs::path dir = fs::path(SAGITTA_FUZZ_DIR) / folder / reader;
    if (!fs::is_directory(dir)) continue;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
      if (!entry.is_regular_file() || entry.path().filename().string()[0] == '.') continue;
      ++files;
      const std::string name = entry.path().filename().string();
      SCOPED_TRACE(reader + " reader on " + entry.path().string());
      try {
        sagitta::fuzz::parse_with(reader, read_bytes(entry.path()), name);
      } catch (const sagitta::InputError& e) {
        const std::string message = e.what();
        EXPECT_EQ(message.rfind(name, 0), 0u) << "message does not start with the file name: " << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << "message is not one line: " << message;
        EXPECT_GT(message.size(), name.size() + 2) << "message names no problem: " << message;
      } catch (const std::exception& e) {
        ADD_FAILURE() << "reader threw something other than InputError: " << e.what();
      }
    }
  }
  return files;
}

TEST(FuzzRegressions, EveryRegressionInputIsParsedOrRejectedCleanly) {
  EXPECT_GT(replay("regressions"), 0u) << "no regression inputs found under " << SAGITTA_FUZZ_DIR;
}

TEST(FuzzRegressions, EverySeedIsParsedOrRejectedCleanly) {
  EXPECT_GE(replay("corpus"), sagitta::fuzz::reader_names().size()) << "a reader has no seed corpus";
}

}  // namespace
