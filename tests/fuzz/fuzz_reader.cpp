// libFuzzer entry point for one reader (SAGITTA_FUZZ_READER, a name from readers.hpp). InputError
// is the only accepted failure: any other exception escapes and libFuzzer reports it as a crash,
// like a sanitizer finding, a leak (-detect_leaks) or a hang (-timeout).
#include "readers.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    sagitta::fuzz::parse_with(SAGITTA_FUZZ_READER, bytes, "fuzz-input");
  } catch (const sagitta::InputError&) {
    // Rejected cleanly: the expected outcome for most mutated inputs.
  }
  return 0;
}
