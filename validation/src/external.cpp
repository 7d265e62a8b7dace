// Certified distance for meshes without (u, v): a certified reference tessellation and CGAL's
// bounded-error Hausdorff distance between the meshes (see certify.hpp and docs/VALIDATION.md).
#include "sagitta/certify.hpp"

#include "conditioning.hpp"
#include "mesh_distance.hpp"
#include "sagitta/budget.hpp"
#include "sagitta/evaluate.hpp"
#include "sagitta/scheme.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Surface_mesh.h>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

namespace sagitta {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<K::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;
constexpr double kUnit = std::numeric_limits<double>::epsilon() / 2;

// Every non-degenerate triangle with its own three vertices: a face soup always forms a valid
// Surface_mesh, whatever the input's connectivity (non-manifold edges included).
SurfaceMesh to_surface_mesh(const Tessellation& mesh) {
  SurfaceMesh sm;
  for (const Triangle& t : mesh.triangles) {
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const K::Point_3 pa(a.x, a.y, a.z), pb(b.x, b.y, b.z), pc(c.x, c.y, c.z);
    if (CGAL::collinear(pa, pb, pc)) continue;  // zero area: bounded apart (zero_area_to_reference)
    sm.add_face(sm.add_vertex(pa), sm.add_vertex(pb), sm.add_vertex(pc));
  }
  return sm;
}

// An upper bound of the distance from the points of the mesh's zero-area triangles (left out of the
// CGAL meshes) to the reference R. Such a triangle is the segment between its two farthest corners;
// the distance to R is 1-Lipschitz, so over a piece of length h it exceeds its value at the piece's
// midpoint by at most h / 2. Branch and bound: the piece with the largest such bound is halved until
// that bound is within max(resolution, 1e-9 x the largest midpoint value) of the largest midpoint
// value seen, or 4096 distances were taken on the segment. (Even pieces of at most 2 x resolution
// took 4096 distances per segment wherever a vertex lay far out, each with CGAL's exact fallback:
// 10 s under the fuzzers' sanitizers for three such segments.)
double zero_area_to_reference(const Tessellation& mesh, const detail::MeshDistance& reference, double resolution) {
  std::vector<std::array<Vec3, 2>> segments;
  for (const Triangle& t : mesh.triangles) {
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    if (!CGAL::collinear(K::Point_3(a.x, a.y, a.z), K::Point_3(b.x, b.y, b.z), K::Point_3(c.x, c.y, c.z))) continue;
    std::array<Vec3, 2> s{a, b};
    if (glm::length(c - a) > glm::length(s[1] - s[0])) s = {a, c};
    if (glm::length(c - b) > glm::length(s[1] - s[0])) s = {b, c};
    segments.push_back(s);
  }
  std::vector<double> worst(segments.size(), 0.0);
  tbb::parallel_for(size_t(0), segments.size(), [&](size_t k) {
    const Vec3 p = segments[k][0], q = segments[k][1];
    const double length = glm::length(q - p);
    struct Piece {
      double t0, t1, at_mid, bound;
      bool operator<(const Piece& o) const { return bound < o.bound; }
    };
    const auto measure = [&](double t0, double t1) {
      const Vec3 mid = p + (0.5 * (t0 + t1)) * (q - p);
      const double d = reference.distance(mid) + reference.rounding_bound(mid);
      return Piece{t0, t1, d, d + 0.5 * (t1 - t0) * length * (1.0 + 8.0 * kUnit)};
    };
    std::vector<Piece> heap{measure(0.0, 1.0)};
    double seen = heap.front().at_mid;
    for (int taken = 1; taken + 2 <= 4096;) {
      const Piece top = heap.front();
      if (top.bound <= seen + std::max(resolution, 1e-9 * seen)) break;
      std::pop_heap(heap.begin(), heap.end());
      heap.pop_back();
      const double mid = 0.5 * (top.t0 + top.t1);
      for (const Piece& half : {measure(top.t0, mid), measure(mid, top.t1)}) {
        seen = std::max(seen, half.at_mid);
        heap.push_back(half);
        std::push_heap(heap.begin(), heap.end());
      }
      taken += 2;
    }
    worst[k] = heap.front().bound;
  });
  return segments.empty() ? 0.0 : *std::max_element(worst.begin(), worst.end());
}

// CGAL's bounded-error Hausdorff distance has no work limit of its own: on overlapping faces its
// candidate queue grew to 3.4 GB. It reads every vertex position through the vertex point map, so
// this map counts those reads (a measure of its work, and of the queue it can have built) and
// checks the run's budget; past `limit` reads it throws WorkLimitReached.
struct WorkLimitReached {};
struct WorkCounter {
  uint64_t reads = 0;
  uint64_t limit = 0;
};
struct CountedPoints {
  using key_type = SurfaceMesh::Vertex_index;
  using value_type = K::Point_3;
  using reference = const K::Point_3&;
  using category = boost::readable_property_map_tag;
  const SurfaceMesh* mesh = nullptr;
  WorkCounter* counter = nullptr;
  friend reference get(const CountedPoints& map, key_type v) {
    if ((++map.counter->reads & 0xFFFFu) == 0) {
      budget::check("the mesh Hausdorff distance");
      if (map.counter->reads > map.counter->limit) throw WorkLimitReached{};
    }
    return map.mesh->point(v);
  }
};

// One-sided bounded-error Hausdorff distance from a to b, or +infinity when it needed more work
// than the limit (then nothing is claimed about it).
double bounded_hausdorff(const SurfaceMesh& a, const SurfaceMesh& b, double error_bound,
                         const ExternalOptions& options) {
  WorkCounter counter;
  counter.limit = std::max<uint64_t>(
      options.hausdorff_min_reads, options.hausdorff_reads_per_triangle * (a.number_of_faces() + b.number_of_faces()));
  try {
    return PMP::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(
        a, b, error_bound, CGAL::parameters::vertex_point_map(CountedPoints{&a, &counter}),
        CGAL::parameters::vertex_point_map(CountedPoints{&b, &counter}));
  } catch (const WorkLimitReached&) {
    return std::numeric_limits<double>::infinity();
  }
}

// The coarsest error bound tried, relative to the model's box diagonal.
constexpr double kCoarsestRelativeError = 1e-3;

// An upper bound of the one-sided Hausdorff distance from a to b: CGAL's value within `error_bound`
// plus that bound. Where that needs more work than the limit (CGAL refines a face that straddles
// edges of coplanar faces until its pieces are smaller than the error bound, so a mesh lying exactly
// in a planar reference costs about length / error_bound), it is tried once more with the error
// bound `coarse`; +infinity when that fails too.
double hausdorff_upper(const SurfaceMesh& a, const SurfaceMesh& b, double error_bound, double coarse,
                       const ExternalOptions& options) {
  const double fine = bounded_hausdorff(a, b, error_bound, options);
  if (std::isfinite(fine) || !(coarse > error_bound)) return fine + error_bound;
  return bounded_hausdorff(a, b, coarse, options) + coarse;
}

// Mesh -> surface lower bound: the mesh points farthest from the reference (vertices, edge
// midpoints, centroids), certified against the exact surface by branch-and-bound.
void mesh_to_surface_lower(const Model& model, const Tessellation& mesh, const detail::MeshDistance& to_reference,
                           double eps_m2s, const ExternalOptions& options, DistanceReport& report) {
  std::vector<Vec3> points;
  for (const Triangle& t : mesh.triangles) {
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    points.push_back((a + b + c) / 3.0);
    points.push_back(0.5 * (a + b));
    points.push_back(a);
  }
  std::vector<double> d(points.size());
  tbb::parallel_for(size_t(0), points.size(), [&](size_t i) { d[i] = to_reference.distance(points[i]); });
  const size_t k = std::min<size_t>(static_cast<size_t>(std::max(options.certify.lower_candidates, 1)), points.size());
  std::vector<size_t> order(points.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::partial_sort(order.begin(), order.begin() + static_cast<long>(k), order.end(),
                    [&](size_t a, size_t b) { return d[a] > d[b]; });
  std::vector<double> low(k);
  tbb::parallel_for(size_t(0), k, [&](size_t i) {
    const size_t j = order[i];
    low[i] = detail::certified_distance_lower(model, points[j], d[j] + eps_m2s, options.certify.lower_node_budget);
  });
  for (size_t i = 0; i < k; ++i) {
    if (low[i] > report.mesh_to_surface.lower) {
      report.mesh_to_surface.lower = low[i];
      report.mesh_to_surface.witness = points[order[i]];
    }
  }
}

// Surface -> mesh lower bound: exact surface samples against the mesh (AABB tree), minus rounding.
void surface_to_mesh_lower(const Model& model, const detail::MeshDistance& to_mesh, double rounding,
                           const ExternalOptions& options, DistanceReport& report) {
  const int n = std::max(options.surface_samples, 1);
  for (uint32_t p = 0; p < model.patches.size(); ++p) {
    const BezierPatch& patch = model.patches[p];
    std::vector<double> best(static_cast<size_t>((n + 1) * (n + 1)));
    std::vector<Vec3> where(best.size());
    tbb::parallel_for(0, (n + 1) * (n + 1), [&](int s) {
      const auto e = de_casteljau<double>(patch, double(s / (n + 1)) / n, double(s % (n + 1)) / n);
      const Vec3 x(e[0], e[1], e[2]);
      where[s] = x;
      best[s] = std::max(0.0, to_mesh.distance(x) - to_mesh.rounding_bound(x) - rounding);
    });
    for (size_t s = 0; s < best.size(); ++s) {
      if (best[s] > report.surface_to_mesh.lower) {
        report.surface_to_mesh.lower = best[s];
        report.surface_to_mesh.witness = where[s];
        report.surface_to_mesh.witness_patch = p;
      }
    }
  }
}

DistanceReport certify_external_conditioned(const Model& model, const Tessellation& mesh,
                                            const ExternalOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  DistanceReport report;
  // Reference: uniform tessellation with its own certified interval.
  const Topology topology = build_topology(model);
  SchemeSpec reference_spec;
  reference_spec.segments = options.reference_segments;
  reference_spec.guard = false;  // as the kernel alone: no front end's size guard
  const Tessellation reference = tessellate(model, topology, reference_spec);
  const DistanceReport ref = certify_distance(model, reference, options.certify);
  const double eps_m2s = ref.mesh_to_surface.upper;  // every reference point is this close to S
  const double eps_s2m = ref.surface_to_mesh.upper;  // every surface point is this close to the reference
  const SurfaceMesh sm = to_surface_mesh(mesh), sr = to_surface_mesh(reference);
  if (sm.number_of_faces() == 0) throw InputError("validate: every triangle of the mesh is degenerate");
  const double diag = model_box(model).diagonal();
  const double error_bound = std::max(0.02 * std::max(eps_m2s, eps_s2m), 1e-9 * diag);
  // Mesh -> reference and reference -> mesh, each within error_bound of the true one-sided value.
  const double coarse = kCoarsestRelativeError * diag;
  const double h_mr = hausdorff_upper(sm, sr, error_bound, coarse, options);
  const double h_rm = hausdorff_upper(sr, sm, error_bound, coarse, options);
  const double rounding = 64.0 * kUnit * diag;
  const detail::MeshDistance to_reference(reference), to_mesh(mesh);
  const double h_zero_area = zero_area_to_reference(mesh, to_reference, error_bound);
  report.mesh_to_surface.upper = std::max(h_mr, h_zero_area + error_bound) + eps_m2s + rounding;
  report.mesh_to_surface.certified = ref.mesh_to_surface.certified && std::isfinite(h_mr);
  report.surface_to_mesh.upper = h_rm + eps_s2m + rounding;
  report.surface_to_mesh.certified = ref.surface_to_mesh.certified && std::isfinite(h_rm);
  report.coverage_ok = ref.coverage_ok;
  report.coverage_note = ref.coverage_note;
  report.not_certified_reason = ref.not_certified_reason;
  if (!std::isfinite(h_mr) || !std::isfinite(h_rm)) {
    report.not_certified_reason += std::string(report.not_certified_reason.empty() ? "" : "; ") +
                                   "the mesh Hausdorff distance needed more work than its limit (overlapping or "
                                   "degenerate faces?)";
  }
  report.rounding = rounding;
  report.leaves = ref.leaves;

  // Lower bounds.
  mesh_to_surface_lower(model, mesh, to_reference, eps_m2s, options, report);
  surface_to_mesh_lower(model, to_mesh, rounding, options, report);
  report.hausdorff.lower = std::max(report.mesh_to_surface.lower, report.surface_to_mesh.lower);
  report.hausdorff.upper = std::max(report.mesh_to_surface.upper, report.surface_to_mesh.upper);
  report.hausdorff.certified = report.mesh_to_surface.certified && report.surface_to_mesh.certified;
  const bool m2s_wins = report.mesh_to_surface.lower >= report.surface_to_mesh.lower;
  report.hausdorff.witness = m2s_wins ? report.mesh_to_surface.witness : report.surface_to_mesh.witness;
  report.hausdorff.witness_patch = m2s_wins ? -1 : report.surface_to_mesh.witness_patch;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace

DistanceReport certify_external(const Model& model, const Tessellation& mesh, const ExternalOptions& options) {
  if (mesh.triangles.empty()) throw InputError("validate: the mesh has no triangles");
  return detail::with_safe_arithmetic(model, mesh, [&](const Model& m, const Tessellation& t) {
    return certify_external_conditioned(m, t, options);
  });
}

}  // namespace sagitta
