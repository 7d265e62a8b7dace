#include "sagitta/io/model_io.hpp"

#include "text_input.hpp"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

namespace sagitta::io {

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open for reading");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw InputError(path + ": read error");
  return s.str();
}

namespace detail {

void TextScanner::scan(const std::string& text) {
  for (; scanned_ < text.size(); ++scanned_) {
    const char c = text[scanned_];
    if (c == '\n') {
      ++line_;
      length_ = 0;
      continue;
    }
    if (c == '\0') throw InputError(name_ + ":" + std::to_string(line_) + ": contains a NUL byte (binary data, not a text file)");
    if (max_line_ && ++length_ > max_line_) {
      throw InputError(name_ + ":" + std::to_string(line_) + ": line longer than " + std::to_string(max_line_) +
                       " bytes (no valid line is that long)");
    }
  }
}

std::string read_file_chunked(const std::string& path, const std::function<void(const std::string&)>& after_chunk) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open for reading");
  std::string bytes;
  std::vector<char> chunk(65536);
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    const std::streamsize got = in.gcount();
    if (got <= 0) break;
    bytes.append(chunk.data(), static_cast<size_t>(got));
    after_chunk(bytes);
  }
  if (in.bad()) throw InputError(path + ": read error");
  return bytes;
}

}  // namespace detail

std::string detail::read_text_input(const std::string& path, size_t max_line) {
  detail::TextScanner scanner(path, max_line);
  return detail::read_file_chunked(path, [&](const std::string& bytes) { scanner.scan(bytes); });
}

namespace {

[[noreturn]] void fail(const std::string& name, size_t line, const std::string& problem) {
  throw InputError(name + ":" + std::to_string(line) + ": " + problem);
}

std::string excerpt(const std::string& s) {
  std::string out;
  for (char c : s.substr(0, 40)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  return s.size() > 40 ? out + "..." : out;
}

// Splits a line into whitespace-separated fields.
std::vector<std::string> fields(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream s(line);
  std::string f;
  while (s >> f) out.push_back(f);
  return out;
}

bool parse_double(const std::string& s, double& out) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && errno != ERANGE;
}

bool parse_int(const std::string& s, long& out) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  out = std::strtol(s.c_str(), &end, 10);
  return end == s.c_str() + s.size() && errno != ERANGE;
}

double finite_number(const std::string& name, size_t line, const std::string& s) {
  double d;
  if (!parse_double(s, d)) fail(name, line, "'" + excerpt(s) + "' is not a number");
  if (!std::isfinite(d)) fail(name, line, "'" + excerpt(s) + "' is not a finite number");
  return d;
}

// Line cursor that skips blank lines and '#' comments.
struct Lines {
  const std::string& text;
  size_t pos = 0;
  size_t number = 0;
  bool next(std::vector<std::string>& out) {
    while (pos < text.size()) {
      const size_t end = text.find('\n', pos);
      const std::string line = text.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
      pos = end == std::string::npos ? text.size() : end + 1;
      ++number;
      if (line.find('\0') != std::string::npos) {
        throw InputError("line " + std::to_string(number) + ": contains a NUL byte (binary data?)");
      }
      out = fields(line.substr(0, line.find('#')));
      if (!out.empty()) return true;
    }
    return false;
  }
};

}  // namespace

Model parse_bpt(const std::string& text, const std::string& name) {
  Lines lines{text};
  std::vector<std::string> f;
  auto next = [&](const std::string& expecting) {
    bool ok;
    try {
      ok = lines.next(f);
    } catch (const InputError& e) {
      throw InputError(name + ":" + std::string(e.what()).substr(5));
    }
    if (!ok) fail(name, lines.number, "file ends early: expected " + expecting);
  };
  next("the patch count");
  long count;
  if (f.size() != 1 || !parse_int(f[0], count)) fail(name, lines.number, "first line must be the patch count");
  if (count <= 0) fail(name, lines.number, "the model is empty (patch count " + std::to_string(count) + ")");
  if (count > 50'000'000) fail(name, lines.number, "patch count " + std::to_string(count) + " is implausibly large");
  Model model;
  model.name = name;
  model.patches.reserve(static_cast<size_t>(std::min<long>(count, 1'000'000)));
  for (long p = 0; p < count; ++p) {
    const std::string which = "patch " + std::to_string(p) + " of " + std::to_string(count);
    next("the degree line \"n m\" of " + which);
    long n, m;
    if (f.size() != 2 || !parse_int(f[0], n) || !parse_int(f[1], m)) {
      fail(name, lines.number, "expected the degree line \"n m\" of " + which + ", got '" + excerpt(f[0]) + "...'");
    }
    if (n < 1 || n > kMaxDegree || m < 1 || m > kMaxDegree) {
      fail(name, lines.number, which + " has degree " + std::to_string(n) + "x" + std::to_string(m) +
                                   ", outside 1.." + std::to_string(kMaxDegree));
    }
    BezierPatch patch;
    patch.degree_u = static_cast<int>(n);
    patch.degree_v = static_cast<int>(m);
    const int points = patch.rows() * patch.cols();
    size_t arity = 0;
    for (int k = 0; k < points; ++k) {
      next("control point " + std::to_string(k) + " of " + which);
      if (arity == 0) arity = f.size();
      if ((f.size() != 3 && f.size() != 4) || f.size() != arity) {
        fail(name, lines.number, "control point " + std::to_string(k) + " of " + which + " needs " +
                                     (arity == 4 ? "4 numbers \"x y z w\"" : "3 numbers \"x y z\"") + ", got " +
                                     std::to_string(f.size()));
      }
      patch.points.emplace_back(finite_number(name, lines.number, f[0]), finite_number(name, lines.number, f[1]),
                                finite_number(name, lines.number, f[2]));
      if (arity == 4) {
        const double w = finite_number(name, lines.number, f[3]);
        if (!(w > 0.0)) fail(name, lines.number, "weight " + excerpt(f[3]) + " must be > 0");
        patch.weights.push_back(w);
      }
    }
    model.patches.push_back(std::move(patch));
  }
  if (lines.next(f)) fail(name, lines.number, "unexpected content after the last of " + std::to_string(count) + " patches");
  validate_model(model, name);
  normalize_weights(model);
  return model;
}

Model read_bpt(const std::string& path) { return parse_bpt(detail::read_text_input(path), path); }

namespace {

// RIB tokens: strings, numbers, '[' and ']', and bare identifiers; '#' comments to end of line.
struct RibToken {
  enum Kind { kIdent, kString, kNumber, kOpen, kClose, kEnd } kind = kEnd;
  std::string text;
  double number = 0.0;
  size_t line = 0;
};

class RibLexer {
 public:
  RibLexer(const std::string& text, const std::string& name) : text_(text), name_(name) {}
  RibToken next() {
    skip();
    RibToken t;
    t.line = line_;
    if (pos_ >= text_.size()) return t;
    const char c = text_[pos_];
    if (c == '[') { ++pos_; t.kind = RibToken::kOpen; return t; }
    if (c == ']') { ++pos_; t.kind = RibToken::kClose; return t; }
    if (c == '"') {
      const size_t end = text_.find('"', pos_ + 1);
      if (end == std::string::npos) fail(name_, line_, "unterminated string");
      if (end - pos_ - 1 > kMaxRibToken) fail(name_, line_, "string longer than " + std::to_string(kMaxRibToken) + " bytes");
      t.kind = RibToken::kString;
      t.text = text_.substr(pos_ + 1, end - pos_ - 1);
      for (char q : t.text) line_ += q == '\n';
      pos_ = end + 1;
      return t;
    }
    size_t end = pos_;
    while (end < text_.size() && !std::isspace(static_cast<unsigned char>(text_[end])) && text_[end] != '[' &&
           text_[end] != ']' && text_[end] != '"' && text_[end] != '#') {
      ++end;
    }
    if (end - pos_ > kMaxRibToken) fail(name_, line_, "token longer than " + std::to_string(kMaxRibToken) + " bytes");
    t.text = text_.substr(pos_, end - pos_);
    pos_ = end;
    if (std::isalpha(static_cast<unsigned char>(t.text[0])) && t.text != "nan" && t.text != "inf") {
      t.kind = RibToken::kIdent;
      return t;
    }
    t.kind = RibToken::kNumber;
    t.number = finite_number(name_, t.line, t.text);
    return t;
  }

 private:
  void skip() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') { ++line_; ++pos_; }
      else if (std::isspace(static_cast<unsigned char>(c))) ++pos_;
      else if (c == '#') { while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_; }
      else if (c == '\0') fail(name_, line_, "contains a NUL byte (binary RIB is not supported)");
      else break;
    }
  }
  const std::string& text_;
  const std::string& name_;
  size_t pos_ = 0;
  size_t line_ = 1;
};

// m with each column scaled to length 1: its determinant has the sign of m's and |det| <= 1
// (Hadamard's bound), without under- or overflow. Returns false for a zero or non-finite column.
bool unit_columns(const glm::dmat4& m, glm::dmat4& unit) {
  for (int c = 0; c < 4; ++c) {
    double largest = 0.0;  // scaled by its largest entry first, so the length cannot overflow
    for (int k = 0; k < 4; ++k) largest = std::max(largest, std::abs(m[c][k]));
    if (!std::isfinite(largest) || !(largest > 0.0)) return false;
    unit[c] = glm::normalize(m[c] / largest);
  }
  return true;
}

// True when a 4x4 matrix is singular up to rounding (|det| <= 1e-12 with unit columns) or not finite.
bool singular(const glm::dmat4& m) {
  glm::dmat4 unit;
  return !unit_columns(m, unit) || !(std::abs(glm::determinant(unit)) > 1e-12);
}

// True when a regular matrix reverses handedness (negative determinant).
bool mirrors(const glm::dmat4& m) {
  glm::dmat4 unit;
  return unit_columns(m, unit) && glm::determinant(unit) < 0.0;
}

// Orientation (RenderMan Interface Specification 3.2, section 4.2.14): the initial coordinate
// system is left-handed and so is the initial current orientation; a transform with a negative
// determinant flips both, so whether they match changes only by ReverseOrientation and
// Orientation. Where they match, the outside normal is dPdu x dPdv computed in object
// coordinates; it is flipped where they do not.
struct RibState {
  glm::dmat4 ctm{1.0};
  bool orientation_matches = true;
};

// One request: its name and the line it starts on (where its problems are reported).
struct RibRequest {
  std::string name;
  size_t line = 0;
};

// The statement reader: the current token, and the numbers that follow a request.
struct RibInput {
  RibInput(const std::string& text, const std::string& file) : lex(text, file), name(file), tok(lex.next()) {}
  void advance() { tok = lex.next(); }

  // Reads the numbers that follow a request, either bare or in one bracketed array; with
  // `expected` non-zero, any other count is refused (after the array is read).
  std::vector<double> numbers(size_t expected, const std::string& request, size_t line) {
    std::vector<double> out;
    advance();
    const bool bracket = tok.kind == RibToken::kOpen;
    if (bracket) advance();
    while (tok.kind == RibToken::kNumber) {
      out.push_back(tok.number);
      advance();
    }
    if (bracket) {
      if (tok.kind != RibToken::kClose) fail(name, tok.line, request + ": missing ']'");
      advance();
    }
    if (expected && out.size() != expected) {
      fail(name, line, request + " needs " + std::to_string(expected) + " numbers, got " + std::to_string(out.size()));
    }
    return out;
  }

  RibLexer lex;
  const std::string& name;
  RibToken tok;  // the current token
};

// What the requests build: the graphics state, the states saved by the open Begin requests, the patches.
struct RibScene {
  RibState state;
  std::vector<RibState> stack;
  Model model;
};

// TransformBegin/AttributeBegin save the state; TransformEnd restores the transformation and
// AttributeEnd also the orientation (an attribute).
void block_request(RibInput& in, const RibRequest& req, RibScene& scene) {
  const std::string& r = req.name;
  if (r == "TransformBegin" || r == "AttributeBegin") {
    if (scene.stack.size() > 10000) fail(in.name, req.line, r + " nested more than 10000 deep");
    scene.stack.push_back(scene.state);
  } else {
    if (scene.stack.empty()) fail(in.name, req.line, r + " without a matching Begin");
    scene.state.ctm = scene.stack.back().ctm;
    if (r == "AttributeEnd") scene.state.orientation_matches = scene.stack.back().orientation_matches;  // an attribute
    scene.stack.pop_back();
  }
  in.advance();
}

// Every transform request leaves a regular current transformation, or the file is refused.
void set_ctm(const RibInput& in, const RibRequest& req, RibState& state, const glm::dmat4& m) {
  if (singular(m)) fail(in.name, req.line, req.name + " makes the transformation singular (or not finite)");
  state.ctm = m;
}

// Identity, Translate, Scale, Rotate, ConcatTransform and Transform.
void transform_request(RibInput& in, const RibRequest& req, RibState& state) {
  const std::string& r = req.name;
  const glm::dmat4& ctm = state.ctm;
  if (r == "Identity") {
    state.ctm = glm::dmat4(1.0);
    in.advance();
  } else if (r == "Translate") {
    const auto v = in.numbers(3, r, req.line);
    set_ctm(in, req, state, glm::translate(ctm, Vec3(v[0], v[1], v[2])));
  } else if (r == "Scale") {
    const auto v = in.numbers(3, r, req.line);
    if (v[0] == 0.0 || v[1] == 0.0 || v[2] == 0.0) {
      fail(in.name, req.line, "Scale by zero makes the transformation singular");
    }
    set_ctm(in, req, state, glm::scale(ctm, Vec3(v[0], v[1], v[2])));
  } else if (r == "Rotate") {
    const auto v = in.numbers(4, r, req.line);
    const Vec3 axis(v[1], v[2], v[3]);
    if (axis == Vec3(0.0)) fail(in.name, req.line, "Rotate about a zero axis");
    set_ctm(in, req, state, glm::rotate(ctm, glm::radians(v[0]), axis));
  } else {  // ConcatTransform or Transform
    const auto v = in.numbers(16, r, req.line);
    glm::dmat4 m;
    for (int k = 0; k < 16; ++k) m[k / 4][k % 4] = v[static_cast<size_t>(k)];  // RIB rows are GLM columns
    if (singular(m)) fail(in.name, req.line, r + " matrix is singular");
    set_ctm(in, req, state, r == "Transform" ? m : ctm * m);  // Transform replaces the current transformation
  }
}

// ReverseOrientation and Orientation "outside" | "inside" | "lh" | "rh".
void orientation_request(RibInput& in, const RibRequest& req, RibState& state) {
  if (req.name == "ReverseOrientation") {
    state.orientation_matches = !state.orientation_matches;
    in.advance();
    return;
  }
  in.advance();
  const RibToken& tok = in.tok;
  const bool left_handed_system = !mirrors(state.ctm);  // the initial system is left-handed
  if (tok.kind == RibToken::kString && tok.text == "outside") {
    state.orientation_matches = true;
  } else if (tok.kind == RibToken::kString && tok.text == "inside") {
    state.orientation_matches = false;
  } else if (tok.kind == RibToken::kString && tok.text == "lh") {
    state.orientation_matches = left_handed_system;
  } else if (tok.kind == RibToken::kString && tok.text == "rh") {
    state.orientation_matches = !left_handed_system;
  } else {
    fail(in.name, req.line, "Orientation must be \"outside\", \"inside\", \"lh\" or \"rh\"");
  }
  in.advance();
}

// Basis "bezier" [step] "bezier" [step]: the only basis accepted.
void basis_request(RibInput& in, const RibRequest& req) {
  in.advance();
  if (in.tok.kind != RibToken::kString || in.tok.text != "bezier") {
    fail(in.name, req.line, "only Basis \"bezier\" is supported");
  }
  in.advance();
  if (in.tok.kind == RibToken::kNumber) in.advance();
  if (in.tok.kind != RibToken::kString || in.tok.text != "bezier") {
    fail(in.name, req.line, "only Basis \"bezier\" is supported");
  }
  in.advance();
  if (in.tok.kind == RibToken::kNumber) in.advance();
}

// The control points of one Patch request as read: u varies fastest; 3 numbers a point, 4 with "Pw".
struct RibPatchPoints {
  int degree = 0;
  bool homogeneous = false;
  std::vector<double> v;
};

// Patch "bicubic" | "bilinear", "P" | "Pw", then the points.
RibPatchPoints read_patch_points(RibInput& in, const RibRequest& req) {
  in.advance();
  if (in.tok.kind != RibToken::kString) fail(in.name, req.line, "Patch needs a type string");
  const std::string type = in.tok.text;
  RibPatchPoints points;
  if (type == "bicubic") {
    points.degree = 3;
  } else if (type == "bilinear") {
    points.degree = 1;
  } else {
    fail(in.name, req.line, "Patch type \"" + excerpt(type) + "\" is not supported (bicubic, bilinear)");
  }
  in.advance();
  if (in.tok.kind != RibToken::kString || (in.tok.text != "P" && in.tok.text != "Pw")) {
    fail(in.name, req.line, "Patch needs \"P\" or \"Pw\" control points");
  }
  points.homogeneous = in.tok.text == "Pw";
  const size_t count = static_cast<size_t>((points.degree + 1) * (points.degree + 1));
  points.v = in.numbers(count * (points.homogeneous ? 4 : 3), "Patch \"" + type + "\"", req.line);
  return points;
}

// The patch in world coordinates, oriented so that du x dv points outside.
BezierPatch patch_request(RibInput& in, const RibRequest& req, const RibState& state) {
  const RibPatchPoints points = read_patch_points(in, req);
  const int degree = points.degree;
  const bool homogeneous = points.homogeneous;
  const std::vector<double>& v = points.v;
  const glm::dmat4& ctm = state.ctm;
  const size_t count = static_cast<size_t>((degree + 1) * (degree + 1));
  BezierPatch patch;
  patch.degree_u = patch.degree_v = degree;
  patch.points.resize(count);
  if (homogeneous) patch.weights.resize(count);
  const int side = degree + 1;
  // du x dv of the stored patch points outside: reverse u where RenderMan flips the normal
  // (orientation not matching the coordinate system) or the transform mirrors (determinant < 0).
  const bool reverse_u = mirrors(ctm) != !state.orientation_matches;
  for (int j = 0; j < side; ++j) {  // RIB varies u fastest
    for (int i0 = 0; i0 < side; ++i0) {
      const int i = reverse_u ? degree - i0 : i0;
      const size_t k = static_cast<size_t>(j * side + i0);
      const size_t arity = homogeneous ? 4 : 3;
      const double w = homogeneous ? v[k * arity + 3] : 1.0;
      if (!(w > 0.0)) fail(in.name, req.line, "Patch weight must be > 0");
      const glm::dvec4 p = ctm * glm::dvec4(v[k * arity] / w, v[k * arity + 1] / w, v[k * arity + 2] / w, 1.0);
      const Vec3 q = Vec3(p) / p.w;
      if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) {
        fail(in.name, req.line, "Patch control point is not finite after the transform");
      }
      patch.at(i, j) = q;
      if (homogeneous) patch.weights[static_cast<size_t>(i * side + j)] = w;
    }
  }
  return patch;
}

// Dispatches one request (the current token, an identifier) and leaves the input at the token after it.
void rib_request(RibInput& in, RibScene& scene) {
  const RibRequest req{in.tok.text, in.tok.line};
  const std::string& r = req.name;
  if (r == "TransformBegin" || r == "AttributeBegin" || r == "TransformEnd" || r == "AttributeEnd") {
    block_request(in, req, scene);
  } else if (r == "Identity" || r == "Translate" || r == "Scale" || r == "Rotate" || r == "ConcatTransform" ||
             r == "Transform") {
    transform_request(in, req, scene.state);
  } else if (r == "ReverseOrientation" || r == "Orientation") {
    orientation_request(in, req, scene.state);
  } else if (r == "ObjectBegin" || r == "ObjectInstance" || r == "MotionBegin" || r == "Skew" || r == "Perspective" ||
             r == "CoordSysTransform" || r == "ReadArchive" || r == "Procedural") {
    fail(in.name, req.line, r + " is not supported (it would place or add geometry this reader cannot follow)");
  } else if (r == "Basis") {
    basis_request(in, req);
  } else if (r == "Patch") {
    scene.model.patches.push_back(patch_request(in, req, scene.state));
  } else if (r == "PatchMesh" || r == "NuPatch") {
    fail(in.name, req.line, r + " is not supported (use Patch \"bicubic\")");
  } else {
    in.advance();  // skipped request; its parameters are skipped by the loop
  }
}

}  // namespace

Model detail::parse_rib(const std::string& text, const std::string& name) {
  RibInput in(text, name);
  RibScene scene;
  scene.model.name = name;
  while (in.tok.kind != RibToken::kEnd) {
    if (in.tok.kind != RibToken::kIdent) {  // parameters of a skipped request
      in.advance();
      continue;
    }
    rib_request(in, scene);
  }
  if (!scene.stack.empty()) {
    fail(name, in.tok.line, std::to_string(scene.stack.size()) + " TransformBegin/AttributeBegin without End");
  }
  if (scene.model.patches.empty()) fail(name, in.tok.line, "the file has no Patch requests: the model is empty");
  validate_model(scene.model, name);
  normalize_weights(scene.model);
  return std::move(scene.model);
}

Model read_rib(const std::string& path) { return detail::parse_rib(detail::read_text_input(path), path); }

std::string file_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

bool is_mesh_file(const std::string& path) {
  const std::string ext = file_extension(path);
  return ext == ".obj" || ext == ".ply" || ext == ".stl";
}

Model read_patch_model(const std::string& path) {
  const std::string ext = file_extension(path);
  if (ext == ".bpt") return read_bpt(path);
  if (ext == ".rib") return read_rib(path);
  throw InputError(path + ": unknown patch file type (expected .bpt or .rib)");
}

}  // namespace sagitta::io
