// Internal: the OCCT shapes behind the public CAD API (plugin/occt only).
#pragma once

#include "sagitta/occt/cad.hpp"

#include <TopoDS_Shape.hxx>

#include <string>

namespace sagitta::occt {

// The shape in a STEP / IGES / BREP file; throws InputError naming the file when it cannot be read.
TopoDS_Shape read_cad_shape(const std::string& path);
// The shape in a BREP text.
TopoDS_Shape read_brep_shape(const std::string& text, const std::string& name);
// Faces of the shape (TopExp::MapShapes order) as Bézier patches, with a report per face.
CadModel cad_model_from_shape(const TopoDS_Shape& shape, const std::string& name, const CadOptions& options);

}  // namespace sagitta::occt
