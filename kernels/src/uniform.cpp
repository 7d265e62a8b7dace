#include "sagitta/uniform.hpp"

#include "boundary.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace sagitta {

int segments_for_level(int level) {
  if (level < 0 || level > kMaxUniformLevel) {
    throw InputError("--level " + std::to_string(level) + " is outside 0.." + std::to_string(kMaxUniformLevel) +
                     " (level L makes 2^L segments per side and 2 * 4^L triangles per patch: level " +
                     std::to_string(kMaxUniformLevel) + " already makes 33.5 million triangles per patch, about 2 GiB "
                     "at 64 bytes per triangle, and 256 such patches would exceed the 32-bit vertex ids)");
  }
  return 1 << level;
}

namespace detail {

int segments_for_paper_level(int level) {
  if (level < 1 || level > kMaxUniformLevel) {
    throw InputError("paper level " + std::to_string(level) + " is outside 1.." + std::to_string(kMaxUniformLevel));
  }
  return (1 << (level + 1)) - 1;
}

}  // namespace detail

uint64_t uniform_triangle_count(const Model& model, int segments, int segments_v) {
  const uint64_t nv = static_cast<uint64_t>(segments_v > 0 ? segments_v : segments);
  return 2ull * static_cast<uint64_t>(segments) * nv * model.patches.size();
}

namespace {

constexpr uint32_t kSkip = UINT32_MAX;  // marks a slot whose triangle repeats a vertex

// A patch's own grid: nu segments along u, nv along v.
struct OwnGrid {
  int nu = 1, nv = 1;
  // Segments along a side: the u = const sides (U0, U1) run along v.
  int along(Side side) const { return side == Side::kU0 || side == Side::kU1 ? nv : nu; }
};

// Every patch's own grid. Throws InputError for segments < 1, segments_v < 0, per-patch levels of
// the wrong size or outside 0..kMaxUniformLevel, or per-patch levels with segments_v.
std::vector<OwnGrid> own_grids(size_t np, const UniformParams& params) {
  if (params.segments_v < 0)
    throw InputError("segments along v must be >= 1, got " + std::to_string(params.segments_v));
  std::vector<OwnGrid> own(np, OwnGrid{params.segments, params.segments_v > 0 ? params.segments_v : params.segments});
  if (params.patch_levels.empty()) {
    if (params.segments < 1) throw InputError("--segments must be >= 1, got " + std::to_string(params.segments));
  } else {
    if (params.segments_v > 0) throw InputError("per-patch levels and segments along v do not combine");
    if (params.patch_levels.size() != np) {
      throw InputError("per-patch levels: " + std::to_string(params.patch_levels.size()) + " levels for " +
                       std::to_string(np) + " patches");
    }
    for (size_t p = 0; p < np; ++p) own[p].nu = own[p].nv = segments_for_level(params.patch_levels[p]);
  }
  return own;
}

// Per patch: how many side samples fall on each of its grid's border cells (1 = not refined),
// whether it needs a centre vertex (a single cell with a refined side), its vertex and triangle
// ranges.
struct PatchPlan {
  int nu = 1, nv = 1;           // the patch's own grid
  int ratio[4] = {1, 1, 1, 1};  // per Side: side segments / the own grid's segments along it
  bool centre = false;
  uint64_t interior_base = 0;
  uint64_t slot_base = 0;
};

// Every patch's plan; `vertices` and `slots` are the totals (side vertices included).
struct Plan {
  std::vector<PatchPlan> patches;
  uint64_t vertices = 0, slots = 0;
};

// Plans the patches in order: interior vertices after the side vertices, triangle slots from 0.
// Throws InputError when a side's samples do not nest with the patch's own grid.
Plan plan_patches(const Topology& topology, const BoundaryLayout& layout, const std::vector<OwnGrid>& own) {
  const size_t np = own.size();
  Plan plan_all;
  std::vector<PatchPlan>& plans = plan_all.patches;
  plans.resize(np);
  uint64_t next_vertex = layout.end, next_slot = 0;
  for (size_t p = 0; p < np; ++p) {
    PatchPlan& plan = plans[p];
    plan.nu = own[p].nu;
    plan.nv = own[p].nv;
    uint64_t extra = 0;
    for (Side side : kAllSides) {
      const Topology::SideInfo& info = topology.side(static_cast<uint32_t>(p), side);
      if (info.collapsed) continue;
      const int count = layout.edge_segments[static_cast<size_t>(info.edge)];
      const int n = own[p].along(side);
      if (count % n != 0) throw InputError("internal: side samples do not nest with the patch grid");
      plan.ratio[static_cast<int>(side)] = count / n;
      extra += static_cast<uint64_t>(count - n);
    }
    plan.centre = plan.nu == 1 && plan.nv == 1 && extra > 0;
    plan.interior_base = next_vertex;
    next_vertex += static_cast<uint64_t>(plan.nu - 1) * static_cast<uint64_t>(plan.nv - 1) + (plan.centre ? 1 : 0);
    plan.slot_base = next_slot;
    // A cell polygon with V vertices gives V - 2 fan triangles (V around a centre vertex).
    next_slot += 2ull * static_cast<uint64_t>(plan.nu) * static_cast<uint64_t>(plan.nv) + extra + (plan.centre ? 2 : 0);
  }
  plan_all.vertices = next_vertex;
  plan_all.slots = next_slot;
  return plan_all;
}

// One patch in the per-patch pass: what it reads and where it writes.
struct PatchPass {
  const BezierPatch& patch;
  uint32_t pid;
  const PatchPlan& plan;
  const BoundaryLayout& layout;
  const Topology& topology;
  const UniformParams& params;
  Tessellation& out;

  // Grid point (a, b) of the patch's own nu x nv grid.
  uint32_t vertex(int a, int b) const {
    const int* ratio = plan.ratio;
    if (a == 0) return side_vertex(layout, topology, pid, Side::kU0, b * ratio[0]);
    if (a == plan.nu) return side_vertex(layout, topology, pid, Side::kU1, b * ratio[1]);
    if (b == 0) return side_vertex(layout, topology, pid, Side::kV0, a * ratio[2]);
    if (b == plan.nv) return side_vertex(layout, topology, pid, Side::kV1, a * ratio[3]);
    return static_cast<uint32_t>(plan.interior_base + static_cast<uint64_t>(a - 1) * (plan.nv - 1) + (b - 1));
  }
  void store_vertex(uint32_t id, const SurfacePointEval& e, double u, double v) const {
    out.positions[id] = e.position;
    if (params.normals) out.normals[id] = detail::unit_normal(e, patch, u, v);
    if (params.surface_data) out.surface_points[id] = {pid, u, v};
  }
};

// Interior samples: the matrix form, one u-contraction per grid row; then the centre vertex of a
// single refined cell.
void sample_interior(const PatchPass& pp) {
  const BezierPatch& patch = pp.patch;
  const int nu = pp.plan.nu, nv = pp.plan.nv;
  if (nu > 1 && nv > 1) {
    const detail::PatchEvaluator eval(patch);
    const int du = patch.degree_u, dv = patch.degree_v;
    std::vector<double> bv(static_cast<size_t>((nv + 1) * (dv + 1))), dbv(bv.size());
    for (int b = 1; b < nv; ++b) {
      eval.basis_row(dv, static_cast<double>(b) / nv, &bv[static_cast<size_t>(b * (dv + 1))],
                     &dbv[static_cast<size_t>(b * (dv + 1))]);
    }
    double a_row[kMaxDegree + 1], da_row[kMaxDegree + 1];
    std::array<double, 4> row[kMaxDegree + 1], drow[kMaxDegree + 1];
    for (int a = 1; a < nu; ++a) {
      const double u = static_cast<double>(a) / nu;
      eval.basis_row(du, u, a_row, da_row);
      if (!pp.params.normals) {  // positions only: no partials to contract
        eval.contract_u_position(a_row, row);
        for (int b = 1; b < nv; ++b) {
          SurfacePointEval e;
          e.position = eval.finish_position(row, &bv[static_cast<size_t>(b * (dv + 1))]);
          pp.store_vertex(pp.vertex(a, b), e, u, static_cast<double>(b) / nv);
        }
        continue;
      }
      eval.contract_u(a_row, da_row, row, drow);
      for (int b = 1; b < nv; ++b) {
        const SurfacePointEval e =
            eval.finish(row, drow, &bv[static_cast<size_t>(b * (dv + 1))], &dbv[static_cast<size_t>(b * (dv + 1))]);
        pp.store_vertex(pp.vertex(a, b), e, u, static_cast<double>(b) / nv);
      }
    }
  }
  const uint32_t centre_id = static_cast<uint32_t>(pp.plan.interior_base);
  if (pp.plan.centre) pp.store_vertex(centre_id, detail::PatchEvaluator(patch).evaluate(0.5, 0.5), 0.5, 0.5);
}

// Writes a patch's triangles into its slots, in order; a triangle repeating a vertex is marked kSkip.
struct SlotWriter {
  Triangle* t;
  std::array<Vec2, 3>* tuv;  // null without surface data
  void emit(uint32_t i0, uint32_t i1, uint32_t i2, const Vec2& q0, const Vec2& q1, const Vec2& q2) {
    *t++ = (i0 == i1 || i1 == i2 || i0 == i2) ? Triangle{kSkip, 0, 0} : Triangle{i0, i1, i2};
    if (tuv) *tuv++ = {q0, q1, q2};
  }
};

struct Corner {
  uint32_t id;
  Vec2 uv;
  bool inside;  // strictly inside the patch's parameter square
};

// A refined border cell (a, b): its boundary counter-clockwise in (u, v), v00 -> v10 -> v11 -> v01,
// with the side samples that fall strictly inside a cell edge lying on a refined patch side, as a
// fan around the centre vertex (single cell) or from its corner inside the patch.
void fan_refined_cell(const PatchPass& pp, int a, int b, std::vector<Corner>& polygon, SlotWriter& w) {
  const int nu = pp.plan.nu, nv = pp.plan.nv;
  const double nud = static_cast<double>(nu), nvd = static_cast<double>(nv);
  const int* ratio = pp.plan.ratio;
  const Vec2 uv00(a / nud, b / nvd), uv10((a + 1) / nud, b / nvd), uv01(a / nud, (b + 1) / nvd),
      uv11((a + 1) / nud, (b + 1) / nvd);
  const uint32_t v00 = pp.vertex(a, b), v10 = pp.vertex(a + 1, b), v01 = pp.vertex(a, b + 1),
                 v11 = pp.vertex(a + 1, b + 1);
  polygon.clear();
  auto corner = [&](int ca, int cb, uint32_t id, const Vec2& uv) {
    polygon.push_back({id, uv, ca > 0 && ca < nu && cb > 0 && cb < nv});
  };
  auto side_samples = [&](Side side, int cell, bool forward) {
    const int r = ratio[static_cast<int>(side)];
    const double count = static_cast<double>(r) * (side == Side::kU0 || side == Side::kU1 ? nv : nu);
    for (int s = 1; s < r; ++s) {
      const int k = cell * r + (forward ? s : r - s);
      polygon.push_back({side_vertex(pp.layout, pp.topology, pp.pid, side, k), side_uv(side, k / count), false});
    }
  };
  corner(a, b, v00, uv00);
  if (b == 0) side_samples(Side::kV0, a, true);
  corner(a + 1, b, v10, uv10);
  if (a + 1 == nu) side_samples(Side::kU1, b, true);
  corner(a + 1, b + 1, v11, uv11);
  if (b + 1 == nv) side_samples(Side::kV1, a, false);
  corner(a, b + 1, v01, uv01);
  if (a == 0) side_samples(Side::kU0, b, false);
  const size_t count = polygon.size();
  if (pp.plan.centre) {  // single cell: fan around the centre vertex
    const uint32_t centre_id = static_cast<uint32_t>(pp.plan.interior_base);
    for (size_t i = 0; i < count; ++i) {
      const Corner& p0 = polygon[i];
      const Corner& p1 = polygon[(i + 1) % count];
      w.emit(centre_id, p0.id, p1.id, Vec2(0.5, 0.5), p0.uv, p1.uv);
    }
    return;
  }
  // Fan from the corner inside the patch: it touches no refined side, so no fan triangle is flat.
  size_t apex = 0;
  while (!polygon[apex].inside) ++apex;
  for (size_t i = 1; i + 1 < count; ++i) {
    const Corner& c0 = polygon[apex];
    const Corner& p0 = polygon[(apex + i) % count];
    const Corner& p1 = polygon[(apex + i + 1) % count];
    w.emit(c0.id, p0.id, p1.id, c0.uv, p0.uv, p1.uv);
  }
}

// The triangles of every cell of the patch's grid, in cell order, into its slots.
void triangulate_cells(const PatchPass& pp, SlotWriter& w) {
  const int nu = pp.plan.nu, nv = pp.plan.nv;
  const double nud = static_cast<double>(nu), nvd = static_cast<double>(nv);
  const int* ratio = pp.plan.ratio;
  std::vector<Corner> polygon;
  // The grid's parameters (the same divisions as a / nu, b / nv at each use) and one row of
  // vertex ids at a time.
  std::vector<double> us(static_cast<size_t>(nu) + 1), vs(static_cast<size_t>(nv) + 1);
  for (int a = 0; a <= nu; ++a) us[static_cast<size_t>(a)] = a / nud;
  for (int b = 0; b <= nv; ++b) vs[static_cast<size_t>(b)] = b / nvd;
  std::vector<uint32_t> row0(static_cast<size_t>(nv) + 1), row1(row0.size());
  for (int b = 0; b <= nv; ++b) row1[static_cast<size_t>(b)] = pp.vertex(0, b);
  for (int a = 0; a < nu; ++a) {
    std::swap(row0, row1);
    for (int b = 0; b <= nv; ++b) row1[static_cast<size_t>(b)] = pp.vertex(a + 1, b);
    for (int b = 0; b < nv; ++b) {
      const bool refined = (a == 0 && ratio[0] > 1) || (a == nu - 1 && ratio[1] > 1) || (b == 0 && ratio[2] > 1) ||
                           (b == nv - 1 && ratio[3] > 1);
      if (refined) {
        fan_refined_cell(pp, a, b, polygon, w);
        continue;
      }
      // two triangles, oriented like the (u, v) square
      const size_t i = static_cast<size_t>(a), j = static_cast<size_t>(b);
      const Vec2 uv00(us[i], vs[j]), uv10(us[i + 1], vs[j]), uv01(us[i], vs[j + 1]), uv11(us[i + 1], vs[j + 1]);
      const uint32_t v00 = row0[j], v10 = row1[j], v01 = row0[j + 1], v11 = row1[j + 1];
      w.emit(v00, v10, v11, uv00, uv10, uv11);
      w.emit(v00, v11, v01, uv00, uv11, uv01);
    }
  }
}

// Drops the skipped slots of one patch's range [begin, end), keeping the order; returns how many
// are kept (at the start of the range).
size_t compact_patch(Triangle* slots, std::array<Vec2, 3>* slot_uv, size_t begin, size_t end) {
  size_t kept = begin;
  for (size_t s = begin; s < end; ++s) {
    if (slots[s][0] == kSkip) continue;
    if (kept != s) {
      slots[kept] = slots[s];
      if (slot_uv) slot_uv[kept] = slot_uv[s];
    }
    ++kept;
  }
  return kept - begin;
}

// Joins the patches' kept slots in patch order, so the output is independent of scheduling: the
// slots become the triangles (and their (u, v)) in place.
void compact(const std::vector<PatchPlan>& plans, const std::vector<size_t>& kept, std::vector<Triangle>&& slots,
             std::vector<std::array<Vec2, 3>>&& slot_uv, bool surface_data, Tessellation& out) {
  const size_t np = plans.size();
  size_t total = 0;
  for (size_t p = 0; p < np; ++p) total += kept[p];
  out.degenerate_triangles += slots.size() - total;
  if (surface_data) out.triangle_patch.resize(total);
  size_t at = 0;
  for (size_t p = 0; p < np; ++p) {
    const size_t begin = plans[p].slot_base;
    if (at != begin) {
      std::copy(slots.begin() + static_cast<long>(begin), slots.begin() + static_cast<long>(begin + kept[p]),
                slots.begin() + static_cast<long>(at));
      if (surface_data)
        std::copy(slot_uv.begin() + static_cast<long>(begin), slot_uv.begin() + static_cast<long>(begin + kept[p]),
                  slot_uv.begin() + static_cast<long>(at));
    }
    if (surface_data)
      std::fill(out.triangle_patch.begin() + static_cast<long>(at),
                out.triangle_patch.begin() + static_cast<long>(at + kept[p]), static_cast<uint32_t>(p));
    at += kept[p];
  }
  slots.resize(total);
  out.triangles = std::move(slots);
  if (surface_data) {
    slot_uv.resize(total);
    out.triangle_uv = std::move(slot_uv);
  }
}

}  // namespace

Tessellation tessellate_uniform(const Model& model, const Topology& topology, const UniformParams& params) {
  const size_t np = model.patches.size();
  const std::vector<OwnGrid> own = own_grids(np, params);
  // A boundary curve takes the finest grid among the patches using it (levels nest, so every
  // user's own segment count divides it). With segments_v every user must ask for the same count.
  const BoundaryLayout layout = layout_boundary(
      topology,
      [&](size_t e) {
        int n = 0;
        for (const SideRef& use : topology.edges[e].uses) {
          const int along = own[use.patch].along(use.side);
          if (params.segments_v > 0 && n > 0 && along != n) {
            throw InputError(
                "segments along u and v differ, and a patch side is shared by a u side and a v side: "
                "give one segment count");
          }
          n = std::max(n, along);
        }
        return std::max(n, 1);
      },
      0);
  const Plan plan = plan_patches(topology, layout, own);
  if (plan.vertices > UINT32_MAX) throw InputError("the tessellation needs more than 2^32 vertices; lower the level");
  // The slots and the final triangle arrays live together at the end.
  budget::check_memory(tessellation_bytes(2.0 * double(plan.slots), double(plan.vertices)), "the uniform tessellation",
                       "lower the level or raise --max-memory");

  Tessellation out;
  out.positions.resize(plan.vertices);
  if (params.normals) out.normals.resize(plan.vertices);
  if (params.surface_data) out.surface_points.resize(plan.vertices);
  fill_boundary(model, topology, layout, out);

  std::vector<Triangle> slots(plan.slots);
  std::vector<std::array<Vec2, 3>> slot_uv(params.surface_data ? plan.slots : 0);
  std::vector<size_t> kept(np, 0);  // per patch: its slots that hold a triangle
  tbb::parallel_for(size_t{0}, np, [&](size_t p) {
    budget::check("the uniform tessellation");
    const PatchPlan& pplan = plan.patches[p];
    const PatchPass pp{model.patches[p], static_cast<uint32_t>(p), pplan, layout, topology, params, out};
    sample_interior(pp);
    SlotWriter w{&slots[pplan.slot_base], params.surface_data ? &slot_uv[pplan.slot_base] : nullptr};
    triangulate_cells(pp, w);
    const size_t end = p + 1 < np ? plan.patches[p + 1].slot_base : plan.slots;
    kept[p] = compact_patch(slots.data(), params.surface_data ? slot_uv.data() : nullptr, pplan.slot_base, end);
  });

  compact(plan.patches, kept, std::move(slots), std::move(slot_uv), params.surface_data, out);
  return out;
}

}  // namespace sagitta
