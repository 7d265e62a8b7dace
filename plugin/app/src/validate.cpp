#include "sagitta/app/validate.hpp"

#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"
#include "sagitta/budget.hpp"

#include <tbb/parallel_invoke.h>

namespace sagitta::app {

Validation validate_mesh(const Model& model, const Topology& topology, const Tessellation& mesh,
                         const ValidationOptions& options) {
  budget::check_memory(validation_bytes(double(mesh.triangles.size())),
                       "validating " + std::to_string(mesh.triangles.size()) + " triangles",
                       "lower --level or raise --max-memory");
  Validation v;
  const Stopwatch clock;
  CertifyOptions certify;
  certify.max_depth = options.max_depth;
  // The certificate (parallel inside) and the topology checks (one thread) run side by side.
  tbb::parallel_invoke(
      [&] {
        const Stopwatch distance_clock;
        if (mesh.has_surface()) {
          v.distance = certify_distance(model, mesh, certify);
          v.method = "bernstein";
        } else {
          ExternalOptions external;
          external.reference_segments = options.reference_segments;
          external.certify = certify;
          v.distance = certify_external(model, mesh, external);
          v.method = "reference";
        }
        v.distance_seconds = distance_clock.seconds();
      },
      [&] {
        const Stopwatch topo_clock;
        v.topology = check_mesh_topology(mesh, &model, &topology);
        v.topology_seconds = topo_clock.seconds();
      });
  v.seconds = clock.seconds();
  return v;
}

nlohmann::json validation_json(const Model& model, const Topology& topology, const Tessellation& mesh,
                               const ValidationOptions& options, const Validation& v) {
  const DistanceReport& distance = v.distance;
  nlohmann::json doc;
  doc["method"] = v.method;
  if (v.method == "reference") doc["reference_segments"] = options.reference_segments;
  doc["patches"] = model.patches.size();
  doc["triangles"] = mesh.triangles.size();
  doc["vertices"] = mesh.positions.size();
  doc["dropped_degenerate_triangles"] = mesh.degenerate_triangles;
  doc["hausdorff"] = interval_json(distance.hausdorff);
  doc["mesh_to_surface"] = interval_json(distance.mesh_to_surface);
  doc["surface_to_mesh"] = interval_json(distance.surface_to_mesh);
  doc["certified"] = distance.hausdorff.certified;
  doc["coverage_ok"] = distance.coverage_ok;
  if (!distance.coverage_note.empty()) doc["coverage_note"] = distance.coverage_note;
  if (!distance.not_certified_reason.empty()) doc["not_certified_reason"] = distance.not_certified_reason;
  doc["rounding_term"] = distance.rounding;
  doc["subtriangles"] = distance.leaves;
  doc["triangles_at_depth_budget"] = distance.budget_exhausted;
  doc["max_depth"] = options.max_depth;
  doc["topology"] = topology_report_json(v.topology);
  doc["model_topology"] = topology_json(model, topology);
  doc["distance_seconds"] = v.distance_seconds;
  doc["topology_seconds"] = v.topology_seconds;
  doc["seconds"] = v.seconds;  // wall clock: the two run side by side
  return doc;
}

}  // namespace sagitta::app
