// Inputs and outputs every front end shares: loading a model from any supported input, the
// output-file checks, atomic JSON writing, and a stopwatch.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/occt/cad.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace sagitta::app {

// Loads a patch model: "" or "default" is the built-in default model; otherwise by extension.
// CAD files (.step, .iges, .brep) give the Bézier patches of their untrimmed faces, and fill
// `cad_stats` (when given) with faces, faces_trimmed, faces_skipped (with reasons), bezier_patches.
Model load_model(const std::string& input, nlohmann::json* cad_stats = nullptr);

// The CAD stats fields of a CAD model (see load_model).
nlohmann::json cad_json(const occt::CadModel& cad);

// An output file with the option that names it ("--out", "run.json" ...), for messages.
using NamedPath = std::pair<std::string, std::string>;

// Refuses (InputError, before anything is read or written) an output that is the same file as any
// input, and two outputs that are the same file; both after resolving symlinks, "./" and "..".
// Empty paths and the input "default" (the built-in model) are ignored. Every command calls it with all its outputs and
// every file it reads.
void check_outputs(const std::vector<NamedPath>& outputs, const std::vector<std::string>& inputs);

// Writes a JSON document atomically, pretty-printed.
void write_json(const std::string& path, const nlohmann::json& doc);

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace sagitta::app
