// A progress line on stderr for long runs (fits, reports): shown only when stderr is a terminal and
// the run has lasted more than a second, so pipes, logs and tests see nothing.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace sagitta::cli {

class ProgressLine {
 public:
  explicit ProgressLine(std::string label);
  ~ProgressLine();  // erases the line if one was drawn
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // Redraws "label [#####.....] step/steps what" ("label step N what" when steps == 0, "label what"
  // when steps < 0).
  void update(int step, int steps, const std::string& what);
  // Erases the line (call before printing results); later updates draw again.
  void clear();

 private:
  std::string label_;
  std::chrono::steady_clock::time_point start_;
  bool enabled_ = false;
  bool drawn_ = false;
};

// For work with no steps to count (one long validation): a thread redraws "label what  N s" once a
// second while the ticker lives (on a terminal only, like ProgressLine), so a long run visibly
// progresses; Ctrl-C and --max-seconds stop the work itself (sagitta/budget.hpp).
class ProgressTicker {
 public:
  ProgressTicker(std::string label, std::string what);
  ~ProgressTicker();  // stops the thread and erases the line
  ProgressTicker(const ProgressTicker&) = delete;
  ProgressTicker& operator=(const ProgressTicker&) = delete;

 private:
  ProgressLine line_;
  std::string what_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace sagitta::cli
