// Whole CAD parts in the front ends: the part mesher's options and JSON (sagitta/occt/part.hpp),
// the per-solid verdict of a part mesh, and the distance certificate on the faces where today's
// certifier applies (untrimmed faces whose triangles stay in their patches; issue 15 does the rest).
#pragma once

#include "sagitta/certify.hpp"
#include "sagitta/occt/part.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/solid_check.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace sagitta::app {

// The mesher's options from a scheme and an edge tolerance (0: the scheme's own edge density).
// Throws InputError for a negative or non-finite edge tolerance.
occt::PartOptions part_options(const SchemeSpec& scheme, double edge_tolerance);

// The part mesh's stats: faces, faces_tessellated, faces_skipped, faces_trimmed, skipped [{face,
// surface, reason}], bezier_patches, edges, edge_vertices, triangles, vertices, seconds, face_list
// [{face, surface, trimmed, solid, status, reason, triangles, scheme_triangles}] and solids [{solid,
// closed, valid, volume, faces, triangles}] (closed/valid/volume as OCCT sees the B-rep solid).
nlohmann::json part_json(const occt::PartMesh& part);

// A B-rep solid that OCCT finds closed and valid, next to its mesh's verdict.
struct SolidVolume {
  int solid = -1;
  bool mesh_closed = false;     // the solid's triangles form a closed surface (SolidCheck::closed)
  double mesh_volume = 0.0;     // SolidCheck::signed_volume (0 when not closed)
  double occt_volume = 0.0;     // PartSolid::volume
  double relative_error = 0.0;  // |mesh - occt| / |occt|; +infinity when the mesh is not closed or occt is 0
};

// check_solids on a part mesh, summarised.
struct PartValidation {
  std::vector<SolidCheck> checks;    // one per solid id present (-1: triangles outside every solid)
  std::vector<SolidVolume> volumes;  // one per closed and valid B-rep solid, in solid order
  uint64_t crack_edges = 0, t_junctions = 0, non_manifold_edges = 0, model_boundary_edges = 0;
  // No crack, T-junction or non-manifold edge in any solid (open edges on the part's
  // boundary_edges are the model's boundary, not cracks).
  bool watertight = false;
  // Every closed and valid B-rep solid has a closed mesh.
  bool closed_solids_closed = false;
  double seconds = 0.0;
};

PartValidation validate_part(const occt::PartMesh& part, const SolidCheckOptions& options = {});

// The summary fields plus solid_checks_json's list ("solid_checks") and the volume comparison.
nlohmann::json part_validation_json(const PartValidation& validation);

// The distance certificate of a whole part, face by face (docs/VALIDATION.md, "Whole parts"). Each
// face is measured against its own triangles: a face kept whole by the scheme (untrimmed, every
// triangle inside its patch) by certify_distance on its patches ("patch" route); any other face
// ("loops" route) by splitting its triangles along the patch grid and certifying the pieces against
// the untrimmed patches, proving that the triangles' (U, V) tile the polygon of the loops' chords
// exactly once, and bounding the slivers between each chord and its trimming curve by the
// surface's speed times the chord's proven deviation (occt::BoundaryChord).
struct FaceCertificate {
  int face = 0;
  std::string route;        // "patch" | "loops" | "" (not tessellated)
  bool certified = false;   // both directions' upper bounds proven
  std::string reason;       // why not certified ("" when certified)
  // Not certified because of this mesh's own shape in (U, V) (its triangles do not tile the face's
  // domain once): a finer mesh of the face may be certified.
  bool mesh_dependent = false;
  DistanceInterval mesh_to_surface, surface_to_mesh, hausdorff;  // face <-> its own triangles
  double upper = 0.0;       // hausdorff.upper when certified
  double sliver = 0.0;      // loops route: the most the slivers add to a triangle's own bound, model units
  // loops route: the triangles' own mesh -> surface bound (each point against the surface at its
  // own (u, v), or at its leaf's projections where they lie in the domain), before the sliver term
  // is added to the triangles on the chords; not by itself a bound of the face (a point over a
  // sliver outside the domain is matched to a surface point outside it).
  double triangles_mesh_to_surface = 0.0;
  uint64_t chords = 0;      // loops route: chords of the face's loops
  double seconds = 0.0;     // this face's certificate (faces run in parallel)
};

struct PartCertificate {
  std::vector<FaceCertificate> faces;  // one per PartMesh face
  int faces_certified = 0;
  uint64_t triangles = 0;   // triangles of the certified faces
  uint64_t patches = 0;     // patches of the certified faces
  // Max over the faces: lower bounds over every face (each is a proven lower bound of its face's
  // distance), upper bounds certified only when every face is (+infinity otherwise).
  DistanceReport distance;
  bool all_certified = false;  // every face of the part is certified (and, for a foreign mesh, every triangle is on a face)
  std::string note;            // why not certified although every face is ("" otherwise)
  double certified_faces_upper = 0.0;  // the largest upper bound among the certified faces
  // Per triangle of the whole part mesh: the certified bound, +infinity outside the certified faces.
  std::vector<double> triangle_upper;
  double seconds = 0.0;
};

// Throws MemoryLimitExceeded before starting when validation_bytes (sagitta/app/validate.hpp) of the
// part's triangles exceeds the memory limit. With stop_above finite (`--max-error`): once a face's
// certified lower bound exceeds it, the part's distance is proven above it, and the faces not yet
// started are skipped (not certified, with that reason; `note` says so).
PartCertificate certify_part(const occt::PartMesh& part, const CertifyOptions& options = {},
                             double stop_above = std::numeric_limits<double>::infinity());

// certified (all_certified), faces_certified, faces_not_certified [{face, reason}], faces [{face,
// surface, trimmed, route, certified, lower, upper, reason}], the part's hausdorff /
// mesh_to_surface / surface_to_mesh intervals (upper null unless all_certified),
// certified_faces_upper, certified_triangles, certified_patches, seconds.
nlohmann::json part_certificate_json(const occt::PartMesh& part, const PartCertificate& certificate);

// The certificate's headline, one line without its end: "certified: hausdorff in [lower, upper] on
// all N faces", or "not certified: K of N faces certified (note) (the certified faces' largest upper
// bound U); largest lower bound over all faces L".
std::string part_certificate_headline(const occt::PartMesh& part, const PartCertificate& certificate);

// A part meshed by one scheme, checked solid by solid and certified where today's certificate
// applies: what `sagitta run` and `sagitta report` measure for each scheme or level.
struct PartRun {
  occt::PartMesh part;
  PartValidation validation;
  PartCertificate certificate;
  // The closed and valid B-rep solids whose mesh is closed (of validation.volumes.size()).
  size_t closed_solid_meshes() const;
};

// Meshes the CAD file with the scheme (mesh_part_file), validates it (CGAL verdicts only when
// `cgal`; never the self-intersection count) and certifies it (certify_part). With timing_runs > 1
// the part is meshed that many times (once when over 100,000 triangles) and part.seconds is the
// fastest (the first run pays for thread start-up); the meshes are identical (deterministic).
PartRun run_part(const std::string& path, const SchemeSpec& scheme, bool cgal, const CertifyOptions& certify = {},
                 int timing_runs = 1);

// One object per face of the part (every face, in face order): face, surface, trimmed, solid,
// status, triangles, certified, and either upper (the certified bound, only on a certified face) or
// reason (why the face is not certified, or why it was skipped).
nlohmann::json part_faces_json(const occt::PartMesh& part, const PartCertificate& certificate);

// part_json with face_list replaced by part_faces_json, plus validation (part_validation_json),
// certificate (part_certificate_json), certified (every face), closed_solids, closed_solid_meshes,
// watertight, crack_edges and t_junctions.
nlohmann::json part_run_json(const PartRun& run);

// "certified faces n/n, certified Hausdorff [lower, upper]" when every face is certified, else
// "not certified (k of n faces)": no certified number unless the whole part is certified.
std::string part_certificate_headline(const PartRun& run);

// The trade report's entry for a part: kind "part", name, input, faces, faces_trimmed, solids,
// closed_solids, scheme "uniform", levels (one object per level run: level, triangles, vertices,
// seconds (the fastest of up to three runs), faces_tessellated, faces, closed_solids,
// closed_solid_meshes, watertight, faces_certified, certified, certified_hausdorff (the interval when
// every face is certified, else null) and not_certified_reason), skipped (levels left out, with
// why) and meshes (empty; `sagitta run` adds its meshes' part_run_json). A level is left out once
// the previous one has more than a quarter of kMaxSweepTriangles triangles (a level has about 4
// times the triangles of the one before). progress (may be empty) is called before each level:
// (done, total, what).
nlohmann::json part_report_entry(const std::string& path, const std::string& name, const std::vector<int>& levels,
                                 const std::function<void(int, int, const std::string&)>& progress);

// A whole part fitted to a target error (`sagitta fit PART`): the uniform scheme's segments per
// patch side N, with every B-rep edge split until its chords lie within target / 2 of the curve.
// The certified error of the part falls as N grows (both the triangles' and the slivers' terms);
// N is doubled until the certificate meets the target, then bisected down to the smallest N that
// meets it, the fewest triangles of this family. Faces that are not certified at some N do not stop
// the search at once: it follows the certified faces' largest bound, and ends with met = false (and
// the faces that are not certified, with why) when some face is still not certified at the chosen N.
// It stops at once when no face is certified, when the same faces are not certified at two
// doublings in a row (their reasons do not depend on N), and at kMaxFitSegments. Faces on graded
// grids then take a real N between the integer that misses and the one that meets (docs/FITTING.md
// step 2b).
struct PartFit {
  bool met = false;
  std::string reason;          // why not met ("" when met)
  double target = 0.0;         // model units
  int segments = 0;            // the chosen N (met), else the last tried; the largest face's when per face
  // Segments per patch side of each face (by face index) when the faces took their own densities;
  // empty when every face took `segments`.
  std::vector<int> face_segments;
  // The real N of faces on graded grids (by face index, 0: the face's integer N), found between the
  // largest integer N that misses and the smallest that meets (occt::PartOptions::face_graded_segments);
  // empty when no face took one.
  std::vector<double> face_graded_segments;
  double edge_tolerance = 0.0;
  // Tighter edge tolerances of some faces (by face index, 0: edge_tolerance), given to the faces
  // whose certified interval the slivers at their trimming curves widened past the ratio limits
  // (kFitRatioTrimmed, kFitRatioUntrimmed); empty when none was needed.
  std::vector<double> face_edge_tolerance;
  PartRun run;                 // the chosen mesh with its validation and certificate
  struct Step {
    int segments = 0;
    uint64_t triangles = 0;
    bool certified = false;
    double upper = 0.0;        // the part's certified upper bound (+inf when not certified)
    double faces_upper = 0.0;  // the certified faces' largest upper bound (+inf when none is)
    double lower = 0.0;        // the part's certified lower bound (every face's)
    double seconds = 0.0;
    bool per_face = false;  // each face its own N (segments is the largest)
    double edge_tolerance = 0.0;
  };
  std::vector<Step> steps;
  double seconds = 0.0;
};

inline constexpr int kMaxFitSegments = 256;
// The tightness the fit aims for on each face, upper / lower of its certified interval (issue 15):
// trimmed faces, untrimmed faces.
inline constexpr double kFitRatioTrimmed = 1.5;
inline constexpr double kFitRatioUntrimmed = 1.1;

// `mesher` meshes the part with the given options (the file or a BREP text). progress (may be empty)
// is told each step: (step, segments). tighten: after the fewest triangles that meet the target,
// the tightness pass (docs/FITTING.md step 4) spends triangles on faces whose certified interval is
// wider than kFitRatioTrimmed / kFitRatioUntrimmed; false keeps the fewest triangles.
PartFit fit_part(const std::function<occt::PartMesh(const occt::PartOptions&)>& mesher, double target,
                 const CertifyOptions& certify, const std::function<void(int, int)>& progress = {},
                 bool tighten = true);

// Faces of a run that are certified, not exact (upper above 1e-9 of the part's size) and wider
// than their ratio limit (kFitRatioTrimmed / kFitRatioUntrimmed): the fit's tightness measure.
bool face_over_ratio_limit(const PartRun& run, size_t face);
int faces_over_ratio_limits(const PartRun& run);

// The fit in a few numbers for reports: part_fit_json without the mesh and the steps (their count
// instead), plus `faces` and `faces_over_ratio_limits`.
nlohmann::json part_fit_summary(const PartFit& fit);

// The faces over their ratio limit (face_over_ratio_limit), worst first: [{face, surface, trimmed,
// lower, upper, ratio}] with the face named as FreeCAD numbers it.
nlohmann::json faces_over_ratio_limits_json(const PartRun& run);

// The fit as JSON: met, reason, target, segments, edge_tolerance, triangles, certified_error,
// certified_lower_bound, certified_faces_error, faces_over_ratio_limits_detail
// (faces_over_ratio_limits_json),
// steps [{segments, triangles, certified, upper, certified_faces_upper, lower, seconds}], seconds, and the chosen
// mesh's part_run_json under "part".
nlohmann::json part_fit_json(const PartFit& fit);

}  // namespace sagitta::app
