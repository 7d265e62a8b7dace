#include "sagitta/io/model_io.hpp"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>

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

Model read_bpt(const std::string& path) { return parse_bpt(read_text_file(path), path); }

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

}  // namespace

Model parse_rib(const std::string& text, const std::string& name) {
  RibLexer lex(text, name);
  std::vector<glm::dmat4> stack;
  glm::dmat4 ctm(1.0);
  Model model;
  model.name = name;
  RibToken tok = lex.next();

  // Reads the numbers that follow a request, either bare or in one bracketed array.
  auto numbers = [&](size_t expected, const std::string& request, size_t line) {
    std::vector<double> out;
    tok = lex.next();
    const bool bracket = tok.kind == RibToken::kOpen;
    if (bracket) tok = lex.next();
    while (tok.kind == RibToken::kNumber) {
      out.push_back(tok.number);
      tok = lex.next();
    }
    if (bracket) {
      if (tok.kind != RibToken::kClose) fail(name, tok.line, request + ": missing ']'");
      tok = lex.next();
    }
    if (expected && out.size() != expected) {
      fail(name, line, request + " needs " + std::to_string(expected) + " numbers, got " + std::to_string(out.size()));
    }
    return out;
  };

  while (tok.kind != RibToken::kEnd) {
    if (tok.kind != RibToken::kIdent) {  // parameters of a skipped request
      tok = lex.next();
      continue;
    }
    const std::string req = tok.text;
    const size_t line = tok.line;
    if (req == "TransformBegin" || req == "AttributeBegin") {
      if (stack.size() > 10000) fail(name, line, req + " nested more than 10000 deep");
      stack.push_back(ctm);
      tok = lex.next();
    } else if (req == "TransformEnd" || req == "AttributeEnd") {
      if (stack.empty()) fail(name, line, req + " without a matching Begin");
      ctm = stack.back();
      stack.pop_back();
      tok = lex.next();
    } else if (req == "Identity") {
      ctm = glm::dmat4(1.0);
      tok = lex.next();
    } else if (req == "Translate") {
      const auto v = numbers(3, req, line);
      ctm = glm::translate(ctm, Vec3(v[0], v[1], v[2]));
    } else if (req == "Scale") {
      const auto v = numbers(3, req, line);
      ctm = glm::scale(ctm, Vec3(v[0], v[1], v[2]));
    } else if (req == "Rotate") {
      const auto v = numbers(4, req, line);
      const Vec3 axis(v[1], v[2], v[3]);
      if (axis == Vec3(0.0)) fail(name, line, "Rotate about a zero axis");
      ctm = glm::rotate(ctm, glm::radians(v[0]), axis);
    } else if (req == "ConcatTransform") {
      const auto v = numbers(16, req, line);
      glm::dmat4 m;
      for (int k = 0; k < 16; ++k) m[k / 4][k % 4] = v[static_cast<size_t>(k)];  // RIB rows are GLM columns
      ctm = ctm * m;
    } else if (req == "Basis") {
      tok = lex.next();
      if (tok.kind != RibToken::kString || tok.text != "bezier") fail(name, line, "only Basis \"bezier\" is supported");
      tok = lex.next();
      if (tok.kind == RibToken::kNumber) tok = lex.next();
      if (tok.kind != RibToken::kString || tok.text != "bezier") fail(name, line, "only Basis \"bezier\" is supported");
      tok = lex.next();
      if (tok.kind == RibToken::kNumber) tok = lex.next();
    } else if (req == "Patch") {
      tok = lex.next();
      if (tok.kind != RibToken::kString) fail(name, line, "Patch needs a type string");
      const std::string type = tok.text;
      int degree;
      if (type == "bicubic") degree = 3;
      else if (type == "bilinear") degree = 1;
      else fail(name, line, "Patch type \"" + excerpt(type) + "\" is not supported (bicubic, bilinear)");
      tok = lex.next();
      if (tok.kind != RibToken::kString || (tok.text != "P" && tok.text != "Pw")) {
        fail(name, line, "Patch needs \"P\" or \"Pw\" control points");
      }
      const bool homogeneous = tok.text == "Pw";
      const size_t count = static_cast<size_t>((degree + 1) * (degree + 1));
      const auto v = numbers(count * (homogeneous ? 4 : 3), "Patch \"" + type + "\"", line);
      BezierPatch patch;
      patch.degree_u = patch.degree_v = degree;
      patch.points.resize(count);
      if (homogeneous) patch.weights.resize(count);
      const int side = degree + 1;
      for (int j = 0; j < side; ++j) {    // RIB varies u fastest
        for (int i = 0; i < side; ++i) {
          const size_t k = static_cast<size_t>(j * side + i);
          const size_t arity = homogeneous ? 4 : 3;
          const double w = homogeneous ? v[k * arity + 3] : 1.0;
          if (!(w > 0.0)) fail(name, line, "Patch weight must be > 0");
          const glm::dvec4 p = ctm * glm::dvec4(v[k * arity] / w, v[k * arity + 1] / w, v[k * arity + 2] / w, 1.0);
          const Vec3 q = Vec3(p) / p.w;
          if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) {
            fail(name, line, "Patch control point is not finite after the transform");
          }
          patch.at(i, j) = q;
          if (homogeneous) patch.weights[static_cast<size_t>(i * side + j)] = w;
        }
      }
      model.patches.push_back(std::move(patch));
    } else if (req == "PatchMesh" || req == "NuPatch") {
      fail(name, line, req + " is not supported (use Patch \"bicubic\")");
    } else {
      tok = lex.next();  // skipped request; its parameters are skipped by the loop
    }
  }
  if (!stack.empty()) fail(name, tok.line, std::to_string(stack.size()) + " TransformBegin/AttributeBegin without End");
  if (model.patches.empty()) fail(name, tok.line, "the file has no Patch requests: the model is empty");
  validate_model(model, name);
  normalize_weights(model);
  return model;
}

Model read_rib(const std::string& path) { return parse_rib(read_text_file(path), path); }

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
