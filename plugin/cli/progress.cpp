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
  } else if (steps == 0) {
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

ProgressTicker::ProgressTicker(std::string label, std::string what)
    : line_(std::move(label)), what_(std::move(what)), thread_([this] {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!wake_.wait_for(lock, std::chrono::seconds(1), [this] { return stop_; })) line_.update(0, -1, what_);
        line_.clear();
      }) {}

ProgressTicker::~ProgressTicker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

}  // namespace sagitta::cli
