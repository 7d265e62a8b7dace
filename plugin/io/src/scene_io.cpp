#include "sagitta/io/scene_io.hpp"

#include "sagitta/io/model_io.hpp"
#include "sagitta/uniform.hpp"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>

namespace sagitta::io {

namespace {

using Json = nlohmann::json;

constexpr size_t kMaxInstances = 1000000;
constexpr int kMaxSceneLevel = 10;

// Reads fields of one JSON object, naming the file and the JSON path of every problem.
class Reader {
 public:
  Reader(const std::string& file, std::string path) : file_(file), path_(std::move(path)) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file_ + ": " + (path_.empty() ? std::string("top level") : path_) + ": " + problem);
  }
  Reader field(const std::string& key) const { return Reader(file_, path_.empty() ? key : path_ + "." + key); }
  Reader element(size_t i) const { return Reader(file_, path_ + "[" + std::to_string(i) + "]"); }

  // The value must be an object holding only `allowed` keys.
  void expect_object(const Json& j, std::initializer_list<const char*> allowed) const {
    if (!j.is_object()) fail("expected an object, got " + std::string(j.type_name()));
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (std::none_of(allowed.begin(), allowed.end(), [&](const char* k) { return it.key() == k; })) {
        field(it.key()).fail("unknown field");
      }
    }
  }
  const Json& require(const Json& object, const char* key) const {
    auto it = object.find(key);
    if (it == object.end()) field(key).fail("missing");
    return *it;
  }
  double number(const Json& j) const {
    if (!j.is_number()) fail("expected a number, got " + std::string(j.type_name()));
    const double x = j.get<double>();
    if (!std::isfinite(x)) fail("must be finite");
    return x;
  }
  int integer(const Json& j, int lo, int hi) const {
    if (!j.is_number_integer()) fail("expected an integer, got " + std::string(j.type_name()));
    const bool in_range = j.is_number_unsigned() ? j.get<uint64_t>() >= static_cast<uint64_t>(std::max(lo, 0)) &&
                                                       j.get<uint64_t>() <= static_cast<uint64_t>(hi)
                                                 : j.get<int64_t>() >= lo && j.get<int64_t>() <= hi;
    if (!in_range) {
      fail("must be in " + std::to_string(lo) + ".." + std::to_string(hi));
    }
    return static_cast<int>(j.get<int64_t>());
  }
  std::string string(const Json& j) const {
    if (!j.is_string()) fail("expected a string, got " + std::string(j.type_name()));
    return j.get<std::string>();
  }
  std::vector<double> numbers(const Json& j, size_t count) const {
    if (!j.is_array() || j.size() != count) {
      fail("expected an array of " + std::to_string(count) + " numbers" +
           (j.is_array() ? ", got " + std::to_string(j.size()) + " elements" : ", got " + std::string(j.type_name())));
    }
    std::vector<double> out;
    for (size_t i = 0; i < count; ++i) out.push_back(element(i).number(j[i]));
    return out;
  }
  Vec3 vec3(const Json& j) const {
    const std::vector<double> v = numbers(j, 3);
    return Vec3(v[0], v[1], v[2]);
  }

 private:
  const std::string& file_;
  std::string path_;
};

// The transform of an instance: "transform" (16 numbers, row-major, last row 0 0 0 1) or any of
// "translate", "rotate" {axis, degrees}, "scale" (a number or 3 numbers), applied scale first.
glm::dmat4 parse_transform(const Json& j, const Reader& r) {
  glm::dmat4 m(1.0);
  if (j.contains("transform")) {
    const Reader t = r.field("transform");
    if (j.contains("translate") || j.contains("rotate") || j.contains("scale")) {
      t.fail("give either a matrix or translate/rotate/scale, not both");
    }
    const std::vector<double> v = t.numbers(j["transform"], 16);
    for (int row = 0; row < 4; ++row) {
      for (int col = 0; col < 4; ++col) m[col][row] = v[static_cast<size_t>(row * 4 + col)];  // glm is column-major
    }
    if (v[12] != 0.0 || v[13] != 0.0 || v[14] != 0.0 || v[15] != 1.0) t.fail("the last row must be 0 0 0 1 (affine)");
  } else {
    if (j.contains("translate")) m = glm::translate(m, r.field("translate").vec3(j["translate"]));
    if (j.contains("rotate")) {
      const Reader rr = r.field("rotate");
      const Json& rot = j["rotate"];
      rr.expect_object(rot, {"axis", "degrees"});
      const Vec3 axis = rr.field("axis").vec3(rr.require(rot, "axis"));
      const double degrees = rr.field("degrees").number(rr.require(rot, "degrees"));
      if (!(glm::length(axis) > 0.0)) rr.field("axis").fail("must not be zero");
      m = glm::rotate(m, glm::radians(degrees), glm::normalize(axis));
    }
    if (j.contains("scale")) {
      const Reader s = r.field("scale");
      const Json& sj = j["scale"];
      const Vec3 scale = sj.is_array() ? s.vec3(sj) : Vec3(s.number(sj));
      m = glm::scale(m, scale);
    }
  }
  const double det = glm::determinant(glm::dmat3(m));
  double size = 0.0;
  for (int c = 0; c < 3; ++c) size = std::max(size, glm::length(Vec3(m[c])));
  if (!std::isfinite(det) || !(std::abs(det) > 1e-12 * size * size * size)) r.fail("the transform is singular");
  for (int c = 0; c < 4; ++c) {
    for (int k = 0; k < 4; ++k) {
      if (!std::isfinite(m[c][k])) r.fail("the transform is not finite");
    }
  }
  return m;
}

// A first pass over the text that builds nothing: refuses nesting deeper than kMaxDepth and more
// than kMaxInstances top-level "instances" before any per-instance data exists, and reports
// syntax errors as nlohmann::json does. Linear in the text (nlohmann's DOM parse with a callback
// is not: 25k instances took 3.6 s, 50k 15 s).
class SceneScan : public nlohmann::json_sax<Json> {
 public:
  static constexpr size_t kMaxDepth = 32;
  explicit SceneScan(const std::string& name) : name_(name) {}

  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(size_t) override { return open(Kind::kObject); }
  bool key(string_t& key) override {
    key_is_instances_ = stack_.size() == 1 && key == "instances";
    return true;
  }
  bool end_object() override { return close(); }
  bool start_array(size_t) override { return open(key_is_instances_ && stack_.size() == 1 ? Kind::kInstances : Kind::kArray); }
  bool end_array() override { return close(); }
  bool parse_error(size_t, const std::string&, const nlohmann::detail::exception& e) override { throw e; }

 private:
  enum class Kind { kObject, kArray, kInstances };
  bool value() {
    if (!stack_.empty() && stack_.back() == Kind::kInstances && ++instances_ > kMaxInstances) {
      throw InputError(name_ + ": instances: more than " + std::to_string(kMaxInstances) + " instances");
    }
    return true;
  }
  bool open(Kind kind) {
    value();
    if (stack_.size() >= kMaxDepth) throw InputError(name_ + ": nesting deeper than " + std::to_string(kMaxDepth) + " levels");
    stack_.push_back(kind);
    key_is_instances_ = false;
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }

  const std::string& name_;
  std::vector<Kind> stack_;
  bool key_is_instances_ = false;
  size_t instances_ = 0;
};

}  // namespace

const std::vector<std::string>& scene_fixture_names() {
  static const std::vector<std::string> names = {"pillow_box", "rational_torus", "default"};
  return names;
}

namespace {

// The document: an empty file, nesting deeper than SceneScan::kMaxDepth and more than
// kMaxInstances instances are refused before anything is built; invalid JSON with nlohmann's
// message on one line.
Json parse_scene_json(const std::string& text, const std::string& name) {
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) throw InputError(name + ": empty scene file");
  try {
    // Deep nesting and too many instances are refused before anything is built.
    SceneScan scan(name);
    Json::sax_parse(text, &scan);
    return Json::parse(text);
  } catch (const Json::exception& e) {
    std::string what = e.what();
    const size_t bracket = what.find("] ");
    if (what.rfind("[json.exception", 0) == 0 && bracket != std::string::npos) what = what.substr(bracket + 2);
    for (char& c : what) {
      if (c == '\n' || c == '\r') c = ' ';
    }
    throw InputError(name + ": not valid JSON: " + what);
  }
}

// models: {"NAME": "SOURCE", ...}, each source non-empty, a known fixture or a file.
std::vector<SceneModel> read_models(const Json& doc, const Reader& top) {
  std::vector<SceneModel> out;
  const Reader models = top.field("models");
  const Json& mj = top.require(doc, "models");
  if (!mj.is_object() || mj.empty()) models.fail("expected a non-empty object {\"name\": \"source\"}");
  for (auto it = mj.begin(); it != mj.end(); ++it) {
    const Reader r = models.field(it.key());
    const std::string source = r.string(it.value());
    if (source.empty()) r.fail("empty source");
    if (source.rfind("fixture:", 0) == 0) {
      const std::string fixture = source.substr(8);
      const auto& known = scene_fixture_names();
      if (std::find(known.begin(), known.end(), fixture) == known.end()) {
        r.fail("unknown fixture \"" + fixture + "\" (known: pillow_box, rational_torus, default)");
      }
    }
    if (source == "data:") r.fail("\"data:\" needs a file name");
    out.push_back({it.key(), source});
  }
  return out;
}

// instances: [{"model": NAME, transform...}, ...], each naming one of `models`.
std::vector<SceneInstance> read_instances(const Json& doc, const Reader& top, const std::vector<SceneModel>& models) {
  std::vector<SceneInstance> out;
  const Reader instances = top.field("instances");
  const Json& ij = top.require(doc, "instances");
  if (!ij.is_array() || ij.empty()) instances.fail("expected a non-empty array");
  if (ij.size() > kMaxInstances) instances.fail("more than " + std::to_string(kMaxInstances) + " instances");
  for (size_t i = 0; i < ij.size(); ++i) {
    const Reader r = instances.element(i);
    r.expect_object(ij[i], {"model", "transform", "translate", "rotate", "scale"});
    const std::string model = r.field("model").string(r.require(ij[i], "model"));
    auto found = std::find_if(models.begin(), models.end(), [&](const SceneModel& m) { return m.name == model; });
    if (found == models.end()) r.field("model").fail("unknown model \"" + model + "\"");
    out.push_back({static_cast<size_t>(found - models.begin()), parse_transform(ij[i], r)});
  }
  return out;
}

// camera: every field required; eye and target apart, up not along the view, fov in (0, 180).
SceneCamera read_camera(const Json& doc, const Reader& top) {
  const Reader camera = top.field("camera");
  const Json& cj = top.require(doc, "camera");
  camera.expect_object(cj, {"eye", "target", "up", "fov_y_degrees", "width", "height"});
  SceneCamera cam;
  cam.eye = camera.field("eye").vec3(camera.require(cj, "eye"));
  cam.target = camera.field("target").vec3(camera.require(cj, "target"));
  cam.up = camera.field("up").vec3(camera.require(cj, "up"));
  cam.fov_y_degrees = camera.field("fov_y_degrees").number(camera.require(cj, "fov_y_degrees"));
  cam.width = camera.field("width").integer(camera.require(cj, "width"), 1, 65536);
  cam.height = camera.field("height").integer(camera.require(cj, "height"), 1, 65536);
  const Vec3 forward = cam.target - cam.eye;
  if (!(glm::length(forward) > 0.0) || !std::isfinite(glm::length(forward))) camera.fail("eye and target coincide");
  const Vec3 side = glm::cross(glm::normalize(forward), cam.up);
  if (!(glm::length(side) > 1e-9 * glm::length(cam.up))) {
    camera.field("up").fail("must not be zero or parallel to the view direction");
  }
  if (!(cam.fov_y_degrees > 0.0 && cam.fov_y_degrees < 180.0)) camera.field("fov_y_degrees").fail("must be in (0, 180)");
  return cam;
}

// tolerance_pixels (required, > 0), then the optional scheme, max_level, backface_culling and description.
void read_settings(const Json& doc, const Reader& top, Scene& scene) {
  const Reader tolerance = top.field("tolerance_pixels");
  scene.tolerance_pixels = tolerance.number(top.require(doc, "tolerance_pixels"));
  if (!(scene.tolerance_pixels > 0.0)) tolerance.fail("must be > 0");

  if (doc.contains("scheme")) {
    scene.scheme = top.field("scheme").string(doc["scheme"]);
    if (scene.scheme != "uniform" && scene.scheme != "esc") top.field("scheme").fail("must be \"uniform\" or \"esc\"");
  }
  if (doc.contains("max_level")) scene.max_level = top.field("max_level").integer(doc["max_level"], 0, kMaxSceneLevel);
  if (doc.contains("backface_culling")) {
    const Json& b = doc["backface_culling"];
    if (b.is_boolean()) {
      scene.backface_culling = b.get<bool>() ? "on" : "off";
    } else {
      scene.backface_culling = top.field("backface_culling").string(b);
      if (scene.backface_culling != "auto") top.field("backface_culling").fail("must be true, false or \"auto\"");
    }
  }
  if (doc.contains("description")) top.field("description").string(doc["description"]);
}

}  // namespace

Scene detail::parse_scene(const std::string& text, const std::string& name) {
  const Json doc = parse_scene_json(text, name);
  const Reader top(name, "");
  top.expect_object(doc, {"models", "instances", "camera", "tolerance_pixels", "scheme", "max_level",
                          "backface_culling", "description"});
  Scene scene;
  scene.models = read_models(doc, top);
  scene.instances = read_instances(doc, top, scene.models);
  scene.camera = read_camera(doc, top);
  read_settings(doc, top, scene);
  return scene;
}

// JSON may be minified onto one line: lines are not limited, NUL bytes (invalid JSON) are refused.
Scene read_scene(const std::string& path) { return detail::parse_scene(detail::read_text_input(path, 0), path); }

}  // namespace sagitta::io
