// Validation of a mesh against its patch model: the certified distance interval and the mesh
// topology verdict, as one result and one JSON report (`sagitta validate --json`, Python's validate).
#pragma once

#include "sagitta/certify.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace sagitta::app {

struct ValidationOptions {
  int max_depth = 8;            // subdivision budget per triangle (CertifyOptions::max_depth)
  int reference_segments = 32;  // a mesh without (u, v): segments of the certified reference tessellation
};

struct Validation {
  std::string method;  // "bernstein" (the mesh has (u, v)) | "reference" (certify_external)
  DistanceReport distance;
  TopologyReport topology;
  double distance_seconds = 0.0;
  double topology_seconds = 0.0;
  double seconds = 0.0;  // wall clock of both (they run side by side)
};

// Bytes a validation needs beyond the mesh, for the memory guard (sagitta/budget.hpp): the
// certificate's per-triangle bounds and per-patch lists, and the topology check's edge maps.
// Generous: the teapot at level 7 measured about 380 bytes per triangle (Python's validate, its
// arrays included), a whole part's certify_part about 250.
inline double validation_bytes(double triangles) { return 512.0 * triangles; }

// Certifies `mesh` against `model` (certify_distance when the mesh has (u, v), else certify_external
// through a uniform reference of options.reference_segments) and checks its topology. Throws
// MemoryLimitExceeded before starting when validation_bytes exceeds the memory limit.
Validation validate_mesh(const Model& model, const Topology& topology, const Tessellation& mesh,
                         const ValidationOptions& options);

// The report fields: method, the three distance intervals, certified, coverage, the depth budget,
// the mesh topology and the model topology, counts and seconds.
nlohmann::json validation_json(const Model& model, const Topology& topology, const Tessellation& mesh,
                               const ValidationOptions& options, const Validation& validation);

}  // namespace sagitta::app
