#include "sagitta/esc.hpp"

#include "boundary.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"

#include <glm/geometric.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace sagitta {

namespace {

// Every pattern vertex of a patch of degree (n, m) at level L lies on the fine lattice
// (a, b), a = 0..n(L+1), b = 0..m(L+1), at (u, v) = (a / (n(L+1)), b / (m(L+1))).
struct Lattice {
  int P = 1;  // segments per coarse edge, L + 1
  int n = 1, m = 1;
  int cols = 2;
  int index(int a, int b) const { return a * cols + b; }
  double u(int a) const { return static_cast<double>(a) / static_cast<double>(n * P); }
  double v(int b) const { return static_cast<double>(b) / static_cast<double>(m * P); }
};

// Lattice point of position c (0..k) in row k (0..P) of coarse triangle `tri` of cell (i, j).
// Row 0 is the apex (the cell corner at the right angle), row P the base (the cell diagonal from
// (i, j) to (i + 1, j + 1)); c = 0 lies on the "left" grid edge and c = k on the "right" one. The
// order makes (row k+1 c, row k c, row k+1 c+1) counter-clockwise in (u, v).
inline void row_point(int P, int tri, int i, int j, int k, int c, int& a, int& b) {
  if (tri == 0) {  // triangle (i,j) (i+1,j) (i+1,j+1): apex (i+1, j), left edge v = j, right edge u = i+1
    a = i * P + P - k + c;
    b = j * P + c;
  } else {  // triangle (i,j) (i+1,j+1) (i,j+1): apex (i, j+1), left edge v = j+1, right edge u = i
    a = i * P + k - c;
    b = j * P + P - c;
  }
}

// The distance test of the seed: insert when the control-net point is farther than rho from the
// surface point; rho == 0 inserts every candidate (the non-adaptive pattern).
inline bool passes(const Vec3& net, const Vec3& surface, double rho) {
  return rho <= 0.0 || glm::length(net - surface) > rho;
}

// Decides the P - 1 candidates of one coarse edge from its surface points S[0..P] (ends included)
// and the control points A, B at its ends; ins[s] = 1 inserts candidate s (1..P-1).
// Paper mode: the distance test at every candidate, net point A + (s / P)(B - A).
// Per-edge levels: nothing when the paper's test inserts nothing; else the smallest level l in
// 1..P-1 whose nested set K_l (K_l = K_{l-1} plus round(t P / (l + 1)), t = 1..l) leaves every
// other candidate within rho of the polyline through the inserted surface points.
void decide_edge(const Vec3* S, const Vec3& A, const Vec3& B, int P, double rho, bool per_edge, uint8_t* ins) {
  bool any = false;
  for (int s = 1; s < P; ++s) {
    const double t = static_cast<double>(s) / P;
    ins[s] = passes(A + t * (B - A), S[s], rho) ? 1 : 0;
    any = any || ins[s];
  }
  if (!per_edge || rho <= 0.0 || !any) return;
  uint8_t set[kMaxEscLevel + 2] = {};
  set[0] = set[P] = 1;
  for (int level = 1; level < P; ++level) {
    for (int t = 1; t <= level; ++t) set[(2 * t * P + level + 1) / (2 * (level + 1))] = 1;
    bool ok = true;
    int lo = 0;
    for (int s = 1; s < P && ok; ++s) {
      if (set[s]) {
        lo = s;
        continue;
      }
      int hi = s + 1;
      while (!set[hi]) ++hi;
      const double w = static_cast<double>(s - lo) / (hi - lo);
      ok = glm::length(S[lo] + w * (S[hi] - S[lo]) - S[s]) <= rho;
    }
    if (ok) break;
  }
  for (int s = 1; s < P; ++s) ins[s] = set[s];
}

struct Node {
  uint32_t id;
  int a, b;    // lattice point (a VV keeps its own lattice point, in another row)
  double pos;  // normalised position along its row, 0..1
};

// Twice the signed area of (p, q, r) in lattice units; > 0 is counter-clockwise in (u, v).
inline long orient(const Node& p, const Node& q, const Node& r) {
  return static_cast<long>(q.a - p.a) * (r.b - p.b) - static_cast<long>(q.b - p.b) * (r.a - p.a);
}

// Vertex ids inside a patch's output before renumbering: side vertices keep their layout id,
// vertices strictly inside the patch are kLocal | (index in the patch's own vertex arrays).
constexpr uint32_t kLocal = 0x80000000u;

struct PatchOutput {
  std::vector<Vec3> positions, normals;  // vertices strictly inside the patch
  std::vector<SurfacePoint> surface_points;
  std::vector<Triangle> triangles;
  std::vector<std::array<Vec2, 3>> uv;
  StripList strips;
  uint64_t degenerate = 0;
  std::vector<uint32_t> local_id;  // final id minus the patch's base for each own vertex; UINT32_MAX unused
  uint32_t local_used = 0;
  std::vector<uint32_t> side_ids;  // side vertex ids its triangles and strips use (with repeats)
};

// Per-thread working arrays of the per-patch pass, reused from patch to patch.
struct Scratch {
  std::vector<uint8_t> mask;
  std::vector<SurfacePointEval> ev;
  std::vector<uint32_t> ids;
  std::vector<Node> upper;
  std::vector<Node> lower;
  std::vector<uint32_t> strip;
  std::vector<uint32_t> side_ids;
};

// Throws InputError, saying why, for parameters outside their ranges or a topology of another model.
void check_params(const Model& model, const Topology& topology, const EscParams& params) {
  if (params.level < 0 || params.level > kMaxEscLevel) {
    throw InputError("esc --level " + std::to_string(params.level) + " is outside 0.." + std::to_string(kMaxEscLevel) +
                     " (level L puts L + 1 segments on every coarse edge and 2 n m (L + 1)^2 triangles in a degree n x m "
                     "patch: at level 15 a degree-25 patch already makes 320,000 triangles, about 0.02 GiB at 64 bytes "
                     "per triangle; for finer meshes use --scheme uniform)");
  }
  if (!std::isfinite(params.threshold) || params.threshold < 0.0) {
    throw InputError("esc --threshold must be a finite distance >= 0 (0 inserts every candidate), got " +
                     std::to_string(params.threshold));
  }
  const size_t np = model.patches.size();
  if (topology.sides.size() != np * 4) throw InputError("internal: the topology does not belong to this model");
  if (!params.patch_thresholds.empty() && params.patch_thresholds.size() != np) {
    throw InputError("per-patch thresholds: " + std::to_string(params.patch_thresholds.size()) + " thresholds for " +
                     std::to_string(np) + " patches");
  }
  for (double t : params.patch_thresholds) {
    if (!std::isfinite(t) || t < 0.0) {
      throw InputError("esc per-patch thresholds must be finite distances >= 0, got " + std::to_string(t));
    }
  }
}

// The threshold rho of patch p.
double patch_rho(const EscParams& params, size_t p) {
  return params.patch_thresholds.empty() ? params.threshold : params.patch_thresholds[p];
}

// The shared side vertices and, per unique boundary curve, which of its samples are inserted.
struct Sides {
  BoundaryLayout layout;
  Tessellation full;                  // side vertices only; patch interiors live in PatchOutput
  std::vector<uint64_t> edge_offset;  // sample k (0..N) of edge e is edge_insert[edge_offset[e] + k]
  std::vector<uint8_t> edge_insert;
};

// 1. Patch sides: one decision per sample of each unique boundary curve, from that curve alone in
// its canonical direction; the surface point is the shared vertex itself (fill_boundary evaluates
// the canonical curve at t = k / N), and the net point is the canonical control polygon
// interpolated linearly.
Sides decide_sides(const Model& model, const Topology& topology, const EscParams& params, int P) {
  Sides sides;
  sides.layout = layout_boundary(
      topology, [&](size_t e) { return static_cast<int>(topology.edges[e].points.size() - 1) * P; }, 0);
  const BoundaryLayout& layout = sides.layout;
  if (layout.end >= kLocal) throw InputError("the tessellation needs more than 2^31 side vertices; lower the level");
  Tessellation& full = sides.full;
  full.positions.resize(layout.end);
  if (params.normals) full.normals.resize(layout.end);
  if (params.surface_data) full.surface_points.resize(layout.end);
  fill_boundary(model, topology, layout, full);
  std::vector<uint64_t>& edge_offset = sides.edge_offset;
  edge_offset.assign(topology.edges.size() + 1, 0);
  for (size_t e = 0; e < topology.edges.size(); ++e) {
    edge_offset[e + 1] = edge_offset[e] + static_cast<uint64_t>(layout.edge_segments[e]) + 1;
  }
  std::vector<uint8_t>& edge_insert = sides.edge_insert;
  edge_insert.assign(edge_offset.back(), 1);
  tbb::parallel_for(size_t{0}, topology.edges.size(), [&](size_t e) {
    const Topology::Edge& edge = topology.edges[e];
    const int n = layout.edge_segments[e];
    double rho = patch_rho(params, edge.uses.front().patch);
    for (const SideRef& use : edge.uses) rho = std::min(rho, patch_rho(params, use.patch));
    Vec3 S[kMaxEscLevel + 2];
    uint8_t ins[kMaxEscLevel + 2];
    for (int seg = 0; seg * P < n; ++seg) {
      for (int s = 0; s <= P; ++s) {
        const int k = seg * P + s;
        S[s] = k == 0   ? edge.points.front()
               : k == n ? edge.points.back()
                        : full.positions[layout.edge_base[e] + static_cast<uint32_t>(k - 1)];
      }
      decide_edge(S, edge.points[static_cast<size_t>(seg)], edge.points[static_cast<size_t>(seg + 1)], P, rho,
                  params.per_edge_levels, ins);
      for (int s = 1; s < P; ++s) edge_insert[edge_offset[e] + static_cast<uint64_t>(seg * P + s)] = ins[s];
    }
  });
  return sides;
}

// What every patch of the per-patch pass reads.
struct EscInput {
  const Model& model;
  const Topology& topology;
  const EscParams& params;
  const Sides& sides;
  int P;
};

// One patch in the per-patch pass: its lattice and the scratch holding its mask, surface and ids.
struct PatchState {
  const BezierPatch& patch;
  uint32_t pid;
  double rho;
  Lattice lat;
  int na, mb;         // the last lattice index along u and along v
  bool collapsed[4];  // which sides of this patch collapse to a point
  Scratch& sc;

  uint8_t& mask(int a, int b) const { return sc.mask[static_cast<size_t>(lat.index(a, b))]; }
  bool inserted(int a, int b) const { return mask(a, b) != 0; }
  // True when lattice point (a, b) lies on a side of the patch collapsed to a point: its vertex id
  // is the collapse vertex, whether or not the point was inserted.
  bool on_collapsed_side(int a, int b) const {
    return (a == 0 && collapsed[static_cast<int>(Side::kU0)]) || (a == na && collapsed[static_cast<int>(Side::kU1)]) ||
           (b == 0 && collapsed[static_cast<int>(Side::kV0)]) || (b == mb && collapsed[static_cast<int>(Side::kV1)]);
  }
  // True when (a, b) lies on a side that is not collapsed (its decision is shared with the neighbour).
  bool on_free_side(int a, int b) const {
    return (a == 0 && !collapsed[static_cast<int>(Side::kU0)]) ||
           (a == na && !collapsed[static_cast<int>(Side::kU1)]) ||
           (b == 0 && !collapsed[static_cast<int>(Side::kV0)]) || (b == mb && !collapsed[static_cast<int>(Side::kV1)]);
  }
};

// Candidates decided by the patch's own coarse edges.
struct Counts {
  uint64_t candidates = 0, inserted = 0;
};

// The mask cleared to the patch's lattice, then set on its four sides from the shared side decisions
// (coarse-edge ends are always inserted).
void mark_sides(const EscInput& in, const PatchState& ps) {
  const int P = in.P;
  const Lattice& lat = ps.lat;
  const int na = ps.na, mb = ps.mb;
  std::vector<uint8_t>& mask = ps.sc.mask;
  mask.assign(static_cast<size_t>((na + 1) * (mb + 1)), 0);
  for (Side side : kAllSides) {
    const Topology::SideInfo& info = in.topology.side(ps.pid, side);
    const bool along_v = side == Side::kU0 || side == Side::kU1;
    const int count = (along_v ? lat.m : lat.n) * P;
    for (int k = 0; k <= count; ++k) {
      const int a = side == Side::kU0 ? 0 : side == Side::kU1 ? na : k;
      const int b = side == Side::kV0 ? 0 : side == Side::kV1 ? mb : k;
      bool ins = true;
      if (k % P != 0) {
        if (info.collapsed) {
          ins = ps.rho <= 0.0;  // net point and surface point are the collapse point: distance 0
        } else {
          const int canonical = info.reversed ? count - k : k;
          ins = in.sides.edge_insert[in.sides.edge_offset[static_cast<size_t>(info.edge)] +
                                     static_cast<uint64_t>(canonical)] != 0;
        }
      }
      mask[static_cast<size_t>(lat.index(a, b))] = ins ? 1 : 0;
    }
  }
}

// The surface on the whole lattice, one u-contraction per lattice row (as the uniform scheme):
// the same numbers PatchEvaluator::evaluate gives, at a fraction of its cost. The partials (for
// normals) only when `partials`; otherwise only the positions are set.
void evaluate_lattice(const PatchState& ps, bool partials) {
  const BezierPatch& patch = ps.patch;
  const Lattice& lat = ps.lat;
  const int na = ps.na, mb = ps.mb;
  const detail::PatchEvaluator eval(patch);
  std::vector<SurfacePointEval>& ev = ps.sc.ev;
  ev.resize(ps.sc.mask.size());
  const int du = patch.degree_u, dv = patch.degree_v;
  std::vector<double> bv(static_cast<size_t>((mb + 1) * (dv + 1))), dbv(bv.size());
  for (int b = 0; b <= mb; ++b) {
    eval.basis_row(dv, lat.v(b), &bv[static_cast<size_t>(b * (dv + 1))], &dbv[static_cast<size_t>(b * (dv + 1))]);
  }
  double a_row[kMaxDegree + 1], da_row[kMaxDegree + 1];
  std::array<double, 4> row[kMaxDegree + 1], drow[kMaxDegree + 1];
  for (int a = 0; a <= na; ++a) {
    eval.basis_row(du, lat.u(a), a_row, da_row);
    if (!partials) {
      eval.contract_u_position(a_row, row);
      for (int b = 0; b <= mb; ++b) {
        ev[static_cast<size_t>(lat.index(a, b))].position =
            eval.finish_position(row, &bv[static_cast<size_t>(b * (dv + 1))]);
      }
      continue;
    }
    eval.contract_u(a_row, da_row, row, drow);
    for (int b = 0; b <= mb; ++b) {
      ev[static_cast<size_t>(lat.index(a, b))] =
          eval.finish(row, drow, &bv[static_cast<size_t>(b * (dv + 1))], &dbv[static_cast<size_t>(b * (dv + 1))]);
    }
  }
}

// Coarse edges inside the patch: grid lines u = i/n, v = j/m and the cell diagonals, each
// decided once from its own surface points and the control points at its ends.
Counts decide_coarse_edges(const EscInput& in, const PatchState& ps) {
  const int P = in.P;
  const BezierPatch& patch = ps.patch;
  const Lattice& lat = ps.lat;
  const std::vector<SurfacePointEval>& ev = ps.sc.ev;
  Counts counts;
  Vec3 S[kMaxEscLevel + 2];
  uint8_t ins[kMaxEscLevel + 2];
  auto decide = [&](int a0, int b0, int da, int db, const Vec3& A, const Vec3& B) {
    for (int s = 0; s <= P; ++s) S[s] = ev[static_cast<size_t>(lat.index(a0 + s * da, b0 + s * db))].position;
    decide_edge(S, A, B, P, ps.rho, in.params.per_edge_levels, ins);
    for (int s = 1; s < P; ++s) {
      ps.mask(a0 + s * da, b0 + s * db) = ins[s];
      ++counts.candidates;
      counts.inserted += ins[s];
    }
  };
  for (int i = 0; i < lat.n; ++i) {
    for (int j = 0; j < lat.m; ++j) {
      if (i > 0) decide(i * P, j * P, 0, 1, patch.at(i, j), patch.at(i, j + 1));
      if (j > 0) decide(i * P, j * P, 1, 0, patch.at(i, j), patch.at(i + 1, j));
      decide(i * P, j * P, 1, 1, patch.at(i, j), patch.at(i + 1, j + 1));
      if (i > 0 && j > 0) ps.mask(i * P, j * P) = 1;
    }
  }
  return counts;
}

// Two adjacent sides collapsed to their common corner C: every lattice point on the two sides is
// C, so any two pattern edges from one vertex to the two sides are one edge in 3D. With a chord
// (a coarse edge without inserted candidates) from the corner cell's grid corner to each side,
// or a corner-cell triangle fanned from C over the diagonal, the corner region closed into a
// bubble (the same triangle twice, non-manifold edges). The corner cell and its two
// neighbours along the sides therefore take the full pattern (as at rho = 0, where the lattice
// triangles are a disc): every point of their coarse edges is inserted, except on a side that is
// not collapsed, whose decision is shared with the neighbouring patch.
void force_collapsed_corners(int P, const PatchState& ps, Counts& counts) {
  const Lattice& lat = ps.lat;
  const int na = ps.na, mb = ps.mb;
  auto force_cell = [&](int i, int j) {
    if (i < 0 || i >= lat.n || j < 0 || j >= lat.m) return;
    for (int s = 0; s <= P; ++s) {
      const int pts[5][2] = {{i * P + s, j * P},
                             {i * P + s, (j + 1) * P},
                             {i * P, j * P + s},
                             {(i + 1) * P, j * P + s},
                             {i * P + s, j * P + s}};
      for (const auto& pt : pts) {
        uint8_t& m = ps.mask(pt[0], pt[1]);
        if (m || ps.on_free_side(pt[0], pt[1])) continue;
        m = 1;
        const bool on_side = pt[0] == 0 || pt[0] == na || pt[1] == 0 || pt[1] == mb;
        if (!on_side) ++counts.inserted;  // an interior candidate the distance test had left out
      }
    }
  };
  for (Side us : {Side::kU0, Side::kU1}) {
    for (Side vs : {Side::kV0, Side::kV1}) {
      if (!ps.collapsed[static_cast<int>(us)] || !ps.collapsed[static_cast<int>(vs)]) continue;
      const int ci = us == Side::kU0 ? 0 : lat.n - 1, cj = vs == Side::kV0 ? 0 : lat.m - 1;
      const int di = us == Side::kU0 ? 1 : -1, dj = vs == Side::kV0 ? 1 : -1;
      force_cell(ci, cj);
      force_cell(ci + di, cj);  // the next cell along the V side
      force_cell(ci, cj + dj);  // the next cell along the U side
    }
  }
}

// An inserted edge vertex inserts its whole row inside the coarse triangle.
void fill_rows(int P, const PatchState& ps) {
  const Lattice& lat = ps.lat;
  for (int i = 0; i < lat.n; ++i) {
    for (int j = 0; j < lat.m; ++j) {
      for (int tri = 0; tri < 2; ++tri) {
        for (int k = 2; k < P; ++k) {
          int a0, b0, a1, b1;
          row_point(P, tri, i, j, k, 0, a0, b0);
          row_point(P, tri, i, j, k, k, a1, b1);
          const uint8_t present = ps.mask(a0, b0) | ps.mask(a1, b1);
          for (int c = 1; c < k; ++c) {
            int a, b;
            row_point(P, tri, i, j, k, c, a, b);
            ps.mask(a, b) = present;
          }
        }
      }
    }
  }
}

// Vertex ids on the lattice: side points take their shared layout id, inserted points strictly
// inside the patch become the patch's own vertices (kLocal ids, in (a, b) order). Returns whether
// no side collapses and the side points' ids are pairwise distinct (no side shares its curve with
// another side of the patch), so that no pattern triangle can repeat an id.
bool number_vertices(const EscInput& in, const PatchState& ps, PatchOutput& out) {
  const BoundaryLayout& layout = in.sides.layout;
  const Topology& topology = in.topology;
  const EscParams& params = in.params;
  const Lattice& lat = ps.lat;
  const int na = ps.na, mb = ps.mb;
  const uint32_t pid = ps.pid;
  std::vector<uint32_t>& ids = ps.sc.ids;
  ids.assign(ps.sc.mask.size(), UINT32_MAX);
  for (int k = 0; k <= mb; ++k) {
    ids[static_cast<size_t>(lat.index(0, k))] = side_vertex(layout, topology, pid, Side::kU0, k);
    ids[static_cast<size_t>(lat.index(na, k))] = side_vertex(layout, topology, pid, Side::kU1, k);
  }
  for (int k = 0; k <= na; ++k) {
    ids[static_cast<size_t>(lat.index(k, 0))] = side_vertex(layout, topology, pid, Side::kV0, k);
    ids[static_cast<size_t>(lat.index(k, mb))] = side_vertex(layout, topology, pid, Side::kV1, k);
  }
  bool distinct_side_ids = false;
  if (!ps.collapsed[0] && !ps.collapsed[1] && !ps.collapsed[2] && !ps.collapsed[3]) {
    std::vector<uint32_t>& side_ids = ps.sc.side_ids;
    side_ids.clear();
    for (int k = 0; k <= mb; ++k) {
      side_ids.push_back(ids[static_cast<size_t>(lat.index(0, k))]);
      side_ids.push_back(ids[static_cast<size_t>(lat.index(na, k))]);
    }
    for (int k = 1; k < na; ++k) {
      side_ids.push_back(ids[static_cast<size_t>(lat.index(k, 0))]);
      side_ids.push_back(ids[static_cast<size_t>(lat.index(k, mb))]);
    }
    std::sort(side_ids.begin(), side_ids.end());
    distinct_side_ids = std::adjacent_find(side_ids.begin(), side_ids.end()) == side_ids.end();
  }
  for (int a = 1; a < na; ++a) {
    for (int b = 1; b < mb; ++b) {
      const size_t s = static_cast<size_t>(lat.index(a, b));
      if (!ps.sc.mask[s]) continue;
      ids[s] = kLocal | static_cast<uint32_t>(out.positions.size());
      const double u = lat.u(a), v = lat.v(b);
      const SurfacePointEval& e = ps.sc.ev[s];
      out.positions.push_back(e.position);
      if (params.normals) {
        const Vec3 cr = glm::cross(e.du, e.dv);
        const double len = glm::length(cr);
        out.normals.push_back((len > 0.0 && std::isfinite(len)) ? cr / len : detail::surface_normal(ps.patch, u, v));
      }
      if (params.surface_data) out.surface_points.push_back({pid, u, v});
    }
  }
  return distinct_side_ids;
}

// One coarse triangle: triangle `tri` (0 or 1) of cell (i, j), with P segments per coarse edge.
struct CoarseTriangle {
  int P, tri, i, j;
  void point(int k, int c, int& a, int& b) const { row_point(P, tri, i, j, k, c, a, b); }
};

// Row k of the pattern with the paper's substitutions: a missing end vertex is replaced by
// a virtual vertex, the nearest inserted vertex on the same coarse edge (ties: the lower
// row); missing base candidates are left out (their neighbours on the base connect).
// On a coarse edge lying on a collapsed side every point is the collapse vertex, so the
// end point is kept at its own lattice point: a VV taken from the apex or the far corner
// would be the same vertex at another lattice point, and the zipper, placing it there,
// fanned one triangle from it in two strips (the same triangle twice).
// Returns whether the row is complete: all k + 1 points inserted, none substituted or left out.
bool build_row(const PatchState& ps, const CoarseTriangle& ct, int k, std::vector<Node>& row) {
  const int P = ct.P;
  row.clear();
  bool complete = true;
  for (int c = 0; c <= k; ++c) {
    int a, b;
    ct.point(k, c, a, b);
    const double pos = k == 0 ? 0.0 : static_cast<double>(c) / k;
    if (!ps.inserted(a, b) && !ps.on_collapsed_side(a, b)) {
      complete = false;
      if (c != 0 && c != k) continue;  // only base-row candidates can be missing here
      const bool left = c == 0;
      for (int d = 1; d <= P; ++d) {
        const int rows[2] = {k + d, k - d};
        bool found = false;
        for (int r : rows) {
          if (r < 0 || r > P) continue;
          ct.point(r, left ? 0 : r, a, b);
          if (ps.inserted(a, b)) {
            found = true;
            break;
          }
        }
        if (found) break;
      }
    }
    row.push_back({ps.sc.ids[static_cast<size_t>(ps.lat.index(a, b))], a, b, pos});
  }
  return complete;
}

// Whether row k of the coarse triangle is in the pattern: the apex and the base always are, a row
// between them when one of its end points is inserted.
bool row_present(const PatchState& ps, const CoarseTriangle& ct, int k) {
  if (k == 0 || k == ct.P) return true;
  int a0, b0, a1, b1;
  ct.point(k, 0, a0, b0);
  ct.point(k, k, a1, b1);
  return ps.inserted(a0, b0) || ps.inserted(a1, b1);
}

// zip_rows for a regular band: rows k - 1 and k both complete (every node at its own lattice point,
// at positions c / (k - 1) and c / k) on a patch without collapsed sides (all ids distinct). There
// the zipper alternates, lower row first, never repeats a vertex and never flips a triangle, so
// this writes the same strip (lower 0, upper 0, lower 1, upper 1, ..., upper k-1, lower k) and the
// same triangles in the same order without its tests.
void zip_regular_band(const Lattice& lat, const std::vector<Node>& upper, const std::vector<Node>& lower,
                      bool surface_data, PatchOutput& out) {
  const size_t k = upper.size();
  const auto uv = [&lat](const Node& n) { return Vec2(lat.u(n.a), lat.v(n.b)); };
  const auto emit = [&](const Node& p, const Node& q, const Node& r) {
    out.triangles.push_back({p.id, q.id, r.id});
    if (surface_data) out.uv.push_back({uv(p), uv(q), uv(r)});
  };
  for (size_t c = 0; c < k; ++c) {
    emit(lower[c], upper[c], lower[c + 1]);
    if (c + 1 < k) emit(lower[c + 1], upper[c], upper[c + 1]);
  }
  uint32_t* strip = out.strips.append(2 * k + 1);
  for (size_t c = 0; c < k; ++c) {
    strip[2 * c] = lower[c].id;
    strip[2 * c + 1] = upper[c].id;
  }
  strip[2 * k] = lower[k].id;
}

// Zip the two rows into one strip: advance along the row whose next vertex comes first
// (ties: the upper row); when two consecutive vertices come from the same row, the
// other row's current vertex is replicated (rule 4), which keeps the strip's parity.
// The strip is kept when it has a triangle; its non-degenerate triangles go to `out`.
void zip_rows(const Lattice& lat, const std::vector<Node>& upper, const std::vector<Node>& lower, bool surface_data,
              std::vector<uint32_t>& strip, PatchOutput& out) {
  strip.clear();
  strip.push_back(lower[0].id);
  strip.push_back(upper[0].id);
  bool last_upper = true;
  size_t ui = 0, di = 0, emitted = 0;
  while (ui + 1 < upper.size() || di + 1 < lower.size()) {
    bool advance_upper = di + 1 >= lower.size() || (ui + 1 < upper.size() && upper[ui + 1].pos <= lower[di + 1].pos);
    // Where a virtual vertex bends a row onto a coarse edge, the positional choice can make a
    // flat or flipped triangle; the other choice is then the valid one (exact lattice test).
    if (ui + 1 < upper.size() && di + 1 < lower.size()) {
      const Node& chosen = advance_upper ? upper[ui + 1] : lower[di + 1];
      const Node& other = advance_upper ? lower[di + 1] : upper[ui + 1];
      if (orient(lower[di], upper[ui], chosen) <= 0 && orient(lower[di], upper[ui], other) > 0) {
        advance_upper = !advance_upper;
      }
    }
    // Both rows at the collapse vertex (distinct lattice points, one id): step along the lower
    // row first. The vertex then fans over this strip's lower row only; fanning it over the
    // upper row would repeat, in 3D, the triangles the strip above fans over that row.
    if (lower[di].id == upper[ui].id && (lower[di].a != upper[ui].a || lower[di].b != upper[ui].b) &&
        di + 1 < lower.size()) {
      advance_upper = false;
    }
    const Node& d = lower[di];
    const Node& u = upper[ui];
    const Node& x = advance_upper ? upper[ui + 1] : lower[di + 1];
    if (advance_upper == last_upper) strip.push_back(advance_upper ? d.id : u.id);
    strip.push_back(x.id);
    last_upper = advance_upper;
    const bool same_point = (d.a == u.a && d.b == u.b) || (d.a == x.a && d.b == x.b) || (u.a == x.a && u.b == x.b);
    if (!same_point) {
      if (d.id == u.id || d.id == x.id || u.id == x.id) {
        ++out.degenerate;  // distinct pattern points on a collapsed side
      } else {
        out.triangles.push_back({d.id, u.id, x.id});
        if (surface_data) {
          out.uv.push_back({Vec2(lat.u(d.a), lat.v(d.b)), Vec2(lat.u(u.a), lat.v(u.b)), Vec2(lat.u(x.a), lat.v(x.b))});
        }
        ++emitted;
      }
    }
    if (advance_upper) {
      ++ui;
    } else {
      ++di;
    }
  }
  if (emitted > 0) out.strips.push_back(strip.begin(), strip.end());
}

// The strips and triangles of every coarse triangle, band by band from the apex to the base.
// `distinct_side_ids`: number_vertices' result (regular bands may skip the zipper's tests).
void build_strips(const EscInput& in, const PatchState& ps, bool distinct_side_ids, PatchOutput& out) {
  const Lattice& lat = ps.lat;
  std::vector<Node>& upper = ps.sc.upper;
  std::vector<Node>& lower = ps.sc.lower;
  for (int i = 0; i < lat.n; ++i) {
    for (int j = 0; j < lat.m; ++j) {
      for (int tri = 0; tri < 2; ++tri) {
        const CoarseTriangle ct{in.P, tri, i, j};
        bool upper_complete = build_row(ps, ct, 0, upper);
        int upper_k = 0;
        for (int k = 1; k <= in.P; ++k) {
          if (!row_present(ps, ct, k)) continue;
          const bool lower_complete = build_row(ps, ct, k, lower);
          if (distinct_side_ids && upper_complete && lower_complete && upper_k + 1 == k) {
            zip_regular_band(lat, upper, lower, in.params.surface_data, out);
          } else {
            zip_rows(lat, upper, lower, in.params.surface_data, ps.sc.strip, out);
          }
          std::swap(upper, lower);
          upper_complete = lower_complete;
          upper_k = k;
        }
      }
    }
  }
}

// Which of its vertices the patch uses. A strip vertex is normally used by one of the strip's
// triangles; on a patch with collapsed sides it may only appear in collapsed ones, and the
// strip still needs a valid id.
void mark_used(PatchOutput& out) {
  out.local_id.assign(out.positions.size(), UINT32_MAX);
  auto mark = [&](uint32_t id) {
    if (id & kLocal) {
      out.local_id[id & ~kLocal] = 0;
    } else {
      out.side_ids.push_back(id);
    }
  };
  // Every triangle's corners are in its strip (the zipper writes each vertex it steps to), so the
  // strips list every vertex used.
  for (uint32_t id : out.strips.indices()) mark(id);
  for (uint32_t& r : out.local_id) {
    if (r == 0) r = out.local_used++;
  }
}

// 2. One patch: the insertion mask on its lattice (coarse-edge tests, then rows), the vertices
// strictly inside the patch (patch-local numbering), and the strips and triangles of every coarse
// triangle. Returns the candidates its own coarse edges decided.
Counts tessellate_patch(const EscInput& in, size_t p, Scratch& sc, PatchOutput& out) {
  const BezierPatch& patch = in.model.patches[p];
  const int P = in.P;
  Lattice lat;
  lat.P = P;
  lat.n = patch.degree_u;
  lat.m = patch.degree_v;
  lat.cols = lat.m * P + 1;
  PatchState ps{patch, static_cast<uint32_t>(p), patch_rho(in.params, p), lat, lat.n * P, lat.m * P, {}, sc};
  for (Side side : kAllSides) ps.collapsed[static_cast<int>(side)] = in.topology.side(ps.pid, side).collapsed;

  mark_sides(in, ps);
  evaluate_lattice(ps, in.params.normals);
  Counts counts = decide_coarse_edges(in, ps);
  force_collapsed_corners(P, ps, counts);
  fill_rows(P, ps);

  out.triangles.reserve(static_cast<size_t>(2 * lat.n * lat.m * P * P));
  if (in.params.surface_data) out.uv.reserve(out.triangles.capacity());
  // A coarse triangle's strips hold about P^2 + 2P ids (2k + 1 for band k, more where vertices are
  // replicated); room for twice that.
  out.strips.reserve(static_cast<size_t>(2 * lat.n * lat.m * P),
                     static_cast<size_t>(2 * lat.n * lat.m * P * (2 * P + 4)));
  const bool distinct_side_ids = number_vertices(in, ps, out);
  build_strips(in, ps, distinct_side_ids, out);
  mark_used(out);
  return counts;
}

// Where each patch's output goes in the result (per patch, with one past the end).
struct Offsets {
  std::vector<uint64_t> tri, strip, strip_index, vertex;
};

// Final ids of the side vertices: only those some patch uses, in layout order; UINT32_MAX unused.
// `used` is their count.
std::vector<uint32_t> remap_side_vertices(const std::vector<PatchOutput>& outputs, uint32_t end, uint64_t& used) {
  std::vector<uint32_t> remap(end, UINT32_MAX);
  for (const PatchOutput& o : outputs) {
    for (uint32_t id : o.side_ids) remap[id] = 0;
  }
  used = 0;
  for (uint32_t& r : remap) {
    if (r == 0) r = static_cast<uint32_t>(used++);
  }
  return remap;
}

// Copies one patch's used vertices, its triangles and its strips (ids made final) into `result`,
// then frees the patch's output.
void copy_patch(const EscParams& params, const std::vector<uint32_t>& remap, const Offsets& at, size_t p,
                PatchOutput& o, Tessellation& result) {
  const uint32_t base = static_cast<uint32_t>(at.vertex[p]);
  auto final_id = [&](uint32_t id) { return (id & kLocal) ? base + o.local_id[id & ~kLocal] : remap[id]; };
  for (size_t v = 0; v < o.local_id.size(); ++v) {
    if (o.local_id[v] == UINT32_MAX) continue;
    const uint32_t r = base + o.local_id[v];
    result.positions[r] = o.positions[v];
    if (params.normals) result.normals[r] = o.normals[v];
    if (params.surface_data) result.surface_points[r] = o.surface_points[v];
  }
  for (size_t t = 0; t < o.triangles.size(); ++t) {
    const Triangle& tri = o.triangles[t];
    result.triangles[at.tri[p] + t] = {final_id(tri[0]), final_id(tri[1]), final_id(tri[2])};
    if (params.surface_data) {
      result.triangle_patch[at.tri[p] + t] = static_cast<uint32_t>(p);
      result.triangle_uv[at.tri[p] + t] = o.uv[t];
    }
  }
  const std::vector<uint32_t>& ids = o.strips.indices();
  uint32_t* strip_ids = result.strips.mutable_indices() + at.strip_index[p];
  for (size_t k = 0; k < ids.size(); ++k) strip_ids[k] = final_id(ids[k]);
  const std::vector<uint64_t>& ends = o.strips.offsets();
  uint64_t* strip_ends = result.strips.mutable_offsets() + at.strip[p];
  for (size_t st = 1; st < ends.size(); ++st) strip_ends[st] = at.strip_index[p] + ends[st];
  o = PatchOutput();
}

// 3. Assemble in patch order. Side samples that failed the test were laid out but belong to no
// triangle: only used side vertices are kept (first, in layout order), then every patch's own
// vertices that a triangle or strip uses. `strips` is the number of strips.
Tessellation assemble(const EscParams& params, const Sides& sides, std::vector<PatchOutput>& outputs,
                      uint64_t& strips) {
  const size_t np = outputs.size();
  Tessellation result;
  uint64_t used = 0;
  const std::vector<uint32_t> remap = remap_side_vertices(outputs, sides.layout.end, used);
  Offsets at;
  at.tri.assign(np + 1, 0);
  at.strip.assign(np + 1, 0);
  at.strip_index.assign(np + 1, 0);
  at.vertex.assign(np + 1, used);
  for (size_t p = 0; p < np; ++p) {
    at.vertex[p + 1] = at.vertex[p] + outputs[p].local_used;
    at.tri[p + 1] = at.tri[p] + outputs[p].triangles.size();
    at.strip[p + 1] = at.strip[p] + outputs[p].strips.size();
    at.strip_index[p + 1] = at.strip_index[p] + outputs[p].strips.indices().size();
    result.degenerate_triangles += outputs[p].degenerate;
  }
  used = at.vertex[np];
  if (used > UINT32_MAX) throw InputError("the tessellation needs more than 2^32 vertices; lower the level");
  const uint64_t triangles = at.tri[np];
  strips = at.strip[np];
  budget::check_memory(tessellation_bytes(2.0 * double(triangles), double(used)), "the ESC tessellation",
                       "lower the level or raise --max-memory");
  result.positions.resize(used);
  if (params.normals) result.normals.resize(used);
  if (params.surface_data) result.surface_points.resize(used);
  const Tessellation& full = sides.full;
  tbb::parallel_for(size_t{0}, remap.size(), [&](size_t id) {
    const uint32_t r = remap[id];
    if (r == UINT32_MAX) return;
    result.positions[r] = full.positions[id];
    if (params.normals) result.normals[r] = full.normals[id];
    if (params.surface_data) result.surface_points[r] = full.surface_points[id];
  });
  result.triangles.resize(triangles);
  result.strips.resize(strips, at.strip_index[np]);
  if (params.surface_data) {
    result.triangle_patch.resize(triangles);
    result.triangle_uv.resize(triangles);
  }
  tbb::parallel_for(size_t{0}, np, [&](size_t p) { copy_patch(params, remap, at, p, outputs[p], result); });
  return result;
}

// 4. Stats: the patches' own candidates plus one per side sample that is not a coarse-edge end.
void fill_stats(const Topology& topology, const Sides& sides, int P, const std::vector<Counts>& patch_counts,
                uint64_t strips, EscStats& stats) {
  uint64_t candidates = 0, inserted = 0;
  for (const Counts& c : patch_counts) {
    candidates += c.candidates;
    inserted += c.inserted;
  }
  for (size_t e = 0; e < topology.edges.size(); ++e) {
    const int n = sides.layout.edge_segments[e];
    for (int k = 1; k < n; ++k) {
      if (k % P == 0) continue;
      ++candidates;
      inserted += sides.edge_insert[sides.edge_offset[e] + static_cast<uint64_t>(k)];
    }
  }
  stats.candidates = candidates;
  stats.inserted_vertices = inserted;
  stats.strips = strips;
}

}  // namespace

uint64_t esc_full_triangle_count(const Model& model, int level) {
  const uint64_t p = static_cast<uint64_t>(level + 1);
  uint64_t total = 0;
  for (const BezierPatch& patch : model.patches) {
    total += 2ull * static_cast<uint64_t>(patch.degree_u) * static_cast<uint64_t>(patch.degree_v) * p * p;
  }
  return total;
}

Tessellation tessellate_esc(const Model& model, const Topology& topology, const EscParams& params, EscStats* stats) {
  check_params(model, topology, params);
  const int P = params.level + 1;
  const size_t np = model.patches.size();
  const Sides sides = decide_sides(model, topology, params, P);

  std::vector<Counts> patch_counts(np);
  std::vector<PatchOutput> outputs(np);
  tbb::enumerable_thread_specific<Scratch> scratch;
  const EscInput in{model, topology, params, sides, P};
  tbb::parallel_for(size_t{0}, np, [&](size_t p) {
    budget::check("the ESC tessellation");
    patch_counts[p] = tessellate_patch(in, p, scratch.local(), outputs[p]);
  });

  uint64_t strips = 0;
  Tessellation result = assemble(params, sides, outputs, strips);
  if (stats) fill_stats(topology, sides, P, patch_counts, strips, *stats);
  return result;
}

}  // namespace sagitta
