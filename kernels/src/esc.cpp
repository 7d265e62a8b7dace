#include "sagitta/esc.hpp"

#include "boundary.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"

#include <glm/geometric.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <type_traits>
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
  int a, b;          // lattice point (a VV keeps its own lattice point, in another row)
  int16_t num, den;  // position along its row, num / den in 0..1 (c / k; 0 / 1 on the apex row)
};

// Whether p's position along its row is at or before q's: the exact comparison of the fractions
// (equal to comparing the rounded quotients, as denominators are at most kMaxEscLevel + 1).
inline bool at_or_before(const Node& p, const Node& q) { return p.num * q.den <= q.num * p.den; }

// One row of the pattern: at most kMaxEscLevel + 2 nodes.
struct Row {
  Node nodes[kMaxEscLevel + 2];
  size_t n = 0;
  size_t size() const { return n; }
  const Node& operator[](size_t i) const { return nodes[i]; }
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

inline Vec2 node_uv(const Lattice& lat, const Node& n) { return Vec2(lat.u(n.a), lat.v(n.b)); }

// The copy path's sink: a patch's triangles and strips into its own PatchOutput (patch-local ids).
struct BufferSink {
  PatchOutput& out;
  bool surface_data;
  void triangle(const Lattice& lat, const Node& p, const Node& q, const Node& r) {
    out.triangles.push_back({p.id, q.id, r.id});
    if (surface_data) out.uv.push_back({node_uv(lat, p), node_uv(lat, q), node_uv(lat, r)});
  }
  void strip(const uint32_t* first, const uint32_t* last) { out.strips.push_back(first, last); }
  uint32_t* append_strip(size_t n) { return out.strips.append(n); }
  bool wants_uv() const { return surface_data; }
  Triangle* append_triangles(size_t n) {
    out.triangles.resize(out.triangles.size() + n);
    return out.triangles.data() + (out.triangles.size() - n);
  }
  void mark_used(const uint32_t*, const uint32_t*) {}  // mark_used (the function) reads the strips
  void degenerate() { ++out.degenerate; }
};

// Per-thread working arrays of the per-patch pass, reused from patch to patch.
struct Scratch {
  std::vector<uint8_t> mask;
  std::vector<SurfacePointEval> ev;
  std::vector<uint32_t> ids;
  Row upper, lower;
  std::vector<uint32_t> strip;
  std::vector<uint32_t> side_ids;
  std::vector<double> bv, dbv;    // v-basis rows of the lattice columns (v_basis_rows)
  std::vector<uint8_t> own_used;  // which own vertices the strips use (direct path)
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
      // At rho = 0 every candidate is inserted without looking at the surface.
      for (int s = 0; s <= P && rho > 0.0; ++s) {
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

// The v-basis rows (values, derivatives) of every lattice column, into the scratch's bv and dbv:
// b's row starts at b (degree_v + 1).
void v_basis_rows(const detail::PatchEvaluator& eval, const PatchState& ps) {
  const int dv = ps.patch.degree_v, mb = ps.mb;
  std::vector<double>& bv = ps.sc.bv;
  std::vector<double>& dbv = ps.sc.dbv;
  bv.resize(static_cast<size_t>((mb + 1) * (dv + 1)));
  dbv.resize(bv.size());
  for (int b = 0; b <= mb; ++b) {
    eval.basis_row(dv, ps.lat.v(b), &bv[static_cast<size_t>(b * (dv + 1))], &dbv[static_cast<size_t>(b * (dv + 1))]);
  }
}

// Which lattice points evaluate_lattice evaluates.
enum class LatticePoints {
  kAll,
  kCoarseEdges,  // those of the coarse edges (grid lines u = i/n, v = j/m, cell diagonals): all
                 // that decide_coarse_edges reads; positions only, the other points left as they were
};

// The surface on the lattice, one u-contraction per lattice row (as the uniform scheme): the same
// numbers PatchEvaluator::evaluate gives, at a fraction of its cost. The partials (for normals)
// only when `partials` (and every point); otherwise only the positions are set, the same bits
// (contract_u_position and finish_position are contract_u's row and finish's position).
void evaluate_lattice(const PatchState& ps, bool partials, LatticePoints points = LatticePoints::kAll) {
  const BezierPatch& patch = ps.patch;
  const Lattice& lat = ps.lat;
  const int na = ps.na, mb = ps.mb;
  const detail::PatchEvaluator eval(patch);
  std::vector<SurfacePointEval>& ev = ps.sc.ev;
  ev.resize(ps.sc.mask.size());
  const int du = patch.degree_u, dv = patch.degree_v;
  v_basis_rows(eval, ps);
  const std::vector<double>& bv = ps.sc.bv;
  const std::vector<double>& dbv = ps.sc.dbv;
  double a_row[kMaxDegree + 1], da_row[kMaxDegree + 1];
  std::array<double, 4> row[kMaxDegree + 1], drow[kMaxDegree + 1];
  const auto position = [&](int a, int b) {
    ev[static_cast<size_t>(lat.index(a, b))].position =
        eval.finish_position(row, &bv[static_cast<size_t>(b * (dv + 1))]);
  };
  for (int a = 0; a <= na; ++a) {
    eval.basis_row(du, lat.u(a), a_row, da_row);
    if (!partials && points == LatticePoints::kCoarseEdges && a % lat.P != 0) {
      // Off the grid lines of constant u: the lines of constant v and the diagonals crossing row a.
      eval.contract_u_position(a_row, row);
      const int s = a % lat.P;
      for (int b = 0; b <= mb; b += lat.P) {
        position(a, b);
        if (b + s <= mb) position(a, b + s);
      }
      continue;
    }
    if (!partials) {
      eval.contract_u_position(a_row, row);
      for (int b = 0; b <= mb; ++b) position(a, b);
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
  // At rho = 0 every candidate is inserted without looking at the surface (which may not be evaluated).
  const bool needs_surface = ps.rho > 0.0;
  auto decide = [&](int a0, int b0, int da, int db, const Vec3& A, const Vec3& B) {
    if (needs_surface) {
      for (int s = 0; s <= P; ++s) S[s] = ev[static_cast<size_t>(lat.index(a0 + s * da, b0 + s * db))].position;
    }
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
          // Along a row (a, b) moves by (1, 1) per c in triangle 0 and by (-1, -1) in triangle 1.
          const std::ptrdiff_t step = (tri == 0 ? 1 : -1) * static_cast<std::ptrdiff_t>(lat.cols + 1);
          uint8_t* first = &ps.mask(a0, b0);
          for (int c = 1; c < k; ++c) first[c * step] = present;
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
      if (params.normals) out.normals.push_back(detail::unit_normal(e, ps.patch, u, v));
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
bool build_row(const PatchState& ps, const CoarseTriangle& ct, int k, Row& row) {
  const int P = ct.P;
  const int cols = ps.lat.cols;
  const uint8_t* mask = ps.sc.mask.data();
  const uint32_t* ids = ps.sc.ids.data();
  const int16_t den = static_cast<int16_t>(k == 0 ? 1 : k);
  int a0, b0;
  ct.point(k, 0, a0, b0);
  const int step = ct.tri == 0 ? 1 : -1;  // (a, b) moves by (step, step) from one c to the next
  size_t n = 0;
  bool complete = true;
  for (int c = 0; c <= k; ++c) {
    int a = a0 + step * c, b = b0 + step * c;
    if (!mask[a * cols + b] && !ps.on_collapsed_side(a, b)) {
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
    row.nodes[n++] = {ids[a * cols + b], a, b, static_cast<int16_t>(c), den};
  }
  row.n = n;
  return complete;
}

// Whether row k of the coarse triangle is in the pattern: the apex and the base always are, a row
// between them when one of its end points is inserted.
inline bool row_present(const PatchState& ps, const CoarseTriangle& ct, int k) {
  if (k == 0 || k == ct.P) return true;
  int a0, b0, a1, b1;
  ct.point(k, 0, a0, b0);
  ct.point(k, k, a1, b1);
  return ps.inserted(a0, b0) || ps.inserted(a1, b1);
}

// The triangles and the strip of a regular band between row k - 1 (upper(c), c < k) and row k
// (lower(c), c <= k): the strip lower 0, upper 0, lower 1, ..., upper k-1, lower k and its
// triangles in the zipper's order. Returns the strip's ids as written (null past the bounds).
template <class Lower, class Upper, class Sink>
uint32_t* write_regular_band(const Lattice& lat, int k, const Lower& lower, const Upper& upper, Sink& out) {
  if (out.wants_uv()) {
    for (int c = 0; c < k; ++c) {
      out.triangle(lat, lower(c), upper(c), lower(c + 1));
      if (c + 1 < k) out.triangle(lat, lower(c + 1), upper(c), upper(c + 1));
    }
  } else if (Triangle* t = out.append_triangles(static_cast<size_t>(2 * k - 1))) {  // one bound check
    for (int c = 0; c < k; ++c) {
      *t++ = {lower(c).id, upper(c).id, lower(c + 1).id};
      if (c + 1 < k) *t++ = {lower(c + 1).id, upper(c).id, upper(c + 1).id};
    }
  }
  // Written in place: staged in a local array, the 4-byte stores were read back by the copy's
  // 16-byte loads, which the processor cannot forward (a stall per strip).
  uint32_t* strip = out.append_strip(static_cast<size_t>(2 * k + 1));
  if (strip) {
    for (int c = 0; c < k; ++c) {
      strip[2 * c] = lower(c).id;
      strip[2 * c + 1] = upper(c).id;
    }
    strip[2 * k] = lower(k).id;
  }
  return strip;
}

// zip_rows for a regular band: rows k - 1 and k both complete (every node at its own lattice point,
// at positions c / (k - 1) and c / k) on a patch without collapsed sides (all ids distinct). There
// the zipper alternates, lower row first, never repeats a vertex and never flips a triangle, so
// this writes the same strip (lower 0, upper 0, lower 1, upper 1, ..., upper k-1, lower k) and the
// same triangles in the same order without its tests.
template <class Sink>
void zip_regular_band(const Lattice& lat, const Row& upper, const Row& lower, Sink& out) {
  const int k = static_cast<int>(upper.size());
  const auto from = [](const Row& row) { return [&row](int c) -> const Node& { return row[static_cast<size_t>(c)]; }; };
  if (uint32_t* strip = write_regular_band(lat, k, from(lower), from(upper), out)) {
    out.mark_used(strip, strip + 2 * k + 1);
  }
}

// Zip the two rows into one strip: advance along the row whose next vertex comes first
// (ties: the upper row); when two consecutive vertices come from the same row, the
// other row's current vertex is replicated (rule 4), which keeps the strip's parity.
// The strip is kept when it has a triangle; its non-degenerate triangles go to `out`.
template <class Sink>
void zip_rows(const Lattice& lat, const Row& upper, const Row& lower, std::vector<uint32_t>& strip, Sink& out) {
  strip.clear();
  strip.push_back(lower[0].id);
  strip.push_back(upper[0].id);
  bool last_upper = true;
  size_t ui = 0, di = 0, emitted = 0;
  while (ui + 1 < upper.size() || di + 1 < lower.size()) {
    bool advance_upper =
        di + 1 >= lower.size() || (ui + 1 < upper.size() && at_or_before(upper[ui + 1], lower[di + 1]));
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
        out.degenerate();  // distinct pattern points on a collapsed side
      } else {
        out.triangle(lat, d, u, x);
        ++emitted;
      }
    }
    if (advance_upper) {
      ++ui;
    } else {
      ++di;
    }
  }
  if (emitted > 0) out.strip(strip.data(), strip.data() + strip.size());
}

// Whether every lattice point of the coarse triangle is inserted.
inline bool coarse_triangle_full(const PatchState& ps, const CoarseTriangle& ct) {
  const int cols = ps.lat.cols;
  const uint8_t* mask = ps.sc.mask.data();
  const int step = ct.tri == 0 ? 1 : -1;
  for (int k = 0; k <= ct.P; ++k) {
    int a, b;
    ct.point(k, 0, a, b);
    const uint8_t* first = mask + a * cols + b;
    for (int c = 0; c <= k; ++c) {
      if (!first[c * step * (cols + 1)]) return false;
    }
  }
  return true;
}

// A coarse triangle whose every lattice point is inserted, on a patch whose side ids are distinct:
// every row is complete, so every band is regular; written straight from the lattice, the same
// triangles and strips as build_row and zip_regular_band give, without building the rows.
template <class Sink>
void emit_full_coarse_triangle(const PatchState& ps, const CoarseTriangle& ct, Sink& out) {
  const int cols = ps.lat.cols;
  const uint32_t* ids = ps.sc.ids.data();
  const int step = ct.tri == 0 ? 1 : -1;  // (a, b) moves by (step, step) from one c to the next
  int ua, ub;
  ct.point(0, 0, ua, ub);
  const uint32_t apex = ids[ua * cols + ub];
  out.mark_used(&apex, &apex + 1);
  for (int k = 1; k <= ct.P; ++k) {
    int la, lb;
    ct.point(k, 0, la, lb);
    const auto lower = [&](int c) {
      const int a = la + step * c, b = lb + step * c;
      return Node{ids[a * cols + b], a, b, 0, 1};
    };
    const auto upper = [&](int c) {
      const int a = ua + step * c, b = ub + step * c;
      return Node{ids[a * cols + b], a, b, 0, 1};
    };
    write_regular_band(ps.lat, k, lower, upper, out);
    // Row k is used (every row is in a strip): its ids marked once, not once per strip.
    uint32_t row[kMaxEscLevel + 2];
    for (int c = 0; c <= k; ++c) row[c] = lower(c).id;
    out.mark_used(row, row + k + 1);
    ua = la;
    ub = lb;
  }
}

// The strips and triangles of every coarse triangle, band by band from the apex to the base.
// `distinct_side_ids`: number_vertices' result (regular bands may skip the zipper's tests).
template <class Sink>
void build_strips(const EscInput& in, const PatchState& ps, bool distinct_side_ids, Sink& out) {
  const Lattice& lat = ps.lat;
  Row* upper = &ps.sc.upper;
  Row* lower = &ps.sc.lower;
  for (int i = 0; i < lat.n; ++i) {
    for (int j = 0; j < lat.m; ++j) {
      for (int tri = 0; tri < 2; ++tri) {
        const CoarseTriangle ct{in.P, tri, i, j};
        if (distinct_side_ids && coarse_triangle_full(ps, ct)) {
          emit_full_coarse_triangle(ps, ct, out);
          continue;
        }
        bool upper_complete = build_row(ps, ct, 0, *upper);
        int upper_k = 0;
        for (int k = 1; k <= in.P; ++k) {
          if (!row_present(ps, ct, k)) continue;
          const bool lower_complete = build_row(ps, ct, k, *lower);
          if (distinct_side_ids && upper_complete && lower_complete && upper_k + 1 == k) {
            zip_regular_band(lat, *upper, *lower, out);
          } else {
            zip_rows(lat, *upper, *lower, ps.sc.strip, out);
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

// Patch p's lattice and sides, working in `sc`.
PatchState patch_state(const EscInput& in, size_t p, Scratch& sc) {
  const BezierPatch& patch = in.model.patches[p];
  Lattice lat;
  lat.P = in.P;
  lat.n = patch.degree_u;
  lat.m = patch.degree_v;
  lat.cols = lat.m * in.P + 1;
  PatchState ps{patch, static_cast<uint32_t>(p), patch_rho(in.params, p), lat, lat.n * in.P, lat.m * in.P, {}, sc};
  for (Side side : kAllSides) ps.collapsed[static_cast<int>(side)] = in.topology.side(ps.pid, side).collapsed;
  return ps;
}

// 2. One patch: the insertion mask on its lattice (coarse-edge tests, then rows), the vertices
// strictly inside the patch (patch-local numbering), and the strips and triangles of every coarse
// triangle. Returns the candidates its own coarse edges decided.
Counts tessellate_patch(const EscInput& in, size_t p, Scratch& sc, PatchOutput& out) {
  const int P = in.P;
  const PatchState ps = patch_state(in, p, sc);
  const Lattice& lat = ps.lat;

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
  BufferSink sink{out, in.params.surface_data};
  build_strips(in, ps, distinct_side_ids, sink);
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

// ---- The direct path: every patch writes its vertices, triangles and strips in place ----
//
// Pass 1 decides each patch's insertion mask (kept, one byte per lattice point), counts its own
// vertices and bounds its triangles and strips from the mask (exactly, for regular bands); the side
// vertices some patch inserted are predicted to be used. Pass 2 numbers the vertices with their
// final ids and writes everything in place, recording which vertices its strips use. Where a
// prediction fails (a vertex no strip uses, an unpredicted one used: only around collapsed sides)
// the result is discarded and the copy path runs, so both paths give the same bits.

struct PatchPlan {
  uint64_t mask_offset = 0;                           // where the patch's mask is kept
  uint32_t own_vertices = 0;                          // inserted lattice points strictly inside the patch
  uint64_t triangles = 0, strips = 0, strip_ids = 0;  // upper bounds, exact for regular bands
  bool distinct_side_ids = false;
  Counts counts;
};

// number_vertices' result without listing the ids (conservative: false when two sides share an
// edge or two corners a corner class, even where the side samples happen to be distinct).
bool side_ids_distinct(const EscInput& in, const PatchState& ps) {
  int32_t edges[4];
  uint32_t corners[4];
  for (int s = 0; s < 4; ++s) {
    const Topology::SideInfo& info = in.topology.side(ps.pid, kAllSides[static_cast<size_t>(s)]);
    if (info.collapsed) return false;
    edges[s] = info.edge;
    corners[s] = in.topology.corner_class[ps.pid * 4 + static_cast<uint32_t>(s)];
  }
  for (int s = 0; s < 4; ++s) {
    for (int t = s + 1; t < 4; ++t) {
      if (edges[s] == edges[t] || corners[s] == corners[t]) return false;
    }
  }
  return true;
}

// Calls f(a, b, id) for every lattice point on the patch's sides, side by side (U0, U1, V0, V1; the
// corners more than once, the V sides last), id = side_vertex(layout, topology, patch, side, k)
// with side_vertex's per-side work done once per side.
template <class F>
void for_each_side_point(const EscInput& in, const PatchState& ps, F&& f) {
  const BoundaryLayout& layout = in.sides.layout;
  for (Side side : kAllSides) {
    const bool along_v = side == Side::kU0 || side == Side::kU1;
    const int count = along_v ? ps.mb : ps.na;
    const int fixed = side == Side::kU1 ? ps.na : side == Side::kV1 ? ps.mb : 0;
    const auto point = [&](int k, uint32_t id) {
      if (along_v) {
        f(fixed, k, id);
      } else {
        f(k, fixed, id);
      }
    };
    const Topology::SideInfo& info = in.topology.side(ps.pid, side);
    const uint32_t first = side_vertex(layout, in.topology, ps.pid, side, 0);
    if (info.collapsed) {
      for (int k = 0; k <= count; ++k) point(k, first);
      continue;
    }
    const int n = layout.edge_segments[static_cast<size_t>(info.edge)];
    const uint32_t last = side_vertex(layout, in.topology, ps.pid, side, n);
    const uint32_t base = layout.edge_base[static_cast<size_t>(info.edge)];
    for (int k = 0; k <= count; ++k) {
      const uint32_t id = k <= 0   ? first
                          : k >= n ? last
                                   : base + static_cast<uint32_t>((info.reversed ? n - k : k) - 1);
      point(k, id);
    }
  }
}

// Pass 1 for patch p: the mask (into `masks` at plan.mask_offset), the counts and bounds, and the
// side vertices it inserts marked in `side_inserted`.
void plan_patch(const EscInput& in, size_t p, Scratch& sc, uint8_t* masks,
                std::vector<std::atomic<uint8_t>>& side_inserted, PatchPlan& plan) {
  const int P = in.P;
  const PatchState ps = patch_state(in, p, sc);
  mark_sides(in, ps);
  if (ps.rho > 0.0) evaluate_lattice(ps, false, LatticePoints::kCoarseEdges);
  plan.counts = decide_coarse_edges(in, ps);
  force_collapsed_corners(P, ps, plan.counts);
  fill_rows(P, ps);
  std::copy(sc.mask.begin(), sc.mask.end(), masks + plan.mask_offset);
  for_each_side_point(in, ps, [&](int a, int b, uint32_t id) {
    if (ps.inserted(a, b)) side_inserted[id].store(1, std::memory_order_relaxed);
  });
  uint32_t own = 0;
  for (int a = 1; a < ps.na; ++a) {
    for (int b = 1; b < ps.mb; ++b) own += ps.mask(a, b);
  }
  plan.own_vertices = own;
  plan.distinct_side_ids = side_ids_distinct(in, ps);
  // The zipper steps once per node after the first of each row and emits at most one triangle per
  // step; its strip holds 2 ids plus at most 2 per step, exactly 2k + 1 on a regular band.
  const auto node = [&](int a, int b) { return ps.inserted(a, b) || ps.on_collapsed_side(a, b); };
  for (int i = 0; i < ps.lat.n; ++i) {
    for (int j = 0; j < ps.lat.m; ++j) {
      for (int tri = 0; tri < 2; ++tri) {
        const CoarseTriangle ct{P, tri, i, j};
        int a, b;
        ct.point(0, 0, a, b);
        bool upper_complete = node(a, b);
        uint64_t upper_len = 1;
        int upper_k = 0;
        for (int k = 1; k <= P; ++k) {
          if (!row_present(ps, ct, k)) continue;
          // Rows between apex and base: fill_rows inserted every point strictly between the ends
          // (none of them on a patch side), so only the ends can be missing. The base row's
          // candidates are counted.
          uint64_t len = static_cast<uint64_t>(k + 1);
          ct.point(k, 0, a, b);
          bool complete = node(a, b);
          ct.point(k, k, a, b);
          complete = complete && node(a, b);
          if (k == P) {
            len = 2;
            for (int c = 1; c < k; ++c) {
              ct.point(k, c, a, b);
              if (node(a, b)) {
                ++len;
              } else {
                complete = false;
              }
            }
          }
          const uint64_t steps = upper_len + len - 2;
          plan.triangles += steps;
          plan.strips += 1;
          const bool regular = plan.distinct_side_ids && upper_complete && complete && upper_k + 1 == k;
          plan.strip_ids += regular ? static_cast<uint64_t>(2 * k + 1) : 2 + 2 * steps;
          upper_complete = complete;
          upper_len = len;
          upper_k = k;
        }
      }
    }
  }
}

// Where the patches write: running sums of the plans (one past the end last).
struct DirectOffsets {
  std::vector<uint64_t> vertex, tri, strip, strip_index;
};

// Pass 2's sink: triangles and strips straight into the result at the patch's slots, never past
// their bounds; records which vertices the kept strips use.
struct DirectSink {
  Triangle* tri;
  std::array<Vec2, 3>* uv;  // null without surface data
  uint32_t* tri_patch;      // null without surface data
  uint32_t pid;
  uint64_t tri_n = 0, tri_cap;
  uint32_t* ids;
  uint64_t ids_n = 0, ids_cap, ids_at;  // ids_at: index of ids[0] in the whole list
  uint64_t* ends;                       // ends[s] is where strip s ends
  uint64_t strips_n = 0, strips_cap;
  uint64_t degenerates = 0;
  bool failed = false;
  uint32_t side_used_end, own_base, own_count;
  std::vector<std::atomic<uint8_t>>* side_used;
  std::vector<uint8_t>* own_used;

  void triangle(const Lattice& lat, const Node& p, const Node& q, const Node& r) {
    if (tri_n == tri_cap) {
      failed = true;
      return;
    }
    tri[tri_n] = {p.id, q.id, r.id};
    if (uv) {
      uv[tri_n] = {node_uv(lat, p), node_uv(lat, q), node_uv(lat, r)};
      tri_patch[tri_n] = pid;
    }
    ++tri_n;
  }
  // A strip whose ids are marked used here (zip_rows' strips, staged in its vector).
  void strip(const uint32_t* first, const uint32_t* last) {
    uint32_t* to = append_strip(static_cast<size_t>(last - first));
    if (to) mark_used(first, last, to);
  }
  void mark_used(const uint32_t* first, const uint32_t* last) { mark_used(first, last, nullptr); }
  // Marks [first, last) used and, with `copy_to`, copies them there in the same pass (4-byte loads
  // as they were stored, so they are forwarded from the stores; a memcpy's wider loads are not).
  void mark_used(const uint32_t* first, const uint32_t* last, uint32_t* copy_to) {
    // The fields in locals: the byte stores below may alias them as far as the compiler knows.
    const uint32_t side_end = side_used_end, base = own_base, own_n = own_count;
    std::atomic<uint8_t>* side = side_used->data();
    uint8_t* own = own_used->data();
    bool unpredicted = false;  // a side vertex pass 1 did not predict
    for (const uint32_t* at = first; at != last; ++at) {
      const uint32_t id = *at;
      if (copy_to) *copy_to++ = id;
      if (id < side_end) {
        side[id].store(1, std::memory_order_relaxed);
      } else if (id - base < own_n) {
        own[id - base] = 1;
      } else {
        unpredicted = true;
      }
    }
    failed = failed || unpredicted;
  }
  bool wants_uv() const { return uv != nullptr; }
  // Room for n triangles (without (u, v): !wants_uv()), filled by the caller; null past the bounds.
  Triangle* append_triangles(size_t n) {
    if (tri_n + n > tri_cap) {
      failed = true;
      return nullptr;
    }
    Triangle* at = tri + tri_n;
    tri_n += n;
    return at;
  }
  // Room for a strip of n ids, filled by the caller (who marks them used); null when past the bounds.
  uint32_t* append_strip(size_t n) {
    if (ids_n + n > ids_cap || strips_n == strips_cap) {
      failed = true;
      return nullptr;
    }
    uint32_t* at = ids + ids_n;
    ids_n += n;
    ends[strips_n++] = ids_at + ids_n;
    return at;
  }
  void degenerate() { ++degenerates; }
};

// PatchEvaluator::finish_position where the weight sum is exactly 1 (a polynomial patch in the power
// basis: the weight row is 1, 0, ..., 0 and the first basis function is 1): the same sums, and the
// division by 1 left out, so the same bits.
template <class Degree>
inline Vec3 finish_unit_weight_position(const Vec3& origin, Degree m, const std::array<double, 4>* row,
                                        const double* b) {
  double x = 0.0, y = 0.0, z = 0.0;
  for (int j = 0; j <= m; ++j) {
    x += b[j] * row[j][0];
    y += b[j] * row[j][1];
    z += b[j] * row[j][2];
  }
  return origin + Vec3(x, y, z);
}
inline Vec3 finish_unit_weight_position(const Vec3& origin, int m, const std::array<double, 4>* row, const double* b) {
  switch (m) {  // the usual degrees unrolled (the same operations)
    case 1:
      return finish_unit_weight_position(origin, std::integral_constant<int, 1>(), row, b);
    case 2:
      return finish_unit_weight_position(origin, std::integral_constant<int, 2>(), row, b);
    case 3:
      return finish_unit_weight_position(origin, std::integral_constant<int, 3>(), row, b);
    default:
      return finish_unit_weight_position<int>(origin, m, row, b);
  }
}

// Pass 2, number_vertices with final ids: side points take their predicted final id
// (UINT32_MAX where not predicted), inserted points strictly inside get own_base + their rank in
// (a, b) order, with their position (normal, surface point) written to the result.
void number_final(const EscInput& in, const PatchState& ps, const std::vector<uint32_t>& side_final, uint32_t own_base,
                  Tessellation& result) {
  const Lattice& lat = ps.lat;
  const int na = ps.na, mb = ps.mb;
  std::vector<uint32_t>& ids = ps.sc.ids;
  ids.assign(ps.sc.mask.size(), UINT32_MAX);
  for_each_side_point(in, ps,
                      [&](int a, int b, uint32_t id) { ids[static_cast<size_t>(lat.index(a, b))] = side_final[id]; });
  const BezierPatch& patch = ps.patch;
  const detail::PatchEvaluator eval(patch);
  const int du = patch.degree_u, dv = patch.degree_v;
  const bool normals = in.params.normals;
  v_basis_rows(eval, ps);
  const std::vector<double>& bv = ps.sc.bv;
  const std::vector<double>& dbv = ps.sc.dbv;
  // A polynomial patch in the power basis has weight sum exactly 1 (as in the uniform grid kernels).
  const bool unit_weight = !patch.rational() && eval.uses_power_basis();
  double a_row[kMaxDegree + 1], da_row[kMaxDegree + 1];
  std::array<double, 4> row[kMaxDegree + 1], drow[kMaxDegree + 1];
  uint32_t next = own_base;
  for (int a = 1; a < na; ++a) {
    const uint8_t* mask_row = &ps.sc.mask[static_cast<size_t>(lat.index(a, 0))];
    if (std::find(mask_row + 1, mask_row + mb, uint8_t{1}) == mask_row + mb) continue;
    eval.basis_row(du, lat.u(a), a_row, da_row);
    if (normals) {
      eval.contract_u(a_row, da_row, row, drow);
    } else {
      eval.contract_u_position(a_row, row);
    }
    for (int b = 1; b < mb; ++b) {
      if (!mask_row[b]) continue;
      const size_t s = static_cast<size_t>(lat.index(a, b));
      ids[s] = next;
      const double* bvb = &bv[static_cast<size_t>(b * (dv + 1))];
      if (normals) {
        const SurfacePointEval e = eval.finish(row, drow, bvb, &dbv[static_cast<size_t>(b * (dv + 1))]);
        result.positions[next] = e.position;
        result.normals[next] = detail::unit_normal(e, patch, lat.u(a), lat.v(b));
      } else if (unit_weight) {
        result.positions[next] = finish_unit_weight_position(eval.origin(), dv, row, bvb);
      } else {
        result.positions[next] = eval.finish_position(row, bvb);
      }
      if (in.params.surface_data) result.surface_points[next] = {ps.pid, lat.u(a), lat.v(b)};
      ++next;
    }
  }
}

// The whole direct path; false (the result to be discarded) where a prediction failed.
bool tessellate_direct(const EscInput& in, Tessellation& result, uint64_t& strips, std::vector<Counts>& patch_counts) {
  const Model& model = in.model;
  const EscParams& params = in.params;
  const int P = in.P;
  const size_t np = model.patches.size();
  const uint32_t side_end = in.sides.layout.end;

  // Pass 1.
  std::vector<PatchPlan> plans(np);
  uint64_t mask_bytes = 0;
  for (size_t p = 0; p < np; ++p) {
    plans[p].mask_offset = mask_bytes;
    mask_bytes += static_cast<uint64_t>(model.patches[p].degree_u * P + 1) *
                  static_cast<uint64_t>(model.patches[p].degree_v * P + 1);
  }
  std::vector<uint8_t> masks(mask_bytes);
  std::vector<std::atomic<uint8_t>> side_inserted(side_end);
  tbb::enumerable_thread_specific<Scratch> scratch;
  tbb::parallel_for(size_t{0}, np, [&](size_t p) {
    budget::check("the ESC tessellation");
    plan_patch(in, p, scratch.local(), masks.data(), side_inserted, plans[p]);
  });

  // Final ids: the inserted side vertices in layout order, then every patch's own vertices.
  std::vector<uint32_t> side_final(side_end, UINT32_MAX);
  uint32_t used_sides = 0;
  for (uint32_t id = 0; id < side_end; ++id) {
    if (side_inserted[id].load(std::memory_order_relaxed)) side_final[id] = used_sides++;
  }
  DirectOffsets at;
  at.vertex.assign(np + 1, used_sides);
  at.tri.assign(np + 1, 0);
  at.strip.assign(np + 1, 0);
  at.strip_index.assign(np + 1, 0);
  for (size_t p = 0; p < np; ++p) {
    at.vertex[p + 1] = at.vertex[p] + plans[p].own_vertices;
    at.tri[p + 1] = at.tri[p] + plans[p].triangles;
    at.strip[p + 1] = at.strip[p] + plans[p].strips;
    at.strip_index[p + 1] = at.strip_index[p] + plans[p].strip_ids;
    patch_counts[p] = plans[p].counts;
  }
  const uint64_t vertices = at.vertex[np];
  if (vertices > UINT32_MAX) throw InputError("the tessellation needs more than 2^32 vertices; lower the level");
  budget::check_memory(tessellation_bytes(2.0 * double(at.tri[np]), double(vertices)) +
                           4.0 * double(at.strip_index[np]) + double(mask_bytes),
                       "the ESC tessellation", "lower the level or raise --max-memory");
  result.positions.resize(vertices);
  if (params.normals) result.normals.resize(vertices);
  if (params.surface_data) result.surface_points.resize(vertices);
  const Tessellation& full = in.sides.full;
  tbb::parallel_for(uint32_t{0}, side_end, [&](uint32_t id) {
    const uint32_t r = side_final[id];
    if (r == UINT32_MAX) return;
    result.positions[r] = full.positions[id];
    if (params.normals) result.normals[r] = full.normals[id];
    if (params.surface_data) result.surface_points[r] = full.surface_points[id];
  });
  result.triangles.resize(at.tri[np]);
  if (params.surface_data) {
    result.triangle_patch.resize(at.tri[np]);
    result.triangle_uv.resize(at.tri[np]);
  }
  result.strips.resize(at.strip[np], at.strip_index[np]);

  // Pass 2.
  std::vector<std::atomic<uint8_t>> side_used(used_sides);
  std::vector<uint64_t> tri_n(np), strips_n(np), ids_n(np), degenerate(np);
  std::atomic<bool> failed{false};
  tbb::parallel_for(size_t{0}, np, [&](size_t p) {
    if (failed.load(std::memory_order_relaxed)) return;
    budget::check("the ESC tessellation");
    Scratch& sc = scratch.local();
    const PatchState ps = patch_state(in, p, sc);
    const PatchPlan& plan = plans[p];
    sc.mask.assign(masks.begin() + static_cast<std::ptrdiff_t>(plan.mask_offset),
                   masks.begin() + static_cast<std::ptrdiff_t>(plan.mask_offset + (ps.na + 1) * (ps.mb + 1)));
    const uint32_t own_base = static_cast<uint32_t>(at.vertex[p]);
    number_final(in, ps, side_final, own_base, result);
    sc.own_used.assign(plan.own_vertices, 0);
    DirectSink sink;
    sink.tri = result.triangles.data() + at.tri[p];
    sink.uv = params.surface_data ? result.triangle_uv.data() + at.tri[p] : nullptr;
    sink.tri_patch = params.surface_data ? result.triangle_patch.data() + at.tri[p] : nullptr;
    sink.pid = static_cast<uint32_t>(p);
    sink.tri_cap = plan.triangles;
    sink.ids = result.strips.mutable_indices() + at.strip_index[p];
    sink.ids_cap = plan.strip_ids;
    sink.ids_at = at.strip_index[p];
    sink.ends = result.strips.mutable_offsets() + at.strip[p] + 1;
    sink.strips_cap = plan.strips;
    sink.side_used_end = used_sides;
    sink.own_base = own_base;
    sink.own_count = plan.own_vertices;
    sink.side_used = &side_used;
    sink.own_used = &sc.own_used;
    build_strips(in, ps, plan.distinct_side_ids, sink);
    const bool all_own_used = std::find(sc.own_used.begin(), sc.own_used.end(), uint8_t{0}) == sc.own_used.end();
    if (sink.failed || !all_own_used) failed.store(true, std::memory_order_relaxed);
    tri_n[p] = sink.tri_n;
    strips_n[p] = sink.strips_n;
    ids_n[p] = sink.ids_n;
    degenerate[p] = sink.degenerates;
  });
  if (failed.load()) return false;
  for (uint32_t id = 0; id < used_sides; ++id) {
    if (!side_used[id].load(std::memory_order_relaxed)) return false;  // predicted, but no strip uses it
  }

  // Close the gaps where a patch wrote less than its bounds (moving down, in patch order).
  uint64_t tri_out = 0, strip_out = 0, id_out = 0;
  uint32_t* ids = result.strips.mutable_indices();
  uint64_t* ends = result.strips.mutable_offsets() + 1;
  for (size_t p = 0; p < np; ++p) {
    if (tri_out != at.tri[p]) {
      std::copy_n(result.triangles.begin() + static_cast<std::ptrdiff_t>(at.tri[p]), tri_n[p],
                  result.triangles.begin() + static_cast<std::ptrdiff_t>(tri_out));
      if (params.surface_data) {
        std::copy_n(result.triangle_uv.begin() + static_cast<std::ptrdiff_t>(at.tri[p]), tri_n[p],
                    result.triangle_uv.begin() + static_cast<std::ptrdiff_t>(tri_out));
        std::copy_n(result.triangle_patch.begin() + static_cast<std::ptrdiff_t>(at.tri[p]), tri_n[p],
                    result.triangle_patch.begin() + static_cast<std::ptrdiff_t>(tri_out));
      }
    }
    const uint64_t shift = at.strip_index[p] - id_out;
    if (shift != 0) std::copy_n(ids + at.strip_index[p], ids_n[p], ids + id_out);
    if (shift != 0 || strip_out != at.strip[p]) {
      for (uint64_t s = 0; s < strips_n[p]; ++s) ends[strip_out + s] = ends[at.strip[p] + s] - shift;
    }
    tri_out += tri_n[p];
    strip_out += strips_n[p];
    id_out += ids_n[p];
    result.degenerate_triangles += degenerate[p];
  }
  result.triangles.resize(tri_out);
  if (params.surface_data) {
    result.triangle_patch.resize(tri_out);
    result.triangle_uv.resize(tri_out);
  }
  result.strips.shrink(strip_out, id_out);
  strips = strip_out;
  return true;
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

namespace {

// Steps 2 and 3 by way of per-patch buffers copied into place (the direct path's fallback).
Tessellation tessellate_by_copy(const EscInput& in, uint64_t& strips, std::vector<Counts>& patch_counts) {
  const size_t np = in.model.patches.size();
  std::vector<PatchOutput> outputs(np);
  tbb::enumerable_thread_specific<Scratch> scratch;
  tbb::parallel_for(size_t{0}, np, [&](size_t p) {
    budget::check("the ESC tessellation");
    patch_counts[p] = tessellate_patch(in, p, scratch.local(), outputs[p]);
  });
  return assemble(in.params, in.sides, outputs, strips);
}

// tessellate_esc in place where `direct` and the prediction holds (`took_direct`, when given, says
// whether it did), else by copy.
Tessellation tessellate_esc_with(const Model& model, const Topology& topology, const EscParams& params, EscStats* stats,
                                 bool direct, bool* took_direct = nullptr) {
  check_params(model, topology, params);
  const int P = params.level + 1;
  const size_t np = model.patches.size();
  const Sides sides = decide_sides(model, topology, params, P);
  const EscInput in{model, topology, params, sides, P};
  std::vector<Counts> patch_counts(np);
  uint64_t strips = 0;
  Tessellation result;
  const bool in_place = direct && tessellate_direct(in, result, strips, patch_counts);
  if (!in_place) result = tessellate_by_copy(in, strips, patch_counts);
  if (took_direct) *took_direct = in_place;
  if (stats) fill_stats(topology, sides, P, patch_counts, strips, *stats);
  return result;
}

}  // namespace

Tessellation tessellate_esc(const Model& model, const Topology& topology, const EscParams& params, EscStats* stats) {
  return tessellate_esc_with(model, topology, params, stats, true);
}

namespace detail {
Tessellation tessellate_esc_by_copy(const Model& model, const Topology& topology, const EscParams& params,
                                    EscStats* stats) {
  return tessellate_esc_with(model, topology, params, stats, false);
}
bool esc_direct_path_applies(const Model& model, const Topology& topology, const EscParams& params) {
  bool took_direct = false;
  tessellate_esc_with(model, topology, params, nullptr, true, &took_direct);
  return took_direct;
}
}  // namespace detail

}  // namespace sagitta
