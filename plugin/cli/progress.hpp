// A progress line on stderr for long runs (fits, reports): shown only when stderr is a terminal and
// the run has lasted more than a second, so pipes, logs and tests see nothing.
#pragma once

#include <chrono>
#include <string>

namespace sagitta::cli {

class ProgressLine {
 public:
  explicit ProgressLine(std::string label);
  ~ProgressLine();  // erases the line if one was drawn
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // Redraws "label [#####.....] step/steps what" (no bar when steps <= 0).
  void update(int step, int steps, const std::string& what);
  // Erases the line (call before printing results); later updates draw again.
  void clear();

 private:
  std::string label_;
  std::chrono::steady_clock::time_point start_;
  bool enabled_ = false;
  bool drawn_ = false;
};

}  // namespace sagitta::cli
