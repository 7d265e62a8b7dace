#include "sagitta/pn.hpp"

#include "sagitta/budget.hpp"
#include "sagitta/mesh_normals.hpp"

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>
#include <unordered_map>

namespace sagitta {
namespace detail {

// ---- The PN triangle --------------------------------------------------------------------------

namespace {

Vec3 normalized_or(const Vec3& v, const Vec3& fallback) {
  const double len = glm::length(v);
  return len > 0.0 && std::isfinite(len) ? v / len : fallback;
}

}  // namespace

PnEdge pn_edge(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1) {
  PnEdge e;
  e.p0 = p0;
  e.p1 = p1;
  e.n0 = n0;
  e.n1 = n1;
  // The two formulas are mirror images term by term, so pn_edge(p1, n1, p0, n0) yields the same
  // c1/c0 bits swapped.
  e.c0 = (2.0 * p0 + p1 - glm::dot(p1 - p0, n0) * n0) / 3.0;
  e.c1 = (2.0 * p1 + p0 - glm::dot(p0 - p1, n1) * n1) / 3.0;
  const Vec3 d = p1 - p0;
  const double dd = glm::dot(d, d);
  const Vec3 sum = n0 + n1;
  if (dd > 0.0) {
    const double v = 2.0 * glm::dot(d, sum) / dd;
    e.n01 = normalized_or(sum - v * d, normalized_or(sum, n0));
  } else {
    e.n01 = normalized_or(sum, n0);
  }
  return e;
}

Vec3 pn_edge_position(const PnEdge& e, double t) {
  const double s = 1.0 - t;
  return (s * s * s) * e.p0 + (3.0 * s * s * t) * e.c0 + (3.0 * s * t * t) * e.c1 + (t * t * t) * e.p1;
}

Vec3 pn_edge_normal(const PnEdge& e, double t) {
  const double s = 1.0 - t;
  return normalized_or((s * s) * e.n0 + (s * t) * e.n01 + (t * t) * e.n1, e.n0);
}

PnTriangle pn_triangle(const std::array<PnEdge, 3>& edges) {
  PnTriangle t;
  t.b[k300] = edges[0].p0;
  t.b[k030] = edges[1].p0;
  t.b[k003] = edges[2].p0;
  t.b[k210] = edges[0].c0;
  t.b[k120] = edges[0].c1;
  t.b[k021] = edges[1].c0;
  t.b[k012] = edges[1].c1;
  t.b[k102] = edges[2].c0;
  t.b[k201] = edges[2].c1;
  const Vec3 e = (t.b[k210] + t.b[k120] + t.b[k021] + t.b[k012] + t.b[k102] + t.b[k201]) / 6.0;
  const Vec3 v = (t.b[k300] + t.b[k030] + t.b[k003]) / 3.0;
  t.b[k111] = e + (e - v) / 2.0;
  t.n[k200] = edges[0].n0;
  t.n[k020] = edges[1].n0;
  t.n[k002] = edges[2].n0;
  t.n[k110] = edges[0].n01;
  t.n[k011] = edges[1].n01;
  t.n[k101] = edges[2].n01;
  return t;
}

PnTriangle pn_triangle(const std::array<Vec3, 3>& p, const std::array<Vec3, 3>& n) {
  return pn_triangle({pn_edge(p[0], n[0], p[1], n[1]), pn_edge(p[1], n[1], p[2], n[2]), pn_edge(p[2], n[2], p[0], n[0])});
}

Vec3 pn_position(const PnTriangle& t, const Bary& b) {
  const double u = b[0], v = b[1], w = b[2];
  return (u * u * u) * t.b[k300] + (v * v * v) * t.b[k030] + (w * w * w) * t.b[k003] +
         (3.0 * u * u * v) * t.b[k210] + (3.0 * u * v * v) * t.b[k120] + (3.0 * v * v * w) * t.b[k021] +
         (3.0 * v * w * w) * t.b[k012] + (3.0 * w * w * u) * t.b[k102] + (3.0 * w * u * u) * t.b[k201] +
         (6.0 * u * v * w) * t.b[k111];
}

Vec3 pn_normal(const PnTriangle& t, const Bary& b) {
  const double u = b[0], v = b[1], w = b[2];
  const Vec3 n = (u * u) * t.n[k200] + (v * v) * t.n[k020] + (w * w) * t.n[k002] + (u * v) * t.n[k110] +
                 (v * w) * t.n[k011] + (w * u) * t.n[k101];
  return normalized_or(n, t.n[k200]);
}

// ---- Patterns -----------------------------------------------------------------------------------

TrianglePattern integer_pattern(int k) {
  if (k < 1) throw InputError("PN integer pattern: --level must be >= 1 segments per edge, got " + std::to_string(k));
  TrianglePattern p;
  // Vertex (i, j): i steps towards corner 1, j towards corner 2.
  std::vector<uint32_t> id(static_cast<size_t>((k + 1) * (k + 1)));
  auto at = [&](int i, int j) -> uint32_t& { return id[static_cast<size_t>(j * (k + 1) + i)]; };
  const double kd = k;
  for (int j = 0; j <= k; ++j) {
    for (int i = 0; i + j <= k; ++i) {
      at(i, j) = static_cast<uint32_t>(p.vertices.size());
      p.vertices.emplace_back((k - i - j) / kd, i / kd, j / kd);
    }
  }
  for (int j = 0; j < k; ++j) {
    for (int i = 0; i + j < k; ++i) {
      p.triangles.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
      if (i + j + 2 <= k) p.triangles.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  for (int q = 0; q <= k; ++q) {
    p.side[0].push_back(at(q, 0));
    p.side[1].push_back(at(k - q, q));
    p.side[2].push_back(at(0, k - q));
  }
  return p;
}

namespace {

double clamp_factor(double f) {
  if (!std::isfinite(f)) throw InputError("PN fractional_odd factor must be a finite number");
  return std::clamp(f, 1.0, kMaxTessFactor);
}

unsigned remove_msb(unsigned v) {
  for (unsigned bit = 1u << 31; bit; bit >>= 1) {
    if (v & bit) return v & ~bit;
  }
  return 0;
}

}  // namespace

int fractional_odd_segments(double factor) {
  const double half = clamp_factor(factor) / 2.0 + 0.5;
  return 2 * static_cast<int>(std::ceil(half)) - 1;
}

std::vector<double> fractional_odd_edge_params(double factor) {
  // Half an edge holds ceil(f/2 + 1/2) points; each point lerps between its place on the pattern of
  // the odd factor below (floor) and above (ceil) by the fraction of f/2 + 1/2. One point of the
  // floor pattern, chosen by the ruler function (D3D11's split point), is the one that splits in
  // two, so the two growing segments appear symmetrically at that place; the other half mirrors.
  const double half = clamp_factor(factor) / 2.0 + 0.5;
  const int floor_half = static_cast<int>(std::floor(half));
  const int ceil_half = static_cast<int>(std::ceil(half));
  const double frac = half - floor_half;
  const int segments = 2 * ceil_half - 1;
  std::vector<double> t(static_cast<size_t>(segments + 1));
  if (floor_half == ceil_half) {  // odd integer factor: uniform
    for (int q = 0; q <= segments; ++q) t[static_cast<size_t>(q)] = static_cast<double>(q) / segments;
    return t;
  }
  const int split = floor_half == 1 ? 0 : static_cast<int>(remove_msb(static_cast<unsigned>(floor_half - 1)) << 1) + 1;
  const double floor_segments = 2 * floor_half - 1, ceil_segments = segments;
  for (int q = 0; q < ceil_half; ++q) {
    const int on_floor = q > split ? q - 1 : q;
    const double x = (on_floor / floor_segments) * (1.0 - frac) + (q / ceil_segments) * frac;
    t[static_cast<size_t>(q)] = x;
    t[static_cast<size_t>(segments - q)] = 1.0 - x;
  }
  return t;
}

namespace {

// Triangles between an outer polyline and an inner one running the same way (inner on the left),
// both with their end points: advance on whichever row has the smaller next-segment midpoint.
void zipper(const std::vector<uint32_t>& out, const std::vector<double>& tout, const std::vector<uint32_t>& in,
            const std::vector<double>& tin, std::vector<Triangle>& tris) {
  size_t i = 0, j = 0;
  const size_t a = out.size() - 1, b = in.size() - 1;
  while (i < a || j < b) {
    const bool advance_out =
        j == b || (i < a && 0.5 * (tout[i] + tout[i + 1]) <= 0.5 * (tin[j] + tin[j + 1]));
    if (advance_out) {
      tris.push_back({out[i], out[i + 1], in[j]});
      ++i;
    } else {
      tris.push_back({out[i], in[j + 1], in[j]});
      ++j;
    }
  }
}

// One ring of a fractional_odd pattern: its corners, and its three sides (side s from corner s to
// corner s + 1) with each point's parameter along its side, 0..1.
struct Ring {
  std::array<uint32_t, 3> corner{};
  std::array<std::vector<uint32_t>, 3> side;
  std::array<std::vector<double>, 3> param;
};

// Outer ring: corner s, then side s's interior points; its vertices are appended to p.
Ring outer_ring(const std::array<double, 3>& outer, TrianglePattern& p) {
  Ring ring;
  std::array<std::vector<double>, 3> edge_t;
  for (int s = 0; s < 3; ++s) edge_t[s] = fractional_odd_edge_params(outer[s]);
  for (int s = 0; s < 3; ++s) {
    Bary b(0.0);
    b[s] = 1.0;
    ring.corner[s] = static_cast<uint32_t>(p.vertices.size());
    p.vertices.push_back(b);
  }
  for (int s = 0; s < 3; ++s) {
    const int a = s, c = (s + 1) % 3;
    ring.side[s].push_back(ring.corner[a]);
    ring.param[s].push_back(0.0);
    for (size_t q = 1; q + 1 < edge_t[s].size(); ++q) {
      Bary b(0.0);
      b[c] = edge_t[s][q];
      b[a] = 1.0 - edge_t[s][q];
      ring.side[s].push_back(static_cast<uint32_t>(p.vertices.size()));
      ring.param[s].push_back(edge_t[s][q]);
      p.vertices.push_back(b);
    }
    ring.side[s].push_back(ring.corner[c]);
    ring.param[s].push_back(1.0);
  }
  return ring;
}

// Ring r (r >= 1) of the inside points x: it uses points q = r .. x.size() - 1 - r, lies on the
// lines b_opposite = 2 x_r / 3 and has x.size() - 1 - 2r segments per side; its vertices are
// appended to p.
Ring inner_ring(const std::vector<double>& x, int r, TrianglePattern& p) {
  const int n_points = static_cast<int>(x.size());
  const double perp = x[static_cast<size_t>(r)] * 2.0 / 3.0;
  const int first = r, last = n_points - 1 - r;
  Ring ring;
  for (int s = 0; s < 3; ++s) {
    Bary b(perp);
    b[s] = 1.0 - 2.0 * perp;
    ring.corner[s] = static_cast<uint32_t>(p.vertices.size());
    p.vertices.push_back(b);
  }
  for (int s = 0; s < 3; ++s) {
    const int a = s, c = (s + 1) % 3, o = (s + 2) % 3;
    ring.side[s].push_back(ring.corner[a]);
    ring.param[s].push_back(0.0);
    const double span = x[static_cast<size_t>(last)] - x[static_cast<size_t>(first)];
    for (int q = first + 1; q < last; ++q) {
      Bary b(0.0);
      b[o] = perp;
      b[c] = x[static_cast<size_t>(q)] - perp / 2.0;
      b[a] = 1.0 - b[c] - b[o];
      ring.side[s].push_back(static_cast<uint32_t>(p.vertices.size()));
      ring.param[s].push_back((x[static_cast<size_t>(q)] - x[static_cast<size_t>(first)]) / span);
      p.vertices.push_back(b);
    }
    ring.side[s].push_back(ring.corner[c]);
    ring.param[s].push_back(1.0);
  }
  return ring;
}

}  // namespace

TrianglePattern fractional_odd_pattern(const std::array<double, 3>& outer, double inside) {
  TrianglePattern p;
  const Ring outer_r = outer_ring(outer, p);
  p.side = outer_r.side;
  const std::array<uint32_t, 3>& corner = outer_r.corner;

  const std::vector<double> x = fractional_odd_edge_params(inside);
  const int n_points = static_cast<int>(x.size());  // even: 2 * ceil_half
  const bool outer_is_one = p.side[0].size() == 2 && p.side[1].size() == 2 && p.side[2].size() == 2;
  if (n_points == 2) {
    if (outer_is_one) {
      p.triangles.push_back({corner[0], corner[1], corner[2]});
    } else {
      // Inside factor 1 with a finer outside: fan from the centre (D3D11 bumps the inside factor
      // instead; see docs/PN.md).
      const uint32_t centre = static_cast<uint32_t>(p.vertices.size());
      p.vertices.emplace_back(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0);
      for (int s = 0; s < 3; ++s) {
        for (size_t q = 0; q + 1 < p.side[s].size(); ++q) p.triangles.push_back({p.side[s][q], p.side[s][q + 1], centre});
      }
    }
    return p;
  }

  // Rings r = 1 .. (n_points - 2) / 2, each zipped to the one outside it.
  Ring prev = outer_r;
  for (int r = 1; 2 * r <= n_points - 2; ++r) {
    Ring ring = inner_ring(x, r, p);
    for (int s = 0; s < 3; ++s) zipper(prev.side[s], prev.param[s], ring.side[s], ring.param[s], p.triangles);
    prev = std::move(ring);
  }
  // Innermost ring has one segment per side: the centre triangle.
  p.triangles.push_back({prev.side[0][0], prev.side[1][0], prev.side[2][0]});
  return p;
}

}  // namespace detail

// ---- The scheme ---------------------------------------------------------------------------------

using namespace detail;  // the scheme is built from the PN triangle and the patterns above

namespace {

// Segments per edge of the integer pattern; throws InputError, saying why, outside 1..4096.
int integer_segments(const PnParams& params) {
  if (!(params.factor >= 1.0) || params.factor != std::floor(params.factor) || params.factor > 4096.0) {
    throw InputError("PN integer pattern: --level must be a whole number of segments per edge in 1..4096 (K segments "
                     "make K^2 triangles per input triangle: 4096 already makes 16.8 million triangles per input "
                     "triangle, about 1 GiB at 64 bytes each, and 512 such triangles would exceed the 32-bit vertex ids)");
  }
  return static_cast<int>(params.factor);
}

TrianglePattern make_pattern(const PnParams& params) {
  if (params.pattern == PnPatternKind::kInteger) {
    return integer_pattern(integer_segments(params));
  }
  if (!(params.factor >= 1.0) || !(params.factor <= kMaxTessFactor)) {
    throw InputError("PN fractional_odd pattern: the factor must be in 1..63 (Direct3D 11's range)");
  }
  return fractional_odd_pattern({params.factor, params.factor, params.factor}, params.factor);
}

std::vector<double> edge_params(const PnParams& params) {
  if (params.pattern == PnPatternKind::kFractionalOdd) return fractional_odd_edge_params(params.factor);
  const int k = static_cast<int>(params.factor);
  std::vector<double> t(static_cast<size_t>(k + 1));
  for (int q = 0; q <= k; ++q) t[static_cast<size_t>(q)] = static_cast<double>(q) / k;
  return t;
}

using Key = std::array<double, 6>;  // position, normal (zeros for position-only matching)

struct KeyHash {
  size_t operator()(const Key& k) const {
    size_t h = 1469598103934665603ull;
    for (double d : k) {
      uint64_t bits;
      std::memcpy(&bits, &d, sizeof bits);
      h = (h ^ bits) * 1099511628211ull;
      h ^= h >> 29;
    }
    return h;
  }
};

// One matched input edge, canonical direction start -> end (start's key is smaller).
struct EdgeInfo {
  uint32_t start = 0, end = 0;
  PnEdge geometry;                 // used for every output sample on the edge
  std::vector<PnEdge> uses;        // AEN: per adjacent triangle, its own edge in canonical direction
  std::vector<std::pair<uint32_t, int>> tri_sides;  // (triangle, side)
};

// Unit normals of the input vertices: the mesh's own, normalised, or angle-weighted ones when it has
// none. Throws InputError for an out-of-range vertex index, a non-finite position, or a zero /
// non-finite normal.
std::vector<Vec3> input_normals(const Tessellation& base) {
  const size_t nv = base.positions.size();
  for (const Triangle& t : base.triangles) {
    for (uint32_t v : t) {
      if (v >= nv) throw InputError("PN input: a triangle uses vertex " + std::to_string(v) + " but the mesh has " + std::to_string(nv));
    }
  }
  for (const Vec3& p : base.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) throw InputError("PN input: a vertex position is not finite");
  }
  std::vector<Vec3> normals;
  if (base.normals.empty()) {
    normals = angle_weighted_normals(base.positions, base.triangles);
  } else {
    if (base.normals.size() != nv) throw InputError("PN input: the mesh has a different number of normals and positions");
    normals.resize(nv);
    for (size_t v = 0; v < nv; ++v) {
      const double len = glm::length(base.normals[v]);
      if (!(len > 0.0) || !std::isfinite(len)) {
        throw InputError("PN input: vertex " + std::to_string(v) + " has a zero or non-finite normal; drop the normals from the file to have them computed");
      }
      normals[v] = base.normals[v] / len;
    }
  }
  return normals;
}

// What every stage reads: the input mesh, its unit normals, the variant and the edge samples.
struct PnInput {
  const Tessellation& base;
  const std::vector<Vec3>& normals;
  bool aen;
  const std::vector<double>& t_edge;  // the pattern's edge parameters, 0..1
  int segments;                       // t_edge.size() - 1
};

// Vertex classes: (position, normal) for basic, position for AEN; each becomes one output vertex.
struct Classes {
  std::vector<uint32_t> class_of;  // per input vertex
  std::vector<Key> key;
  std::vector<uint32_t> vertex;  // first input vertex of the class
  std::vector<Vec3> normal;      // AEN: the normalised sum over the class; basic: the first vertex's
};

Classes vertex_classes(const PnInput& in) {
  const Tessellation& base = in.base;
  const std::vector<Vec3>& normals = in.normals;
  const size_t nv = base.positions.size();
  auto key_of = [&](uint32_t v, bool with_normal) {
    const Vec3& p = base.positions[v];
    const Vec3 n = with_normal ? normals[v] : Vec3(0.0);
    return Key{p.x + 0.0, p.y + 0.0, p.z + 0.0, n.x + 0.0, n.y + 0.0, n.z + 0.0};
  };
  Classes cl;
  std::unordered_map<Key, uint32_t, KeyHash> class_of_key;
  cl.class_of.resize(nv);
  for (uint32_t v = 0; v < nv; ++v) {
    const Key k = key_of(v, !in.aen);
    const auto [it, inserted] = class_of_key.emplace(k, static_cast<uint32_t>(cl.key.size()));
    if (inserted) {
      cl.key.push_back(k);
      cl.vertex.push_back(v);
    }
    cl.class_of[v] = it->second;
  }
  const size_t nc = cl.key.size();
  cl.normal.assign(nc, Vec3(0.0));
  if (in.aen) {
    for (uint32_t v = 0; v < nv; ++v) cl.normal[cl.class_of[v]] += normals[v];
    for (size_t c = 0; c < nc; ++c) cl.normal[c] = normalized_or(cl.normal[c], normals[cl.vertex[c]]);
  } else {
    for (size_t c = 0; c < nc; ++c) cl.normal[c] = normals[cl.vertex[c]];
  }
  return cl;
}

// The matched edges and, per input triangle, its sides' edges; a triangle with two vertices in one
// class is skipped.
struct Edges {
  std::vector<uint8_t> skipped;
  std::vector<std::array<int32_t, 3>> tri_edge;
  std::vector<std::array<bool, 3>> tri_reversed;  // the side runs against its edge's canonical direction
  std::vector<EdgeInfo> edges;
};

Edges match_edges(const PnInput& in, const Classes& cl, PnStats& stats) {
  const Tessellation& base = in.base;
  const std::vector<Vec3>& normals = in.normals;
  const size_t nt = base.triangles.size();
  Edges ed;
  ed.skipped.assign(nt, 0);
  ed.tri_edge.assign(nt, {-1, -1, -1});
  ed.tri_reversed.assign(nt, {false, false, false});
  std::unordered_map<uint64_t, uint32_t> edge_of;
  std::vector<EdgeInfo>& edges = ed.edges;
  for (size_t t = 0; t < nt; ++t) {
    const Triangle& tri = base.triangles[t];
    const std::array<uint32_t, 3> c = {cl.class_of[tri[0]], cl.class_of[tri[1]], cl.class_of[tri[2]]};
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) {
      ed.skipped[t] = 1;
      ++stats.skipped_triangles;
      continue;
    }
    for (int s = 0; s < 3; ++s) {
      const uint32_t a = c[s], b = c[(s + 1) % 3];
      const bool reversed = cl.key[b] < cl.key[a];
      const uint32_t lo = reversed ? b : a, hi = reversed ? a : b;
      const uint64_t ek = (static_cast<uint64_t>(lo) << 32) | hi;
      const auto [it, inserted] = edge_of.emplace(ek, static_cast<uint32_t>(edges.size()));
      if (inserted) {
        EdgeInfo e;
        e.start = lo;
        e.end = hi;
        edges.push_back(std::move(e));
      }
      EdgeInfo& e = edges[it->second];
      e.tri_sides.emplace_back(static_cast<uint32_t>(t), s);
      ed.tri_edge[t][s] = static_cast<int32_t>(it->second);
      ed.tri_reversed[t][s] = reversed;
      if (in.aen) {
        const uint32_t va = tri[reversed ? (s + 1) % 3 : s], vb = tri[reversed ? s : (s + 1) % 3];
        e.uses.push_back(pn_edge(base.positions[va], normals[va], base.positions[vb], normals[vb]));
      }
    }
  }
  stats.edges = edges.size();
  return ed;
}

// Every edge's geometry from its classes; PN-AEN averages the edge control points over the adjacent
// triangles.
void edge_geometry(const PnInput& in, const Classes& cl, std::vector<EdgeInfo>& edges) {
  const Tessellation& base = in.base;
  tbb::parallel_for(size_t{0}, edges.size(), [&](size_t ei) {
    EdgeInfo& e = edges[ei];
    const Vec3& p0 = base.positions[cl.vertex[e.start]];
    const Vec3& p1 = base.positions[cl.vertex[e.end]];
    if (!in.aen) {
      e.geometry = pn_edge(p0, cl.normal[e.start], p1, cl.normal[e.end]);
      return;
    }
    // PN-AEN: average the edge control points over the adjacent triangles.
    Vec3 c0(0.0), c1(0.0);
    for (const PnEdge& u : e.uses) {
      c0 += u.c0;
      c1 += u.c1;
    }
    const double m = static_cast<double>(e.uses.size());
    e.geometry = pn_edge(p0, cl.normal[e.start], p1, cl.normal[e.end]);
    e.geometry.c0 = c0 / m;
    e.geometry.c1 = c1 / m;
  });
}

// Output layout: classes, then N - 1 samples per edge, then pattern interiors per triangle.
struct OutputLayout {
  std::vector<int> role;                 // per pattern vertex: -1 interior; else side * (N + 1) + q
  std::vector<uint32_t> interior_local;  // per interior pattern vertex: its index among the interior ones
  uint32_t interior_count = 0;
  uint64_t edge_base = 0, interior_base = 0, total = 0;
};

// Throws InputError when the output needs more than 2^32 vertices; checks the memory budget.
OutputLayout layout_output(const TrianglePattern& pattern, int segments, size_t nc, size_t n_edges, size_t nt) {
  OutputLayout lo;
  lo.role.assign(pattern.vertices.size(), -1);
  for (int s = 0; s < 3; ++s) {
    for (size_t q = 0; q < pattern.side[s].size(); ++q) {
      lo.role[pattern.side[s][q]] = s * (segments + 1) + static_cast<int>(q);
    }
  }
  lo.interior_local.assign(pattern.vertices.size(), 0);
  for (size_t v = 0; v < pattern.vertices.size(); ++v) {
    if (lo.role[v] < 0) lo.interior_local[v] = lo.interior_count++;
  }
  lo.edge_base = nc;
  lo.interior_base = lo.edge_base + static_cast<uint64_t>(n_edges) * static_cast<uint64_t>(segments - 1);
  lo.total = lo.interior_base + static_cast<uint64_t>(nt) * lo.interior_count;
  if (lo.total > UINT32_MAX) throw InputError("the PN tessellation needs more than 2^32 vertices; lower --level");
  budget::check_memory(tessellation_bytes(2.0 * double(nt) * double(pattern.triangles.size()), double(lo.total)),
                       "the PN tessellation", "lower --level or raise --max-memory");
  return lo;
}

// The output's (u, v) at barycentric point b of input triangle t.
Vec2 interpolate_uv(const Tessellation& base, size_t t, const Bary& b) {
  const auto& uv = base.triangle_uv[t];
  return b[0] * uv[0] + b[1] * uv[1] + b[2] * uv[2];
}

// The shared output vertices: one per class, then the N - 1 samples of every edge (surface points,
// when `sp_out`, recorded from the first triangle using the edge).
void write_shared_vertices(const PnInput& in, const Classes& cl, const Edges& ed, const OutputLayout& lo, bool sp_out,
                           Tessellation& out) {
  const Tessellation& base = in.base;
  const int segments = in.segments;
  for (size_t c = 0; c < cl.key.size(); ++c) {
    out.positions[c] = base.positions[cl.vertex[c]];
    out.normals[c] = cl.normal[c];
    if (sp_out) out.surface_points[c] = base.surface_points[cl.vertex[c]];
  }
  tbb::parallel_for(size_t{0}, ed.edges.size(), [&](size_t ei) {
    const EdgeInfo& e = ed.edges[ei];
    for (int q = 1; q < segments; ++q) {
      const double t = in.t_edge[static_cast<size_t>(q)];
      const uint64_t id = lo.edge_base + ei * static_cast<uint64_t>(segments - 1) + static_cast<uint64_t>(q - 1);
      out.positions[id] = pn_edge_position(e.geometry, t);
      if (in.aen) {
        Vec3 n(0.0);
        for (const PnEdge& u : e.uses) n += pn_edge_normal(u, t);
        out.normals[id] = normalized_or(n, pn_edge_normal(e.geometry, t));
      } else {
        out.normals[id] = pn_edge_normal(e.geometry, t);
      }
      if (sp_out) {
        // Recorded from the first triangle using the edge.
        const auto [tri, side] = e.tri_sides.front();
        const bool reversed = ed.tri_reversed[tri][side];
        Bary b(0.0);
        const double along = reversed ? 1.0 - t : t;
        b[(side + 1) % 3] = along;
        b[side] = 1.0 - along;
        const Vec2 uv = interpolate_uv(base, tri, b);
        out.surface_points[id] = {base.triangle_patch[tri], uv.x, uv.y};
      }
    }
  });
}

// The PN triangle of input triangle t: basic takes its own vertices' normals; AEN the averaged edge
// geometry in each side's direction, with this triangle's own normals for shading.
PnTriangle triangle_geometry(const PnInput& in, const Edges& ed, size_t t) {
  const Tessellation& base = in.base;
  const std::vector<Vec3>& normals = in.normals;
  const Triangle& tri = base.triangles[t];
  std::array<PnEdge, 3> side_edges;
  for (int s = 0; s < 3; ++s) {
    const uint32_t va = tri[s], vb = tri[(s + 1) % 3];
    if (!in.aen) {
      side_edges[s] = pn_edge(base.positions[va], normals[va], base.positions[vb], normals[vb]);
    } else {
      // Averaged geometry in this side's direction; this triangle's own normals for shading.
      const EdgeInfo& e = ed.edges[static_cast<size_t>(ed.tri_edge[t][s])];
      PnEdge own = pn_edge(base.positions[va], normals[va], base.positions[vb], normals[vb]);
      const bool rev = ed.tri_reversed[t][s];
      own.c0 = rev ? e.geometry.c1 : e.geometry.c0;
      own.c1 = rev ? e.geometry.c0 : e.geometry.c1;
      side_edges[s] = own;
    }
  }
  return pn_triangle(side_edges);
}

// One input triangle: its pattern's interior vertices written to `out`, its pattern triangles (with
// output ids: shared class and edge vertices on its sides) written to `slots`.
void tessellate_triangle(const PnInput& in, const Classes& cl, const Edges& ed, const TrianglePattern& pattern,
                         const OutputLayout& lo, bool sp_out, size_t t, Triangle* slots, Tessellation& out) {
  const Tessellation& base = in.base;
  const int segments = in.segments;
  const Triangle& tri = base.triangles[t];
  const PnTriangle pn = triangle_geometry(in, ed, t);
  const uint64_t ibase = lo.interior_base + static_cast<uint64_t>(t) * lo.interior_count;
  std::vector<uint32_t> ids(pattern.vertices.size());
  for (size_t v = 0; v < pattern.vertices.size(); ++v) {
    if (lo.role[v] < 0) {
      const uint64_t id = ibase + lo.interior_local[v];
      ids[v] = static_cast<uint32_t>(id);
      out.positions[id] = pn_position(pn, pattern.vertices[v]);
      out.normals[id] = pn_normal(pn, pattern.vertices[v]);
      if (sp_out) {
        const Vec2 uv = interpolate_uv(base, t, pattern.vertices[v]);
        out.surface_points[id] = {base.triangle_patch[t], uv.x, uv.y};
      }
      continue;
    }
    const int s = lo.role[v] / (segments + 1), q = lo.role[v] % (segments + 1);
    if (q == 0) {
      ids[v] = cl.class_of[tri[s]];
    } else if (q == segments) {
      ids[v] = cl.class_of[tri[(s + 1) % 3]];
    } else {
      const int canonical_q = ed.tri_reversed[t][s] ? segments - q : q;
      ids[v] = static_cast<uint32_t>(lo.edge_base + static_cast<uint64_t>(ed.tri_edge[t][s]) * (segments - 1) +
                                     static_cast<uint64_t>(canonical_q - 1));
    }
  }
  for (size_t k = 0; k < pattern.triangles.size(); ++k) {
    const Triangle& pt = pattern.triangles[k];
    slots[k] = {ids[pt[0]], ids[pt[1]], ids[pt[2]]};
  }
}

// The slots in input order, skipped triangles counted as degenerate; (u, v) per triangle when `uv_out`.
void compact(const Tessellation& base, const TrianglePattern& pattern, const std::vector<uint8_t>& skipped,
             const std::vector<Triangle>& slots, bool uv_out, Tessellation& out) {
  const size_t nt = base.triangles.size();
  const size_t per_tri = pattern.triangles.size();
  out.triangles.reserve(slots.size());
  if (uv_out) {
    out.triangle_patch.reserve(slots.size());
    out.triangle_uv.reserve(slots.size());
  }
  for (size_t t = 0; t < nt; ++t) {
    if (skipped[t]) {
      out.degenerate_triangles += per_tri;
      continue;
    }
    for (size_t k = 0; k < per_tri; ++k) {
      out.triangles.push_back(slots[t * per_tri + k]);
      if (uv_out) {
        const Triangle& pt = pattern.triangles[k];
        out.triangle_patch.push_back(base.triangle_patch[t]);
        out.triangle_uv.push_back({interpolate_uv(base, t, pattern.vertices[pt[0]]),
                                   interpolate_uv(base, t, pattern.vertices[pt[1]]),
                                   interpolate_uv(base, t, pattern.vertices[pt[2]])});
      }
    }
  }
}

// Open edges and cracks. An edge with one adjacent triangle leaves `segments` open output edges.
// Basic: group edges by their end positions; a group of several is a crease split by normals.
void count_cracks(const PnInput& in, const Classes& cl, const std::vector<EdgeInfo>& edges, PnStats& stats) {
  const int segments = in.segments;
  std::map<std::array<double, 6>, std::vector<uint32_t>> by_position;
  for (size_t ei = 0; ei < edges.size(); ++ei) {
    const EdgeInfo& e = edges[ei];
    if (e.tri_sides.size() == 1) stats.open_edges += static_cast<size_t>(segments);
    const Key& a = cl.key[e.start];
    const Key& b = cl.key[e.end];
    std::array<double, 6> pk{a[0], a[1], a[2], b[0], b[1], b[2]};
    if (std::tie(b[0], b[1], b[2]) < std::tie(a[0], a[1], a[2])) pk = {b[0], b[1], b[2], a[0], a[1], a[2]};
    by_position[pk].push_back(static_cast<uint32_t>(ei));
  }
  for (const auto& [pk, group] : by_position) {
    if (in.aen) {
      // A crease here is an edge whose adjacent triangles disagree on the normals.
      const EdgeInfo& e = edges[group.front()];
      for (const PnEdge& u : e.uses) {
        if (u.n0 != e.uses.front().n0 || u.n1 != e.uses.front().n1) {
          ++stats.crease_edges;
          break;
        }
      }
      continue;
    }
    if (group.size() < 2) continue;
    ++stats.crease_edges;
    for (uint32_t ei : group) {
      if (edges[ei].tri_sides.size() == 1) stats.crack_edges += static_cast<size_t>(segments);
    }
    // All edges of a group run the same way: positions differ, so the position decides the order.
    for (size_t g = 1; g < group.size(); ++g) {
      for (int q = 1; q < segments; ++q) {
        const double t = in.t_edge[static_cast<size_t>(q)];
        const double gap = glm::length(pn_edge_position(edges[group[0]].geometry, t) - pn_edge_position(edges[group[g]].geometry, t));
        stats.max_crack_gap = std::max(stats.max_crack_gap, gap);
      }
    }
  }
}

}  // namespace

uint64_t pn_triangles_per_input(const PnParams& params) {
  // The integer pattern is counted, not built: at K = 4096 it would allocate ~0.4 GiB just to size
  // the output. Fractional_odd patterns (factor <= 63) are small enough to build.
  if (params.pattern == PnPatternKind::kInteger) {
    const uint64_t k = static_cast<uint64_t>(integer_segments(params));
    return k * k;
  }
  return make_pattern(params).triangles.size();
}

Tessellation tessellate_pn(const Tessellation& base, const PnParams& params, PnStats* stats_out) {
  const TrianglePattern pattern = make_pattern(params);
  const std::vector<double> t_edge = edge_params(params);
  const int segments = static_cast<int>(t_edge.size()) - 1;
  PnStats stats;
  stats.segments_per_edge = segments;
  stats.input_triangles = base.triangles.size();
  const std::vector<Vec3> normals = input_normals(base);
  const PnInput in{base, normals, params.variant == PnVariant::kAen, t_edge, segments};

  const Classes cl = vertex_classes(in);
  Edges ed = match_edges(in, cl, stats);
  edge_geometry(in, cl, ed.edges);

  const size_t nt = base.triangles.size();
  const OutputLayout lo = layout_output(pattern, segments, cl.key.size(), ed.edges.size(), nt);
  const bool uv_out = base.has_surface() && base.triangle_patch.size() == nt && base.triangle_uv.size() == nt;
  const bool sp_out = uv_out && base.surface_points.size() == base.positions.size();
  Tessellation out;
  out.positions.resize(lo.total);
  out.normals.resize(lo.total);
  if (sp_out) out.surface_points.resize(lo.total);
  write_shared_vertices(in, cl, ed, lo, sp_out, out);

  const size_t per_tri = pattern.triangles.size();
  std::vector<Triangle> slots(nt * per_tri);
  tbb::parallel_for(size_t{0}, nt, [&](size_t t) {
    if ((t & 1023u) == 0) budget::check("the PN tessellation");
    if (ed.skipped[t]) return;
    tessellate_triangle(in, cl, ed, pattern, lo, sp_out, t, &slots[t * per_tri], out);
  });

  compact(base, pattern, ed.skipped, slots, uv_out, out);
  count_cracks(in, cl, ed.edges, stats);
  if (stats_out) *stats_out = stats;
  return out;
}

}  // namespace sagitta
