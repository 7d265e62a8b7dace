// Proven bounds on how far a face's trimming curve leaves the chords the part mesher draws between
// its shared edge samples (docs/CAD.md, "Certificate of whole parts"). The certificate of a trimmed
// face needs, for every chord, a number delta with: every point of the trimming curve between the
// chord's two samples lies within delta of the chord segment, in the face's patch parameters (U, V).
#pragma once

#include "sagitta/patch.hpp"

#include <Geom2d_Curve.hxx>

#include <functional>
#include <limits>
#include <vector>

namespace sagitta::occt::detail {

// The map from a p-curve's coordinates (u, v) (OCCT's surface parameters, periodic shift included)
// to the patches' (U, V). `identity`: (U, V) = (u, v) (B-spline, Bézier and plane faces);
// otherwise the map is separable and monotone in each coordinate (OCCT's conversion of circles:
// U depends on u only, V on v only), evaluated by `to_uv`.
struct ParameterMap {
  bool identity = true;
  Vec2 shift{0.0};  // added to (u, v) first (whole periods)
  std::function<Vec2(const Vec2&)> to_uv;  // of the shifted (u, v); unused when identity
  double to_uv_error = 0.0;                // bound on to_uv's own error (an iterative solve)
  Vec2 metric{1.0};  // distances are measured with U scaled by metric.x and V by metric.y
};

// The B-spline parameter of the point at angle x on OCCT's conversion of a circle parametrised by its
// angle (Convert_TgtThetaOver2): rational quadratic arcs with knots at the angles `breaks`, span k of
// half width a (arc_tan[k] = tan(a / 2)) and weights 1, cos a, 1. With m the span's middle,
// tan((x - m) / 2) = t tan(a / 2) at the arc's parameter t in [-1, 1]. Exact up to rounding; x itself
// outside the breaks.
double circle_arc_parameter(const std::vector<double>& breaks, const std::vector<double>& arc_tan, double x);

// Upper bound of max over p in [p0, p1] of dist(map(pcurve(p)), segment [a, b]) (both scaled by
// map.metric), from the convex hull of the curve's Bézier pieces (OCCT's exact conversion; rational
// pieces need positive weights), split best-first until the largest hull is within 10 % of the
// largest curve point distance seen (or a depth / node budget is spent). Through a non-identity map
// each piece's (u, v) box is mapped corner by corner (monotone coordinates). +infinity when the
// curve cannot be converted or has a non-positive weight.
//
// With `trace`: also a finer polyline along the same curve piece, from a_uv to b_uv in (U, V), and a
// proven bound (same metric) such that the curve's sub-arc between consecutive points lies within
// it of the segment between them. Sub-arcs are halved (de Casteljau, no further OCCT call) until
// each bound is at most 1/32 of the chord's deviation (or 8 halvings per Bézier piece). A curve
// within the straight-curve floor of its chord (1e-9 of its length), or through a non-identity
// map, is traced by the chord itself (its deviation); left with the two end points and +infinity
// when the deviation is not proven.
struct ChordTrace {
  std::vector<Vec2> points;
  double deviation = std::numeric_limits<double>::infinity();
};
// With `overshoot`: also a proven bound (same metric) on how far the curve's points project beyond
// the segment's ends along it (0 when none does; +infinity when not proven or the chord has no
// length), from the same hulls, halved near the ends (at most 12 times).
// With `sides`: also proven bounds (same metric) on how far the curve's points lie to the left and
// to the right of the line through a and b (left: +90 degrees from b - a; +infinity when not
// proven): the deviation on the side the curve's middle point lies on, and on the other side a
// bound from the same hulls, halved where they touch or cross the line (0 when the curve does not
// reach it).
struct ChordSides {
  double left = std::numeric_limits<double>::infinity(), right = std::numeric_limits<double>::infinity();
};
double chord_deviation(const Handle(Geom2d_Curve) & pcurve, double p0, double p1, const ParameterMap& map,
                       const Vec2& a_uv, const Vec2& b_uv, ChordTrace* trace = nullptr, double* overshoot = nullptr,
                       ChordSides* sides = nullptr);

}  // namespace sagitta::occt::detail
