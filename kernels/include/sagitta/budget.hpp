// The resource budget of one run, shared by every command and every long loop: a time limit
// (--max-seconds), a cancellation flag (Ctrl-C, or another thread) and a memory limit
// (--max-memory) that up-front estimates and allocation sites are checked against.
// Process-wide on purpose: the loops that honour it (validator, tessellators, scene planner) need
// no extra parameter, and a signal handler can reach it.
#pragma once

#include <stdexcept>
#include <string>

namespace sagitta {

// Thrown when the time budget is spent or cancellation was requested; the message says which.
// Nothing computed by the interrupted work may be reported as certified.
struct BudgetExhausted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Thrown when an estimate or an allocation would exceed the memory limit (an input the user must
// shrink, or a limit to raise: the message says which).
struct MemoryLimitExceeded : std::runtime_error {
  using std::runtime_error::runtime_error;
};

namespace budget {

// Starts the time budget now: check() throws once `seconds` have passed. <= 0 or not finite: no limit.
void set_max_seconds(double seconds);
// Requests cancellation: the next check() throws. Async-signal-safe (a lock-free atomic store).
void request_cancel() noexcept;
// The memory limit in bytes; <= 0 or not finite: no limit.
void set_max_bytes(double bytes);
double max_bytes();
// Clears the time limit, the cancellation request and the memory limit (tests, the Python module).
void reset();

// True once cancellation was requested or the time limit has passed.
bool exhausted() noexcept;
// Throws BudgetExhausted (naming `where`) when exhausted(). Cheap: call it once per unit of work
// (a patch, a refinement leaf, an instance), not per arithmetic operation.
void check(const char* where = nullptr);

// Throws MemoryLimitExceeded ("WHAT would need about X GiB, more than --max-memory Y GiB; HINT")
// when `bytes` exceeds the memory limit. Used both up front (estimates) and where the memory is
// allocated (reserve sites), so an estimate that missed something is still caught.
void check_memory(double bytes, const std::string& what, const std::string& hint = "");

}  // namespace budget
}  // namespace sagitta
