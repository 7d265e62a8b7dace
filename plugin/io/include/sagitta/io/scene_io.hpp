// Scene files (JSON): patch models loaded once, instances placing them with affine transforms, a
// perspective camera and a screen-space tolerance in pixels. See docs/SCENES.md for the schema.
#pragma once

#include "sagitta/patch.hpp"

#include <glm/mat4x4.hpp>

#include <string>
#include <vector>

namespace sagitta::io {

// Where a scene model comes from, as written in the file (resolved by the scene loader):
//   "data:NAME"      NAME inside the shared data folder (--data-dir, else SAGITTA_DATA_DIR)
//   "fixture:NAME"   a built-in fixture: pillow_box, rational_torus, default
//   anything else    a path relative to the scene file's folder (or absolute)
struct SceneModel {
  std::string name;
  std::string source;
};

struct SceneInstance {
  size_t model = 0;                  // index into Scene::models
  glm::dmat4 transform{1.0};         // affine: world = transform * (x, y, z, 1)
};

struct SceneCamera {
  Vec3 eye{0.0, 0.0, 10.0};
  Vec3 target{0.0};
  Vec3 up{0.0, 1.0, 0.0};
  double fov_y_degrees = 45.0;  // vertical field of view, in (0, 180)
  int width = 1920;             // image size in pixels, 1..65536
  int height = 1080;
};

struct Scene {
  std::vector<SceneModel> models;
  std::vector<SceneInstance> instances;
  SceneCamera camera;
  double tolerance_pixels = 1.0;  // > 0
  std::string scheme = "uniform";  // "uniform" or "esc"
  int max_level = 6;               // finest uniform level a patch may get, 0..10
  // Back-face culling: "auto" culls only on closed, consistently oriented models; "on", "off".
  std::string backface_culling = "auto";
};

// Reads and parses a scene file (see detail::parse_scene for what is refused).
Scene read_scene(const std::string& path);

// The fixtures a scene may name with "fixture:".
const std::vector<std::string>& scene_fixture_names();

// Used by read_scene, exported for the tests and fuzzers only.
namespace detail {

// Parses a scene from its bytes; `name` is used in messages. Pure: touches no file. Throws
// InputError with one line "NAME: JSON.PATH: problem" for malformed JSON, missing or unknown fields,
// wrong types, non-finite numbers, degenerate cameras or transforms, and instances naming an unknown
// model or an unknown fixture.
Scene parse_scene(const std::string& text, const std::string& name);

}  // namespace detail

}  // namespace sagitta::io
