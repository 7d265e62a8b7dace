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
// How far a triangle's (u, v) may lie outside [0, 1]^2 and still be clamped onto it (rounding).
constexpr double kUvTolerance = 1e-12;

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
                     {"triangles", f.triangles},
                     {"scheme_triangles", f.scheme_triangles},
                     {"max_boundary_offset", f.max_boundary_offset}});
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

namespace {

// Why the certificate does not cover face f ("" when it does): only tessellated, untrimmed faces
// whose triangles' (u, v) all lie in [0, 1]^2 (within kUvTolerance) of their own patch.
std::string uncovered_reason(const occt::PartMesh& part, const occt::PartFace& f,
                             const std::vector<std::vector<uint32_t>>& face_triangles) {
  if (f.status != "tessellated") return "not tessellated: " + f.reason;
  if (f.trimmed) return kTrimmedNotCertified;
  if (f.patch_count <= 0) return "no Bézier patch";
  for (const uint32_t t : face_triangles[static_cast<size_t>(f.face_index)]) {
    const uint32_t patch = part.mesh.triangle_patch[t];
    if (patch < static_cast<uint32_t>(f.first_patch) || patch >= static_cast<uint32_t>(f.first_patch + f.patch_count))
      return "triangles cross the patch grid";
    for (const Vec2& q : part.mesh.triangle_uv[t]) {
      if (!(q.x >= -kUvTolerance && q.x <= 1.0 + kUvTolerance && q.y >= -kUvTolerance && q.y <= 1.0 + kUvTolerance))
        return "triangles cross the patch grid";
    }
  }
  return "";
}

// The sub-mesh of the covered faces' triangles and the sub-model of their patches (patch indices
// renumbered, (u, v) clamped onto [0, 1]^2). part_triangle[k] is sub-triangle k's index in the part.
struct SubPart {
  Model model;
  Tessellation mesh;
  std::vector<uint32_t> part_triangle;
  std::vector<uint32_t> part_patch;  // sub-model patch -> part model patch
};

SubPart covered_sub_part(const occt::PartMesh& part, const std::vector<bool>& covered) {
  SubPart sub;
  sub.model.name = part.name;
  std::vector<int64_t> patch_map(part.model.patches.size(), -1), vertex_map(part.mesh.positions.size(), -1);
  for (const occt::PartFace& f : part.faces) {
    if (!covered[static_cast<size_t>(f.face_index)]) continue;
    for (int p = f.first_patch; p < f.first_patch + f.patch_count; ++p) {
      patch_map[static_cast<size_t>(p)] = static_cast<int64_t>(sub.model.patches.size());
      sub.model.patches.push_back(part.model.patches[static_cast<size_t>(p)]);
      sub.part_patch.push_back(static_cast<uint32_t>(p));
    }
  }
  for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
    if (!covered[part.triangle_face[t]]) continue;
    Triangle tri{};
    for (int c = 0; c < 3; ++c) {
      int64_t& index = vertex_map[part.mesh.triangles[t][c]];
      if (index < 0) {
        index = static_cast<int64_t>(sub.mesh.positions.size());
        sub.mesh.positions.push_back(part.mesh.positions[part.mesh.triangles[t][c]]);
      }
      tri[c] = static_cast<uint32_t>(index);
    }
    std::array<Vec2, 3> uv = part.mesh.triangle_uv[t];
    for (Vec2& q : uv) q = {std::clamp(q.x, 0.0, 1.0), std::clamp(q.y, 0.0, 1.0)};
    sub.mesh.triangles.push_back(tri);
    sub.mesh.triangle_patch.push_back(static_cast<uint32_t>(patch_map[part.mesh.triangle_patch[t]]));
    sub.mesh.triangle_uv.push_back(uv);
    sub.part_triangle.push_back(static_cast<uint32_t>(t));
  }
  return sub;
}

}  // namespace

namespace {

// Why face f's own triangles do not tile its patches' (u, v) domains ("" when every patch's
// triangles add up to area 1 and none is reversed): the certifier's coverage test, per face, so one
// such face (a collapsed side the part mesher fans differently) leaves the others certifiable.
std::string tiling_reason(const occt::PartMesh& part, const occt::PartFace& f, const std::vector<uint32_t>& triangles) {
  std::vector<long double> area(static_cast<size_t>(f.patch_count), 0.0L);
  for (const uint32_t t : triangles) {
    const auto& q = part.mesh.triangle_uv[t];
    const long double a =
        0.5L * ((static_cast<long double>(q[1].x) - q[0].x) * (static_cast<long double>(q[2].y) - q[0].y) -
                (static_cast<long double>(q[2].x) - q[0].x) * (static_cast<long double>(q[1].y) - q[0].y));
    if (a < 0.0L) return "a triangle is reversed in (u, v)";
    area[part.mesh.triangle_patch[t] - static_cast<uint32_t>(f.first_patch)] += a;
  }
  for (size_t p = 0; p < area.size(); ++p) {
    if (std::abs(area[p] - 1.0L) > 1e-9L) {
      return "the triangles cover " + std::to_string(static_cast<double>(area[p])) + " of a patch's (u, v) domain";
    }
  }
  return "";
}

// certify_distance on the sub-mesh of the covered faces; fills cert's distance, counts and
// triangle_upper (only when the sub-mesh is certified). Returns whether it is.
bool certify_covered(const occt::PartMesh& part, const std::vector<bool>& covered, const CertifyOptions& options,
                     PartCertificate& cert) {
  const SubPart sub = covered_sub_part(part, covered);
  cert.triangles = sub.mesh.triangles.size();
  cert.patches = sub.model.patches.size();
  cert.distance = DistanceReport{};
  std::fill(cert.triangle_upper.begin(), cert.triangle_upper.end(), kInf);
  if (sub.mesh.triangles.empty()) return false;
  cert.distance = certify_distance(sub.model, sub.mesh, options);
  for (DistanceInterval* d :
       {&cert.distance.hausdorff, &cert.distance.mesh_to_surface, &cert.distance.surface_to_mesh}) {
    if (d->witness_patch >= 0 && static_cast<size_t>(d->witness_patch) < sub.part_patch.size())
      d->witness_patch = sub.part_patch[static_cast<size_t>(d->witness_patch)];
  }
  if (!cert.distance.hausdorff.certified) return false;
  for (size_t k = 0; k < sub.part_triangle.size(); ++k)
    cert.triangle_upper[sub.part_triangle[k]] = cert.distance.triangle_upper[k];
  return true;
}

}  // namespace

PartCertificate certify_part(const occt::PartMesh& part, const CertifyOptions& options) {
  const Stopwatch clock;
  if (!part.mesh.has_surface()) throw InputError(part.name + ": the part mesh has no (u, v) to certify");
  PartCertificate cert;
  cert.triangle_upper.assign(part.mesh.triangles.size(), kInf);
  std::vector<std::vector<uint32_t>> face_triangles(part.faces.size());
  for (size_t t = 0; t < part.triangle_face.size(); ++t)
    face_triangles[part.triangle_face[t]].push_back(static_cast<uint32_t>(t));
  std::vector<bool> covered(part.faces.size(), false);
  for (const occt::PartFace& f : part.faces) {
    FaceCertificate fc;
    fc.face = f.face_index;
    fc.reason = uncovered_reason(part, f, face_triangles);
    covered[static_cast<size_t>(f.face_index)] = fc.reason.empty();
    cert.faces.push_back(fc);
  }
  bool certified = certify_covered(part, covered, options, cert);
  if (!certified && cert.triangles > 0 && !cert.distance.coverage_ok) {
    // The certifier also reconstructs triangles dropped at collapsed sides, so this per-face test
    // runs only after it failed: the faces that do not tile their patches leave, the rest is retried.
    bool dropped = false;
    for (FaceCertificate& fc : cert.faces) {
      const size_t f = static_cast<size_t>(fc.face);
      if (!covered[f]) continue;
      fc.reason = tiling_reason(part, part.faces[f], face_triangles[f]);
      covered[f] = fc.reason.empty();
      dropped = dropped || !covered[f];
    }
    if (dropped) certified = certify_covered(part, covered, options, cert);
  }
  for (FaceCertificate& fc : cert.faces) {
    if (!covered[static_cast<size_t>(fc.face)]) continue;
    for (const uint32_t t : face_triangles[static_cast<size_t>(fc.face)])
      fc.upper = std::max(fc.upper, cert.triangle_upper[t]);
    fc.certified = certified;
    if (!certified) {
      const DistanceReport& d = cert.distance;
      fc.reason = "not certified: " + (d.not_certified_reason.empty() ? d.coverage_note : d.not_certified_reason);
    }
    cert.faces_certified += fc.certified ? 1 : 0;
  }
  cert.all_certified = certified && cert.faces_certified == static_cast<int>(part.faces.size());
  cert.seconds = clock.seconds();
  return cert;
}

nlohmann::json part_certificate_json(const occt::PartMesh& part, const PartCertificate& c) {
  nlohmann::json j;
  j["certified"] = c.all_certified;
  j["faces_certified"] = c.faces_certified;
  nlohmann::json missing = nlohmann::json::array(), bounds = nlohmann::json::array();
  for (const FaceCertificate& f : c.faces) {
    const std::string& name = part.faces[static_cast<size_t>(f.face)].name;
    if (!f.certified) missing.push_back({{"face", name}, {"reason", f.reason}});
    if (f.certified) bounds.push_back({{"face", name}, {"upper", f.upper}});
  }
  j["faces_not_certified"] = missing;
  j["face_upper"] = bounds;
  j["certified_triangles"] = c.triangles;
  j["certified_patches"] = c.patches;
  if (c.triangles > 0) {
    j["hausdorff"] = interval_json(c.distance.hausdorff);
    j["mesh_to_surface"] = interval_json(c.distance.mesh_to_surface);
    j["surface_to_mesh"] = interval_json(c.distance.surface_to_mesh);
    j["coverage_ok"] = c.distance.coverage_ok;
    if (!c.distance.coverage_note.empty()) j["coverage_note"] = c.distance.coverage_note;
    if (!c.distance.not_certified_reason.empty()) j["not_certified_reason"] = c.distance.not_certified_reason;
  }
  j["seconds"] = c.seconds;
  return j;
}

void refuse_cad_part(const std::string& input, const std::string& command) {
  if (!occt::is_cad_file(input) || !occt::is_whole_part(occt::read_cad_file(input))) return;
  throw InputError(input + ": `sagitta " + command +
                   "` on a CAD part is not implemented yet (issue 15: certified whole parts); use `sagitta tessellate` "
                   "or `sagitta validate`");
}

}  // namespace sagitta::app
