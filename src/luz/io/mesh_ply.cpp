#include "luz/io/mesh_ply.h"

#include <fast_float/fast_float.h>

#include <sys/stat.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string_view>

#include "luz/core/memory.h"
#include "luz/io/error.h"

namespace luz {

namespace {

enum class PlyType : uint8_t { Int8, Uint8, Int16, Uint16, Int32, Uint32, Float32, Float64, None };

struct TypeName {
  std::string_view name;
  PlyType type;
};
// The PLY 1.0 names and their sized aliases (as rply and Mitsuba accept).
constexpr TypeName kTypeNames[] = {
    {"char", PlyType::Int8},     {"int8", PlyType::Int8},       {"uchar", PlyType::Uint8},
    {"uint8", PlyType::Uint8},   {"short", PlyType::Int16},     {"int16", PlyType::Int16},
    {"ushort", PlyType::Uint16}, {"uint16", PlyType::Uint16},   {"int", PlyType::Int32},
    {"int32", PlyType::Int32},   {"uint", PlyType::Uint32},     {"uint32", PlyType::Uint32},
    {"float", PlyType::Float32}, {"float32", PlyType::Float32}, {"double", PlyType::Float64},
    {"float64", PlyType::Float64}};

size_t type_size(PlyType t) {
  constexpr size_t kSize[] = {1, 1, 2, 2, 4, 4, 4, 8, 0};
  return kSize[(int)t];
}
bool is_integer(PlyType t) { return t < PlyType::Float32; }
int64_t type_min(PlyType t) {
  constexpr int64_t kMin[] = {-128, 0, -32768, 0, INT32_MIN, 0};
  return kMin[(int)t];
}
int64_t type_max(PlyType t) {
  constexpr int64_t kMax[] = {127, 255, 32767, 65535, INT32_MAX, UINT32_MAX};
  return kMax[(int)t];
}

// What the reader does with a property's values.
enum class Slot : uint8_t { Skip, X, Y, Z, Nx, Ny, Nz, U, V, R, G, B, Indices, FaceIndex, FaceR, FaceG, FaceB };

struct Property {
  std::string name;
  PlyType type = PlyType::None;        // the scalar's type, or a list's item type
  PlyType count_type = PlyType::None;  // a list's count type; None for a scalar
  Slot slot = Slot::Skip;
  int line = 0;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  int line = 0;
  std::vector<Property> props;
};

enum class Format { Ascii, BinaryLittle, BinaryBig };

struct Header {
  Format format = Format::Ascii;
  std::vector<Element> elements;
  size_t data_offset = 0;  // first byte after end_header's line
  int data_line = 0;       // that byte's line
  int vertex = -1, face = -1;
  bool normals = false, uvs = false, colors = false, face_indices = false, face_colors = false;
};

std::string quoted(std::string_view s) {
  constexpr size_t kMax = 40;  // a binary blob mistaken for a token stays short
  return "'" + std::string(s.substr(0, kMax)) + (s.size() > kMax ? "...'" : "'");
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    size_t b = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
  return out;
}

// Reads the header and decides what each property becomes.
class HeaderParser {
 public:
  HeaderParser(const std::string& name, const char* data, size_t size)
      : name_(name), data_(data), size_(size) {}

  Header parse() {
    if (size_ < 3 || std::memcmp(data_, "ply", 3) != 0) fail(1, "not a PLY file (it does not start with 'ply')");
    size_t pos = 0;
    int line = 0;
    bool have_format = false, ended = false;
    while (!ended) {
      if (pos >= size_) fail(line, "the header has no end_header line");
      size_t eol = pos;
      while (eol < size_ && data_[eol] != '\n') ++eol;
      std::string_view text(data_ + pos, eol - pos);
      ++line;
      pos = eol + 1;
      std::vector<std::string_view> tok = split(text);
      if (line == 1) {
        if (tok.size() != 1 || tok[0] != "ply") fail(line, "not a PLY file (its first line is not 'ply')");
        continue;
      }
      if (tok.empty()) continue;
      std::string_view key = tok[0];
      if (key == "comment" || key == "obj_info") continue;
      if (key == "end_header") {
        if (tok.size() != 1) fail(line, "extra text after end_header");
        ended = true;
      } else if (key == "format") {
        if (have_format) fail(line, "a second format line");
        if (tok.size() != 3) fail(line, "the format line needs a format and a version, e.g. 'format ascii 1.0'");
        if (tok[1] == "ascii") h_.format = Format::Ascii;
        else if (tok[1] == "binary_little_endian") h_.format = Format::BinaryLittle;
        else if (tok[1] == "binary_big_endian") h_.format = Format::BinaryBig;
        else fail(line, "unknown format " + quoted(tok[1]) + " (ascii, binary_little_endian or binary_big_endian)");
        if (tok[2] != "1.0") fail(line, "unsupported PLY version " + quoted(tok[2]) + " (1.0)");
        have_format = true;
      } else if (key == "element") {
        if (!have_format) fail(line, "an element before the format line");
        element(tok, line);
      } else if (key == "property") {
        property(tok, line);
      } else {
        fail(line, "unknown header line starting with " + quoted(key));
      }
    }
    if (!have_format) fail(line, "the header has no format line");
    h_.data_offset = std::min(pos, size_);
    h_.data_line = line + 1;
    assign_slots(line);
    check_size();
    return h_;
  }

 private:
  [[noreturn]] void fail(int line, const std::string& problem) const { throw InputError(name_, line, problem); }

  void element(const std::vector<std::string_view>& tok, int line) {
    if (tok.size() != 3) fail(line, "an element line needs a name and a count, e.g. 'element vertex 8'");
    Element e;
    e.name = tok[1];
    e.line = line;
    auto r = std::from_chars(tok[2].data(), tok[2].data() + tok[2].size(), e.count);
    if (r.ec != std::errc() || r.ptr != tok[2].data() + tok[2].size())
      fail(line, "element " + quoted(tok[1]) + ": count " + quoted(tok[2]) + " is not a non-negative integer");
    for (const Element& other : h_.elements)
      if (other.name == e.name) fail(line, "a second element " + quoted(e.name) + " (the first is on line " + std::to_string(other.line) + ")");
    h_.elements.push_back(std::move(e));
  }

  PlyType type(std::string_view name, int line) const {
    for (const TypeName& t : kTypeNames)
      if (t.name == name) return t.type;
    fail(line, "unknown property type " + quoted(name) +
                   " (char, uchar, short, ushort, int, uint, float, double or int8 ... float64)");
  }

  void property(const std::vector<std::string_view>& tok, int line) {
    if (h_.elements.empty()) fail(line, "a property before any element");
    Property p;
    p.line = line;
    if (tok.size() >= 2 && tok[1] == "list") {
      if (tok.size() != 5) fail(line, "a list property needs a count type, an item type and a name, e.g. 'property list uchar int vertex_indices'");
      p.count_type = type(tok[2], line);
      p.type = type(tok[3], line);
      p.name = tok[4];
      if (!is_integer(p.count_type)) fail(line, "list " + quoted(p.name) + ": the count type must be an integer type");
    } else {
      if (tok.size() != 3) fail(line, "a property needs a type and a name, e.g. 'property float x'");
      p.type = type(tok[1], line);
      p.name = tok[2];
    }
    Element& e = h_.elements.back();
    for (const Property& other : e.props)
      if (other.name == p.name) fail(line, "element " + quoted(e.name) + " has a second property " + quoted(p.name));
    e.props.push_back(std::move(p));
  }

  // Finds the property `name` of `e`, which must be a scalar; nullptr if absent.
  Property* scalar(Element& e, std::string_view name) const {
    for (Property& p : e.props)
      if (p.name == name) {
        if (p.count_type != PlyType::None) fail(p.line, "property " + quoted(name) + " must be a scalar, not a list");
        return &p;
      }
    return nullptr;
  }

  // Whether every one of `names` is a scalar property of e.
  static bool all_scalars(const Element& e, const std::array<std::string_view, 3>& names) {
    for (std::string_view name : names) {
      bool found = false;
      for (const Property& p : e.props) found |= p.name == name && p.count_type == PlyType::None;
      if (!found) return false;
    }
    return true;
  }

  // Sets the slots of a group of properties that come all or none
  // (x y z, nx ny nz, u v, r g b); true if all are there.
  bool group(Element& e, std::initializer_list<std::string_view> names, Slot first) const {
    Property* found[3] = {};
    int n = 0, i = 0;
    for (std::string_view name : names) n += (found[i++] = scalar(e, name)) != nullptr;
    if (n == 0) return false;
    i = 0;
    for (std::string_view name : names) {
      if (!found[i]) {
        for (Property* p : found)
          if (p) fail(p->line, "vertex property " + quoted(p->name) + " without " + quoted(name));
      }
      found[i]->slot = (Slot)((int)first + i);
      ++i;
    }
    return true;
  }

  void assign_slots(int end_line) {
    for (size_t i = 0; i < h_.elements.size(); ++i) {
      if (h_.elements[i].name == "vertex") h_.vertex = (int)i;
      if (h_.elements[i].name == "face") h_.face = (int)i;
    }
    if (h_.vertex < 0) fail(end_line, "the header declares no 'vertex' element");
    if (h_.face < 0) {
      for (const Element& e : h_.elements)
        if (e.name == "tristrips") fail(e.line, "triangle strips (element 'tristrips') are not supported; faces are");
      fail(end_line, "the header declares no 'face' element (a point cloud is not a mesh)");
    }
    Element& v = h_.elements[h_.vertex];
    if (!group(v, {"x", "y", "z"}, Slot::X)) fail(v.line, "element 'vertex' has no x, y, z properties");
    if (v.count > UINT32_MAX) fail(v.line, "more vertices than 32-bit indices can address");
    h_.normals = group(v, {"nx", "ny", "nz"}, Slot::Nx);
    for (auto uv : {std::pair{"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}})
      if (!h_.uvs) h_.uvs = group(v, {uv.first, uv.second}, Slot::U);
    // Colours only where all three channels are scalars (as Mitsuba 3 groups
    // them); others are skipped, as any property Luz does not read.
    for (auto rgb : {std::array<std::string_view, 3>{"r", "g", "b"}, {"red", "green", "blue"}})
      if (!h_.colors && all_scalars(v, rgb)) h_.colors = group(v, {rgb[0], rgb[1], rgb[2]}, Slot::R);

    Element& f = h_.elements[h_.face];
    Property* indices = nullptr;
    for (Property& p : f.props) {
      if (p.name == "vertex_indices" || p.name == "vertex_index") {
        if (indices) fail(p.line, "element 'face' has both 'vertex_indices' and 'vertex_index'");
        if (p.count_type == PlyType::None) fail(p.line, "face property " + quoted(p.name) + " must be a list");
        if (!is_integer(p.type)) fail(p.line, "face property " + quoted(p.name) + " must list an integer type");
        indices = &p;
        p.slot = Slot::Indices;
      }
    }
    if (!indices) fail(f.line, "element 'face' has no 'vertex_indices' list");
    if (Property* p = scalar(f, "face_indices")) {
      if (!is_integer(p->type)) fail(p->line, "face property 'face_indices' must be an integer type");
      p->slot = Slot::FaceIndex;
      h_.face_indices = true;
    }
    for (auto rgb : {std::array<std::string_view, 3>{"r", "g", "b"}, {"red", "green", "blue"}})
      if (!h_.face_colors && all_scalars(f, rgb)) h_.face_colors = group(f, {rgb[0], rgb[1], rgb[2]}, Slot::FaceR);
  }

  // The fewest bytes an entry of `e` can take: binary, every scalar and list
  // count, and a face's 3 indices; ASCII, each such value a character and a
  // separator. Refuses counts the rest of the file cannot hold before
  // anything is allocated for them.
  void check_size() const {
    size_t left = size_ - h_.data_offset;
    uint64_t total = 0;
    for (const Element& e : h_.elements) {
      uint64_t entry = 0;
      for (const Property& p : e.props) {
        uint64_t values = p.slot == Slot::Indices ? 3 : 0;
        if (h_.format == Format::Ascii)
          entry += 2 * (1 + values);
        else
          entry += p.count_type == PlyType::None ? type_size(p.type) : type_size(p.count_type) + values * type_size(p.type);
      }
      uint64_t room = left + (h_.format == Format::Ascii);  // the last value needs no separator
      if (entry > 0 && (e.count > room / entry || total + e.count * entry > room))
        fail(e.line, "element " + quoted(e.name) + " declares " + std::to_string(e.count) +
                         " entries, which need at least " + std::to_string(e.count) + " x " + std::to_string(entry) +
                         " bytes, but only " + std::to_string(left) + " bytes follow the header");
      total += e.count * entry;
    }
  }

  const std::string& name_;
  const char* data_;
  size_t size_;
  Header h_;
};

template <class U>
U byte_swap(U v) {
  if constexpr (sizeof(U) == 2) return __builtin_bswap16(v);
  else if constexpr (sizeof(U) == 4) return __builtin_bswap32(v);
  else return __builtin_bswap64(v);
}

// Binary data: values read with bounds checks, errors at "byte N".
class BinarySource {
 public:
  BinarySource(const std::string& name, const char* data, size_t size, const Header& h)
      : name_(name), data_(data), size_(size), pos_(h.data_offset),
        swap_((h.format == Format::BinaryBig) != (std::endian::native == std::endian::big)) {}

  void begin_entry(const char* element, uint64_t index) {
    element_ = element;
    index_ = index;
    entry_ = at_ = pos_;
  }
  void end_entry() {}

  double real(PlyType t) {
    const char* p = need(type_size(t));
    switch (t) {
      case PlyType::Float32: return load<float, uint32_t>(p);
      case PlyType::Float64: return load<double, uint64_t>(p);
      default: return (double)integer_at(p, t);
    }
  }
  int64_t integer(PlyType t) { return integer_at(need(type_size(t)), t); }
  void skip(PlyType t, uint64_t n) { need(n * type_size(t)); }

  [[noreturn]] void fail(const std::string& problem) const { fail_at(at_, problem); }
  [[noreturn]] void fail_entry(const std::string& problem) const { fail_at(entry_, problem); }

  void finish() const {
    if (pos_ != size_)
      throw InputError(name_, 0, "byte " + std::to_string(pos_) + ": data after the last element (" +
                                     std::to_string(size_ - pos_) + " bytes; do the header's counts match the data?)");
  }

 private:
  [[noreturn]] void fail_at(size_t pos, const std::string& problem) const {
    throw InputError(name_, 0, "byte " + std::to_string(pos) + ": " + element_ + " " + std::to_string(index_) + ": " + problem);
  }
  const char* need(uint64_t n) {
    at_ = pos_;
    if (size_ - pos_ < n)
      fail("the file ends inside it (truncated, or the header declares more than the file holds)");
    const char* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  template <class T, class U>
  T load(const char* p) const {
    U u;
    std::memcpy(&u, p, sizeof u);
    if (swap_) u = byte_swap(u);
    return std::bit_cast<T>(u);
  }
  int64_t integer_at(const char* p, PlyType t) const {
    switch (t) {
      case PlyType::Int8: return (int8_t)*p;
      case PlyType::Uint8: return (uint8_t)*p;
      case PlyType::Int16: return load<int16_t, uint16_t>(p);
      case PlyType::Uint16: return load<uint16_t, uint16_t>(p);
      case PlyType::Int32: return load<int32_t, uint32_t>(p);
      default: return load<uint32_t, uint32_t>(p);
    }
  }

  const std::string& name_;
  const char* data_;
  size_t size_, pos_, at_ = 0, entry_ = 0;
  bool swap_;
  const char* element_ = "";
  uint64_t index_ = 0;
};

// ASCII data: one entry per line, numbers by fast_float (reals) and
// std::from_chars (integers), errors at "line N".
class AsciiSource {
 public:
  AsciiSource(const std::string& name, const char* data, size_t size, const Header& h)
      : name_(name), p_(data + h.data_offset), end_(data + size), line_(h.data_line) {}

  // Blank lines between entries are allowed.
  void begin_entry(const char* element, uint64_t index) {
    element_ = element;
    index_ = index;
    skip_space(true);
    if (p_ == end_) fail("the file ends before it (truncated, or the header declares more than the file holds)");
  }
  void end_entry() {
    skip_space(false);
    if (p_ != end_ && *p_ != '\n') fail("extra value " + quoted(token_at(p_)) + " after its last property");
  }

  double real(PlyType t) {
    std::string_view tok = token();
    if (is_integer(t)) return (double)parse_integer(tok, t);
    double d = 0;
    fast_float::from_chars_result r;
    if (t == PlyType::Float32) {
      float f = 0;
      r = fast_float::from_chars(tok.data(), tok.data() + tok.size(), f);
      d = f;
    } else {
      r = fast_float::from_chars(tok.data(), tok.data() + tok.size(), d);
    }
    if (r.ec != std::errc() || r.ptr != tok.data() + tok.size()) fail(quoted(tok) + " is not a number");
    return d;
  }
  int64_t integer(PlyType t) { return parse_integer(token(), t); }
  void skip(PlyType t, uint64_t n) {
    for (uint64_t i = 0; i < n; ++i) real(t);
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(name_, line_, std::string(element_) + " " + std::to_string(index_) + ": " + problem);
  }
  [[noreturn]] void fail_entry(const std::string& problem) const { fail(problem); }

  void finish() {
    skip_space(true);
    if (p_ != end_) throw InputError(name_, line_, "data after the last element (do the header's counts match the data?)");
  }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
  void skip_space(bool newlines) {
    for (; p_ != end_; ++p_) {
      if (*p_ == '\n' && newlines) ++line_;
      else if (!is_space(*p_)) break;
    }
  }
  std::string_view token_at(const char* b) const {
    const char* e = b;
    while (e != end_ && *e != '\n' && !is_space(*e)) ++e;
    return {b, size_t(e - b)};
  }
  std::string_view token() {
    skip_space(false);
    if (p_ == end_ || *p_ == '\n') fail("too few values on its line");
    std::string_view tok = token_at(p_);
    p_ += tok.size();
    return tok;
  }
  int64_t parse_integer(std::string_view tok, PlyType t) const {
    int64_t v = 0;
    auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (r.ec != std::errc() || r.ptr != tok.data() + tok.size()) fail(quoted(tok) + " is not an integer");
    if (v < type_min(t) || v > type_max(t)) fail(quoted(tok) + " is out of its type's range");
    return v;
  }

  const std::string& name_;
  const char* p_;
  const char* end_;
  int line_;
  const char* element_ = "";
  uint64_t index_ = 0;
};

// An integer colour channel as Mitsuba 3 reads it: normalised by its type's
// maximum (negative values to 0), then sRGB-decoded.
float color_value(double v, PlyType t) {
  const double x = std::max(v, 0.0) / double(type_max(t));
  return float(x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4));
}

// Reads past a property the mesh does not use (ASCII: checking its numbers).
template <class Source>
void skip_property(Source& src, const Property& p) {
  if (p.count_type == PlyType::None) {
    src.real(p.type);
    return;
  }
  int64_t n = src.integer(p.count_type);
  if (n < 0) src.fail("list " + quoted(p.name) + " has a negative count");
  src.skip(p.type, (uint64_t)n);
}

template <class Source>
void read_vertices(Source& src, const Header& h, const Element& e, PlyMesh& m) {
  m.positions.resize(e.count);
  if (h.normals) m.normals.resize(e.count);
  if (h.uvs) m.uvs.resize(e.count);
  if (h.colors) m.colors.resize(e.count);
  for (uint64_t i = 0; i < e.count; ++i) {
    src.begin_entry("vertex", i);
    float v[12] = {};  // by Slot
    for (const Property& p : e.props) {
      if (p.slot == Slot::Skip) skip_property(src, p);
      else if (p.slot >= Slot::R && p.slot <= Slot::B && is_integer(p.type)) v[(int)p.slot] = color_value(src.real(p.type), p.type);
      else v[(int)p.slot] = (float)src.real(p.type);
    }
    m.positions[i] = {v[1], v[2], v[3]};
    if (!std::isfinite(v[1]) || !std::isfinite(v[2]) || !std::isfinite(v[3])) src.fail_entry("its position is not finite");
    if (h.normals) {
      m.normals[i] = {v[4], v[5], v[6]};
      if (!is_finite(m.normals[i])) src.fail_entry("its normal is not finite");
    }
    if (h.uvs) {
      m.uvs[i] = {v[7], v[8]};
      if (!std::isfinite(v[7]) || !std::isfinite(v[8])) src.fail_entry("its texture coordinates are not finite");
    }
    if (h.colors) m.colors[i] = {v[9], v[10], v[11]};  // checked where used (SceneBuilder)
    src.end_entry();
  }
}

template <class Source>
void read_faces(Source& src, const Header& h, const Element& e, PlyMesh& m) {
  const uint64_t vertices = h.elements[h.vertex].count;
  m.indices.reserve(3 * e.count);  // the header's counts passed check_size
  if (h.face_indices) m.face_indices.reserve(e.count);
  bool polygons = false;
  for (uint64_t i = 0; i < e.count; ++i) {
    src.begin_entry("face", i);
    int64_t face_index = 0;
    Color color;
    for (const Property& p : e.props) {
      if (p.slot == Slot::Indices) {
        int64_t n = src.integer(p.count_type);
        if (n < 3) src.fail("it has " + std::to_string(n) + " vertices; a face needs at least 3");
        auto index = [&] {
          int64_t k = src.integer(p.type);
          if (k < 0 || (uint64_t)k >= vertices)
            src.fail("vertex index " + std::to_string(k) + " is out of range (" + std::to_string(vertices) + " vertices)");
          return (uint32_t)k;
        };
        if (n > 3 && !polygons) {
          // The first polygon: every face before it was one triangle.
          polygons = true;
          m.face_first_triangle.resize(size_t(i));
          for (uint32_t f = 0; f < uint32_t(i); ++f) m.face_first_triangle[f] = f;
        }
        if (polygons) m.face_first_triangle.push_back(uint32_t(m.indices.size() / 3));
        uint32_t first = index(), prev = index();
        for (int64_t k = 2; k < n; ++k) {
          uint32_t cur = index();
          m.indices.insert(m.indices.end(), {first, prev, cur});
          prev = cur;
        }
      } else if (p.slot == Slot::FaceIndex) {
        face_index = src.integer(p.type);
        if (face_index < INT32_MIN || face_index > INT32_MAX) src.fail("face_indices value out of the int32 range");
      } else if (p.slot >= Slot::FaceR && p.slot <= Slot::FaceB) {
        const double v = src.real(p.type);
        color[int(p.slot) - int(Slot::FaceR)] = is_integer(p.type) ? color_value(v, p.type) : float(v);
      } else {
        skip_property(src, p);
      }
    }
    src.end_entry();
    if (h.face_indices) m.face_indices.resize(m.indices.size() / 3, (int32_t)face_index);
    if (h.face_colors) m.face_colors.resize(m.indices.size() / 3, color);
  }
}

template <class Source>
void read_other(Source& src, const Element& e) {
  if (e.props.empty()) return;
  for (uint64_t i = 0; i < e.count; ++i) {
    src.begin_entry(e.name.c_str(), i);
    for (const Property& p : e.props) skip_property(src, p);
    src.end_entry();
  }
}

template <class Source>
PlyMesh read_data(Source src, const Header& h) {
  PlyMesh m;
  for (size_t i = 0; i < h.elements.size(); ++i) {
    const Element& e = h.elements[i];
    if ((int)i == h.vertex) read_vertices(src, h, e, m);
    else if ((int)i == h.face) read_faces(src, h, e, m);
    else read_other(src, e);
  }
  src.finish();
  return m;
}

}  // namespace

PlyMesh read_ply_memory(const std::string& name, const char* data, size_t size) {
  Header h = HeaderParser(name, data, size).parse();
  uint64_t need = 0;  // the mesh's arrays, from the header's counts
  if (h.vertex >= 0)
    need += h.elements[size_t(h.vertex)].count * (sizeof(Vec3) + (h.normals ? sizeof(Vec3) : 0) + (h.uvs ? sizeof(Vec2) : 0) +
                                                  (h.colors ? sizeof(Vec3) : 0));
  if (h.face >= 0)
    need += h.elements[size_t(h.face)].count *
            (3 * sizeof(uint32_t) + (h.face_indices ? sizeof(int32_t) : 0) + (h.face_colors ? sizeof(Color) : 0));
  require_memory(need, name, "its vertices and faces");
  if (h.format == Format::Ascii) return read_data(AsciiSource(name, data, size, h), h);
  return read_data(BinarySource(name, data, size, h), h);
}

namespace {

// The data of a gzip file (pbrt-v4 reads .ply.gz), up to kMaxSize bytes: a
// bomb is refused at that size, not when memory runs out.
std::string gunzip(const std::string& path, const std::string& in) {
  constexpr size_t kMaxSize = size_t(1) << 32;
  z_stream zs{};
  if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) throw InputError(path, 0, "cannot start zlib");
  std::unique_ptr<z_stream, int (*)(z_stream*)> end(&zs, inflateEnd);
  std::string out(std::max<size_t>(4 * in.size(), 4096), '\0');
  zs.next_in = (Bytef*)in.data();
  zs.avail_in = (uInt)in.size();  // read_ply refuses files of 4 GiB and more
  for (;;) {
    if (zs.total_out == out.size()) {
      if (out.size() >= kMaxSize) throw InputError(path, 0, "decompresses to more than 4 GiB");
      require_memory(std::min(2 * out.size(), kMaxSize) - out.size(), path, "its decompressed data");
      out.resize(std::min(2 * out.size(), kMaxSize));
    }
    zs.next_out = (Bytef*)out.data() + zs.total_out;
    zs.avail_out = (uInt)std::min<size_t>(out.size() - zs.total_out, UINT32_MAX);
    int r = inflate(&zs, Z_NO_FLUSH);
    if (r == Z_STREAM_END) break;
    if (r == Z_BUF_ERROR && zs.avail_in == 0)
      throw InputError(path, 0, "byte " + std::to_string(zs.total_in) + ": the gzip data end early (truncated)");
    if (r != Z_OK && r != Z_BUF_ERROR)
      throw InputError(path, 0, "byte " + std::to_string(zs.total_in) + ": bad gzip data (" + (zs.msg ? zs.msg : "zlib error " + std::to_string(r)) + ")");
  }
  out.resize(zs.total_out);
  return out;
}

}  // namespace

PlyMesh read_ply(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), std::fclose);
  if (!f) throw InputError(path, 0, std::string("cannot open: ") + std::strerror(errno));
  struct stat st;
  if (fstat(fileno(f.get()), &st) != 0) throw InputError(path, 0, std::string("cannot read: ") + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw InputError(path, 0, "not a regular file");
  std::string data((size_t)st.st_size, '\0');
  if (std::fread(data.data(), 1, data.size(), f.get()) != data.size())
    throw InputError(path, 0, "cannot read: " + std::string(std::strerror(errno)));
  if (data.size() < 2 || (uint8_t)data[0] != 0x1f || (uint8_t)data[1] != 0x8b) return read_ply_memory(path, data.data(), data.size());
  if (data.size() >= UINT32_MAX) throw InputError(path, 0, "a gzip file of 4 GiB or more");
  data = gunzip(path, data);
  try {
    return read_ply_memory(path, data.data(), data.size());
  } catch (const InputError& e) {
    if (e.line() > 0) throw;
    std::string problem = e.problem();  // "byte N: ..."
    throw InputError(path, 0, problem.insert(problem.find(':'), " of the decompressed data"));
  }
}

}  // namespace luz
