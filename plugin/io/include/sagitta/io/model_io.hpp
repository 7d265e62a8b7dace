// Readers for patch files. Every reader throws sagitta::InputError with one line
// "FILE:LINE: problem" for malformed input; none modifies its input.
#pragma once

#include "sagitta/model.hpp"

#include <string>

namespace sagitta::io {

// .bpt: first line the patch count; per patch a line "n m" (degrees 1..25), then (n+1)(m+1)
// lines "x y z" (or "x y z w" for a rational patch, all points of the patch alike), row-major.
Model read_bpt(const std::string& path);
Model parse_bpt(const std::string& text, const std::string& name);

// RenderMan RIB: Patch "bicubic" / "bilinear" with "P" (or homogeneous "Pw"), under Basis "bezier"
// (the default), with TransformBegin/End, AttributeBegin/End, Identity, Translate, Rotate, Scale
// and ConcatTransform. Other requests are skipped; unsupported geometry is reported.
Model read_rib(const std::string& path);

// Chooses the reader by extension (.bpt, .rib). CAD files (.step, .iges, .brep) go through the
// OCCT adapter instead.
Model read_patch_model(const std::string& path);

// Reads a whole file; throws InputError naming it when it cannot be read.
std::string read_text_file(const std::string& path);

// The longest line a text input may have (.bpt, .rib, .obj, ASCII PLY and STL): far beyond any
// valid line (an OBJ n-gon of 5000 corners fits), small enough that junk is refused at once.
constexpr size_t kMaxLineBytes = 65536;
// The longest RIB token (a number, a name or a string).
constexpr size_t kMaxRibToken = 4096;

// The file name's extension in lower case with its dot (".obj"), or "" when it has none.
// Only the last path component counts: "dir.d/file" has none.
std::string file_extension(const std::string& path);

// True for the mesh types read_mesh / write_mesh handle: .obj, .ply, .stl (any case).
bool is_mesh_file(const std::string& path);

// Used by the readers above, exported for the tests and fuzzers only.
namespace detail {

// read_rib's parser on a text already in memory.
Model parse_rib(const std::string& text, const std::string& name);

// Reads a text input file, refusing it with "FILE:LINE: problem" as soon as a NUL byte or (when
// max_line > 0) a line longer than max_line bytes is read: /dev/zero or /dev/urandom given as an
// input are refused after one 64 KiB chunk instead of filling memory.
std::string read_text_input(const std::string& path, size_t max_line = kMaxLineBytes);

}  // namespace detail

}  // namespace sagitta::io
