// Certified distances between a tessellation and the exact Bézier surfaces of its model.
//
// Every interval [lower, upper] returned here satisfies lower <= true distance <= upper, with
// floating-point rounding accounted for by an explicit additive term (see docs/VALIDATION.md).
// Models far from unit size (coordinates like 1e110 or 1e-300, weights like 1e-200) are rescaled
// by exact powers of two first; where that cannot make the arithmetic safe, the upper bounds are
// not certified and DistanceReport::not_certified_reason says why. lower <= upper and the absence
// of NaN are checked before any report is returned.
// A bound that could not be certified (for example surface->mesh when the triangles' (u, v) do not
// cover a patch's domain) has certified == false and upper = +infinity.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace sagitta {

struct DistanceInterval {
  double lower = 0.0;
  double upper = std::numeric_limits<double>::infinity();
  bool certified = false;  // upper is a proven bound (lower always is)
  // Where the lower bound was attained (a mesh point for mesh->surface, a surface point for
  // surface->mesh); patch = -1 when unknown.
  Vec3 witness{0.0};
  int64_t witness_patch = -1;
  double width() const { return upper - lower; }
  double ratio() const { return lower > 0.0 ? upper / lower : std::numeric_limits<double>::infinity(); }
};

struct CertifyOptions {
  // Subdivide a triangle's barycentric domain (4-split) while its bound exceeds
  // target_ratio * (current lower estimate), down to max_depth levels (4^max_depth leaves).
  double target_ratio = 1.05;
  int max_depth = 8;
  // A triangle whose bound is at most this fraction of the model's box diagonal is not refined
  // further: its bound stands (still proven, only looser than it could be). 0: no floor beyond the
  // rounding level (1e-12).
  double refine_floor = 0.0;
  // Number of worst candidate points per direction whose distance is certified for the lower bounds.
  int lower_candidates = 24;
  // Node budget of the branch-and-bound that certifies d(x, S) from below, per candidate point.
  int lower_node_budget = 200000;
  // Restricted domain (a trimmed face, docs/CAD.md): when set, only surface points S(patch, u, v)
  // with in_domain(patch, (u, v)) true belong to the surface. The caller vouches that each
  // triangle's (u, v) lies in the domain (or reports the bound as not certified); the validator then
  //  - bounds mesh->surface with the triangle's own (u, v) only (no matching by projection or to
  //    other patches, whose (u, v) could leave the domain),
  //  - takes surface->mesh lower-bound witnesses only where in_domain is true,
  //  - does not claim coverage: surface_to_mesh stays uncertified, and the bound over the surface
  //    points above the triangles' (u, v) is given in DistanceReport::surface_to_mesh_over_triangles
  //    (certified by the caller when it proves the triangles cover the domain).
  // Called from several threads at once: it must be thread safe.
  std::function<bool(uint32_t patch, Vec2 uv)> in_domain;
  // With in_domain: the domain contains every patch whole (an untrimmed face cut along its patch
  // grid; in_domain then only keeps lower-bound witnesses off the boundary). Mesh->surface may then
  // match a triangle to its corners' projections onto its own patch (a (u, v) triangle inside the
  // patch lies in the domain) and a leaf to its neighbouring patches, as without in_domain; the
  // other restrictions stay.
  bool domain_contains_patches = false;
  // With in_domain (and not domain_contains_patches): how far the surface over the box [lo, hi] of
  // patch `patch`'s (u, v) may be from the surface over the domain: 0 only when every point of the
  // box belongs to the domain; a finite m when every point p of the box has a point p' of the
  // domain with |S(p) - S(p')| <= m; +infinity when neither is known. `inside` is a point of the box
  // that lies in a mesh triangle's own (u, v) (the centroid of a leaf). Mesh->surface may then match
  // a leaf to its corners' projections onto its own patch, adding m, where the box of the leaf's
  // (u, v) and the projections is vouched for (a re-parametrised cone's triangle, whose own-(u, v)
  // bound slides along the surface). Thread safe, as in_domain.
  std::function<double(uint32_t patch, const Vec2& lo, const Vec2& hi, const Vec2& inside)> box_in_domain;
};

struct DistanceReport {
  DistanceInterval mesh_to_surface;
  DistanceInterval surface_to_mesh;
  DistanceInterval hausdorff;
  std::vector<double> triangle_upper;  // per triangle: max of both directions' bounds over it
  bool coverage_ok = false;            // every patch's domain is covered by the triangles' (u, v)
  std::string coverage_note;           // why coverage failed, when it did
  // Why no upper bound is certified although the mesh covers the surface: the arithmetic cannot
  // guarantee one (weights or coordinates beyond what an exact rescaling brings into range, a
  // non-finite vertex) or a final consistency check failed. Empty otherwise.
  std::string not_certified_reason;
  // With CertifyOptions::in_domain: max over the triangles of the surface->mesh bound of the surface
  // points above the triangle's (u, v); +infinity otherwise.
  double surface_to_mesh_over_triangles = std::numeric_limits<double>::infinity();
  uint64_t holes = 0;                  // dropped degenerate (u, v) triangles reconstructed at collapsed sides
  double rounding = 0.0;               // the largest rounding term added to any triangle's bound
  uint64_t leaves = 0;                 // sub-triangles evaluated in total
  uint64_t budget_exhausted = 0;       // triangles still above the target at max_depth
  double seconds = 0.0;
};

// The last check before a report is shown: no NaN anywhere, lower >= 0, and an upper bound that is
// not finite or lies below its own lower bound is withdrawn (certified = false, upper = +infinity,
// the reason in not_certified_reason). The Hausdorff interval is recomputed from the two directions.
// certify_distance and certify_external apply it; a caller that edits a report applies it again.
void check_distance_report(DistanceReport& report);

// Certified distance for a tessellation that carries triangle_patch and triangle_uv (our schemes).
// Upper bounds: per triangle, the Bernstein coefficients of S(phi(b)) - X(b) over sub-triangles,
// where phi, X are affine (either the triangle's own (u, v), or corners matched by projection),
// bound the error by the convex hull property. Lower bounds: exact distances at candidate points
// certified by branch-and-bound (mesh->surface) and by an AABB tree on the mesh (surface->mesh).
// Throws InputError when the tessellation has no surface data or refers to a missing patch.
DistanceReport certify_distance(const Model& model, const Tessellation& mesh, const CertifyOptions& options = {});

// Upper bound of max over the triangle of |S(sum b_i q_i) - sum b_i X_i| (q_i in the patch's
// domain), from the Bernstein form of the composition (degree n + m, or n + m + 1 for rational
// patches), rounding included. The scene planner uses it to bound a patch's error at a level.
double affine_error_bound(const BezierPatch& patch, const Vec2 q[3], const Vec3 X[3]);

// Certified distance for a mesh without (u, v) (an STL, OCCT's BRepMesh output). A uniform
// reference tessellation R is certified first (eps_ref per direction); then CGAL's
// bounded_error_Hausdorff_distance gives h(M->R) and h(R->M) within a stated error e, and
//   mesh->surface <= h(M->R) + e + eps_ref(R->S),   surface->mesh <= h(R->M) + e + eps_ref(S->R)
// (triangle inequality). Lower bounds: mesh points farthest from R certified against S by
// branch-and-bound; exact surface samples against M by an AABB tree. Throws InputError for an
// empty mesh.
struct ExternalOptions {
  int reference_segments = 32;   // uniform segments per patch side of the reference tessellation
  int surface_samples = 64;      // samples per patch side for surface->mesh
  // The work limit of each CGAL Hausdorff distance between the mesh and the reference, in vertex
  // reads: the larger of the two (past it that direction is not certified). Measured: 200 to 320
  // reads per triangle of both meshes on the teapot at levels 2 and 4; 402 overlapping triangles on
  // a flat square reach 20M reads in 1.5 s and 36 MB.
  uint64_t hausdorff_min_reads = 20'000'000;
  uint64_t hausdorff_reads_per_triangle = 2000;
  CertifyOptions certify;
};
DistanceReport certify_external(const Model& model, const Tessellation& mesh, const ExternalOptions& options = {});

// Per point: a proven lower bound of its distance to the mesh's triangles (CGAL's AABB distance less
// its rounding bound; 0 for a point that is not finite). For lower-bound witnesses the caller knows
// to lie on the surface (a trimmed face's boundary curve, for instance).
std::vector<double> distance_lower_bounds(const Tessellation& mesh, const std::vector<Vec3>& points);

namespace detail {

// Used by certify_distance and certify_external, exported for tests: a value <= the distance from x
// to the union of all patches of the model, tightened by branch-and-bound towards `target` (it never
// exceeds target). Spends at most node_budget nodes.
double certified_distance_lower(const Model& model, const Vec3& x, double target, int node_budget);

}  // namespace detail

}  // namespace sagitta
