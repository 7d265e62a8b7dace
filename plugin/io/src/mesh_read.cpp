// Mesh readers: OBJ, PLY (ASCII and binary) and STL (ASCII and binary). Each rejects malformed
// input with "FILE:LINE: problem" (or "FILE: problem" for binary data) and never modifies the file.
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/io/model_io.hpp"

#include "text_input.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <vector>

namespace sagitta::io {

namespace {

[[noreturn]] void fail(const std::string& name, size_t line, const std::string& problem) {
  throw InputError(line ? name + ":" + std::to_string(line) + ": " + problem : name + ": " + problem);
}

bool to_double(const std::string& s, double& out) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && errno != ERANGE && std::isfinite(out);
}

bool to_long(const std::string& s, long& out) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  out = std::strtol(s.c_str(), &end, 10);
  return end == s.c_str() + s.size() && errno != ERANGE;
}

void require_faces(const Tessellation& mesh, const std::string& name) {
  if (mesh.triangles.empty()) fail(name, 0, "the mesh has no faces");
  for (const Vec3& p : mesh.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) fail(name, 0, "a vertex is not finite");
  }
}

// Fan-triangulates a polygon given by vertex ids.
void add_polygon(Tessellation& mesh, const std::vector<uint32_t>& poly) {
  for (size_t k = 1; k + 1 < poly.size(); ++k) mesh.triangles.push_back({poly[0], poly[k], poly[k + 1]});
}

// An OBJ file as read: positions and normals in file order, and the corners of the faces.
struct ObjRecords {
  std::vector<Vec3> positions, normals;
  std::vector<std::pair<long, long>> corners;  // (position index, normal index or -1), 0-based
  std::vector<size_t> face_sizes;
};

// The rest of a "v" or "vn" line: 3 finite numbers.
void read_obj_vector(std::istringstream& s, const std::string& tag, ObjRecords& obj, const std::string& name,
                     size_t line_no) {
  double c[3];
  std::string f;
  for (double& x : c) {
    if (!(s >> f) || !to_double(f, x)) fail(name, line_no, "'" + tag + "' needs 3 finite numbers");
  }
  (tag == "v" ? obj.positions : obj.normals).emplace_back(c[0], c[1], c[2]);
}

// The rest of an "f" line: at least 3 corners "v", "v/t", "v//n" or "v/t/n", each index of a
// position or normal read so far (negative: counted back from the last one).
void read_obj_face(std::istringstream& s, ObjRecords& obj, const std::string& name, size_t line_no) {
  size_t count = 0;
  std::string corner;
  while (s >> corner) {
    const size_t s1 = corner.find('/');
    const size_t s2 = s1 == std::string::npos ? std::string::npos : corner.find('/', s1 + 1);
    long vi, ni = 0;
    if (!to_long(corner.substr(0, s1), vi)) fail(name, line_no, "bad face corner '" + corner + "'");
    if (s2 != std::string::npos && s2 + 1 < corner.size() && !to_long(corner.substr(s2 + 1), ni)) {
      fail(name, line_no, "bad normal index in '" + corner + "'");
    }
    const long nv = static_cast<long>(obj.positions.size()), nn = static_cast<long>(obj.normals.size());
    if (vi < 0) vi += nv + 1;
    if (vi < 1 || vi > nv) {
      fail(name, line_no,
           "vertex index " + corner.substr(0, s1) + " is out of range (" + std::to_string(nv) + " vertices so far)");
    }
    if (ni < 0) ni += nn + 1;
    if (ni != 0 && (ni < 1 || ni > nn)) fail(name, line_no, "normal index in '" + corner + "' is out of range");
    obj.corners.emplace_back(vi - 1, ni - 1);
    ++count;
  }
  if (count < 3) fail(name, line_no, "a face needs at least 3 vertices");
  obj.face_sizes.push_back(count);
}

// Reads the "v", "vn" and "f" lines; other lines, '#' comments and blank lines are skipped.
ObjRecords read_obj_records(const std::string& text, const std::string& name) {
  ObjRecords obj;
  size_t line_no = 0, pos = 0;
  while (pos < text.size()) {
    const size_t end = text.find('\n', pos);
    std::string line = text.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    pos = end == std::string::npos ? text.size() : end + 1;
    ++line_no;
    if (line.find('\0') != std::string::npos) fail(name, line_no, "contains a NUL byte (not a text OBJ file)");
    std::istringstream s(line.substr(0, line.find('#')));
    std::string tag;
    if (!(s >> tag)) continue;
    if (tag == "v" || tag == "vn") {
      read_obj_vector(s, tag, obj, name, line_no);
    } else if (tag == "f") {
      read_obj_face(s, obj, name, line_no);
    }
  }
  return obj;
}

// Fills the mesh's positions (and normals, when every corner has one) and returns the mesh vertex
// of every corner. Keeps the file's vertex numbering when every corner has a normal and each
// position has one normal (or when no corner has one); splits a position per distinct normal
// otherwise (creases).
std::vector<uint32_t> obj_vertices(const ObjRecords& obj, Tessellation& mesh) {
  const std::vector<Vec3>& positions = obj.positions;
  const std::vector<Vec3>& normals = obj.normals;
  const std::vector<std::pair<long, long>>& corners = obj.corners;
  std::vector<long> normal_of(positions.size(), -2);
  bool consistent = true, all_normals = true, any_normal = false;
  for (const auto& [v, n] : corners) {
    all_normals &= n >= 0;
    any_normal |= n >= 0;
    if (normal_of[static_cast<size_t>(v)] == -2) normal_of[static_cast<size_t>(v)] = n;
    consistent &= normal_of[static_cast<size_t>(v)] == n;
  }
  std::vector<uint32_t> ids;
  ids.reserve(corners.size());
  if (consistent && (all_normals || !any_normal)) {
    mesh.positions = positions;
    if (all_normals) {
      mesh.normals.assign(positions.size(), Vec3(0.0));
      for (const auto& [v, n] : corners) mesh.normals[static_cast<size_t>(v)] = normals[static_cast<size_t>(n)];
    }
    for (const auto& c : corners) ids.push_back(static_cast<uint32_t>(c.first));
  } else {
    std::map<std::pair<long, long>, uint32_t> vertex_of;
    for (const auto& c : corners) {
      auto [it, inserted] = vertex_of.emplace(c, static_cast<uint32_t>(mesh.positions.size()));
      if (inserted) {
        mesh.positions.push_back(positions[static_cast<size_t>(c.first)]);
        mesh.normals.push_back(c.second >= 0 ? normals[static_cast<size_t>(c.second)] : Vec3(0.0));
      }
      ids.push_back(it->second);
    }
    if (!all_normals) mesh.normals.clear();
  }
  return ids;
}

Tessellation parse_obj(const std::string& text, const std::string& name) {
  const ObjRecords obj = read_obj_records(text, name);
  if (obj.positions.empty()) fail(name, 0, "the mesh has no vertices");
  Tessellation mesh;
  const std::vector<uint32_t> ids = obj_vertices(obj, mesh);
  size_t at = 0;
  std::vector<uint32_t> poly;
  for (size_t size : obj.face_sizes) {  // fan-triangulated faces, in file order
    poly.assign(ids.begin() + static_cast<long>(at), ids.begin() + static_cast<long>(at + size));
    add_polygon(mesh, poly);
    at += size;
  }
  require_faces(mesh, name);
  return mesh;
}

struct PlyProperty {
  std::string name, type, count_type;  // count_type non-empty for lists
};
struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> props;
};

size_t ply_type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

class PlyValues {
 public:
  PlyValues(const std::string& text, size_t pos, int format, const std::string& name)
      : text_(text), pos_(pos), format_(format), name_(name) {}
  double next(const std::string& type) {
    if (format_ == 0) {
      while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
      size_t end = pos_;
      while (end < text_.size() && !std::isspace(static_cast<unsigned char>(text_[end]))) ++end;
      double d;
      if (!to_double(text_.substr(pos_, end - pos_), d)) fail(name_, 0, "bad or missing number in the PLY body");
      pos_ = end;
      return d;
    }
    const size_t size = ply_type_size(type);
    if (pos_ + size > text_.size()) fail(name_, 0, "the PLY body is truncated");
    unsigned char b[8];
    std::memcpy(b, text_.data() + pos_, size);
    pos_ += size;
    if (format_ == 2) std::reverse(b, b + size);
    auto get = [&](auto v) {
      std::memcpy(&v, b, sizeof v);
      return static_cast<double>(v);
    };
    if (type == "char" || type == "int8") return get(int8_t{});
    if (type == "uchar" || type == "uint8") return get(uint8_t{});
    if (type == "short" || type == "int16") return get(int16_t{});
    if (type == "ushort" || type == "uint16") return get(uint16_t{});
    if (type == "int" || type == "int32") return get(int32_t{});
    if (type == "uint" || type == "uint32") return get(uint32_t{});
    if (type == "float" || type == "float32") return get(float{});
    return get(double{});
  }

 private:
  const std::string& text_;
  size_t pos_;
  int format_;  // 0 ascii, 1 binary little endian, 2 binary big endian
  const std::string& name_;
};

// A PLY header: the body's format, the elements in file order and where the body starts.
struct PlyHeader {
  int format = -1;  // 0 ascii, 1 binary little endian, 2 binary big endian
  std::vector<PlyElement> elements;
  size_t body = 0;  // the first byte after the end_header line
};

// One header line: "format", "element" and "property" lines are read, other lines skipped.
void read_ply_header_line(const std::string& line, size_t line_no, PlyHeader& header, const std::string& name) {
  std::istringstream s(line);
  std::string tag;
  s >> tag;
  if (tag == "format") {
    std::string f;
    s >> f;
    header.format = f == "ascii" ? 0 : f == "binary_little_endian" ? 1 : f == "binary_big_endian" ? 2 : -1;
    if (header.format < 0) fail(name, line_no, "unknown PLY format '" + f + "'");
  } else if (tag == "element") {
    PlyElement e;
    long count;
    std::string c;
    s >> e.name >> c;
    if (!to_long(c, count) || count < 0) fail(name, line_no, "bad element count");
    e.count = static_cast<size_t>(count);
    header.elements.push_back(e);
  } else if (tag == "property") {
    if (header.elements.empty()) fail(name, line_no, "property before any element");
    PlyProperty p;
    s >> p.type;
    if (p.type == "list") s >> p.count_type >> p.type;
    s >> p.name;
    if (!ply_type_size(p.type) || (!p.count_type.empty() && !ply_type_size(p.count_type))) {
      fail(name, line_no, "unknown property type in '" + line + "'");
    }
    header.elements.back().props.push_back(p);
  }
}

// The header: from "ply" at the start of the file to the end_header line, with a format line.
PlyHeader read_ply_header(const std::string& text, const std::string& name) {
  const size_t header_end = text.find("end_header");
  if (text.compare(0, 3, "ply") != 0 || header_end == std::string::npos) fail(name, 1, "not a PLY file (no header)");
  std::istringstream lines(text.substr(0, header_end));
  PlyHeader header;
  std::string line;
  size_t line_no = 0;
  while (std::getline(lines, line)) read_ply_header_line(line, ++line_no, header, name);
  if (header.format < 0) fail(name, 0, "PLY header has no format line");
  size_t body = text.find('\n', header_end);
  header.body = body == std::string::npos ? text.size() : body + 1;
  return header;
}

// A list property of record k of element e: a face's vertex_indices (or vertex_index) become a
// fan of triangles over the vertices read so far; any other list is read and dropped.
void read_ply_list(const PlyElement& e, const PlyProperty& prop, size_t k, PlyValues& values, Tessellation& mesh,
                   const std::string& name) {
  const bool indices = e.name == "face" && (prop.name == "vertex_indices" || prop.name == "vertex_index");
  const double cnt = values.next(prop.count_type);
  if (cnt < 0 || cnt > 1e6) fail(name, 0, "bad list length in element " + e.name);
  std::vector<uint32_t> poly;
  for (int q = 0; q < static_cast<int>(cnt); ++q) {
    const double idx = values.next(prop.type);
    if (indices) {
      if (idx < 0 || idx >= static_cast<double>(mesh.positions.size())) {
        fail(name, 0,
             "face " + std::to_string(k) + " has vertex index " + std::to_string(static_cast<long>(idx)) +
                 " out of range (" + std::to_string(mesh.positions.size()) + " vertices)");
      }
      poly.push_back(static_cast<uint32_t>(idx));
    }
  }
  if (indices) {
    if (poly.size() < 3) fail(name, 0, "face " + std::to_string(k) + " has fewer than 3 vertices");
    add_polygon(mesh, poly);
  }
}

// The records of one element: a vertex appends its position (x, y, z required) and, when the
// element has nx, ny and nz, its normal; faces append triangles; other elements are read and dropped.
void read_ply_element(const PlyElement& e, size_t text_size, PlyValues& values, Tessellation& mesh,
                      const std::string& name) {
  if (e.count > text_size) {
    fail(name, 0, "element " + e.name + " count " + std::to_string(e.count) + " exceeds the file size");
  }
  const bool vertex = e.name == "vertex";
  bool has_normals = false;
  if (vertex) {
    auto has = [&](const char* n) {
      return std::any_of(e.props.begin(), e.props.end(), [&](const PlyProperty& p) { return p.name == n; });
    };
    if (!has("x") || !has("y") || !has("z")) fail(name, 0, "vertex element lacks x, y or z");
    has_normals = has("nx") && has("ny") && has("nz");
  }
  for (size_t k = 0; k < e.count; ++k) {
    Vec3 p(0.0), n(0.0);
    for (const PlyProperty& prop : e.props) {
      if (!prop.count_type.empty()) {
        read_ply_list(e, prop, k, values, mesh, name);
        continue;
      }
      const double x = values.next(prop.type);
      if (!std::isfinite(x)) fail(name, 0, "a " + e.name + " property is not finite");
      if (vertex) {
        if (prop.name == "x") p.x = x;
        if (prop.name == "y") p.y = x;
        if (prop.name == "z") p.z = x;
        if (prop.name == "nx") n.x = x;
        if (prop.name == "ny") n.y = x;
        if (prop.name == "nz") n.z = x;
      }
    }
    if (vertex) {
      mesh.positions.push_back(p);
      if (has_normals) mesh.normals.push_back(n);
    }
  }
}

Tessellation parse_ply(const std::string& text, const std::string& name) {
  const PlyHeader header = read_ply_header(text, name);
  PlyValues values(text, header.body, header.format, name);
  Tessellation mesh;
  for (const PlyElement& e : header.elements) read_ply_element(e, text.size(), values, mesh, name);
  require_faces(mesh, name);
  return mesh;
}

Tessellation parse_stl(const std::string& text, const std::string& name) {
  std::vector<Vec3> corners;
  const bool binary_size_ok = text.size() >= 84 && [&] {
    uint32_t n;
    std::memcpy(&n, text.data() + 80, 4);
    return text.size() == 84 + 50ull * n;
  }();
  if (binary_size_ok) {
    uint32_t n;
    std::memcpy(&n, text.data() + 80, 4);
    for (uint32_t t = 0; t < n; ++t) {
      for (int c = 0; c < 3; ++c) {
        float q[3];
        std::memcpy(q, text.data() + 84 + 50ull * t + 12 + 12 * c, 12);
        corners.emplace_back(q[0], q[1], q[2]);
      }
    }
  } else if (text.compare(0, 5, "solid") == 0) {
    std::istringstream s(text);
    std::string line;
    size_t line_no = 0;
    while (std::getline(s, line)) {
      ++line_no;
      std::istringstream f(line);
      std::string tag;
      f >> tag;
      if (tag != "vertex") continue;
      double c[3];
      std::string w;
      for (double& x : c) {
        if (!(f >> w) || !to_double(w, x)) fail(name, line_no, "'vertex' needs 3 finite numbers");
      }
      corners.emplace_back(c[0], c[1], c[2]);
    }
    if (corners.size() % 3) fail(name, 0, "ASCII STL has a facet without 3 vertices");
  } else {
    fail(name, 0, "not an STL file: binary size does not match its triangle count and no 'solid' header");
  }
  // STL stores corners per facet: identical positions (exact bits) are one vertex.
  Tessellation mesh;
  std::map<std::array<double, 3>, uint32_t> index;
  for (size_t k = 0; k < corners.size(); k += 3) {
    Triangle t;
    for (int c = 0; c < 3; ++c) {
      const Vec3& p = corners[k + static_cast<size_t>(c)];
      auto [it, inserted] = index.emplace(std::array<double, 3>{p.x, p.y, p.z}, static_cast<uint32_t>(mesh.positions.size()));
      if (inserted) mesh.positions.push_back(p);
      t[static_cast<size_t>(c)] = it->second;
    }
    mesh.triangles.push_back(t);
  }
  require_faces(mesh, name);
  return mesh;
}

}  // namespace

namespace {

// A PLY file: the header is text (it must start with "ply" and end within 1 MiB; NUL bytes and
// long lines are refused as they are read); an ASCII body is checked the same way, a binary body is read as it is.
std::string read_ply_file(const std::string& path) {
  detail::TextScanner scanner(path, kMaxLineBytes);
  size_t header_end = std::string::npos;
  bool binary = false;
  return detail::read_file_chunked(path, [&](const std::string& bytes) {
    if (bytes.compare(0, 3, "ply", 0, std::min<size_t>(3, bytes.size())) != 0) fail(path, 1, "not a PLY file (no header)");
    if (header_end == std::string::npos) {
      header_end = bytes.find("end_header");
      if (header_end != std::string::npos) {
        const size_t format = bytes.find("\nformat binary");
        binary = format != std::string::npos && format < header_end;
      } else {
        scanner.scan(bytes);
        if (bytes.size() > (1u << 20)) fail(path, 0, "no end_header in the first MiB (not a PLY header)");
        return;
      }
    }
    if (!binary) scanner.scan(bytes);
  });
}

// An STL file: binary (84 + 50 n bytes for n triangles) or ASCII ("solid" ...). Reading stops as
// soon as the bytes can be neither: past the binary size without a "solid" header, or, once past
// the binary size, at a NUL byte or an over-long line.
std::string read_stl_file(const std::string& path) {
  detail::TextScanner scanner(path, kMaxLineBytes);
  return detail::read_file_chunked(path, [&](const std::string& bytes) {
    if (bytes.size() < 84) return;
    uint32_t n;
    std::memcpy(&n, bytes.data() + 80, 4);
    if (bytes.size() <= 84 + 50ull * n) return;  // may still be binary
    if (bytes.compare(0, 5, "solid") != 0) {
      fail(path, 0, "not an STL file: binary size does not match its triangle count and no 'solid' header");
    }
    scanner.scan(bytes);
  });
}

}  // namespace

Tessellation read_mesh(const std::string& path) {
  const std::string ext = file_extension(path);
  if (!is_mesh_file(path)) {
    throw InputError(path + ": unknown mesh type (expected .obj, .ply or .stl)");
  }
  if (ext == ".ply") return detail::parse_mesh(read_ply_file(path), path, ext);
  if (ext == ".stl") return detail::parse_mesh(read_stl_file(path), path, ext);
  return detail::parse_mesh(detail::read_text_input(path), path, ext);
}

Tessellation detail::parse_mesh(const std::string& bytes, const std::string& name, const std::string& ext) {
  if (ext == ".obj") return parse_obj(bytes, name);
  if (ext == ".ply") return parse_ply(bytes, name);
  if (ext == ".stl") return parse_stl(bytes, name);
  throw InputError(name + ": unknown mesh type '" + ext + "' (expected .obj, .ply or .stl)");
}

}  // namespace sagitta::io
