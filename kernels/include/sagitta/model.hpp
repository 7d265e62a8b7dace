// A model is a list of Bézier patches; its topology says which patch sides are shared, which are
// free boundary and which collapse to a point. All matching is exact (bit-identical control points).
#pragma once

#include "sagitta/patch.hpp"

#include <string>
#include <vector>

namespace sagitta {

struct Model {
  std::string name;
  std::vector<BezierPatch> patches;
};

// Throws InputError unless the model has at least one patch and every patch is well formed.
void validate_model(const Model& model, const std::string& what);

// normalize_weights on every patch: the same surfaces, weights in a safe range. Readers call it
// after validate_model on every model they return.
void normalize_weights(Model& model);

// `copies` translated instances of the model laid out on a square grid with a gap between them
// (the papers' "5 cups", "100 cups" scenes). copies == 1 returns the model unchanged.
Model replicate(const Model& model, int copies);

// Bounding box of all control points.
Box model_box(const Model& model);

// Diagonal of the bounding box of the points (0 when there are none): of a part mesh's vertices,
// which lie on the part, the diagonal `sagitta fit --relative` scales the target by.
double points_box_diagonal(const std::vector<Vec3>& points);

struct SideRef {
  uint32_t patch = 0;
  Side side = Side::kU0;
};

// Corner c of a patch: 0 = (u0, v0), 1 = (u0, v1), 2 = (u1, v0), 3 = (u1, v1).
inline constexpr int kCornersPerPatch = 4;
namespace detail {  // used by the topology and the boundary layout only
// The two corners at the start and end of a side, in the side's increasing parameter order.
std::array<int, 2> side_corners(Side side);
// (u, v) of a corner.
Vec2 corner_uv(int corner);
}  // namespace detail

struct Topology {
  // One unique boundary curve. Its canonical direction is the lexicographically smaller of the
  // control polygon read forwards or backwards, so it depends only on the curve, not on the patch
  // order; every patch using it evaluates it in that direction.
  struct Edge {
    std::vector<SideRef> uses;       // 1: free boundary; 2: shared; > 2: non-manifold
    std::vector<bool> use_reversed;  // per use: the side runs against the canonical direction
    std::vector<Vec3> points;        // control polygon in canonical direction
    std::vector<double> weights;     // canonical weights (empty when polynomial)
  };
  struct SideInfo {
    int32_t edge = -1;  // index into edges; -1 when the side is collapsed to a point
    bool reversed = false;
    bool collapsed = false;
  };
  // Two unmatched sides whose control polygons nearly coincide: a seam gap that is reported, never
  // closed silently.
  struct NearMiss {
    SideRef a, b;
    double distance = 0.0;  // largest distance between corresponding control points
  };

  std::vector<Edge> edges;
  std::vector<SideInfo> sides;           // index patch * 4 + side
  std::vector<uint32_t> corner_class;    // index patch * 4 + corner -> shared corner id
  uint32_t corner_classes = 0;
  std::vector<Vec3> corner_position;     // per corner class
  std::vector<NearMiss> near_misses;     // sorted by (a, b); each pair once
  double near_miss_tolerance = 0.0;      // the model-wide tolerance used (see build_topology)
  double near_miss_patch_fraction = 0.0; // and the fraction of a patch's size that caps it (0: none)
  std::vector<SideRef> near_collapsed;   // sides shorter than the tolerance but not exactly a point

  const SideInfo& side(uint32_t patch, Side s) const { return sides[patch * 4 + static_cast<int>(s)]; }
  size_t free_edges() const;
  size_t shared_edges() const;
  size_t nonmanifold_edges() const;
  size_t collapsed_sides() const;
};

// Default near-miss tolerance of a side: the smaller of these fractions of the model's box diagonal
// and of the side's patch's control-box diagonal.
inline constexpr double kNearMissModelFraction = 1e-2;
inline constexpr double kNearMissPatchFraction = 5e-2;

// Builds the topology. Near misses and near-collapsed sides are only reported, never merged: two
// unmatched sides are a near miss when their control polygons lie within the smaller of their
// tolerances, and a side is near-collapsed when shorter than its tolerance. A side's tolerance is
// `near_miss_tolerance` (model units) when > 0, else the default above. Found with a spatial
// index (no quadratic pass); honours the run's budget (sagitta/budget.hpp).
Topology build_topology(const Model& model, double near_miss_tolerance = 0.0);

// Bytes build_topology allocates for `patches` patches of degree up to `degree` (an estimate for
// the memory guard, generous rather than tight).
double topology_bytes(size_t patches, int degree);
// Bytes of a model of `patches` patches of degree up to (du, dv), rational or not.
double model_bytes(size_t patches, int du, int dv, bool rational);

}  // namespace sagitta
