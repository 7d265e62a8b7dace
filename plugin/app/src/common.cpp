#include "sagitta/app/common.hpp"

#include "sagitta/fixtures.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/occt/cad.hpp"

#include <filesystem>

namespace sagitta::app {

Model load_model(const std::string& input, nlohmann::json* cad_stats) {
  if (input.empty() || input == "default") return fixtures::default_model();
  if (!std::filesystem::exists(input)) throw InputError(input + ": no such file");
  if (occt::is_cad_file(input)) {
    occt::CadModel cad = occt::read_cad_file(input);
    if (cad_stats) *cad_stats = cad_json(cad);
    if (cad.model.patches.empty()) {
      throw InputError(input + ": no untrimmed face to tessellate (" + std::to_string(cad.faces_trimmed) +
                       " trimmed, " + std::to_string(cad.faces_skipped) + " skipped; see docs/CAD.md)");
    }
    return std::move(cad.model);
  }
  return io::read_patch_model(input);
}

nlohmann::json cad_json(const occt::CadModel& cad) {
  nlohmann::json j;
  j["faces"] = cad.faces.size();
  j["faces_tessellated"] = cad.faces_tessellated;
  j["faces_trimmed"] = cad.faces_trimmed;
  j["faces_skipped"] = cad.faces_skipped;
  j["bezier_patches"] = cad.bezier_patches;
  j["bezier_patches_tessellated"] = cad.model.patches.size();
  j["snap_tolerance"] = cad.snap_tolerance;
  j["snapped_patches"] = cad.snapped_patches;
  j["max_snap"] = cad.max_snap;
  nlohmann::json trimmed = nlohmann::json::array(), skipped = nlohmann::json::array();
  for (const occt::FaceReport& f : cad.faces) {
    const nlohmann::json face = {
        {"face", f.name}, {"surface", f.surface_type}, {"reason", f.reason}, {"bezier_patches", f.patch_count}};
    if (f.status == "trimmed") trimmed.push_back(face);
    if (f.status == "skipped") skipped.push_back(face);
  }
  j["trimmed"] = trimmed;
  j["skipped"] = skipped;
  return j;
}

namespace {

// True when a and b name the same file: the same inode when both exist, else the same path once
// symlinks, "." and ".." are resolved (two outputs that do not exist yet).
bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ea, eb;
  if (fs::exists(a, ea) && fs::exists(b, eb)) return fs::equivalent(a, b, ea) && !ea;
  const fs::path ca = fs::weakly_canonical(a, ea), cb = fs::weakly_canonical(b, eb);
  return !ea && !eb && ca == cb;
}

}  // namespace

void check_outputs(const std::vector<NamedPath>& outputs, const std::vector<std::string>& inputs) {
  for (size_t k = 0; k < outputs.size(); ++k) {
    const auto& [option, path] = outputs[k];
    if (path.empty()) continue;
    for (const std::string& input : inputs) {
      if (!input.empty() && input != "default" && same_file(path, input)) {
        throw InputError(path + ": " + option + " is the input file " + input + "; refusing to overwrite the input");
      }
    }
    for (size_t j = 0; j < k; ++j) {
      if (!outputs[j].second.empty() && same_file(path, outputs[j].second)) {
        throw InputError(path + ": " + outputs[j].first + " and " + option + " name the same file");
      }
    }
  }
}

void write_json(const std::string& path, const nlohmann::json& doc) { io::write_file_atomic(path, doc.dump(2) + "\n"); }

}  // namespace sagitta::app
