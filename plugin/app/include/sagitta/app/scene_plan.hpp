// View-dependent tessellation of a scene: every visible patch of every instance gets the coarsest
// parameter (uniform level, or largest ESC threshold) whose certified error, projected to the
// screen, is within the scene's tolerance in pixels. See docs/SCENES.md.
#pragma once

#include "sagitta/io/scene_io.hpp"
#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sagitta::app::scene {

// A scene with its models read, their topologies built, and what back-face culling may assume.
struct LoadedScene {
  io::Scene scene;
  std::vector<Model> models;
  std::vector<Topology> topologies;
  // Per model: +1 / -1 when the model is closed and consistently oriented with du x dv pointing
  // out of (+1) or into (-1) the solid, so back-facing patches are hidden; 0: never cull it.
  std::vector<int> facing;
};

// Resolves the model sources ("data:NAME" against data_dir, "fixture:NAME", else relative to
// scene_dir) and loads them. Throws InputError naming the scene model whose file is missing, or
// "data:" with no data folder given.
LoadedScene load_scene(const io::Scene& scene, const std::string& scene_dir, const std::string& data_dir);

// The file a scene model is read from ("" for a "fixture:" model); throws InputError for "data:"
// without a data folder.
std::string scene_model_path(const io::SceneModel& model, const std::string& scene_dir, const std::string& data_dir);

// The camera's frame and projection.
struct View {
  Vec3 eye{0.0}, forward{0.0, 0.0, -1.0}, right{1.0, 0.0, 0.0}, up{0.0, 1.0, 0.0};
  double focal_px = 1.0;  // pixels per unit of (lateral offset / depth)
  double tan_x = 1.0, tan_y = 1.0;
  double depth(const Vec3& x) const;
};
View make_view(const io::SceneCamera& camera);

enum class PatchState : uint8_t { kVisible, kOutsideView, kBackFacing };

struct PatchChoice {
  PatchState state = PatchState::kVisible;
  int parameter = 0;             // uniform level, or ESC threshold index (threshold = scale * 2^-index)
  double required_error = 0.0;   // model-space error the tolerance allows (0: box reaches the eye plane)
  double certified_error = 0.0;  // model-space certified error of the patch as tessellated
  double error_pixels = 0.0;     // certified error projected to the screen (conservative)
  bool over_tolerance = false;   // the finest parameter still exceeds the tolerance
};

struct ModelCounts {
  std::string name;
  uint64_t instances = 0, patches = 0, visible_patches = 0, triangles = 0;
};

struct SceneResult {
  Tessellation mesh;                              // world space; triangle_patch indexes `world`
  Model world;                                    // the visible patches, transformed
  std::vector<uint32_t> world_instance;           // per world patch: its instance
  std::vector<uint32_t> world_model_patch;        // per world patch: its patch in the instance's model
  std::vector<std::vector<PatchChoice>> choices;  // per instance, per model patch
  std::vector<ModelCounts> models;
  uint64_t culled_outside = 0, culled_backfacing = 0, over_tolerance = 0;
  uint64_t stitch_refinements = 0;            // levels raised because stitching to a finer neighbour cost accuracy
  std::vector<uint64_t> parameter_histogram;  // visible patches per parameter value
  std::vector<double> esc_thresholds;         // ESC: threshold per index, per model (model-major)
  double certify_seconds = 0.0, tessellate_seconds = 0.0;
};

// Chooses per-patch parameters for a camera and tessellates every instance. Keeps the certified
// per-patch errors it computes (per model patch and parameter, and per stitching configuration),
// so later cameras over the same scene reuse them. The scene must outlive the planner.
class ScenePlanner {
 public:
  explicit ScenePlanner(const LoadedScene& scene);
  ~ScenePlanner();
  ScenePlanner(const ScenePlanner&) = delete;
  ScenePlanner& operator=(const ScenePlanner&) = delete;
  // What tessellate_scene guarantees, for `camera` instead of the scene's own.
  SceneResult run(const io::SceneCamera& camera, const std::function<void(size_t, size_t)>& progress = {});

 private:
  class Caches;
  const LoadedScene& scene_;
  std::unique_ptr<Caches> caches_;
};

// Chooses per-patch parameters and tessellates every instance; `progress(done, total)` is called
// after each instance when given. Guarantees: for every visible patch not flagged over_tolerance,
// certified_error * (largest stretch of the instance's linear map) * focal_px / (smallest depth of
// the patch's transformed control points) <= tolerance_pixels; a patch is culled only when its
// control points (hence the patch) lie outside one frustum plane, or when its normal cone proves
// every point faces away from the eye on a closed model; within an instance, neighbours share
// their boundary vertices (no cracks, no T-junctions).
SceneResult tessellate_scene(const LoadedScene& scene, const std::function<void(size_t, size_t)>& progress = {});

// Largest singular value of the linear part of an affine transform (how much it can stretch an error).
double largest_stretch(const glm::dmat4& transform);

}  // namespace sagitta::app::scene
