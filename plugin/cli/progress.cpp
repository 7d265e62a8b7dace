#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace sagitta::cli {

ProgressLine::ProgressLine(std::string label)
    : label_(std::move(label)), start_(std::chrono::steady_clock::now()), enabled_(isatty(STDERR_FILENO) == 1) {}

ProgressLine::~ProgressLine() { clear(); }

void ProgressLine::clear() {
  if (drawn_) std::fprintf(stderr, "\r\033[K");
  drawn_ = false;
}

void ProgressLine::update(int step, int steps, const std::string& what) {
  if (!enabled_) return;
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (elapsed < 1.0) return;
  std::string line = label_ + " ";
  if (steps > 0) {
    constexpr int kWidth = 24;
    const int filled = std::clamp(step * kWidth / steps, 0, kWidth);
    line += "[" + std::string(filled, '#') + std::string(kWidth - filled, '.') + "] " + std::to_string(step) + "/" +
            std::to_string(steps) + " ";
  } else {
    line += "step " + std::to_string(step) + " ";
  }
  line += what;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "  %.0f s", elapsed);
  line += seconds;
  std::fprintf(stderr, "\r\033[K%s", line.c_str());
  std::fflush(stderr);
  drawn_ = true;
}

}  // namespace sagitta::cli
