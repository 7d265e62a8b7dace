// `sagitta scene SCENE.json`: view-dependent tessellation of a scene of placed models.
#include "commands.hpp"
#include "sagitta/app/scene_plan.hpp"

#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/io/scene_io.hpp"

#include "progress.hpp"

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>

namespace sagitta::cli {

namespace scene = app::scene;

namespace {

struct SceneOptions {
  std::string scene;
  std::string json;
  std::string out;
  std::string data_dir;
};

nlohmann::json point_json(const Vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); }

nlohmann::json scene_json(const scene::LoadedScene& loaded, const scene::SceneResult& r) {
  const io::Scene& s = loaded.scene;
  nlohmann::json j;
  j["scheme"] = s.scheme;
  j["tolerance_pixels"] = s.tolerance_pixels;
  j["max_level"] = s.max_level;
  j["camera"] = {{"eye", point_json(s.camera.eye)}, {"target", point_json(s.camera.target)},
                 {"up", point_json(s.camera.up)},   {"fov_y_degrees", s.camera.fov_y_degrees},
                 {"width", s.camera.width},         {"height", s.camera.height}};
  j["instances"] = s.instances.size();
  nlohmann::json models = nlohmann::json::array();
  uint64_t patches = 0, visible = 0;
  for (size_t m = 0; m < r.models.size(); ++m) {
    const scene::ModelCounts& c = r.models[m];
    models.push_back({{"name", c.name},
                      {"source", s.models[m].source},
                      {"instances", c.instances},
                      {"patches", c.patches},
                      {"visible_patches", c.visible_patches},
                      {"triangles", c.triangles},
                      {"backface_culling", loaded.facing[m] != 0}});
    patches += c.patches;
    visible += c.visible_patches;
  }
  j["models"] = models;
  j["patches"] = patches;
  j["visible_patches"] = visible;
  j["culled"] = {{"outside_view", r.culled_outside}, {"back_facing", r.culled_backfacing}};
  j["triangles"] = r.mesh.triangles.size();
  j["vertices"] = r.mesh.positions.size();
  j["over_tolerance"] = r.over_tolerance;
  j["stitch_refinements"] = r.stitch_refinements;
  double worst = 0.0;
  for (const auto& instance : r.choices) {
    for (const scene::PatchChoice& c : instance) {
      if (c.state == scene::PatchState::kVisible) worst = std::max(worst, c.error_pixels);
    }
  }
  j["max_error_pixels"] = worst;
  j[s.scheme == "esc" ? "threshold_index_histogram" : "level_histogram"] = r.parameter_histogram;
  return j;
}

}  // namespace

Command register_scene(CLI::App& app) {
  auto options = std::make_shared<SceneOptions>();
  CLI::App* cmd = app.add_subcommand("scene", "Tessellate a scene (models, instances, camera) to a tolerance in pixels");
  cmd->add_option("scene", options->scene, "Scene file (JSON, see docs/SCENES.md)")->required();
  cmd->add_option("--json", options->json, "Write counts per model, culling, levels and times to this JSON file");
  cmd->add_option("--out", options->out, "Write the scene's mesh (.obj, .ply, .stl)");
  cmd->add_option("--data-dir", options->data_dir,
                  "Folder that \"data:NAME\" models are read from (default: $SAGITTA_DATA_DIR)");
  Command command;
  command.app = cmd;
  command.run = [options]() {
    const Stopwatch total;
    const std::vector<NamedPath> outputs = {{"--out", options->out}, {"--json", options->json}};
    check_outputs(outputs, {options->scene});
    if (!options->out.empty() && !io::is_mesh_file(options->out)) {
      throw InputError(options->out + ": unknown mesh type (use .obj, .ply or .stl)");
    }
    std::string data_dir = options->data_dir;
    if (data_dir.empty()) {
      if (const char* env = std::getenv("SAGITTA_DATA_DIR")) data_dir = env;
    }
    const io::Scene scene = io::read_scene(options->scene);
    const std::string scene_dir = std::filesystem::path(options->scene).parent_path().string();
    std::vector<std::string> inputs = {options->scene};  // the scene's model files are inputs too
    for (const io::SceneModel& m : scene.models) inputs.push_back(scene::scene_model_path(m, scene_dir.empty() ? "." : scene_dir, data_dir));
    check_outputs(outputs, inputs);
    const Stopwatch load;
    const scene::LoadedScene loaded = scene::load_scene(scene, scene_dir.empty() ? "." : scene_dir, data_dir);
    const double load_seconds = load.seconds();
    const Stopwatch run;
    ProgressLine bar("scene");  // drawn only on a terminal, after a second
    const scene::SceneResult result = scene::tessellate_scene(
        loaded, [&](size_t done, size_t all) { bar.update(static_cast<int>(done), static_cast<int>(all), "instances"); });
    const double run_seconds = run.seconds();
    if (!options->out.empty()) io::write_mesh(result.mesh, options->out);
    nlohmann::json j = scene_json(loaded, result);
    j["scene"] = options->scene;
    j["seconds"] = {{"load", load_seconds},
                    {"choose_and_tessellate", run_seconds},
                    {"certify", result.certify_seconds},
                    {"tessellate", result.tessellate_seconds},
                    {"total", total.seconds()}};
    if (!options->json.empty()) write_json(options->json, j);
    std::cout << "scene " << options->scene << ": " << j["triangles"] << " triangles, " << j["visible_patches"] << " of "
              << j["patches"] << " patches visible (" << result.culled_outside << " outside the view, "
              << result.culled_backfacing << " facing away), " << result.over_tolerance
              << " over the tolerance, " << total.seconds() << " s\n";
    for (const auto& m : j["models"]) {
      std::cout << "  " << m["name"].get<std::string>() << ": " << m["instances"] << " instances, "
                << m["visible_patches"] << " visible patches, " << m["triangles"] << " triangles\n";
    }
  };
  return command;
}

}  // namespace sagitta::cli
