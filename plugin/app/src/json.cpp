#include "sagitta/app/json.hpp"

#include <algorithm>
#include <cmath>

namespace sagitta::app {

nlohmann::json vec_json(const Vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); }

// Infinity is not JSON: an uncertified upper bound is written as null.
nlohmann::json number_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json interval_json(const DistanceInterval& d) {
  nlohmann::json j;
  j["lower"] = d.lower;
  j["upper"] = number_or_null(d.upper);
  j["width"] = number_or_null(d.width());
  j["ratio"] = number_or_null(d.ratio());
  j["upper_certified"] = d.certified;
  j["lower_certified"] = true;
  j["witness"] = vec_json(d.witness);
  j["witness_patch"] = d.witness_patch;
  return j;
}

namespace {

// Topology findings: kind, position, patch, triangle, vertices.
nlohmann::json findings_json(const std::vector<TopologyFinding>& findings) {
  nlohmann::json list = nlohmann::json::array();
  for (const TopologyFinding& f : findings) {
    list.push_back({{"kind", f.kind},
                    {"position", vec_json(f.position)},
                    {"patch", f.patch},
                    {"triangle", f.triangle},
                    {"vertices", {f.vertices[0], f.vertices[1]}}});
  }
  return list;
}

}  // namespace

nlohmann::json topology_report_json(const TopologyReport& t) {
  nlohmann::json j;
  j["edges"] = t.edges;
  j["open_edges"] = t.open_edges;
  j["model_boundary_edges"] = t.model_boundary_edges;
  j["crack_edges"] = t.crack_edges;
  j["t_junctions"] = t.t_junctions;
  j["non_manifold_edges"] = t.non_manifold_edges;
  j["inconsistent_orientation_edges"] = t.inconsistent_orientation_edges;
  j["degenerate_triangles"] = t.degenerate_triangles;
  j["duplicated_faces"] = t.duplicated_faces;
  j["components"] = t.components;
  j["closed_components"] = t.closed_components;
  j["inside_out_components"] = t.inside_out_components;
  nlohmann::json comps = nlohmann::json::array();
  for (const MeshComponent& c : t.component_list) {
    comps.push_back({{"triangles", c.triangles},
                     {"first_triangle", c.first_triangle},
                     {"patch", c.patch},
                     {"box", {vec_json(c.box_min), vec_json(c.box_max)}},
                     {"closed", c.closed},
                     {"signed_volume", c.closed ? nlohmann::json(c.signed_volume) : nlohmann::json(nullptr)},
                     {"inside_out", c.inside_out}});
  }
  j["component_list"] = comps;
  j["watertight"] = t.watertight();
  j["open_edges_classified_by"] =
      t.classified_with_uv ? "patch (u, v)" : "distance to the model's free boundary curves";
  j["findings"] = findings_json(t.findings);
  return j;
}

nlohmann::json solid_checks_json(const std::vector<SolidCheck>& checks) {
  nlohmann::json list = nlohmann::json::array();
  for (const SolidCheck& c : checks) {
    nlohmann::json j;
    j["solid"] = c.solid;
    j["triangles"] = c.triangles;
    j["vertices"] = c.vertices;
    j["edges"] = c.edges;
    j["open_edges"] = c.open_edges;
    j["model_boundary_edges"] = c.model_boundary_edges;
    j["crack_edges"] = c.crack_edges;
    j["non_manifold_edges"] = c.non_manifold_edges;
    j["t_junctions"] = c.t_junctions;
    j["inconsistent_orientation_edges"] = c.inconsistent_orientation_edges;
    j["degenerate_triangles"] = c.degenerate_triangles;
    j["components"] = c.components;
    j["euler_characteristic"] = c.euler_characteristic;
    j["closed"] = c.closed;
    j["signed_volume"] = c.closed ? nlohmann::json(c.signed_volume) : nlohmann::json(nullptr);
    j["cgal_checked"] = c.cgal_checked;
    j["cgal_note"] = c.cgal_note;
    j["cgal_closed"] = c.cgal_closed;
    j["cgal_outward"] = c.cgal_outward;
    j["cgal_self_intersections"] = c.cgal_self_intersections;
    j["cgal_volume"] = c.cgal_closed ? nlohmann::json(c.cgal_volume) : nlohmann::json(nullptr);
    j["findings"] = findings_json(c.findings);
    list.push_back(std::move(j));
  }
  return list;
}

nlohmann::json topology_json(const Model& model, const Topology& topo) {
  nlohmann::json j;
  j["shared_edges"] = topo.shared_edges();
  j["free_boundary_edges"] = topo.free_edges();
  j["nonmanifold_edges"] = topo.nonmanifold_edges();
  j["collapsed_sides"] = topo.collapsed_sides();
  j["corners"] = topo.corner_classes;
  nlohmann::json misses = nlohmann::json::array();
  for (const Topology::NearMiss& m : topo.near_misses) {
    misses.push_back({{"patch_a", m.a.patch},
                      {"side_a", side_name(m.a.side)},
                      {"patch_b", m.b.patch},
                      {"side_b", side_name(m.b.side)},
                      {"distance", m.distance}});
  }
  j["near_misses"] = misses;
  // Two unmatched sides are listed when their control polygons are closer than the smaller of the
  // two sides' tolerances: min(model_wide, patch_fraction x the side's patch control-box diagonal).
  j["near_miss_tolerance"] = {{"model_wide", topo.near_miss_tolerance},
                              {"patch_fraction", topo.near_miss_patch_fraction}};
  nlohmann::json near = nlohmann::json::array();
  for (const SideRef& s : topo.near_collapsed) near.push_back({{"patch", s.patch}, {"side", side_name(s.side)}});
  j["near_collapsed_sides"] = near;
  (void)model;
  return j;
}

nlohmann::json scheme_stats_json(const SchemeStats& s) {
  nlohmann::json j;
  j["scheme"] = scheme_name(s.scheme);
  switch (s.scheme) {
    case Scheme::kUniform:
      if (s.level >= 0) j["level"] = s.level;
      j["segments"] = s.segments;
      break;
    case Scheme::kEsc:
      j["level"] = s.level;
      j["threshold"] = s.threshold;
      j["per_edge_levels"] = s.per_edge_levels;
      j["candidates"] = s.esc.candidates;
      j["inserted_vertices"] = s.esc.inserted_vertices;
      j["strips"] = s.esc.strips;
      break;
    case Scheme::kPn:
      if (s.base_level >= 0) j["base_level"] = s.base_level;
      j["pattern"] = pn_pattern_name(s.pattern);
      j["pn_variant"] = pn_variant_name(s.pn_variant);
      j["factor"] = s.factor;
      j["normals"] = pn_normals_name(s.normals);
      j["segments_per_edge"] = s.pn.segments_per_edge;
      j["input_triangles"] = s.pn.input_triangles;
      j["skipped_triangles"] = s.pn.skipped_triangles;
      j["crease_edges"] = s.pn.crease_edges;
      j["open_edges"] = s.pn.open_edges;
      j["crack_edges"] = s.pn.crack_edges;
      j["max_crack_gap"] = s.pn.max_crack_gap;
      break;
  }
  return j;
}

nlohmann::json fitted_model_json(const FittedModel& m) {
  nlohmann::json j;
  j["model"] = m.name;
  j["formula"] = m.formula;
  j["variable"] = m.variable;
  if (m.level >= 0) j["level"] = m.level;
  nlohmann::json params;
  for (size_t i = 0; i < m.parameters.size(); ++i) params[m.parameter_names[i]] = m.parameters[i];
  j["parameters"] = params;
  j["log_residuals"] = m.residuals;
  j["cost"] = m.cost;
  j["loss"] = "Huber(0.1) on log(error)";
  return j;
}

nlohmann::json fit_result_json(const FitResult& r) {
  nlohmann::json j;
  j["scheme"] = scheme_name(r.scheme);
  j["target_error"] = r.target_error;
  j["met"] = r.met;
  if (r.scheme == Scheme::kUniform) {
    j["segments"] = r.level;
  } else {
    j["level"] = r.level;
  }
  if (r.scheme == Scheme::kEsc) j["threshold"] = r.threshold;
  if (r.scheme == Scheme::kPn) j["base_level"] = r.base_level;
  j["certified_error"] = std::isfinite(r.certified_error) ? nlohmann::json(r.certified_error) : nlohmann::json(nullptr);
  j["certified_lower_bound"] = r.lower_bound;
  j["triangles"] = r.triangles;
  j["iterations"] = r.iterations;
  j["refinement_steps"] = std::max(r.iterations - 1, 0);
  j["certifications"] = r.certifications;
  j["seconds"] = r.seconds;
  nlohmann::json models = nlohmann::json::array();
  for (const FittedModel& m : r.models) models.push_back(fitted_model_json(m));
  j["fit"] = models;
  nlohmann::json samples = nlohmann::json::array();
  for (const FitSample& s : r.samples) {
    nlohmann::json k;
    k[r.scheme == Scheme::kUniform ? "segments" : "level"] = s.level;
    if (r.scheme == Scheme::kEsc) k["threshold"] = s.threshold;
    if (r.scheme == Scheme::kPn) k["base_level"] = s.base_level;
    k["triangles"] = s.triangles;
    k["certified_error"] =
        std::isfinite(s.certified_error) ? nlohmann::json(s.certified_error) : nlohmann::json(nullptr);
    k["lower_bound"] = s.lower_bound;
    k["seconds"] = s.seconds;
    samples.push_back(k);
  }
  j["samples"] = samples;
  if (!r.patches.empty()) {
    nlohmann::json patches = nlohmann::json::array();
    for (const PatchChoice& p : r.patches) {
      nlohmann::json k{{"patch", p.patch}, {"level", p.level}, {"certified_error", p.certified_error}};
      if (r.scheme == Scheme::kEsc) k["threshold"] = p.threshold;
      patches.push_back(k);
    }
    j["patches"] = patches;
  }
  return j;
}

}  // namespace sagitta::app
