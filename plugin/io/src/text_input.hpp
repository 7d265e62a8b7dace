// Bounded reading of untrusted input files (internal to plugin/io). A text reader refuses a NUL
// byte or a line longer than any valid one as soon as it is read, so a device such as /dev/zero
// or /dev/urandom given as an input costs one chunk of memory, not all of it.
#pragma once

#include "sagitta/model.hpp"

#include <functional>
#include <string>

namespace sagitta::io::detail {

// Checks text incrementally: scan() looks at the bytes appended since the last call and throws
// InputError "NAME:LINE: problem" at the first NUL byte or at a line longer than max_line bytes
// (max_line 0: lines are not limited, NUL still refused).
class TextScanner {
 public:
  TextScanner(std::string name, size_t max_line) : name_(std::move(name)), max_line_(max_line) {}
  void scan(const std::string& text);

 private:
  std::string name_;
  size_t max_line_;
  size_t scanned_ = 0;  // bytes of the text already checked
  size_t line_ = 1;
  size_t length_ = 0;   // bytes of the current line so far
};

// Reads a whole file in 64 KiB chunks, calling `after_chunk(bytes_so_far)` after each; the callback
// stops the read by throwing. Throws InputError naming the file when it cannot be opened or read.
std::string read_file_chunked(const std::string& path, const std::function<void(const std::string&)>& after_chunk);

}  // namespace sagitta::io::detail
