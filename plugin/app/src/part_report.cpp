// Whole parts in `sagitta run` and `sagitta report`: one scheme's part mesh measured (per-solid
// checks, certificate where it applies) and the sweep over uniform levels.
#include "sagitta/app/common.hpp"
#include "sagitta/app/json.hpp"
#include "sagitta/app/part.hpp"
#include "sagitta/app/report.hpp"

#include <glm/common.hpp>

#include <algorithm>
#include <sstream>

namespace sagitta::app {

size_t PartRun::closed_solid_meshes() const {
  return static_cast<size_t>(std::count_if(validation.volumes.begin(), validation.volumes.end(),
                                           [](const SolidVolume& v) { return v.mesh_closed; }));
}

PartRun run_part(const std::string& path, const SchemeSpec& scheme, bool cgal, const CertifyOptions& certify,
                 int timing_runs) {
  PartRun run;
  run.part = occt::mesh_part_file(path, part_options(scheme, 0.0));
  for (int k = 1; k < timing_runs && run.part.mesh.triangles.size() < 100'000; ++k) {
    const double seconds = occt::mesh_part_file(path, part_options(scheme, 0.0)).seconds;
    run.part.seconds = std::min(run.part.seconds, seconds);
  }
  SolidCheckOptions check_options;
  check_options.cgal = cgal;
  check_options.self_intersections = false;
  run.validation = validate_part(run.part, check_options);
  run.certificate = certify_part(run.part, certify);
  return run;
}

nlohmann::json part_faces_json(const occt::PartMesh& part, const PartCertificate& certificate) {
  nlohmann::json faces = nlohmann::json::array();
  for (const occt::PartFace& f : part.faces) {
    const FaceCertificate& c = certificate.faces[static_cast<size_t>(f.face_index)];
    nlohmann::json j = {{"face", f.name},          {"surface", f.surface_type}, {"trimmed", f.trimmed},
                        {"solid", f.solid},        {"status", f.status},        {"triangles", f.triangles},
                        {"certified", c.certified},  {"route", c.route},          {"lower", c.hausdorff.lower}};
    if (c.certified)
      j["upper"] = c.upper;
    else
      j["reason"] = c.reason;
    faces.push_back(std::move(j));
  }
  return faces;
}

nlohmann::json part_run_json(const PartRun& run) {
  nlohmann::json j = part_json(run.part);
  j["face_list"] = part_faces_json(run.part, run.certificate);
  j["validation"] = part_validation_json(run.validation);
  j["certificate"] = part_certificate_json(run.part, run.certificate);
  j["certified"] = run.certificate.all_certified;
  j["closed_solids"] = run.validation.volumes.size();
  j["closed_solid_meshes"] = run.closed_solid_meshes();
  j["watertight"] = run.validation.watertight;
  j["crack_edges"] = run.validation.crack_edges;
  j["t_junctions"] = run.validation.t_junctions;
  return j;
}

std::string part_certificate_headline(const PartRun& run) {
  const PartCertificate& c = run.certificate;
  std::ostringstream s;
  if (c.all_certified) {
    s << "certified faces " << c.faces_certified << "/" << run.part.faces.size() << ", certified Hausdorff ["
      << c.distance.hausdorff.lower << ", " << c.distance.hausdorff.upper << "]";
  } else {
    s << "not certified (" << c.faces_certified << " of " << run.part.faces.size() << " faces)";
  }
  return s.str();
}

namespace {

// Why the part mesh is not certified ("" when it is): the count and the first face's reason.
std::string not_certified_reason(const PartRun& run) {
  if (run.certificate.all_certified) return "";
  const size_t n = run.part.faces.size();
  std::string reason =
      std::to_string(run.certificate.faces_certified) + " of " + std::to_string(n) + " faces certified";
  for (const FaceCertificate& f : run.certificate.faces) {
    if (f.certified) continue;
    return reason + "; e.g. " + run.part.faces[static_cast<size_t>(f.face)].name + ": " + f.reason;
  }
  return reason;
}

// One row of the level sweep.
nlohmann::json level_row(int level, const PartRun& run) {
  const occt::PartMesh& part = run.part;
  nlohmann::json row;
  row["level"] = level;
  row["triangles"] = part.mesh.triangles.size();
  row["vertices"] = part.mesh.positions.size();
  row["seconds"] = part.seconds;
  row["faces"] = part.faces.size();
  row["faces_tessellated"] = part.faces_tessellated;
  row["closed_solids"] = run.validation.volumes.size();
  row["closed_solid_meshes"] = run.closed_solid_meshes();
  row["watertight"] = run.validation.watertight;
  row["faces_certified"] = run.certificate.faces_certified;
  row["certified"] = run.certificate.all_certified;
  row["certified_hausdorff"] =
      run.certificate.all_certified ? interval_json(run.certificate.distance.hausdorff) : nlohmann::json(nullptr);
  row["not_certified_reason"] = not_certified_reason(run);
  row["certify_seconds"] = run.certificate.seconds;
  return row;
}

}  // namespace

nlohmann::json part_report_entry(const std::string& path, const std::string& name, const std::vector<int>& levels,
                                 const std::function<void(int, int, const std::string&)>& progress) {
  nlohmann::json entry;
  entry["kind"] = "part";
  entry["name"] = name;
  entry["input"] = path;
  entry["scheme"] = "uniform";
  nlohmann::json rows = nlohmann::json::array(), skipped = nlohmann::json::array();
  uint64_t previous = 0;
  for (size_t k = 0; k < levels.size(); ++k) {
    const int level = levels[k];
    if (progress)
      progress(static_cast<int>(k), static_cast<int>(levels.size()), name + ": level " + std::to_string(level));
    if (4 * previous > kMaxSweepTriangles) {
      skipped.push_back("level " + std::to_string(level) + ": about " + std::to_string(4 * previous) + " triangles");
      continue;
    }
    SchemeSpec scheme;
    scheme.level = level;
    scheme.guard = false;  // bounded by the rule above
    const PartRun run = run_part(path, scheme, false, CertifyOptions{}, 3);
    if (k == 0) {
      entry["faces"] = run.part.faces.size();
      entry["faces_trimmed"] = run.part.faces_trimmed;
      entry["solids"] = run.part.solids.size();
      entry["closed_solids"] = run.validation.volumes.size();
      // The box of the first level's vertices (points on the part): the fit's default target is 1e-3 of it.
      entry["box_diagonal"] = points_box_diagonal(run.part.mesh.positions);
    }
    previous = run.part.mesh.triangles.size();
    rows.push_back(level_row(level, run));
  }
  entry["levels"] = rows;
  entry["skipped"] = skipped;
  entry["meshes"] = nlohmann::json::array();
  return entry;
}

}  // namespace sagitta::app
