#include "sagitta/app/scene_plan.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/esc.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/uniform.hpp"

#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>

namespace sagitta::app::scene {

namespace {

// ESC thresholds per model: scale * 2^-index for index 0..kEscSteps-1, and 0 (every candidate) at kEscSteps.
constexpr int kEscSteps = 24;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// +1 / -1 when the model is closed and consistently oriented (du x dv out of / into the solid), else 0.
int closed_orientation(const Model& model, const Topology& topology) {
  if (topology.free_edges() != 0 || topology.nonmanifold_edges() != 0 || !topology.near_misses.empty()) return 0;
  SchemeSpec spec;
  spec.segments = 4;
  spec.vertex_normals = false;
  spec.guard = false;
  const Tessellation mesh = tessellate(model, topology, spec);
  const TopologyReport report = check_mesh_topology(mesh, &model, &topology);
  if (!report.watertight() || report.open_edges != 0 || report.inconsistent_orientation_edges != 0) return 0;
  double volume = 0.0;  // six times the signed volume (divergence theorem)
  for (const Triangle& t : mesh.triangles) {
    volume += glm::dot(mesh.positions[t[0]], glm::cross(mesh.positions[t[1]], mesh.positions[t[2]]));
  }
  return volume > 0.0 ? 1 : volume < 0.0 ? -1 : 0;
}

// The triangles of each patch of a tessellation, in order (one pass, so that per-patch work on a
// large mesh is linear in the mesh, not patches x triangles).
std::vector<std::vector<uint32_t>> triangles_by_patch(const Tessellation& mesh, size_t patches) {
  std::vector<std::vector<uint32_t>> out(patches);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) out[mesh.triangle_patch[t]].push_back(static_cast<uint32_t>(t));
  return out;
}

// The given triangles of one patch as a one-patch tessellation (vertices renumbered, patch index 0).
Tessellation patch_submesh(const Tessellation& mesh, const std::vector<uint32_t>& triangles) {
  Tessellation out;
  std::map<uint32_t, uint32_t> renumber;
  for (const uint32_t t : triangles) {
    Triangle tri;
    for (int k = 0; k < 3; ++k) {
      const uint32_t id = mesh.triangles[t][static_cast<size_t>(k)];
      auto [it, fresh] = renumber.emplace(id, static_cast<uint32_t>(out.positions.size()));
      if (fresh) {
        out.positions.push_back(mesh.positions[id]);
        const Vec2& uv = mesh.triangle_uv[t][static_cast<size_t>(k)];
        out.surface_points.push_back({0, uv.x, uv.y});
      }
      tri[static_cast<size_t>(k)] = it->second;
    }
    out.triangles.push_back(tri);
    out.triangle_patch.push_back(0);
    out.triangle_uv.push_back(mesh.triangle_uv[t]);
  }
  return out;
}

// Largest bound of |S(phi(b)) - X(b)| over a triangle (phi, X affine: its (u, v) corners and its
// vertices), from the validator's Bernstein bound on the 4^depth sub-triangles of a uniform split.
double subdivided_affine_bound(const BezierPatch& patch, const std::array<Vec2, 3>& uv, const std::array<Vec3, 3>& x,
                               int depth) {
  if (depth == 0) {
    const Vec2 q[3] = {uv[0], uv[1], uv[2]};
    const Vec3 X[3] = {x[0], x[1], x[2]};
    return affine_error_bound(patch, q, X);
  }
  const std::array<Vec2, 3> mq = {0.5 * (uv[0] + uv[1]), 0.5 * (uv[1] + uv[2]), 0.5 * (uv[2] + uv[0])};
  const std::array<Vec3, 3> mx = {0.5 * (x[0] + x[1]), 0.5 * (x[1] + x[2]), 0.5 * (x[2] + x[0])};
  double bound = subdivided_affine_bound(patch, {uv[0], mq[0], mq[2]}, {x[0], mx[0], mx[2]}, depth - 1);
  bound = std::max(bound, subdivided_affine_bound(patch, {mq[0], uv[1], mq[1]}, {mx[0], x[1], mx[1]}, depth - 1));
  bound = std::max(bound, subdivided_affine_bound(patch, {mq[2], mq[1], uv[2]}, {mx[2], mx[1], x[2]}, depth - 1));
  return std::max(bound, subdivided_affine_bound(patch, {mq[0], mq[1], mq[2]}, {mx[0], mx[1], mx[2]}, depth - 1));
}

// Certified model-space error of patch p's triangles in `mesh`: an upper bound of the distance from
// any point of them to the surface and from any point of the patch to them.
// Without collapsed sides the triangles' (u, v) tile the patch's square, so the parametric bound
// |S(phi(b)) - X(b)| over each triangle bounds both directions; it is cheap (the validator's
// Bernstein bound on 16 sub-triangles per triangle). With a collapsed side the dropped degenerate
// triangles leave slivers of the square uncovered, and the validator (which reconstructs them)
// certifies the patch instead.
// `triangles`: the patch's triangles in `mesh`.
double certified_patch_error(const BezierPatch& patch, bool collapsed_side, const Tessellation& mesh,
                             const std::vector<uint32_t>& triangles) {
  if (!collapsed_side) {
    double error = 0.0;
    for (const uint32_t t : triangles) {
      if ((t & 4095u) == 0) budget::check("the scene's error bounds");
      const Triangle& tri = mesh.triangles[t];
      const std::array<Vec3, 3> x = {mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]};
      error = std::max(error, subdivided_affine_bound(patch, mesh.triangle_uv[t], x, 2));
    }
    return error;
  }
  Model one;
  one.patches.push_back(patch);
  const Tessellation sub = patch_submesh(mesh, triangles);
  if (sub.triangles.empty()) return 0.0;  // every triangle collapsed: the patch is a point or a curve
  // Only the per-triangle upper bounds are used: the certified lower bounds get a token budget, and
  // the refinement stops at depth 5 (a looser bound only ever asks for a finer level).
  CertifyOptions options;
  options.lower_candidates = 1;
  options.lower_node_budget = 1000;
  options.max_depth = 5;
  const DistanceReport report = certify_distance(one, sub, options);
  double error = 0.0;
  for (double e : report.triangle_upper) error = std::max(error, e);
  if (!report.coverage_ok) error = std::numeric_limits<double>::infinity();
  return error;
}

// World-space control points of a patch under an affine transform.
std::vector<Vec3> transformed_points(const BezierPatch& patch, const glm::dmat4& m) {
  std::vector<Vec3> out;
  out.reserve(patch.points.size());
  for (const Vec3& p : patch.points) out.push_back(Vec3(m * glm::dvec4(p, 1.0)));
  return out;
}

// True when every control point lies strictly outside one plane of the view frustum (the eye plane
// or one of the four sides): by the convex hull property the patch is then invisible.
bool outside_view(const std::vector<Vec3>& points, const View& view) {
  bool behind = true, left = true, right = true, below = true, above = true;
  for (const Vec3& x : points) {
    const Vec3 d = x - view.eye;
    const double z = glm::dot(d, view.forward), sx = glm::dot(d, view.right), sy = glm::dot(d, view.up);
    behind = behind && z <= 0.0;
    right = right && sx > view.tan_x * z;
    left = left && -sx > view.tan_x * z;
    above = above && sy > view.tan_y * z;
    below = below && -sy > view.tan_y * z;
  }
  return behind || left || right || below || above;
}

// True when the normal cone proves every point of the (polynomial) patch faces away from the eye:
// du x dv is a non-negative combination of the cross products of the control net's u- and
// v-differences, so if every such product (times `outward`) makes a positive dot product with
// (x - eye) for every control point x, so does the outward normal at every surface point.
bool faces_away(const BezierPatch& patch, const std::vector<Vec3>& world, int outward, const View& view) {
  if (patch.rational() || outward == 0) return false;
  const int rows = patch.rows(), cols = patch.cols();
  auto at = [&](int i, int j) { return world[static_cast<size_t>(i * cols + j)]; };
  std::vector<Vec3> du, dv;
  for (int i = 0; i + 1 < rows; ++i) {
    for (int j = 0; j < cols; ++j) du.push_back(at(i + 1, j) - at(i, j));
  }
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j + 1 < cols; ++j) dv.push_back(at(i, j + 1) - at(i, j));
  }
  for (const Vec3& a : du) {
    for (const Vec3& b : dv) {
      const Vec3 n = static_cast<double>(outward) * glm::cross(a, b);
      for (const Vec3& x : world) {
        if (!(glm::dot(x - view.eye, n) > 0.0)) return false;
      }
    }
  }
  return true;
}

// One instance's plan: per patch its choice, its parameter q and its nearest depth.
struct InstancePlan {
  InstancePlan(const io::SceneInstance& instance_, size_t patches)
      : instance(instance_), model(instance_.model), choices(patches), q(patches, 0), min_depth(patches, 0.0) {}
  const io::SceneInstance& instance;
  size_t model = 0;
  double stretch = 1.0;  // largest_stretch of the instance's transform
  int outward = 0;       // the model's facing, flipped by a mirroring transform
  std::vector<PatchChoice> choices;
  std::vector<int> q;
  std::vector<double> min_depth;
};

}  // namespace

// Per-model tessellation with one parameter per patch, and the error caches of the level choice.
class ScenePlanner::Caches {
 public:
  explicit Caches(const LoadedScene& scene) : scene_(scene) {
    esc_ = scene.scene.scheme == "esc";
    finest_ = esc_ ? kEscSteps : scene.scene.max_level;
    plain_.resize(scene.models.size());
    for (const Model& m : scene.models) scale_.push_back(model_box(m).diagonal());
  }

  bool esc() const { return esc_; }
  int finest() const { return finest_; }

  // Stage 1 of run(): culls each patch of the instance, and for a visible one sets the error the
  // tolerance allows and the coarsest parameter meeting it on its own.
  void choose(InstancePlan& plan, const Model& model, const View& view, double tolerance_pixels) {
    const size_t mi = plan.model;
    const size_t np = model.patches.size();
    for (uint32_t p = 0; p < np; ++p) {
      PatchChoice& c = plan.choices[p];
      const std::vector<Vec3> world = transformed_points(model.patches[p], plan.instance.transform);
      if (outside_view(world, view)) {
        c.state = PatchState::kOutsideView;
        continue;
      }
      if (faces_away(model.patches[p], world, plan.outward, view)) {
        c.state = PatchState::kBackFacing;
        continue;
      }
      double depth = std::numeric_limits<double>::infinity();
      for (const Vec3& x : world) depth = std::min(depth, view.depth(x));
      plan.min_depth[p] = depth;
      // Where the box reaches the eye plane no finite level is provably enough: use the finest.
      c.required_error = depth > 0.0 ? tolerance_pixels * depth / (view.focal_px * plan.stretch) : 0.0;
      int level = 0;
      while (level < finest() && !(plain_error(mi, p, level) <= c.required_error)) ++level;
      plan.q[p] = level;
    }
  }

  // Stage 2 of run(): a patch next to a finer neighbour is triangulated differently along that side;
  // its certified error is checked as tessellated and its parameter raised until it holds. Returns
  // the instance's model-space mesh with the final parameters; counts the raises.
  Tessellation stitch(InstancePlan& plan, size_t np, uint64_t& stitch_refinements) {
    const size_t mi = plan.model;
    Tessellation mesh;
    for (;;) {
      budget::check("the scene");
      mesh = tessellate(mi, plan.q);
      const std::vector<std::vector<uint32_t>> by_patch = triangles_by_patch(mesh, np);
      bool changed = false;
      for (uint32_t p = 0; p < np; ++p) {
        PatchChoice& c = plan.choices[p];
        if (c.state != PatchState::kVisible) continue;
        const std::array<int, 4> sides = side_parameters(mi, p, plan.q);
        const bool stitched = std::any_of(sides.begin(), sides.end(), [&](int s) { return s > plan.q[p]; });
        c.certified_error = stitched ? stitched_error(mi, p, plan.q, mesh, by_patch[p]) : plain_error(mi, p, plan.q[p]);
        if (!(c.certified_error <= c.required_error) && plan.q[p] < finest() && stitched) {
          ++plan.q[p];
          ++stitch_refinements;
          changed = true;
        }
      }
      if (!changed) break;
    }
    return mesh;
  }

  double threshold(size_t model, int index) const {
    return index >= kEscSteps ? 0.0 : scale_[model] * std::ldexp(1.0, -index);
  }

  // Model-space tessellation of `model` with parameter q[p] for patch p.
  Tessellation tessellate(size_t model, const std::vector<int>& q) const {
    const Model& m = scene_.models[model];
    const Topology& topology = scene_.topologies[model];
    SchemeSpec spec;
    spec.guard = false;  // the planner bounds its sizes itself
    if (esc_) {
      spec.scheme = Scheme::kEsc;
      spec.level = std::min(scene_.scene.max_level, kMaxEscLevel);
      for (int index : q) spec.patch_thresholds.push_back(threshold(model, index));
    } else {
      spec.patch_levels = q;
    }
    return sagitta::tessellate(m, topology, spec);
  }

  // Certified error of patch p of `model` when every patch uses parameter q (cached).
  double plain_error(size_t model, uint32_t p, int q) {
    std::vector<std::vector<double>>& table = plain_[model];
    if (table.size() <= static_cast<size_t>(q)) table.resize(static_cast<size_t>(q) + 1);
    std::vector<double>& errors = table[static_cast<size_t>(q)];
    if (errors.empty()) {
      const auto start = std::chrono::steady_clock::now();
      const Model& m = scene_.models[model];
      const Tessellation mesh = tessellate(model, std::vector<int>(m.patches.size(), q));
      const std::vector<std::vector<uint32_t>> by_patch = triangles_by_patch(mesh, m.patches.size());
      errors.resize(m.patches.size());
      tbb::parallel_for(size_t{0}, m.patches.size(), [&](size_t k) {
        errors[k] = certified_patch_error(m.patches[k], collapsed(model, static_cast<uint32_t>(k)), mesh, by_patch[k]);
      });
      certify_seconds += seconds_since(start);
    }
    return errors[p];
  }

  // Certified error of patch p in `mesh` (tessellated with parameters q), cached by the patch's own
  // parameter and the parameters its sides were decided with.
  double stitched_error(size_t model, uint32_t p, const std::vector<int>& q, const Tessellation& mesh,
                        const std::vector<uint32_t>& triangles) {
    const std::array<int, 4> sides = side_parameters(model, p, q);
    const auto key = std::make_tuple(model, p, q[p], sides);
    auto it = stitched_.find(key);
    if (it != stitched_.end()) return it->second;
    const auto start = std::chrono::steady_clock::now();
    const double error = certified_patch_error(scene_.models[model].patches[p], collapsed(model, p), mesh, triangles);
    certify_seconds += seconds_since(start);
    stitched_.emplace(key, error);
    return error;
  }

  bool collapsed(size_t model, uint32_t p) const {
    const Topology& topology = scene_.topologies[model];
    return std::any_of(kAllSides.begin(), kAllSides.end(), [&](Side s) { return topology.side(p, s).collapsed; });
  }

  // Per side of patch p: the finest parameter among the patches sharing it (-1: collapsed side).
  std::array<int, 4> side_parameters(size_t model, uint32_t p, const std::vector<int>& q) const {
    const Topology& topology = scene_.topologies[model];
    std::array<int, 4> sides{};
    for (Side s : kAllSides) {
      const Topology::SideInfo& info = topology.side(p, s);
      int finest = -1;
      if (!info.collapsed) {
        for (const SideRef& use : topology.edges[static_cast<size_t>(info.edge)].uses)
          finest = std::max(finest, q[use.patch]);
      }
      sides[static_cast<size_t>(s)] = finest;
    }
    return sides;
  }

  double certify_seconds = 0.0;

 private:
  const LoadedScene& scene_;
  bool esc_ = false;
  int finest_ = 0;
  std::vector<double> scale_;
  std::vector<std::vector<std::vector<double>>> plain_;  // [model][q][patch]
  std::map<std::tuple<size_t, uint32_t, int, std::array<int, 4>>, double> stitched_;
};

namespace {

// Stage 3 of run(): records the instance's choices and counts, and appends its visible patches to
// the world model; returns each patch's world patch (-1: culled).
std::vector<int64_t> record_choices(InstancePlan& plan, const Model& model, const View& view, double tolerance_pixels,
                                    size_t inst, ModelCounts& counts, SceneResult& result) {
  const size_t np = model.patches.size();
  std::vector<int64_t> world_patch(np, -1);
  for (uint32_t p = 0; p < np; ++p) {
    PatchChoice& c = plan.choices[p];
    c.parameter = plan.q[p];
    if (c.state == PatchState::kOutsideView) {
      ++result.culled_outside;
      continue;
    }
    if (c.state == PatchState::kBackFacing) {
      ++result.culled_backfacing;
      continue;
    }
    c.error_pixels = plan.min_depth[p] > 0.0 ? c.certified_error * plan.stretch * view.focal_px / plan.min_depth[p]
                                             : std::numeric_limits<double>::infinity();
    c.over_tolerance = !(c.error_pixels <= tolerance_pixels);
    result.over_tolerance += c.over_tolerance ? 1 : 0;
    ++result.parameter_histogram[static_cast<size_t>(plan.q[p])];
    ++counts.visible_patches;
    world_patch[p] = static_cast<int64_t>(result.world.patches.size());
    BezierPatch w = model.patches[p];
    w.points = transformed_points(model.patches[p], plan.instance.transform);
    result.world.patches.push_back(std::move(w));
    result.world_instance.push_back(static_cast<uint32_t>(inst));
    result.world_model_patch.push_back(p);
  }
  return world_patch;
}

// Appends the triangles of the instance's visible patches to the scene's mesh, in world space.
void append_world_mesh(const Tessellation& mesh, const io::SceneInstance& instance,
                       const std::vector<int64_t>& world_patch, size_t inst, ModelCounts& counts, SceneResult& result) {
  const glm::dmat3 linear(instance.transform);
  const glm::dmat3 normal_map = glm::transpose(glm::inverse(linear));
  std::vector<uint32_t> renumber(mesh.positions.size(), UINT32_MAX);
  Tessellation& out = result.mesh;
  budget::check_memory(tessellation_bytes(double(out.triangles.size() + mesh.triangles.size()),
                                          double(out.positions.size() + mesh.positions.size())),
                       "the scene's mesh after instance " + std::to_string(inst),
                       "raise the tolerance or --max-memory");
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const int64_t wp = world_patch[mesh.triangle_patch[t]];
    if (wp < 0) continue;
    Triangle tri;
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t id = mesh.triangles[t][k];
      if (renumber[id] == UINT32_MAX) {
        if (out.positions.size() >= UINT32_MAX) throw InputError("the scene needs more than 2^32 vertices");
        renumber[id] = static_cast<uint32_t>(out.positions.size());
        out.positions.push_back(Vec3(instance.transform * glm::dvec4(mesh.positions[id], 1.0)));
        const Vec3 n = normal_map * mesh.normals[id];
        out.normals.push_back(glm::length(n) > 0.0 ? glm::normalize(n) : mesh.normals[id]);
        const Vec2& uv = mesh.triangle_uv[t][k];
        out.surface_points.push_back({static_cast<uint32_t>(wp), uv.x, uv.y});
      }
      tri[k] = renumber[id];
    }
    out.triangles.push_back(tri);
    out.triangle_patch.push_back(static_cast<uint32_t>(wp));
    out.triangle_uv.push_back(mesh.triangle_uv[t]);
    ++counts.triangles;
  }
  out.degenerate_triangles += mesh.degenerate_triangles;
}

}  // namespace

double View::depth(const Vec3& x) const { return glm::dot(x - eye, forward); }

View make_view(const io::SceneCamera& camera) {
  View view;
  view.eye = camera.eye;
  view.forward = glm::normalize(camera.target - camera.eye);
  view.right = glm::normalize(glm::cross(view.forward, camera.up));
  view.up = glm::cross(view.right, view.forward);
  view.tan_y = std::tan(0.5 * camera.fov_y_degrees * M_PI / 180.0);
  view.tan_x = view.tan_y * static_cast<double>(camera.width) / static_cast<double>(camera.height);
  view.focal_px = 0.5 * static_cast<double>(camera.height) / view.tan_y;
  return view;
}

double largest_stretch(const glm::dmat4& transform) {
  // Square root of the largest eigenvalue of A^T A (symmetric 3x3), by power iteration from a
  // start that is not orthogonal to it, then rounded up slightly.
  const glm::dmat3 a(transform);
  const glm::dmat3 ata = glm::transpose(a) * a;
  double frobenius = 0.0;
  for (int c = 0; c < 3; ++c) frobenius += glm::dot(ata[c], ata[c]);
  Vec3 x(1.0, 0.7, 0.3);
  double lambda = 0.0;
  for (int it = 0; it < 200; ++it) {
    const Vec3 y = ata * x;
    const double len = glm::length(y);
    if (!(len > 0.0)) break;
    lambda = glm::dot(x, y) / glm::dot(x, x);
    x = y / len;
  }
  // The power iteration approaches from below; the Frobenius norm of A^T A bounds it from above.
  // Use the smaller of (converged value + margin) and that upper bound.
  const double upper = std::sqrt(std::sqrt(frobenius));
  return std::min(upper, std::sqrt(lambda) * (1.0 + 1e-9));
}

std::string scene_model_path(const io::SceneModel& m, const std::string& scene_dir, const std::string& data_dir) {
  const std::string& source = m.source;
  if (source.rfind("fixture:", 0) == 0) return "";
  std::filesystem::path path;
  if (source.rfind("data:", 0) == 0) {
    if (data_dir.empty()) {
      throw InputError("scene model \"" + m.name + "\": " + source +
                       " needs the shared data folder (--data-dir or SAGITTA_DATA_DIR)");
    }
    path = std::filesystem::path(data_dir) / source.substr(5);
  } else {
    path = std::filesystem::path(source);
    if (path.is_relative()) path = std::filesystem::path(scene_dir) / path;
  }
  return path.string();
}

LoadedScene load_scene(const io::Scene& scene, const std::string& scene_dir, const std::string& data_dir) {
  LoadedScene loaded;
  loaded.scene = scene;
  for (const io::SceneModel& m : scene.models) {
    Model model;
    const std::string path = scene_model_path(m, scene_dir, data_dir);
    if (path.empty()) {
      const std::string name = m.source.substr(8);
      model = name == "pillow_box"       ? fixtures::pillow_box()
              : name == "rational_torus" ? fixtures::rational_torus()
                                         : fixtures::default_model();
    } else {
      if (!std::filesystem::exists(path))
        throw InputError("scene model \"" + m.name + "\": " + path + ": no such file");
      model = io::read_patch_model(path);
    }
    model.name = m.name;
    loaded.topologies.push_back(build_topology(model));
    loaded.facing.push_back(closed_orientation(model, loaded.topologies.back()));
    if (scene.backface_culling == "off") loaded.facing.back() = 0;
    loaded.models.push_back(std::move(model));
  }
  return loaded;
}

ScenePlanner::ScenePlanner(const LoadedScene& scene) : scene_(scene), caches_(std::make_unique<Caches>(scene)) {}
ScenePlanner::~ScenePlanner() = default;

SceneResult tessellate_scene(const LoadedScene& loaded, const std::function<void(size_t, size_t)>& progress) {
  ScenePlanner planner(loaded);
  return planner.run(loaded.scene.camera, progress);
}

SceneResult ScenePlanner::run(const io::SceneCamera& camera, const std::function<void(size_t, size_t)>& progress) {
  const LoadedScene& loaded = scene_;
  const io::Scene& scene = loaded.scene;
  const View view = make_view(camera);
  Caches& planner = *caches_;
  const double certify_before = planner.certify_seconds;
  SceneResult result;
  result.parameter_histogram.assign(static_cast<size_t>(planner.finest()) + 1, 0);
  for (const Model& m : loaded.models) {
    ModelCounts counts;
    counts.name = m.name;
    result.models.push_back(counts);
  }
  if (planner.esc()) {
    for (size_t m = 0; m < loaded.models.size(); ++m) {
      for (int q = 0; q <= kEscSteps; ++q) result.esc_thresholds.push_back(planner.threshold(m, q));
    }
  }
  result.mesh.surface_points.clear();
  const auto start_all = std::chrono::steady_clock::now();

  for (size_t inst = 0; inst < scene.instances.size(); ++inst) {
    const io::SceneInstance& instance = scene.instances[inst];
    const size_t mi = instance.model;
    const Model& model = loaded.models[mi];
    const size_t np = model.patches.size();
    InstancePlan plan(instance, np);
    plan.stretch = largest_stretch(instance.transform);
    plan.outward = loaded.facing[mi] * (glm::determinant(glm::dmat3(instance.transform)) < 0.0 ? -1 : 1);
    ModelCounts& counts = result.models[mi];
    ++counts.instances;
    counts.patches += np;
    planner.choose(plan, model, view, scene.tolerance_pixels);
    const Tessellation mesh = planner.stitch(plan, np, result.stitch_refinements);
    const std::vector<int64_t> world_patch =
        record_choices(plan, model, view, scene.tolerance_pixels, inst, counts, result);
    append_world_mesh(mesh, instance, world_patch, inst, counts, result);
    result.choices.push_back(std::move(plan.choices));
    if (progress) progress(inst + 1, scene.instances.size());
  }
  result.certify_seconds = planner.certify_seconds - certify_before;
  result.tessellate_seconds = seconds_since(start_all) - result.certify_seconds;
  return result;
}

}  // namespace sagitta::app::scene
