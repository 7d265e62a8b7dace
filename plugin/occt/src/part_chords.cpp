// Chord deviations of trimming curves (part_chords.hpp).
#include "part_chords.hpp"

#include <Geom2dConvert.hxx>
#include <Geom2dConvert_BSplineCurveToBezierCurve.hxx>
#include <Geom2d_BSplineCurve.hxx>
#include <Geom2d_BezierCurve.hxx>
#include <Geom2d_TrimmedCurve.hxx>
#include <Standard_Failure.hxx>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <queue>
#include <vector>

namespace sagitta::occt::detail {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kNodeBudget = 512;  // sub-arcs split per Bézier piece of a chord's curve
// Through a non-identity map a sub-arc's bound is its mapped box, which shrinks linearly with the
// sub-arc (not quadratically like a hull): a deeper search and a larger budget, paid for by the
// map's memo (each split solves about one new value).
constexpr int kMappedNodeBudget = 8 * kNodeBudget;
constexpr int kMappedDepth = 20;
constexpr int kTraceDepth = 8;    // halvings per Bézier piece for ChordTrace

double segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double len2 = glm::dot(d, d);
  const double s = len2 > 0.0 ? std::clamp(glm::dot(p - a, d) / len2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + s * d));
}

// A Bézier arc in homogeneous form: (w x, w y, w) per control point.
using Arc = std::vector<glm::dvec3>;

// Values of a one-dimensional function by exact argument (bit pattern), open addressing: the few
// hundred values a chord's bounds ask for, without a heap node per value.
class ExactMemo {
 public:
  // The stored value of x, or nullptr; `store` keeps a value for x.
  const double* find(double x) const {
    if (count_ == 0) return nullptr;
    for (size_t i = slot(x);; i = (i + 1) & (keys_.size() - 1)) {
      if (!used_[i]) return nullptr;
      if (keys_[i] == bits(x)) return &values_[i];
    }
  }
  void store(double x, double value) {
    if (2 * (count_ + 1) > keys_.size()) grow();
    for (size_t i = slot(x);; i = (i + 1) & (keys_.size() - 1)) {
      if (!used_[i]) {
        used_[i] = 1, keys_[i] = bits(x), values_[i] = value, ++count_;
        return;
      }
      if (keys_[i] == bits(x)) return;  // the first value stays
    }
  }

 private:
  static uint64_t bits(double x) {
    uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
  }
  size_t slot(double x) const { return static_cast<size_t>((bits(x) * 0x9E3779B97F4A7C15ull) >> shift_); }
  void grow() {
    std::vector<uint64_t> keys = std::move(keys_);
    std::vector<double> values = std::move(values_);
    std::vector<uint8_t> used = std::move(used_);
    const size_t size = keys.empty() ? 64 : 2 * keys.size();
    shift_ = 64 - __builtin_ctzll(size);  // size is a power of two
    keys_.assign(size, 0), values_.assign(size, 0.0), used_.assign(size, 0), count_ = 0;
    for (size_t i = 0; i < keys.size(); ++i) {
      if (!used[i]) continue;
      double x;
      std::memcpy(&x, &keys[i], sizeof x);
      store(x, values[i]);
    }
  }
  std::vector<uint64_t> keys_;
  std::vector<double> values_;
  std::vector<uint8_t> used_;
  size_t count_ = 0;
  int shift_ = 58;
};

Vec2 euclid(const glm::dvec3& h) { return Vec2(h.x / h.z, h.y / h.z); }

// de Casteljau at s = 1/2: the two halves. The levels are worked in place in `right`: level L's
// last point stays at n - 1 - L, which is the right half's point there; the left half takes each
// level's first. Only the two results are allocated.
std::pair<Arc, Arc> halves(const Arc& arc) {
  const size_t n = arc.size();
  Arc left(n), right = arc;
  for (size_t level = 0; level < n; ++level) {
    left[level] = right[0];
    for (size_t k = 0; k + 1 < n - level; ++k) right[k] = 0.5 * (right[k] + right[k + 1]);
  }
  return {std::move(left), std::move(right)};
}

Vec2 midpoint(const Arc& arc) {
  glm::dvec3 work[32];
  if (arc.size() > 32) return euclid(halves(arc).second.front());
  const size_t n = arc.size();
  std::copy(arc.begin(), arc.end(), work);
  for (size_t level = 1; level < n; ++level) {
    for (size_t k = 0; k + level < n; ++k) work[k] = 0.5 * (work[k] + work[k + 1]);
  }
  return euclid(work[0]);
}

struct Bounder {
  const ParameterMap& map;
  Vec2 a, b;
  double floor;
  int max_depth;

  Vec2 mapped(const Vec2& uv) const {
    return map.metric * (map.identity ? uv + map.shift : map.to_uv(uv + map.shift));
  }

  // Through a non-identity map (separable: U depends on u alone, V on v alone), the mapped U of u
  // (evaluated at the point (u, v)) and V of v (at (u, v)). A box's u-extremes recur in the boxes of
  // its sub-arcs (a split point ends both halves), so each value is solved once per chord: the map
  // is an iterative solve, most of a chord's cost.
  double mapped_u(double u, double v) const {
    if (const double* known = u_memo.find(u)) return *known;
    const double U = mapped(Vec2(u, v)).x;
    u_memo.store(u, U);
    return U;
  }
  double mapped_v(double u, double v) const {
    if (const double* known = v_memo.find(v)) return *known;
    const double V = mapped(Vec2(u, v)).y;
    v_memo.store(v, V);
    return V;
  }
  // A curve point mapped (metric), its U and V kept for the boxes whose extremes it is (the split
  // point of a sub-arc is an end of both halves).
  Vec2 mapped_point(const Vec2& uv) const {
    const Vec2 m = mapped(uv);
    if (!map.identity) u_memo.store(uv.x, m.x), v_memo.store(uv.y, m.y);
    return m;
  }
  mutable ExactMemo u_memo, v_memo;

  // Calls f(x) for each of the hull's points x (metric): the control points, or through a
  // non-identity map the corners of the hull's (u, v) box mapped corner by corner (monotone
  // coordinates; the map's own error, map_error(), is the caller's to add).
  template <class F>
  void for_each_hull_point(const Arc& arc, F&& f) const {
    if (map.identity) {
      for (const glm::dvec3& h : arc) f(mapped(euclid(h)));
      return;
    }
    Vec2 lo(kInf), hi(-kInf);
    for (const glm::dvec3& h : arc) lo = glm::min(lo, euclid(h)), hi = glm::max(hi, euclid(h));
    const Vec2 mid = 0.5 * (lo + hi);
    const double u0 = mapped_u(lo.x, mid.y), u1 = mapped_u(hi.x, mid.y);
    const double v0 = mapped_v(mid.x, lo.y), v1 = mapped_v(mid.x, hi.y);
    for (double U : {u0, u1}) {
      for (double V : {v0, v1}) f(Vec2(U, V));
    }
  }
  double map_error() const { return map.identity ? 0.0 : map.to_uv_error * std::max(map.metric.x, map.metric.y); }

  // A bound of the arc's distance to [a, b] from its control points' hull (through the map: the
  // hull's box, mapped corner by corner, plus the map's own error).
  double hull_bound(const Arc& arc) const { return hull_bound(arc, a, b); }
  double hull_bound(const Arc& arc, const Vec2& a, const Vec2& b) const {
    double d = 0.0;
    for_each_hull_point(arc, [&](const Vec2& x) { d = std::max(d, segment_distance(x, a, b)); });
    return d + map_error();
  }

  // A bound of how far the arc's points project beyond [a, b]'s ends along it (<= 0: none do):
  // the hull's, halved where it is positive (only sub-arcs at the ends can be) up to 12 times.
  double overshoot(const Arc& arc, int depth = 0) const {
    const Vec2 d = b - a;
    const double length = glm::length(d);
    if (!(length > 0.0)) return kInf;
    const Vec2 along = d / length;
    double worst = -kInf;
    for_each_hull_point(arc, [&](const Vec2& x) {
      const double t = glm::dot(x - a, along);
      worst = std::max({worst, -t, t - length});
    });
    worst += map_error();
    if (!(worst > 0.0)) return 0.0;
    // Through a map, no halving brings the bound below the map's own error (an end sub-arc's hull
    // starts at the chord's end): within twice that error it is final.
    if (depth >= 12 || !std::isfinite(worst) || worst <= 2.0 * map_error()) return worst;
    auto [left, right] = halves(arc);
    return std::max(overshoot(left, depth + 1), overshoot(right, depth + 1));
  }

  // A bound of how far the arc's points lie on one side of the line through [a, b] (side +1: the
  // left of a -> b, -1: the right; 0 when none do): branch and bound over sub-arcs, the largest hull
  // value first, until it is at most 10 % above the largest curve point value seen (midpoints), at
  // most `enough` or the floor, or 32 sub-arcs have been split; the largest hull value left is the
  // bound.
  double side(const Arc& arc, double sign, double enough) const {
    const Vec2 d = b - a;
    const double length = glm::length(d);
    if (!(length > 0.0)) return kInf;
    const Vec2 left(-d.y / length, d.x / length);
    const auto hull = [&](const Arc& h) {
      double worst = -kInf;
      for_each_hull_point(h, [&](const Vec2& x) { worst = std::max(worst, sign * glm::dot(x - a, left)); });
      return worst + map_error();
    };
    struct Node {
      double hull;
      Arc arc;
      bool operator<(const Node& o) const { return hull < o.hull; }
    };
    std::priority_queue<Node> open;
    open.push({hull(arc), arc});
    double seen = 0.0;
    for (int nodes = 0;; nodes += 2) {
      const Node& top = open.top();
      seen = std::max(seen, sign * glm::dot(mapped_point(midpoint(top.arc)) - a, left));
      if (!(top.hull > std::max(floor, enough)) || top.hull <= 1.1 * seen || nodes >= 2 * 32)
        return std::max(top.hull, 0.0);
      auto [l, r] = halves(top.arc);
      open.pop();
      open.push({hull(l), std::move(l)});
      open.push({hull(r), std::move(r)});
    }
  }

  // Branch and bound over sub-arcs (largest hull first): a sub-arc whose hull bound is within 10 %
  // of the largest curve point distance seen so far cannot raise the maximum by more, so it is not
  // split; sub-arcs at max_depth or beyond the node budget keep their hull bound. Returns the largest
  // bound left: an upper bound of the arc's distance to [a, b].
  double bound(const Arc& arc) const {
    struct Node {
      double hull;
      int depth;
      Arc arc;
      bool operator<(const Node& o) const { return hull < o.hull; }
    };
    std::priority_queue<Node> open;
    open.push({hull_bound(arc), 0, arc});
    double seen = 0.0, settled = 0.0;
    int nodes = 0;
    while (!open.empty()) {
      Node n = open.top();
      open.pop();
      seen = std::max(seen, segment_distance(mapped_point(midpoint(n.arc)), a, b));
      if (!(n.hull > floor) || n.hull <= 1.1 * seen) return std::max(settled, n.hull);
      if (n.depth >= max_depth || nodes >= (map.identity ? kNodeBudget : kMappedNodeBudget)) {
        settled = std::max(settled, n.hull);
        continue;
      }
      auto [left, right] = halves(n.arc);
      nodes += 2;
      open.push({hull_bound(left), n.depth + 1, std::move(left)});
      open.push({hull_bound(right), n.depth + 1, std::move(right)});
    }
    return settled;
  }

  // Appends the end points (metric) of sub-arcs of `arc`, halved until each lies within `target` of
  // the segment between its own end points (or after kTraceDepth halvings); `deviation` gets the
  // largest such bound. The first sub-arc starts at the arc's first control point.
  void trace(const Arc& arc, int depth, double target, std::vector<Vec2>& points, double& deviation) const {
    const Vec2 s = mapped(euclid(arc.front())), e = mapped(euclid(arc.back()));
    const double h = hull_bound(arc, s, e);
    if (h <= target || depth >= kTraceDepth) {
      points.push_back(e);
      deviation = std::max(deviation, h);
      return;
    }
    auto [left, right] = halves(arc);
    trace(left, depth + 1, target, points, deviation);
    trace(right, depth + 1, target, points, deviation);
  }
};

}  // namespace

double circle_arc_parameter(const std::vector<double>& breaks, const std::vector<double>& arc_tan, double x) {
  if (breaks.size() < 2 || arc_tan.size() + 1 != breaks.size() || !(x >= breaks.front() && x <= breaks.back()))
    return x;
  const size_t k = std::min(static_cast<size_t>(std::upper_bound(breaks.begin(), breaks.end(), x) - breaks.begin()),
                            breaks.size() - 1) -
                   1;
  const double half = 0.5 * (breaks[k + 1] - breaks[k]), middle = breaks[k] + half;
  return middle + half * (std::tan(0.5 * (x - middle)) / arc_tan[k]);
}

double chord_deviation(const Handle(Geom2d_Curve) & pcurve, double p0, double p1, const ParameterMap& map,
                       const Vec2& a_uv, const Vec2& b_uv, ChordTrace* trace, double* overshoot, ChordSides* sides) {
  if (trace) *trace = ChordTrace{{a_uv, b_uv}, kInf};
  if (overshoot) *overshoot = kInf;
  if (sides) *sides = ChordSides{};
  const Vec2 a = map.metric * a_uv, b = map.metric * b_uv;
  const double scale = std::max({std::abs(a.x), std::abs(a.y), std::abs(b.x), std::abs(b.y)}) + glm::length(b - a);
  // The map's own error is part of every hull bound through it and no split removes it: the floor
  // is at least twice that (a chord on an iso-line would otherwise be split to the node budget).
  const double map_error = map.identity ? 0.0 : map.to_uv_error * std::max(map.metric.x, map.metric.y);
  const Bounder bounder{
      map, a, b, std::max(1e-9 * glm::length(b - a), 2.0 * map_error), map.identity ? 16 : kMappedDepth, {}, {}};
  const double rounding = 1e-13 * scale;
  try {
    if (p0 == p1) {
      const gp_Pnt2d q = pcurve->Value(p0);
      const double d = segment_distance(bounder.mapped(Vec2(q.X(), q.Y())), a, b) + map_error + rounding;
      if (trace) trace->deviation = d;
      return d;  // a point: no overshoot proven (the chord's ends are the point's neighbours)
    }
    // The piece's exact Bézier arcs (homogeneous poles); empty when a weight is not positive.
    const auto bezier_arcs = [&](double lo, double hi) {
      Handle(Geom2d_TrimmedCurve) piece = new Geom2d_TrimmedCurve(pcurve, lo, hi);
      const Handle(Geom2d_BSplineCurve) spline = Geom2dConvert::CurveToBSplineCurve(piece);
      Geom2dConvert_BSplineCurveToBezierCurve bezier(spline);
      std::vector<Arc> result;
      for (int k = 1; k <= bezier.NbArcs(); ++k) {
        const Handle(Geom2d_BezierCurve) arc = bezier.Arc(k);
        Arc h;
        for (int i = 1; i <= arc->NbPoles(); ++i) {
          const double w = arc->Weight(i);
          if (!(w > 0.0) || !std::isfinite(w)) return std::vector<Arc>{};
          const gp_Pnt2d q = arc->Pole(i);
          h.push_back(glm::dvec3(w * q.X(), w * q.Y(), w));
        }
        result.push_back(std::move(h));
      }
      return result;
    };
    // A piece a few 1e-10 of its parameter long (an edge split near a seam or a vertex) is below
    // OCCT's parameter confusion: its trimming or its Bézier split throws. Then a wider piece around
    // it, inside the curve's range, is bounded instead: it holds the piece's points, so its deviation,
    // overshoot and sides bound the piece's; the chord is its own trace then.
    double lo = std::min(p0, p1), hi = std::max(p0, p1);
    bool widened = false;
    std::vector<Arc> arcs;
    try {
      arcs = bezier_arcs(lo, hi);
    } catch (const Standard_Failure&) {
      const double first = pcurve->IsPeriodic() ? -kInf : pcurve->FirstParameter();
      const double last = pcurve->IsPeriodic() ? kInf : pcurve->LastParameter();
      const double unit = 1e-8 * std::max(1.0, std::max(std::abs(lo), std::abs(hi)));
      if (!(hi - lo < unit)) throw;
      const double mid = 0.5 * (lo + hi);
      lo = std::max(first, mid - unit);
      hi = std::min(last, mid + unit);
      if (!(hi - lo > 0.5 * unit)) throw;
      arcs = bezier_arcs(lo, hi);
      widened = true;
    }
    if (arcs.empty()) return kInf;
    double deviation = 0.0;
    for (const Arc& h : arcs) deviation = std::max(deviation, bounder.bound(h));
    if (!std::isfinite(deviation)) return kInf;
    if (overshoot) {
      double beyond = 0.0;
      for (const Arc& h : arcs) beyond = std::max(beyond, bounder.overshoot(h));
      *overshoot = std::isfinite(beyond) ? beyond + rounding : kInf;
    }
    if (sides) {
      // The side the curve bulges to (that of its middle point) keeps the deviation (the curve lies
      // within it of the segment, so of its line); the other side is bounded by the hulls, to 1/64
      // of the deviation (as good as none for the certificate's terms).
      const Arc& middle = arcs[arcs.size() / 2];
      const Vec2 d = b - a, left(-d.y, d.x);
      const double bulge = glm::dot(bounder.mapped(midpoint(middle)) - a, left) >= 0.0 ? 1.0 : -1.0;
      double other = 0.0;
      for (const Arc& h : arcs) other = std::max(other, bounder.side(h, -bulge, deviation / 64.0));
      if (std::isfinite(other)) {
        const double bulging = deviation + rounding, opposite = std::min(other, deviation) + rounding;
        *sides = bulge > 0.0 ? ChordSides{bulging, opposite} : ChordSides{opposite, bulging};
      }
    }
    if (trace && (deviation <= bounder.floor || !map.identity || widened)) {
      // A straight curve, or one through a non-identity map (not traced: its iterative map would cost
      // up to 90 % more part tessellation time): the chord is its own trace.
      trace->deviation = deviation + rounding;
    } else if (trace && !arcs.empty()) {
      // Sub-arcs in increasing curve parameter; the polyline runs from a to b, so it is reversed when
      // p0 > p1. Its ends are moved onto a and b, and consecutive Bézier pieces may meet a rounding
      // apart: those moves are added to the bound (the distance to a segment moves by at most the
      // move of its end points).
      std::vector<Vec2> points{bounder.mapped(euclid(arcs.front().front()))};
      double bound = 0.0, joins = 0.0;
      for (const Arc& h : arcs) {
        joins = std::max(joins, glm::length(bounder.mapped(euclid(h.front())) - points.back()));
        bounder.trace(h, 0, deviation / 32.0, points, bound);
      }
      if (p0 > p1) std::reverse(points.begin(), points.end());
      joins = std::max({joins, glm::length(points.front() - a), glm::length(points.back() - b)});
      points.front() = a, points.back() = b;
      trace->points.clear();
      for (const Vec2& q : points) trace->points.push_back(q / map.metric);
      trace->points.front() = a_uv, trace->points.back() = b_uv;
      // Metric <-> (U, V) divisions round each point by a few units of `scale`.
      trace->deviation = bound + joins + 2.0 * rounding;
      if (!std::isfinite(trace->deviation)) *trace = ChordTrace{{a_uv, b_uv}, kInf};
    }
    return deviation + rounding;
  } catch (const Standard_Failure&) {
    return kInf;
  }
}

}  // namespace sagitta::occt::detail
