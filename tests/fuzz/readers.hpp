// The readers the fuzzers and the regression test drive, by short name: every reader of untrusted
// bytes in plugin/io. A reader may only return a result or throw sagitta::InputError.
#pragma once

#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/io/scene_io.hpp"

#include <string>
#include <vector>

namespace sagitta::fuzz {

// Names of the readers, which are also the corpus and regression folder names.
inline std::vector<std::string> reader_names() { return {"bpt", "rib", "obj", "ply", "stl", "scene"}; }

// Parses `bytes` with the named reader; `name` is the file name put into error messages.
// Guarantees: returns normally or throws what the reader throws; an unknown reader is a logic error.
inline void parse_with(const std::string& reader, const std::string& bytes, const std::string& name) {
  if (reader == "bpt") {
    (void)io::parse_bpt(bytes, name);
  } else if (reader == "rib") {
    (void)io::parse_rib(bytes, name);
  } else if (reader == "obj" || reader == "ply" || reader == "stl") {
    (void)io::parse_mesh(bytes, name, "." + reader);
  } else if (reader == "scene") {
    (void)io::parse_scene(bytes, name);
  } else {
    throw std::logic_error("no reader called '" + reader + "'");
  }
}

}  // namespace sagitta::fuzz
