// Whole CAD parts: every face of a B-rep tessellated into one indexed mesh that is watertight across
// faces (docs/CAD.md, "Whole parts"). Each B-rep edge is discretised once and every face that uses it
// takes the same vertices; inside a face the chosen scheme (uniform or ESC) runs on the face's Bézier
// patches and the cells its trimming loops cross are re-triangulated with CGAL's constrained Delaunay
// triangulation in the patches' parameters. No OCCT type appears in this header.
#pragma once

#include "sagitta/model.hpp"
#include "sagitta/occt/cad.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/tessellation.hpp"

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace sagitta::occt {

struct PartOptions {
  // uniform (level / segments) or esc (threshold); pn is a scheme for triangle meshes and is refused.
  SchemeSpec scheme;
  // > 0: every edge is split until each chord is within this distance of the edge's 3D curve
  // (sampled; issue "Certified whole parts" proves it), on top of the scheme's own density.
  double edge_tolerance = 0.0;
  // uniform only: segments per patch side of each face (by face index, 0-based), overriding the
  // scheme's level / segments where > 0 (the fit gives each face its own density). Shorter than the
  // face count: the remaining faces take the scheme's.
  std::vector<int> face_segments;
  // uniform only: where > 0, a real N for face f's graded grid (docs/CAD.md, "Graded grids") in place
  // of its integer segments, at most that integer: the fit's steps between two integer N, since a
  // graded face's cells grow with N continuously. A face that keeps the per-patch grid ignores it.
  std::vector<double> face_graded_segments;
  // > 0: a tighter edge tolerance for the edges of face f (by face index; an edge takes the smallest
  // of the global one and those of its faces). The fit tightens the trimming curves of faces whose
  // certified interval is widened by the slivers between curve and chords. Shorter than the face
  // count: the remaining faces take edge_tolerance.
  std::vector<double> face_edge_tolerance;
  // uniform only: a face whose knot spans need different densities (a B-spline fillet with spans of
  // 0.1 and 4 mm side by side) gets one grid of its own lines, each span as many cells as its bending
  // needs and short spans sharing cells, instead of the same N x N cells on every patch (docs/CAD.md,
  // "Graded grids"); off: always the per-patch grid.
  bool graded_grids = true;
  CadOptions cad;
  // PartSolid::valid (BRepCheck_Analyzer) and ::volume (BRepGProp): OCCT's own facts about each
  // solid, for the reports; off, they stay false / 0 (they cost more than the tessellation on
  // large parts, so the benchmark leaves them out).
  bool solid_facts = true;
};

// One chord of a face's trimming loops, between the shared edge vertices a and b, in the face's patch
// parameters (U, V) (PartFace::u_breaks / v_breaks).
struct BoundaryChord {
  uint32_t a = 0, b = 0;
  Vec2 uv_a{0.0}, uv_b{0.0};
  // Proven: every point of the trimming curve between a and b lies within this distance of the
  // segment [uv_a, uv_b], measured in (U, V) scaled by PartFace::chord_metric (convex hull of the
  // p-curve's exact Bézier pieces); +infinity when it could not be proven.
  double deviation = std::numeric_limits<double>::infinity();
  // Proven (same metric): how far the trimming curve's points project beyond the chord's ends along
  // the chord (0: none does; +infinity when not proven). With the deviation it bounds the step from a
  // sliver point to its nearest chord point: across the chord by at most `deviation`, along it by at
  // most this (docs/VALIDATION.md, "the slivers' term").
  double overshoot = std::numeric_limits<double>::infinity();
  // Proven (same metric): how far the trimming curve's points lie to the left / to the right of the
  // chord's line, looking from uv_a to uv_b (0: none do; +infinity when not proven). A curve that
  // bulges only away from the chord's triangle has 0 (up to rounding) on the triangle's side: the
  // mesh there covers no point outside the face (docs/VALIDATION.md, "the slivers' two sides").
  double left = std::numeric_limits<double>::infinity(), right = std::numeric_limits<double>::infinity();
  // Points of the face on its trimming curve between a and b (the p-curve at 1/4, 1/2 and 3/4 of
  // the chord's parameter range, evaluated on the face's patches): lower-bound witnesses for the
  // face -> mesh distance, each within curve_point_error of the face.
  std::array<Vec3, 3> curve_points{};
  double curve_point_error = 0.0;
  // A finer polyline along the same trimming curve, from uv_a to uv_b in (U, V): the curve's piece
  // between consecutive points lies within trace_deviation (metric as `deviation`; about 1/32 of
  // it, or the chord alone on re-parametrised faces) of the segment between them. It decides which
  // side of the curve a point of a sliver lies on (the certificate's lower bounds, VALIDATION.md).
  std::vector<Vec2> trace;
  double trace_deviation = std::numeric_limits<double>::infinity();
};

// One face of the part (faces in TopExp::MapShapes order, named as FreeCAD names them).
struct PartFace {
  int face_index = 0;        // 0-based
  std::string name;          // "Face 12"
  std::string surface_type;  // "Plane", "Cylinder", "BSplineSurface", ...
  bool trimmed = false;      // the face's domain is not its whole parameter rectangle
  int solid = -1;            // index into PartMesh::solids; -1 for a face outside every solid
  std::string status;        // "tessellated" | "skipped"
  std::string reason;        // why skipped ("" when tessellated)
  int first_patch = -1;      // into PartMesh::model.patches
  int patch_count = 0;
  int segments = 0;               // uniform: the scheme's segments per patch side on this face (0: esc)
  // uniform: the grid every patch of the face is sampled on, segments_u x segments_v: `segments`
  // along the direction that bends more, fewer along one that bends less (a cylinder's rulings take
  // one), 1 x 1 on a flat face (0 x 0: esc).
  int segments_u = 0, segments_v = 0;
  // uniform on a face whose knot spans differ in size (docs/CAD.md, "Graded grids"): the cells of
  // the face's own grid along U and V, which replaces the per-patch grid above (0: not graded).
  int graded_u = 0, graded_v = 0;
  double graded_segments = 0.0;   // the real N the graded grid was built for (0: not graded)
  uint64_t triangles = 0;         // emitted triangles of the face
  uint64_t scheme_triangles = 0;  // of those, the scheme's own triangles kept unchanged
  uint64_t boundary_vertices = 0; // shared edge vertices on the face's loops
  // Largest distance between a boundary vertex's position and the face's Bézier surface at the
  // (u, v) the p-curve maps it to (the conversion's parametrisation checked at every boundary vertex).
  double max_boundary_offset = 0.0;
  // The scheme's tessellation of the face's patches was kept unchanged (an untrimmed face whose
  // edges carry the scheme's side vertices): every triangle lies in [0, 1]^2 of its patch.
  bool kept_whole = false;
  // The face's patch grid in its surface's parameters (U, V): patch first_patch + i * (v_breaks.size()
  // - 1) + j spans [u_breaks[i], u_breaks[i + 1]] x [v_breaks[j], v_breaks[j + 1]] (u mirrored inside
  // the patch when `reversed`); periods of the surface in U and V (0: not periodic).
  std::vector<double> u_breaks, v_breaks;
  bool reversed = false;
  double u_period = 0.0, v_period = 0.0;
  // A face re-triangulated inside its loops (not kept_whole): the loops' chords (a pole's segment
  // included, from the pole to itself).
  std::vector<BoundaryChord> chords;
  Vec2 chord_metric{1.0};  // the scale of U and V in which chord deviations are measured
  // A face re-triangulated inside its loops with a pole (a degenerated edge: one mesh vertex, a
  // segment in (U, V)): the (U, V) triangles with two corners on that segment, left out of the mesh
  // because they collapse onto the edge from their third corner to the pole. With the emitted
  // triangles they tile the loops' polygon; the certificate bounds the surface above them.
  struct CollapsedTriangle {
    std::array<uint32_t, 3> vertices{};  // mesh vertices (two are the pole's)
    std::array<Vec2, 3> uv{};            // (U, V), oriented as the face's emitted triangles
  };
  std::vector<CollapsedTriangle> collapsed;
};

// A solid of the B-rep, as OCCT sees it.
struct PartSolid {
  int index = 0;
  bool closed = false;        // every shell of the solid is closed (BRep_Tool::IsClosed)
  bool valid = false;         // BRepCheck_Analyzer (PartOptions::solid_facts)
  double volume = 0.0;        // BRepGProp::VolumeProperties (PartOptions::solid_facts)
  uint64_t faces = 0;
  uint64_t triangles = 0;
};

struct PartMesh {
  std::string name;
  Model model;  // every tessellated face's Bézier patches (u reversed on reversed faces), in face order
  // One indexed mesh: shared edge vertices; triangles wind counter-clockwise seen from outside the
  // solid; triangle_patch / triangle_uv / surface_points refer to `model` (a triangle re-triangulated
  // near a trimming loop may reach into the neighbouring patch: its (u, v) are then outside [0, 1]).
  Tessellation mesh;
  std::vector<uint32_t> triangle_face;   // per triangle: PartFace::face_index
  std::vector<int32_t> triangle_solid;   // per triangle: PartSolid::index, -1 outside every solid
  // Mesh edges (vertex pairs) on free B-rep edges, i.e. edges used by one face only: the model's real
  // boundary (an open shell's rim), never a crack.
  std::vector<std::array<uint32_t, 2>> boundary_edges;
  std::vector<PartFace> faces;
  std::vector<PartSolid> solids;
  int faces_tessellated = 0;
  int faces_skipped = 0;
  int faces_trimmed = 0;
  int edges = 0;                 // B-rep edges (degenerated ones included)
  uint64_t edge_vertices = 0;    // vertices on edges (B-rep vertices included)
  uint64_t unassigned_triangles = 0;  // a foreign mesh's triangles that lie on no single face
  // A foreign mesh's vertices closer than 1e-9 of the part were welded: the largest move. The
  // certificate of this PartMesh adds it to its bounds, so they hold for the mesh as it was read.
  double welded = 0.0;
  double seconds = 0.0;
};

// Reads a .step/.stp, .iges/.igs or .brep/.brp file and tessellates every face. Throws InputError
// (one line naming the file) for unreadable input, for a pn scheme and for parameters the scheme
// refuses. A face that cannot be converted is listed with its reason (faces_skipped), never dropped
// silently. Deterministic: the same input gives a bit-identical mesh with any number of threads.
PartMesh mesh_part_file(const std::string& path, const PartOptions& options);

// The same for an OCCT BREP text (FreeCAD: Part.Shape.exportBrepToString()); `name` names it in messages.
PartMesh mesh_part_brep_string(const std::string& brep_text, const std::string& name, const PartOptions& options);

// A compound of free faces (every edge on one face: FreeCAD's import of an IGES file) sewn as
// read_cad_shape sews an IGES file, in the same face order, as BREP text; any other shape's text
// (solids, shells, faces that share edges, fewer than two faces) is returned unchanged.
std::string sew_free_faces_brep_string(const std::string& brep_text, const std::string& name);

// Another mesher's mesh of the part, in the same form: OCCT's BRepMesh_IncrementalMesh with these
// options, each face's triangulation with its nodes' (U, V) (face_to_uv of the node's (u, v); boundary
// nodes at their loop points) and its loops' chords from the edges' polygons and p-curves, so that
// certify_part certifies it face by face exactly as it certifies our own (docs/CAD.md, "The peer on
// whole parts"). Nodes are merged by topology (a B-rep vertex, an edge's parameter), then by
// bit-identical position. PartMesh::seconds is BRepMesh's time alone. Faces that cannot be taken
// (no triangulation, no edge parameters, no Bézier form) are listed as skipped with the reason.
struct BRepMeshOptions {
  double deflection = 1e-3;  // linear deflection (model units, or relative to each edge's size)
  double angle = 0.5;        // angular deflection (radians)
  bool relative = false;
  bool parallel = true;
  bool solid_facts = true;   // as PartOptions::solid_facts
};
PartMesh brepmesh_part_file(const std::string& path, const BRepMeshOptions& options);
PartMesh brepmesh_part_brep_string(const std::string& brep_text, const std::string& name, const BRepMeshOptions& options);

// Any mesh of the part (read from an STL, OBJ or PLY: no (u, v), no face ids) in the same form: its
// vertices merged by bit-identical position, each found on the B-rep's edges (within 1e-6 of the part's
// size or twice the edge's tolerance of its 3D curve: the edge parameter) and faces (projected on the
// surface within the same tolerance and classified inside the face: the face's (u, v)); a triangle
// belongs to the face its three corners share (the nearest surface to its centroid when several do).
// A face whose edges have no mesh vertex at a B-rep vertex, or with a pole, is listed as skipped with
// the reason; triangles on no face are counted (PartMesh::unassigned_triangles).
PartMesh mesh_on_part_file(const std::string& path, const Tessellation& mesh, const std::string& mesh_name);
// The same for an OCCT BREP text (FreeCAD: a Mesh object against the Part it approximates).
PartMesh mesh_on_part_brep_string(const std::string& brep_text, const std::string& name, const Tessellation& mesh);

}  // namespace sagitta::occt
