#include "sagitta/budget.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace sagitta::budget {

namespace {

using Clock = std::chrono::steady_clock;

std::atomic<bool> g_cancelled{false};
static_assert(std::atomic<bool>::is_always_lock_free, "request_cancel must be async-signal-safe");
// Deadline in steady-clock ticks; 0 = none. Limit in seconds kept for the message.
std::atomic<Clock::rep> g_deadline{0};
std::atomic<double> g_max_seconds{0.0};
std::atomic<double> g_max_bytes{0.0};

std::string gib(double bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", bytes / double(1ull << 30));
  return text;
}

}  // namespace

void set_max_seconds(double seconds) {
  if (!(seconds > 0.0) || !std::isfinite(seconds)) {
    g_deadline = 0;
    g_max_seconds = 0.0;
    return;
  }
  const auto span = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(seconds, 1e9)));
  g_deadline = (Clock::now() + span).time_since_epoch().count();
  g_max_seconds = seconds;
}

void request_cancel() noexcept { g_cancelled.store(true, std::memory_order_relaxed); }

void set_max_bytes(double bytes) { g_max_bytes = (bytes > 0.0 && std::isfinite(bytes)) ? bytes : 0.0; }

double max_bytes() { return g_max_bytes; }

void reset() {
  g_cancelled = false;
  g_deadline = 0;
  g_max_seconds = 0.0;
  g_max_bytes = 0.0;
}

bool exhausted() noexcept {
  if (g_cancelled.load(std::memory_order_relaxed)) return true;
  const Clock::rep deadline = g_deadline.load(std::memory_order_relaxed);
  return deadline != 0 && Clock::now().time_since_epoch().count() >= deadline;
}

void check(const char* where) {
  if (!exhausted()) return;
  std::string message = g_cancelled.load() ? "interrupted" : "time budget exhausted (--max-seconds " + [] {
    char text[32];
    std::snprintf(text, sizeof text, "%g", g_max_seconds.load());
    return std::string(text);
  }() + ")";
  if (where) message += std::string(" during ") + where;
  throw BudgetExhausted(message + ": stopped before finishing, no result");
}

void check_memory(double bytes, const std::string& what, const std::string& hint) {
  const double limit = g_max_bytes;
  if (limit > 0.0 && !(bytes <= limit)) {
    throw MemoryLimitExceeded(what + " would need about " + gib(bytes) + " GiB, more than --max-memory " + gib(limit) +
                              " GiB" + (hint.empty() ? std::string() : "; " + hint));
  }
}

}  // namespace sagitta::budget
