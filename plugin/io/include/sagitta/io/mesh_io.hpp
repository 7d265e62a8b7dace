// Mesh files: OBJ, binary PLY and binary STL. Writers are atomic: they write a temporary file in
// the target's folder and rename it over the target only when everything was written.
#pragma once

#include "sagitta/tessellation.hpp"

#include <string>
#include <vector>

namespace sagitta::io {

struct MeshWriteOptions {
  bool normals = true;                   // OBJ "vn", PLY nx ny nz (STL always has facet normals)
  const std::vector<float>* face_error = nullptr;  // PLY: per-face "error" property
};

void write_ply(const Tessellation& mesh, const std::string& path, const MeshWriteOptions& options = {});
void write_stl(const Tessellation& mesh, const std::string& path, const MeshWriteOptions& options = {});
// By extension: .obj, .ply, .stl.
void write_mesh(const Tessellation& mesh, const std::string& path, const MeshWriteOptions& options = {});

// Reads a triangle mesh (polygons are fan-triangulated; OBJ "vn" kept when every corner has one and
// each vertex has a single normal, PLY nx/ny/nz kept). Positions, normals, triangles only.
Tessellation read_mesh(const std::string& path);

// Writes `bytes` to `path` atomically (temp file + rename). Throws InputError on failure and then
// leaves no temporary file. A new file gets mode 0666 minus the umask, a replaced one keeps its
// mode. SIGINT, SIGTERM and SIGHUP remove the temporary files of writes in progress and then take
// their default action (the handler is installed at the first write where the signal has its
// default disposition; a program with its own handler should call remove_temp_files from it).
void write_file_atomic(const std::string& path, const std::string& bytes);

// Unlinks the temporary file of every write_file_atomic in progress. Async-signal-safe.
void remove_temp_files() noexcept;

// Exported for the tests and fuzzers only.
namespace detail {

void write_obj(const Tessellation& mesh, const std::string& path, const MeshWriteOptions& options = {});
// read_mesh's parser on bytes already in memory; `ext` is ".obj", ".ply" or ".stl".
Tessellation parse_mesh(const std::string& bytes, const std::string& name, const std::string& ext);

}  // namespace detail

}  // namespace sagitta::io
