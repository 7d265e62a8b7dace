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

struct SideRef {
  uint32_t patch = 0;
  Side side = Side::kU0;
};

// Corner c of a patch: 0 = (u0, v0), 1 = (u0, v1), 2 = (u1, v0), 3 = (u1, v1).
inline constexpr int kCornersPerPatch = 4;
// The two corners at the start and end of a side, in the side's increasing parameter order.
std::array<int, 2> side_corners(Side side);
// (u, v) of a corner.
Vec2 corner_uv(int corner);

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
  std::vector<NearMiss> near_misses;
  std::vector<SideRef> near_collapsed;   // sides shorter than the tolerance but not exactly a point

  const SideInfo& side(uint32_t patch, Side s) const { return sides[patch * 4 + static_cast<int>(s)]; }
  size_t free_edges() const;
  size_t shared_edges() const;
  size_t nonmanifold_edges() const;
  size_t collapsed_sides() const;
};

// Builds the topology. `near_miss_tolerance` (model units; <= 0 picks 1e-2 of the model's box
// diagonal) only controls which unmatched sides are reported as near misses.
Topology build_topology(const Model& model, double near_miss_tolerance = 0.0);

}  // namespace sagitta
