// Internal: the OCCT shapes behind the public CAD API (plugin/occt only).
#pragma once

#include "sagitta/occt/cad.hpp"
#include "sagitta/occt/part.hpp"

#include <Geom_BSplineSurface.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>

#include <string>

namespace sagitta::occt {

// The shape in a STEP / IGES / BREP file; throws InputError naming the file when it cannot be read.
TopoDS_Shape read_cad_shape(const std::string& path);
// A shape of free faces (no shell; IGES files often are) with its faces sewn where they meet, or the
// shape itself. Faces whose edges' 3D curves lie on the face to within 1e-6 of the shape's diagonal
// are sewn at that tolerance (a face whose edges lie further off stays free: sewing would move its
// boundary onto curves off it). The result is one shell holding every face in the shape's face order
// (the faces' names stay), or a solid, oriented outward, when every face was sewn into one closed
// shell.
TopoDS_Shape sew_free_faces(const TopoDS_Shape& shape);
// The shape in a BREP text.
TopoDS_Shape read_brep_shape(const std::string& text, const std::string& name);
// The surface under any rectangular trims (Geom_RectangularTrimmedSurface) of it.
Handle(Geom_Surface) untrimmed(Handle(Geom_Surface) surface);
// The face's surface (location applied), or, for an offset (OCCT's Geom_OffsetSurface, possibly
// rectangular-trimmed) of a plane, cylinder, cone, sphere or torus, the elementary surface it equals
// with the same (u, v) (Geom_OffsetSurface::Surface(), checked over the face's (u, v) bounds). An
// offset of anything else has no exact rational form and is returned as it is.
Handle(Geom_Surface) exact_surface(const TopoDS_Face& face);
// The face's Bézier patches (u reversed on a reversed face); empty when the face is skipped, with
// r.reason saying why. Sets r's surface type, breaks and (for a trimmed face) status "trimmed".
// `converted` (when given) receives the B-spline surface the patches split, in the breaks' parameters
// (null when the face's surface is a whole Bézier surface: then they are its own).
std::vector<BezierPatch> face_patches(const TopoDS_Face& face, const std::string& name, const CadOptions& options,
                                      FaceReport& r, Handle(Geom_BSplineSurface)* converted = nullptr);
// Faces of the shape (TopExp::MapShapes order) as Bézier patches, with a report per face.
CadModel cad_model_from_shape(const TopoDS_Shape& shape, const std::string& name, const CadOptions& options);
// The whole-part mesher on a shape already read (part.cpp; the benchmark times it without the reader).
PartMesh mesh_part_shape(const TopoDS_Shape& shape, const std::string& name, const PartOptions& options);

}  // namespace sagitta::occt
