#include "server/geometry/mesh_io.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <random>
#include <sstream>
#include <unistd.h>
#include <unordered_map>

#include <fmt/format.h>

namespace touchmend::geometry {
namespace {

// ---------------------------------------------------------------------------------------
// Small text scanner: whitespace-separated tokens with line numbers.
class TextScanner {
 public:
  explicit TextScanner(std::string_view text) : text_(text) {}

  //! Next token on the current line, or empty when the line is exhausted.
  std::string_view token_on_line() {
    while (pos_ < text_.size() &&
           (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\r'))
      ++pos_;
    if (pos_ >= text_.size() || text_[pos_] == '\n') return {};
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    return text_.substr(start, pos_ - start);
  }

  //! Next token anywhere (crossing lines), skipping '#' comments; empty at end of input.
  std::string_view token() {
    for (;;) {
      while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
        if (text_[pos_] == '\n') ++line_;
        ++pos_;
      }
      if (pos_ >= text_.size()) return {};
      if (text_[pos_] == '#') {
        skip_line();
        continue;
      }
      const std::size_t start = pos_;
      while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
      return text_.substr(start, pos_ - start);
    }
  }

  void skip_line() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    if (pos_ < text_.size()) {
      ++pos_;
      ++line_;
    }
  }

  bool at_end() const { return pos_ >= text_.size(); }
  std::size_t line() const { return line_; }
  std::size_t position() const { return pos_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 1;
};

bool parse_double(std::string_view token, double& value) {
  if (token.empty()) return false;
  if (token.front() == '+') token.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && ptr == token.data() + token.size();
}

bool parse_int(std::string_view token, long long& value) {
  if (token.empty()) return false;
  if (token.front() == '+') token.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && ptr == token.data() + token.size();
}

std::string printable(std::string_view token) {
  std::string out;
  for (char c : token.substr(0, 32)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  if (token.size() > 32) out += "...";
  return out;
}

ReadResult fail(std::string message) {
  ReadResult r;
  r.error = std::move(message);
  return r;
}

//! Adds a polygon as a triangle fan; counts polygons with more than three corners.
void add_polygon(const std::vector<std::uint32_t>& corners, ReadResult& r) {
  for (std::size_t i = 1; i + 1 < corners.size(); ++i)
    r.soup.triangles.push_back({corners[0], corners[i], corners[i + 1]});
  if (corners.size() > 3) ++r.report.polygons_triangulated;
}

std::string check_finite(const Vec3& p, std::size_t index, std::size_t line) {
  if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) return {};
  return fmt::format(
      "vertex {} (line {}) has a non-finite coordinate ({} {} {}): NaN and "
      "infinity are not valid positions",
      index, line, p[0], p[1], p[2]);
}

// ---------------------------------------------------------------------------------------
// OFF
ReadResult parse_off(std::string_view text, const ReadOptions& options) {
  TextScanner in(text);
  std::string_view magic = in.token();
  if (magic.empty()) return fail("OFF: the file is empty");
  // Accept the common header variants (OFF, COFF, NOFF, CNOFF, ...), but only the 3D form.
  if (magic.size() < 3 || magic.substr(magic.size() - 3) != "OFF")
    return fail(
        fmt::format("OFF: expected the keyword 'OFF' on line 1, found '{}'", printable(magic)));
  if (magic.find('4') != std::string_view::npos || magic.find('n') != std::string_view::npos)
    return fail("OFF: only 3D OFF is supported (no 4OFF/nOFF)");
  long long counts[3];
  for (long long& c : counts) {
    const std::string_view tok = in.token();
    if (!parse_int(tok, c) || c < 0)
      return fail(fmt::format("OFF: line {}: expected the vertex/face/edge counts, found '{}'",
                              in.line(), printable(tok)));
  }
  const auto n_vertices = static_cast<std::size_t>(counts[0]);
  const auto n_faces = static_cast<std::size_t>(counts[1]);
  if (n_vertices > options.max_elements || n_faces > options.max_elements)
    return fail(
        fmt::format("OFF: the header declares {} vertices and {} faces, above the limit "
                    "of {} elements",
                    n_vertices, n_faces, options.max_elements));
  // A declared count cannot exceed what the bytes could hold (at least 2 bytes per number).
  if (n_vertices > text.size() / 6 + 1 || n_faces > text.size() / 8 + 1)
    return fail(
        fmt::format("OFF: the header declares {} vertices and {} faces, more than a "
                    "{}-byte file can hold (truncated file?)",
                    n_vertices, n_faces, text.size()));
  ReadResult r;
  r.report.format = MeshFormat::Off;
  r.soup.points.reserve(n_vertices);
  for (std::size_t i = 0; i < n_vertices; ++i) {
    in.skip_line();  // each vertex starts a line; extra columns (colours) are ignored
    Vec3 p;
    for (int k = 0; k < 3; ++k) {
      std::string_view tok = in.token_on_line();
      while (tok.empty() && !in.at_end()) {  // blank or comment lines between records
        in.skip_line();
        tok = in.token_on_line();
        if (!tok.empty() && tok.front() == '#') {
          tok = {};
        }
      }
      if (tok.empty())
        return fail(fmt::format("OFF: the file ends after {} of {} vertices (truncated file)", i,
                                n_vertices));
      if (!parse_double(tok, p[k]))
        return fail(fmt::format("OFF: line {}: vertex {} has an invalid coordinate '{}'", in.line(),
                                i, printable(tok)));
    }
    if (auto e = check_finite(p, i, in.line()); !e.empty()) return fail("OFF: " + e);
    r.soup.points.push_back(p);
  }
  std::vector<std::uint32_t> corners;
  for (std::size_t f = 0; f < n_faces; ++f) {
    in.skip_line();
    std::string_view tok = in.token_on_line();
    while ((tok.empty() || tok.front() == '#') && !in.at_end()) {
      in.skip_line();
      tok = in.token_on_line();
    }
    long long n = 0;
    if (tok.empty())
      return fail(
          fmt::format("OFF: the file ends after {} of {} faces (truncated file)", f, n_faces));
    if (!parse_int(tok, n) || n < 3 || n > 1'000'000)
      return fail(fmt::format("OFF: line {}: face {} has an invalid corner count '{}'", in.line(),
                              f, printable(tok)));
    corners.clear();
    for (long long k = 0; k < n; ++k) {
      tok = in.token_on_line();
      long long idx = 0;
      if (tok.empty())
        return fail(fmt::format("OFF: line {}: face {} declares {} corners but lists {}", in.line(),
                                f, n, k));
      if (!parse_int(tok, idx))
        return fail(fmt::format("OFF: line {}: face {} has an invalid vertex index '{}'", in.line(),
                                f, printable(tok)));
      if (idx < 0 || static_cast<std::size_t>(idx) >= n_vertices)
        return fail(
            fmt::format("OFF: line {}: face {} references vertex {}, but the file has "
                        "only {} vertices (0..{})",
                        in.line(), f, idx, n_vertices, n_vertices == 0 ? 0 : n_vertices - 1));
      corners.push_back(static_cast<std::uint32_t>(idx));
    }
    add_polygon(corners, r);
  }
  r.ok = true;
  return r;
}

// ---------------------------------------------------------------------------------------
// OBJ (geometry only: v and f records; texture and normal indices are accepted and ignored)
ReadResult parse_obj(std::string_view text, const ReadOptions& options) {
  if (text.empty()) return fail("OBJ: the file is empty");
  TextScanner in(text);
  ReadResult r;
  r.report.format = MeshFormat::Obj;
  std::vector<std::uint32_t> corners;
  struct PendingFace {
    std::vector<long long> idx;
    std::size_t line;
  };
  std::vector<PendingFace> faces;  // resolved after all vertices are known
  bool first = true;
  while (!in.at_end()) {
    if (!first) in.skip_line();
    first = false;
    const std::string_view key = in.token_on_line();
    if (key == "v") {
      Vec3 p;
      for (int k = 0; k < 3; ++k) {
        const std::string_view tok = in.token_on_line();
        if (!parse_double(tok, p[k]))
          return fail(fmt::format("OBJ: line {}: vertex {} has an invalid coordinate '{}'",
                                  in.line(), r.soup.points.size() + 1, printable(tok)));
      }
      if (auto e = check_finite(p, r.soup.points.size(), in.line()); !e.empty())
        return fail("OBJ: " + e);
      if (r.soup.points.size() >= options.max_elements)
        return fail(fmt::format("OBJ: more than {} vertices", options.max_elements));
      r.soup.points.push_back(p);
    } else if (key == "f") {
      PendingFace face{{}, in.line()};
      for (std::string_view tok = in.token_on_line(); !tok.empty(); tok = in.token_on_line()) {
        const std::string_view head = tok.substr(0, tok.find('/'));
        long long idx = 0;
        if (!parse_int(head, idx) || idx == 0)
          return fail(fmt::format("OBJ: line {}: invalid vertex reference '{}'", in.line(),
                                  printable(tok)));
        // Negative indices count back from the last vertex defined so far.
        if (idx < 0) idx = static_cast<long long>(r.soup.points.size()) + idx + 1;
        face.idx.push_back(idx);
      }
      if (face.idx.size() < 3)
        return fail(fmt::format("OBJ: line {}: a face needs at least 3 corners, found {}",
                                in.line(), face.idx.size()));
      if (faces.size() >= options.max_elements)
        return fail(fmt::format("OBJ: more than {} faces", options.max_elements));
      faces.push_back(std::move(face));
    }
    // Every other record (vt, vn, g, o, s, usemtl, mtllib, comments) carries no geometry.
  }
  for (const PendingFace& face : faces) {
    corners.clear();
    for (long long idx : face.idx) {
      if (idx < 1 || static_cast<std::size_t>(idx) > r.soup.points.size())
        return fail(
            fmt::format("OBJ: line {}: face references vertex {}, but the file has only "
                        "{} vertices (1..{})",
                        face.line, idx, r.soup.points.size(), r.soup.points.size()));
      corners.push_back(static_cast<std::uint32_t>(idx - 1));
    }
    add_polygon(corners, r);
  }
  if (r.soup.points.empty()) return fail("OBJ: the file has no vertices ('v' records)");
  r.ok = true;
  return r;
}

// ---------------------------------------------------------------------------------------
// PLY
enum class PlyType { Int8, Uint8, Int16, Uint16, Int32, Uint32, Float32, Float64 };

bool ply_type(std::string_view name, PlyType& t) {
  static constexpr std::pair<std::string_view, PlyType> kTypes[] = {
      {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::Uint8},
      {"uint8", PlyType::Uint8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
      {"ushort", PlyType::Uint16},  {"uint16", PlyType::Uint16},   {"int", PlyType::Int32},
      {"int32", PlyType::Int32},    {"uint", PlyType::Uint32},     {"uint32", PlyType::Uint32},
      {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
      {"float64", PlyType::Float64}};
  for (const auto& [n, type] : kTypes)
    if (n == name) {
      t = type;
      return true;
    }
  return false;
}

std::size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::Int8:
    case PlyType::Uint8:
      return 1;
    case PlyType::Int16:
    case PlyType::Uint16:
      return 2;
    case PlyType::Int32:
    case PlyType::Uint32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  bool is_list = false;
  PlyType count_type = PlyType::Uint8;
  PlyType type = PlyType::Float32;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

//! Reads PLY values from either the ASCII body or a binary body.
class PlyBody {
 public:
  PlyBody(std::string_view body, bool ascii, bool big_endian)
      : body_(body), ascii_(ascii), big_endian_(big_endian), text_(body) {}

  bool read(PlyType t, double& value) {
    if (ascii_) {
      const std::string_view tok = text_.token();
      return parse_double(tok, value);
    }
    const std::size_t n = ply_size(t);
    if (pos_ + n > body_.size()) return false;
    std::array<unsigned char, 8> b{};
    std::memcpy(b.data(), body_.data() + pos_, n);
    pos_ += n;
    if (big_endian_ != (std::endian::native == std::endian::big))
      std::reverse(b.begin(), b.begin() + n);
    switch (t) {
      case PlyType::Int8:
        value = static_cast<std::int8_t>(b[0]);
        break;
      case PlyType::Uint8:
        value = b[0];
        break;
      case PlyType::Int16:
        value = load<std::int16_t>(b);
        break;
      case PlyType::Uint16:
        value = load<std::uint16_t>(b);
        break;
      case PlyType::Int32:
        value = load<std::int32_t>(b);
        break;
      case PlyType::Uint32:
        value = load<std::uint32_t>(b);
        break;
      case PlyType::Float32:
        value = load<float>(b);
        break;
      case PlyType::Float64:
        value = load<double>(b);
        break;
    }
    return true;
  }

  std::string where() const {
    return ascii_ ? fmt::format("body line {}", text_.line()) : fmt::format("body byte {}", pos_);
  }

 private:
  template <typename T>
  static T load(const std::array<unsigned char, 8>& b) {
    T v;
    std::memcpy(&v, b.data(), sizeof(T));
    return v;
  }

  std::string_view body_;
  bool ascii_;
  bool big_endian_;
  TextScanner text_;
  std::size_t pos_ = 0;
};

ReadResult parse_ply(std::string_view bytes, const ReadOptions& options) {
  if (bytes.empty()) return fail("PLY: the file is empty");
  const std::size_t header_end = bytes.find("end_header");
  if (bytes.substr(0, 3) != "ply") return fail("PLY: the file does not start with 'ply'");
  if (header_end == std::string_view::npos)
    return fail("PLY: no 'end_header' line (truncated or not a PLY file)");
  std::size_t body_start = bytes.find('\n', header_end);
  if (body_start == std::string_view::npos) return fail("PLY: the file ends after the header");
  ++body_start;
  TextScanner header(bytes.substr(0, header_end + 10));
  std::vector<PlyElement> elements;
  std::string format;
  header.skip_line();  // "ply"
  while (!header.at_end()) {
    const std::string_view key = header.token_on_line();
    if (key == "format") {
      format = std::string(header.token_on_line());
    } else if (key == "element") {
      PlyElement e;
      e.name = std::string(header.token_on_line());
      long long count = 0;
      const std::string_view tok = header.token_on_line();
      if (!parse_int(tok, count) || count < 0)
        return fail(fmt::format("PLY: header line {}: invalid element count '{}'", header.line(),
                                printable(tok)));
      if (static_cast<std::size_t>(count) > options.max_elements)
        return fail(fmt::format("PLY: element '{}' declares {} entries, above the limit of {}",
                                e.name, count, options.max_elements));
      e.count = static_cast<std::size_t>(count);
      elements.push_back(std::move(e));
    } else if (key == "property") {
      if (elements.empty())
        return fail(fmt::format("PLY: header line {}: property before any element", header.line()));
      PlyProperty p;
      std::string_view t = header.token_on_line();
      if (t == "list") {
        p.is_list = true;
        if (!ply_type(header.token_on_line(), p.count_type) ||
            !ply_type(header.token_on_line(), p.type))
          return fail(
              fmt::format("PLY: header line {}: unknown list property type", header.line()));
      } else if (!ply_type(t, p.type)) {
        return fail(fmt::format("PLY: header line {}: unknown property type '{}'", header.line(),
                                printable(t)));
      }
      p.name = std::string(header.token_on_line());
      elements.back().properties.push_back(std::move(p));
    } else if (key == "end_header") {
      break;
    }
    header.skip_line();
  }
  bool ascii = false;
  bool big_endian = false;
  if (format == "ascii") {
    ascii = true;
  } else if (format == "binary_little_endian") {
  } else if (format == "binary_big_endian") {
    big_endian = true;
  } else {
    return fail(fmt::format("PLY: unknown format '{}'", printable(format)));
  }
  ReadResult r;
  r.report.format = MeshFormat::Ply;
  r.report.binary = !ascii;
  PlyBody body(bytes.substr(body_start), ascii, big_endian);
  bool have_vertices = false;
  std::vector<std::uint32_t> corners;
  for (const PlyElement& e : elements) {
    int ix = -1, iy = -1, iz = -1, iface = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const std::string& n = e.properties[k].name;
      if (n == "x") ix = static_cast<int>(k);
      if (n == "y") iy = static_cast<int>(k);
      if (n == "z") iz = static_cast<int>(k);
      if ((n == "vertex_indices" || n == "vertex_index") && e.properties[k].is_list)
        iface = static_cast<int>(k);
    }
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0))
      return fail("PLY: the vertex element lacks an x, y or z property");
    if (is_face && iface < 0) return fail("PLY: the face element lacks a vertex_indices list");
    if (is_face && !have_vertices)
      return fail("PLY: faces come before vertices; this reader needs vertices first");
    if (!ascii) {  // a binary body must hold at least the fixed-size part of every entry
      std::size_t fixed = 0;
      for (const PlyProperty& p : e.properties)
        fixed += ply_size(p.is_list ? p.count_type : p.type);
      if (fixed != 0 && e.count > (bytes.size() - body_start) / fixed + 1)
        return fail(
            fmt::format("PLY: element '{}' declares {} entries, more than the {}-byte "
                        "body can hold (truncated file?)",
                        e.name, e.count, bytes.size() - body_start));
    }
    if (is_vertex) r.soup.points.reserve(e.count);
    for (std::size_t i = 0; i < e.count; ++i) {
      Vec3 p;
      corners.clear();
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& prop = e.properties[k];
        double v = 0;
        if (!prop.is_list) {
          if (!body.read(prop.type, v))
            return fail(
                fmt::format("PLY: {} entry {}: missing or invalid '{}' value ({}; "
                            "truncated file?)",
                            e.name, i, prop.name, body.where()));
          if (static_cast<int>(k) == ix) p[0] = v;
          if (static_cast<int>(k) == iy) p[1] = v;
          if (static_cast<int>(k) == iz) p[2] = v;
          continue;
        }
        double count = 0;
        if (!body.read(prop.count_type, count) || count < 0 || count > 1'000'000 ||
            count != std::floor(count))
          return fail(
              fmt::format("PLY: {} entry {}: invalid list length ({})", e.name, i, body.where()));
        for (int c = 0; c < static_cast<int>(count); ++c) {
          if (!body.read(prop.type, v))
            return fail(fmt::format("PLY: {} entry {}: list ends early ({}; truncated file?)",
                                    e.name, i, body.where()));
          if (static_cast<int>(k) == iface) {
            if (v < 0 || v != std::floor(v) || v >= static_cast<double>(r.soup.points.size()))
              return fail(
                  fmt::format("PLY: face {} references vertex {}, but the file has only "
                              "{} vertices",
                              i, v, r.soup.points.size()));
            corners.push_back(static_cast<std::uint32_t>(v));
          }
        }
      }
      if (is_vertex) {
        if (auto err = check_finite(p, i, 0); !err.empty()) return fail("PLY: " + err);
        r.soup.points.push_back(p);
      } else if (is_face) {
        if (corners.size() < 3)
          return fail(fmt::format("PLY: face {} has {} corners; a face needs at least 3", i,
                                  corners.size()));
        add_polygon(corners, r);
      }
    }
    if (is_vertex) have_vertices = true;
  }
  if (!have_vertices) return fail("PLY: the file has no vertex element");
  r.ok = true;
  return r;
}

// ---------------------------------------------------------------------------------------
// STL
struct PointHash {
  std::size_t operator()(const Vec3& p) const {
    std::size_t h = 0;
    for (int k = 0; k < 3; ++k) {
      const double v = p[k] == 0.0 ? 0.0 : p[k];  // +0 and -0 weld together
      h = h * 1000003u ^ std::hash<double>{}(v);
    }
    return h;
  }
};

void add_stl_triangle(const std::array<Vec3, 3>& corners, const ReadOptions& options,
                      std::unordered_map<Vec3, std::uint32_t, PointHash>& index, ReadResult& r) {
  Triangle t;
  for (int k = 0; k < 3; ++k) {
    if (options.weld_stl_vertices) {
      Vec3 key = corners[k];
      for (int c = 0; c < 3; ++c)
        if (key[c] == 0.0) key[c] = 0.0;
      const auto [it, inserted] =
          index.try_emplace(key, static_cast<std::uint32_t>(r.soup.points.size()));
      if (inserted) {
        r.soup.points.push_back(corners[k]);
      } else {
        ++r.report.stl_corners_welded;
      }
      t[k] = it->second;
    } else {
      t[k] = static_cast<std::uint32_t>(r.soup.points.size());
      r.soup.points.push_back(corners[k]);
    }
  }
  r.soup.triangles.push_back(t);
}

ReadResult parse_stl_binary(std::string_view bytes, std::uint32_t count,
                            const ReadOptions& options) {
  ReadResult r;
  r.report.format = MeshFormat::Stl;
  r.report.binary = true;
  std::unordered_map<Vec3, std::uint32_t, PointHash> index;
  r.soup.triangles.reserve(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    const char* rec = bytes.data() + 84 + std::size_t{50} * i;
    std::array<Vec3, 3> corners;
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) {
        float f;
        std::memcpy(&f, rec + 12 + 12 * c + 4 * k, 4);
        corners[c][k] = f;
      }
    for (int c = 0; c < 3; ++c)
      if (auto e = check_finite(corners[c], 3 * std::size_t{i} + c, 0); !e.empty())
        return fail(fmt::format("STL: triangle {}: {}", i, e));
    add_stl_triangle(corners, options, index, r);
  }
  r.ok = true;
  return r;
}

ReadResult parse_stl_ascii(std::string_view text, const ReadOptions& options) {
  TextScanner in(text);
  ReadResult r;
  r.report.format = MeshFormat::Stl;
  std::unordered_map<Vec3, std::uint32_t, PointHash> index;
  std::array<Vec3, 3> corners;
  int n = 0;
  for (std::string_view tok = in.token(); !tok.empty(); tok = in.token()) {
    if (tok == "facet") {
      if (n != 0)
        return fail(
            fmt::format("STL: line {}: facet starts before the previous one had 3 "
                        "vertices",
                        in.line()));
    } else if (tok == "vertex") {
      if (n == 3)
        return fail(fmt::format("STL: line {}: a facet has more than 3 vertices", in.line()));
      for (int k = 0; k < 3; ++k) {
        const std::string_view v = in.token();
        if (!parse_double(v, corners[n][k]))
          return fail(
              fmt::format("STL: line {}: invalid vertex coordinate '{}'", in.line(), printable(v)));
      }
      if (auto e = check_finite(corners[n], 3 * r.soup.triangles.size() + n, in.line()); !e.empty())
        return fail("STL: " + e);
      ++n;
    } else if (tok == "endfacet") {
      if (n != 3)
        return fail(
            fmt::format("STL: line {}: facet ends with {} vertices instead of 3", in.line(), n));
      if (r.soup.triangles.size() >= options.max_elements)
        return fail(fmt::format("STL: more than {} facets", options.max_elements));
      add_stl_triangle(corners, options, index, r);
      n = 0;
    }
  }
  if (n != 0) return fail("STL: the file ends inside a facet (truncated file)");
  if (r.soup.triangles.empty()) return fail("STL: no facets found");
  r.ok = true;
  return r;
}

ReadResult parse_stl(std::string_view bytes, const ReadOptions& options) {
  if (bytes.empty()) return fail("STL: the file is empty");
  if (bytes.size() >= 84) {
    std::uint32_t count = 0;
    std::memcpy(&count, bytes.data() + 80, 4);
    if (std::size_t{84} + std::size_t{50} * count == bytes.size()) {
      if (count > options.max_elements)
        return fail(
            fmt::format("STL: {} triangles, above the limit of {}", count, options.max_elements));
      return parse_stl_binary(bytes, count, options);
    }
  }
  std::size_t first = 0;
  while (first < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[first]))) ++first;
  const bool looks_ascii = bytes.substr(first, 5) == "solid" &&
                           bytes.find("facet", first) != std::string_view::npos &&
                           bytes.substr(0, std::min<std::size_t>(bytes.size(), 512)).find('\0') ==
                               std::string_view::npos;
  if (looks_ascii) return parse_stl_ascii(bytes, options);
  if (bytes.size() < 84)
    return fail(
        fmt::format("STL: {} bytes is too short for a binary STL (84-byte header) and "
                    "it is not ASCII STL",
                    bytes.size()));
  std::uint32_t count = 0;
  std::memcpy(&count, bytes.data() + 80, 4);
  return fail(
      fmt::format("STL: binary header declares {} triangles ({} bytes), but the file has "
                  "{} bytes (truncated or wrong triangle count)",
                  count, std::size_t{84} + std::size_t{50} * count, bytes.size()));
}

// ---------------------------------------------------------------------------------------
// Writing
void append_number(std::string& out, double v) {
  char buf[32];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof(buf), v);  // shortest round-trip form
  out.append(buf, ec == std::errc() ? ptr : buf);
}

template <typename T>
void append_binary(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

}  // namespace

bool format_from_path(const std::string& path, MeshFormat& format) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".off")
    format = MeshFormat::Off;
  else if (ext == ".obj")
    format = MeshFormat::Obj;
  else if (ext == ".ply")
    format = MeshFormat::Ply;
  else if (ext == ".stl")
    format = MeshFormat::Stl;
  else
    return false;
  return true;
}

const char* format_name(MeshFormat format) {
  switch (format) {
    case MeshFormat::Off:
      return "OFF";
    case MeshFormat::Obj:
      return "OBJ";
    case MeshFormat::Ply:
      return "PLY";
    case MeshFormat::Stl:
      return "STL";
  }
  return "?";
}

ReadResult parse_mesh(std::string_view bytes, MeshFormat format, const ReadOptions& options) {
  ReadResult r;
  switch (format) {
    case MeshFormat::Off:
      r = parse_off(bytes, options);
      break;
    case MeshFormat::Obj:
      r = parse_obj(bytes, options);
      break;
    case MeshFormat::Ply:
      r = parse_ply(bytes, options);
      break;
    case MeshFormat::Stl:
      r = parse_stl(bytes, options);
      break;
  }
  if (r.ok && r.soup.points.size() > std::numeric_limits<std::uint32_t>::max() / 2)
    return fail("too many vertices");
  return r;
}

ReadResult read_mesh_file(const std::string& path, const ReadOptions& options) {
  MeshFormat format;
  if (!format_from_path(path, format))
    return fail(
        fmt::format("{}: unknown mesh file extension (expected .stl, .obj, .off or .ply)", path));
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) return fail(fmt::format("{}: no such file", path));
  if (!std::filesystem::is_regular_file(status))
    return fail(fmt::format("{}: not a regular file", path));
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return fail(fmt::format("{}: cannot read its size: {}", path, ec.message()));
  if (size > options.max_file_bytes)
    return fail(fmt::format("{}: {} bytes is above the limit of {} bytes", path, size,
                            options.max_file_bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::string bytes(size, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size)
    return fail(fmt::format("{}: read error", path));
  ReadResult r = parse_mesh(bytes, format, options);
  if (!r.ok) r.error = path + ": " + r.error;
  return r;
}

WriteResult serialize_mesh(const Mesh& mesh, MeshFormat format, const WriteOptions& options,
                           std::string& out) {
  WriteResult w;
  // Compact indices: deleted vertices are skipped, the others keep their relative order.
  std::vector<std::uint32_t> index(mesh.n_vertices(), 0);
  std::vector<VertexHandle> vertices;
  vertices.reserve(mesh.n_vertices());
  for (const VertexHandle v : mesh.vertices()) {  // skips deleted elements
    index[v.idx()] = static_cast<std::uint32_t>(vertices.size());
    vertices.push_back(v);
  }
  std::vector<Triangle> faces;
  faces.reserve(mesh.n_faces());
  for (const FaceHandle f : mesh.faces()) {
    Triangle t;
    int k = 0;
    for (const VertexHandle v : mesh.fv_range(f)) t[k++] = index[v.idx()];
    faces.push_back(t);
  }
  w.vertices_written = vertices.size();
  w.faces_written = faces.size();
  out.clear();
  out.reserve(vertices.size() * 60 + faces.size() * 24);
  const bool binary = options.binary && (format == MeshFormat::Ply || format == MeshFormat::Stl);
  auto add_point = [&](const Vec3& p) {
    append_number(out, p[0]);
    out += ' ';
    append_number(out, p[1]);
    out += ' ';
    append_number(out, p[2]);
  };
  switch (format) {
    case MeshFormat::Off:
      out += fmt::format("OFF\n{} {} 0\n", vertices.size(), faces.size());
      for (const VertexHandle v : vertices) {
        add_point(mesh.point(v));
        out += '\n';
      }
      for (const Triangle& t : faces) out += fmt::format("3 {} {} {}\n", t[0], t[1], t[2]);
      break;
    case MeshFormat::Obj:
      out += "# written by touchmend\n";
      for (const VertexHandle v : vertices) {
        out += "v ";
        add_point(mesh.point(v));
        out += '\n';
      }
      for (const Triangle& t : faces)
        out += fmt::format("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
      break;
    case MeshFormat::Ply:
      out += fmt::format(
          "ply\nformat {} 1.0\ncomment written by touchmend\nelement vertex {}\n"
          "property double x\nproperty double y\nproperty double z\nelement face {}\n"
          "property list uchar int vertex_indices\nend_header\n",
          binary ? (std::endian::native == std::endian::little ? "binary_little_endian"
                                                               : "binary_big_endian")
                 : "ascii",
          vertices.size(), faces.size());
      for (const VertexHandle v : vertices) {
        const Vec3& p = mesh.point(v);
        if (binary) {
          for (int k = 0; k < 3; ++k) append_binary(out, p[k]);
        } else {
          add_point(p);
          out += '\n';
        }
      }
      for (const Triangle& t : faces) {
        if (binary) {
          append_binary<std::uint8_t>(out, 3);
          for (int k = 0; k < 3; ++k) append_binary(out, static_cast<std::int32_t>(t[k]));
        } else {
          out += fmt::format("3 {} {} {}\n", t[0], t[1], t[2]);
        }
      }
      break;
    case MeshFormat::Stl: {
      std::size_t changed = 0;
      if (binary) {
        std::string header = "binary STL written by touchmend";
        header.resize(80, ' ');
        out += header;
        append_binary(out, static_cast<std::uint32_t>(faces.size()));
      } else {
        out += "solid touchmend\n";
      }
      for (const Triangle& t : faces) {
        const Vec3& a = mesh.point(vertices[t[0]]);
        const Vec3& b = mesh.point(vertices[t[1]]);
        const Vec3& c = mesh.point(vertices[t[2]]);
        Vec3 n = OpenMesh::cross(b - a, c - a);
        const double len = n.norm();
        if (len > 0) n /= len;
        if (binary) {
          for (int k = 0; k < 3; ++k) append_binary(out, static_cast<float>(n[k]));
          for (const Vec3* p : {&a, &b, &c})
            for (int k = 0; k < 3; ++k) {
              const float f = static_cast<float>((*p)[k]);
              if (static_cast<double>(f) != (*p)[k]) ++changed;
              append_binary(out, f);
            }
          append_binary<std::uint16_t>(out, 0);
        } else {
          out += "facet normal ";
          add_point(n);
          out += "\n outer loop\n";
          for (const Vec3* p : {&a, &b, &c}) {
            out += "  vertex ";
            add_point(*p);
            out += '\n';
          }
          out += " endloop\nendfacet\n";
        }
      }
      if (!binary) out += "endsolid touchmend\n";
      if (changed > 0)
        w.warnings.push_back(fmt::format(
            "binary STL stores single-precision floats: {} coordinates were rounded; write ASCII "
            "STL, OFF, OBJ or PLY to keep them exact",
            changed));
      break;
    }
  }
  w.ok = true;
  return w;
}

bool write_file_atomically(const std::string& path, std::string_view bytes, std::string& error) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::random_device rd;
  const fs::path tmp = dir / fmt::format(".{}.tmp-{:08x}", target.filename().string(), rd());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    error = fmt::format("{}: cannot create a temporary file in {}: {}", path, dir.string(),
                        std::strerror(errno));
    return false;
  }
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    written += static_cast<std::size_t>(n);
  }
  const int write_errno = errno;
  const bool synced = written == bytes.size() && ::fsync(fd) == 0;
  ::close(fd);
  if (!synced) {
    ::unlink(tmp.c_str());
    error = fmt::format("{}: writing failed: {}", path, std::strerror(write_errno));
    return false;
  }
  if (::rename(tmp.c_str(), target.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    error =
        fmt::format("{}: cannot rename the temporary file into place: {}", path, std::strerror(e));
    return false;
  }
  // Make the rename itself durable.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return true;
}

WriteResult write_mesh_file(const Mesh& mesh, const std::string& path,
                            const WriteOptions& options) {
  WriteResult w;
  MeshFormat format;
  if (!format_from_path(path, format)) {
    w.error =
        fmt::format("{}: unknown mesh file extension (expected .stl, .obj, .off or .ply)", path);
    return w;
  }
  std::string bytes;
  w = serialize_mesh(mesh, format, options, bytes);
  if (!w.ok) return w;
  std::string error;
  if (!write_file_atomically(path, bytes, error)) {
    w.ok = false;
    w.error = error;
  }
  return w;
}

}  // namespace touchmend::geometry
