// Internal: keeps the validator's floating-point arithmetic in the range where its rounding terms
// hold. Squares of coordinates, CGAL's predicates (degree <= 6 in the coordinates) and the weighted
// control points w (P - o) must neither overflow nor underflow; a model with coordinates near 1e110,
// weights near 1e-200 or coordinates near 1e-300 breaks that (a sum of squares underflows to 0 and a
// bound collapses below the truth; CGAL's exact fallback is handed an infinity).
//
// Multiplying every coordinate by one power of two, and each rational patch's weights by another,
// changes no surface (the weights' common factor cancels) and scales every distance by exactly that
// power: bounds computed on the rescaled model, multiplied back, are bounds for the original. Where
// no exact rescaling brings the numbers into range (a rescaled value would round, or one patch's
// weights span more than kMaxWeightSpan), the answer is "not certified", with the reason.
#pragma once

#include "sagitta/certify.hpp"

#include <functional>
#include <string>

namespace sagitta::detail {

// A patch whose largest and smallest weights differ by more than this factor is not certified: the
// bounds divide by the smallest weight and the rounding terms would no longer cover the products.
inline constexpr double kMaxWeightSpan = 1e60;

// Runs `certify` on the model and mesh, rescaled by powers of two when their magnitudes leave the
// safe range (otherwise on the originals, unchanged), and returns its report in the original units
// after check_distance_report(). A mesh vertex that is not finite, or a model that cannot be rescaled
// exactly, gives a report with no certified upper bound and the reason in not_certified_reason.
DistanceReport with_safe_arithmetic(const Model& model, const Tessellation& mesh,
                                    const std::function<DistanceReport(const Model&, const Tessellation&)>& certify);

// The same for a certified lower bound of the distance from x to the model (0 when not certifiable);
// `lower` gets the factor (a power of two) by which distances were scaled, for its targets.
double lower_with_safe_arithmetic(const Model& model, const Vec3& x,
                                  const std::function<double(const Model&, const Vec3&, double)>& lower);



}  // namespace sagitta::detail
