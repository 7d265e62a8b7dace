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
};

// Certifies `mesh` against `model` (certify_distance when the mesh has (u, v), else certify_external
// through a uniform reference of options.reference_segments) and checks its topology.
Validation validate_mesh(const Model& model, const Topology& topology, const Tessellation& mesh,
                         const ValidationOptions& options);

// The report fields: method, the three distance intervals, certified, coverage, the depth budget,
// the mesh topology and the model topology, counts and seconds.
nlohmann::json validation_json(const Model& model, const Topology& topology, const Tessellation& mesh,
                               const ValidationOptions& options, const Validation& validation);

}  // namespace sagitta::app
