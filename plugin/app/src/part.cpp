#include "sagitta/app/part.hpp"

#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"
#include "sagitta/occt/cad.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sagitta::app {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

occt::PartOptions part_options(const SchemeSpec& scheme, double edge_tolerance) {
  if (!(edge_tolerance >= 0.0) || !std::isfinite(edge_tolerance)) {
    throw InputError("the edge tolerance must be a finite number >= 0, got " + std::to_string(edge_tolerance));
  }
  occt::PartOptions options;
  options.scheme = scheme;
  options.edge_tolerance = edge_tolerance;
  return options;
}

nlohmann::json part_json(const occt::PartMesh& part) {
  nlohmann::json j;
  j["faces"] = part.faces.size();
  j["faces_tessellated"] = part.faces_tessellated;
  j["faces_skipped"] = part.faces_skipped;
  j["faces_trimmed"] = part.faces_trimmed;
  j["bezier_patches"] = part.model.patches.size();
  j["edges"] = part.edges;
  j["edge_vertices"] = part.edge_vertices;
  j["triangles"] = part.mesh.triangles.size();
  j["vertices"] = part.mesh.positions.size();
  j["boundary_edges"] = part.boundary_edges.size();
  j["seconds"] = part.seconds;
  nlohmann::json skipped = nlohmann::json::array(), faces = nlohmann::json::array(), solids = nlohmann::json::array();
  for (const occt::PartFace& f : part.faces) {
    if (f.status == "skipped") skipped.push_back({{"face", f.name}, {"surface", f.surface_type}, {"reason", f.reason}});
    faces.push_back({{"face", f.name},
                     {"surface", f.surface_type},
                     {"trimmed", f.trimmed},
                     {"solid", f.solid},
                     {"status", f.status},
                     {"reason", f.reason},
                     {"segments", f.segments},
                     {"grid", {f.segments_u, f.segments_v}},
                     {"triangles", f.triangles},
                     {"scheme_triangles", f.scheme_triangles},
                     {"max_boundary_offset", f.max_boundary_offset}});
    if (f.graded_u > 0)
      faces.back()["graded_grid"] = {f.graded_u, f.graded_v}, faces.back()["graded_segments"] = f.graded_segments;
  }
  for (const occt::PartSolid& s : part.solids) {
    solids.push_back({{"solid", s.index},
                      {"closed", s.closed},
                      {"valid", s.valid},
                      {"volume", s.volume},
                      {"faces", s.faces},
                      {"triangles", s.triangles}});
  }
  j["skipped"] = skipped;
  j["face_list"] = faces;
  j["solids"] = solids;
  return j;
}

PartValidation validate_part(const occt::PartMesh& part, const SolidCheckOptions& options) {
  const Stopwatch clock;
  PartValidation v;
  v.checks = check_solids(part.mesh, part.triangle_solid, part.boundary_edges, options);
  for (const SolidCheck& c : v.checks) {
    v.crack_edges += c.crack_edges;
    v.t_junctions += c.t_junctions;
    v.non_manifold_edges += c.non_manifold_edges;
    v.model_boundary_edges += c.model_boundary_edges;
  }
  v.watertight = v.crack_edges == 0 && v.t_junctions == 0 && v.non_manifold_edges == 0;
  v.closed_solids_closed = true;
  for (const occt::PartSolid& s : part.solids) {
    if (!s.closed || !s.valid) continue;
    SolidVolume sv;
    sv.solid = s.index;
    sv.occt_volume = s.volume;
    const auto check =
        std::find_if(v.checks.begin(), v.checks.end(), [&](const SolidCheck& c) { return c.solid == s.index; });
    sv.mesh_closed = check != v.checks.end() && check->closed;
    sv.mesh_volume = check != v.checks.end() ? check->signed_volume : 0.0;
    sv.relative_error =
        sv.mesh_closed && s.volume != 0.0 ? std::abs(sv.mesh_volume - s.volume) / std::abs(s.volume) : kInf;
    v.closed_solids_closed = v.closed_solids_closed && sv.mesh_closed;
    v.volumes.push_back(sv);
  }
  v.seconds = clock.seconds();
  return v;
}

nlohmann::json part_validation_json(const PartValidation& v) {
  nlohmann::json j;
  j["watertight"] = v.watertight;
  j["closed_solids_closed"] = v.closed_solids_closed;
  j["crack_edges"] = v.crack_edges;
  j["t_junctions"] = v.t_junctions;
  j["non_manifold_edges"] = v.non_manifold_edges;
  j["model_boundary_edges"] = v.model_boundary_edges;
  j["solid_checks"] = solid_checks_json(v.checks);
  nlohmann::json volumes = nlohmann::json::array();
  for (const SolidVolume& s : v.volumes) {
    volumes.push_back({{"solid", s.solid},
                       {"mesh_closed", s.mesh_closed},
                       {"mesh_volume", s.mesh_closed ? nlohmann::json(s.mesh_volume) : nlohmann::json(nullptr)},
                       {"occt_volume", s.occt_volume},
                       {"relative_error", number_or_null(s.relative_error)}});
  }
  j["volumes"] = volumes;
  j["seconds"] = v.seconds;
  return j;
}

}  // namespace sagitta::app
