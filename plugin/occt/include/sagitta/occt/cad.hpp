// CAD input through OpenCASCADE: STEP, IGES and OCCT BREP files become Bézier patch models, and
// OCCT's own mesher (BRepMesh_IncrementalMesh) is the peer our schemes are compared with.
// No OCCT type appears in this header; only plugin/ links OCCT.
#pragma once

#include "sagitta/certify.hpp"
#include "sagitta/model.hpp"
#include "sagitta/tessellation.hpp"

#include <string>
#include <vector>

namespace sagitta::occt {

struct CadOptions {
  // Two patch sides that come from one shared B-rep edge are made bit-identical when their control
  // points agree within this distance (model units); <= 0 picks the largest edge tolerance of the
  // B-rep, kept between 1e-6 and 1e-5 of the model's box diagonal.
  double snap_tolerance = 0.0;
  // Planes, cylinders, cones, spheres and tori are converted to rational Bézier patches (exact).
  bool convert_analytic = true;
};

// What happened to one face of the B-rep (faces in TopExp_Explorer order).
struct FaceReport {
  int face_index = 0;        // 0-based
  std::string name;          // "Face 12": 1-based, as FreeCAD names faces
  std::string surface_type;  // "BSplineSurface", "BezierSurface", "Plane", "Cylinder", ...
  std::string status;        // "tessellated" | "trimmed" | "skipped"
  std::string reason;        // why trimmed or skipped ("" when tessellated)
  int first_patch = -1;      // tessellated: index into CadModel::model.patches; trimmed: into trimmed_patches
  int patch_count = 0;       // Bézier patches the face's surface decomposes into (0 when skipped)
  // The patch grid: patch (i, j) (index first_patch + i * (v_breaks.size() - 1) + j) spans
  // [u_breaks[i], u_breaks[i + 1]] x [v_breaks[j], v_breaks[j + 1]] of the converted surface's parameters
  // (before the u reversal of reversed faces).
  std::vector<double> u_breaks, v_breaks;
};

struct CadModel {
  // Bézier patches of the untrimmed faces: what our schemes tessellate and the validator measures.
  Model model;
  // The (untrimmed) Bézier patches under each trimmed face, kept for counting and reporting.
  std::vector<BezierPatch> trimmed_patches;
  std::vector<FaceReport> faces;
  std::vector<int> patch_face;  // per patch of `model`: its face_index
  int faces_tessellated = 0;
  int faces_trimmed = 0;
  int faces_skipped = 0;
  int bezier_patches = 0;       // model.patches + trimmed_patches
  int snapped_patches = 0;      // patches with a boundary control point snapped onto a neighbour face's copy
  double max_snap = 0.0;        // the largest distance a control point moved while snapping
  double snap_tolerance = 0.0;  // the tolerance used
  int solids = 0;               // TopoDS_Solid / TopoDS_Shell in the shape
  int shells = 0;
};

// True when the shape is a part (a solid or a shell), or has a trimmed face: it is then meshed whole
// (sagitta/occt/part.hpp) by the CLI, Python and FreeCAD alike. Loose untrimmed faces (a patch model
// written as CAD faces, e.g. wing.brep) keep the patch path: the schemes on `model` with bit-exact
// seams and the patch certificate.
bool is_whole_part(const CadModel& cad);

// Reads .step/.stp, .iges/.igs or .brep/.brp (by extension). Throws InputError with one line naming
// the file for unreadable, empty or malformed input, and when no face can be converted at all.
CadModel read_cad_file(const std::string& path, const CadOptions& options = {});

// The same for an OCCT BREP text (FreeCAD: Part.Shape.exportBrepToString()); `name` names it in messages.
CadModel read_brep_string(const std::string& brep_text, const std::string& name, const CadOptions& options = {});

// True for the extensions read_cad_file accepts (any case).
bool is_cad_file(const std::string& path);

// The OpenCASCADE version this was built against ("7.6.3").
std::string occt_version();

struct PeerOptions {
  double deflection = 1e-3;  // BRepMesh linear deflection (model units)
  double angle = 0.5;        // BRepMesh angular deflection (radians)
  bool relative = false;     // deflection relative to each edge's size (BRepMesh's "relative" mode)
  CertifyOptions certify;
};

struct PeerResult {
  Tessellation mesh;          // OCCT's triangulation, vertices merged across faces by exact position
  double mesh_seconds = 0.0;  // BRepMesh_IncrementalMesh only
  size_t triangles = 0;            // all triangles OCCT made
  size_t triangles_validated = 0;  // those in `mesh`: the faces the validator can measure
  int faces_meshed = 0;            // faces that received a triangulation
  int faces_without_mesh = 0;
  // "bernstein": every face is one Bézier patch and each vertex carries its (patch, u, v), so the
  // validator's own-mesh certificate applies.
  std::string route;
  double max_node_offset = 0.0;  // largest |node - S(u, v)| over OCCT's nodes (bernstein route)
  DistanceReport distance;
  double validate_seconds = 0.0;
};

// Meshes a patch model with OCCT: one Geom_BezierSurface face per patch, sewn so that neighbouring
// faces share edges, then BRepMesh_IncrementalMesh; validates the result against `model`.
PeerResult peer_mesh_model(const Model& model, const PeerOptions& options = {});

// CAD files: BRepMesh's mesh of the whole part as a PartMesh (brepmesh_part_file, sagitta/occt/part.hpp),
// certified face by face by app::certify_part.

}  // namespace sagitta::occt
