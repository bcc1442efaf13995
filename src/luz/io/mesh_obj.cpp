#include "luz/io/mesh_obj.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <tuple>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "luz/io/error.h"
#include "luz/texture/texture.h"

namespace luz {

namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// The first whitespace-separated token of a line ("" when none).
std::string_view first_token(std::string_view line) {
  size_t b = 0;
  while (b < line.size() && is_space(line[b])) ++b;
  size_t e = b;
  while (e < line.size() && !is_space(line[e])) ++e;
  return line.substr(b, e - b);
}

// Whitespace-separated tokens of one line, into `out` (reused: no
// allocation per line once it has grown).
void split(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  size_t k = 0;
  auto space = is_space;
  while (k < line.size()) {
    while (k < line.size() && space(line[k])) ++k;
    const size_t b = k;
    while (k < line.size() && !space(line[k])) ++k;
    if (k > b) out.push_back(line.substr(b, k - b));
  }
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string_view> v;
  split(std::string_view(line), v);
  return {v.begin(), v.end()};
}

// The line starting at pos, and pos moved past its end. Lines end as
// tinyobjloader's safeGetline ends them: "\n", "\r\n" or a lone "\r" (splitting
// at "\n" only would hide from the checks whatever follows a lone "\r").
std::string_view next_line_view(const std::string& text, size_t& pos) {
  size_t eol = pos;  // a loop: find_first_of tests each byte with memchr
  while (eol < text.size() && text[eol] != '\n' && text[eol] != '\r') ++eol;
  std::string_view line(text.data() + pos, eol - pos);
  pos = eol + (eol + 1 < text.size() && text[eol] == '\r' && text[eol + 1] == '\n' ? 2 : 1);
  return line;
}

std::string next_line(const std::string& text, size_t& pos) { return std::string(next_line_view(text, pos)); }

// A finite number, or an error naming the file, the line and the value.
void check_number(const std::string& path_, std::string_view t, int line_no, std::string_view key) {
  const char* b = t.data();
  const char* e = b + t.size();
  if (b < e && *b == '+') ++b;
  float f = 0;
  auto r = std::from_chars(b, e, f);
  if (r.ptr != e || b == e || (r.ec != std::errc() && r.ec != std::errc::result_out_of_range))
    throw InputError(path_, line_no, "'" + std::string(key) + "': '" + std::string(t) + "' is not a number");
  if (r.ec == std::errc::result_out_of_range) {
    // Out of range is an overflow, or an underflow (harmless: it reads as 0).
    double d = std::strtod(std::string(b, e).c_str(), nullptr);
    if (std::fabs(d) > 1.0)
      throw InputError(path_, line_no, "'" + std::string(key) + "': '" + std::string(t) + "' is not a finite number (out of range)");
  } else if (!std::isfinite(f)) {
    throw InputError(path_, line_no, "'" + std::string(key) + "': '" + std::string(t) + "' is not a finite number");
  }
}

// tinyobjloader is lenient where Luz must not be: a coordinate it cannot parse
// ("nan", "abc") silently becomes 0, and face indices are not range-checked
// (an index past the end would read out of bounds). So the file is checked
// first, line by line, and every problem is reported with its line.
class ObjChecker {
 public:
  ObjChecker(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  // Each face's number of corners, in the file's order (tinyobjloader keeps
  // them modulo 256).
  const std::vector<uint32_t>& face_sizes() const { return face_sizes_; }
  // How many `v` lines give a colour (x y z r g b: the common extension;
  // tinyobjloader reads the 4th to 6th numbers of any longer line as one),
  // and the first colour outside [0, 1] (line 0: none).
  size_t colored_vertices() const { return colored_; }
  int bad_color_line() const { return bad_color_line_; }
  const std::string& bad_color() const { return bad_color_; }

  void check() {
    // Pass 1 counts the vertex data, so positive face indices may refer ahead;
    // pass 2 checks numbers and indices (negative ones are relative to the
    // vertices read so far).
    for (int pass = 0; pass < 2; ++pass) {
      size_t v = 0, vt = 0, vn = 0;
      int line_no = 0;
      std::vector<std::string_view> tok;
      for (size_t pos = 0; pos < text_.size();) {
        std::string_view line = next_line_view(text_, pos);
        ++line_no;
        size_t hash = line.find('#');
        if (hash != std::string_view::npos) line = line.substr(0, hash);
        if (pass == 0) {  // counting needs the first token only
          const std::string_view key = first_token(line);
          if (key == "v" || key == "vn" || key == "vt") ++(key == "v" ? v : key == "vn" ? vn : vt);
          continue;
        }
        split(line, tok);
        if (tok.empty()) continue;
        const std::string_view key = tok[0];
        if (key == "v" || key == "vn" || key == "vt") {
          size_t& count = key == "v" ? v : key == "vn" ? vn : vt;
          ++count;
          size_t need = key == "vt" ? 1 : 3;
          if (tok.size() - 1 < need)
            throw InputError(path_, line_no, "'" + std::string(key) + "' needs " + std::to_string(need) + " numbers");
          for (size_t k = 1; k < tok.size(); ++k) number(tok[k], line_no, key);
          if (key == "v" && tok.size() >= 7) {
            ++colored_;
            for (size_t k = 4; k < 7; ++k) {
              const double c = std::strtod(std::string(tok[k]).c_str(), nullptr);
              if (!(c >= 0.0 && c <= 1.0) && bad_color_line_ == 0) bad_color_line_ = line_no, bad_color_ = tok[k];
            }
          }
        } else if (key == "f" && pass == 1) {
          if (tok.size() < 4) throw InputError(path_, line_no, "a face needs at least 3 vertices");
          for (size_t k = 1; k < tok.size(); ++k) face_vertex(tok[k], line_no, v, vt, vn);
          face_sizes_.push_back(uint32_t(tok.size() - 1));
        }
      }
      if (pass == 0) total_v_ = v, total_vt_ = vt, total_vn_ = vn;
    }
  }

 private:
  void number(std::string_view t, int line_no, std::string_view key) const {
    check_number(path_, t, line_no, key);
  }

  // "v", "v/t", "v//n" or "v/t/n": each index non-zero and in range.
  void face_vertex(std::string_view t, int line_no, size_t v, size_t vt, size_t vn) const {
    std::string_view part[3];
    int np = 0;
    size_t start = 0;
    for (size_t k = 0; k <= t.size(); ++k) {
      if (k < t.size() && t[k] != '/') continue;
      if (np > 2) throw InputError(path_, line_no, "face vertex '" + std::string(t) + "' is malformed");
      part[np++] = t.substr(start, k - start);
      start = k + 1;
    }
    const char* what[3] = {"vertex", "texture coordinate", "normal"};
    size_t so_far[3] = {v, vt, vn}, total[3] = {total_v_, total_vt_, total_vn_};
    for (int k = 0; k < np; ++k) {
      if (part[k].empty()) {
        if (k == 0) throw InputError(path_, line_no, "face vertex '" + std::string(t) + "' lacks a vertex index");
        continue;
      }
      long long i = 0;
      const char* b = part[k].data();
      const char* e = b + part[k].size();
      auto r = std::from_chars(b, e, i);
      if (r.ec != std::errc() || r.ptr != e)
        throw InputError(path_, line_no,
                         "face vertex '" + std::string(t) + "': '" + std::string(part[k]) + "' is not an index");
      bool ok = i > 0 ? size_t(i) <= total[k] : i < 0 && size_t(-i) <= so_far[k];
      if (!ok)
        throw InputError(path_, line_no,
                         std::string(what[k]) + " index " + std::string(part[k]) + " is out of range (" +
                             std::to_string(i > 0 ? total[k] : so_far[k]) + " defined)");
    }
  }

  const std::string& path_;
  const std::string& text_;
  size_t total_v_ = 0, total_vt_ = 0, total_vn_ = 0;
  size_t colored_ = 0;
  int bad_color_line_ = 0;
  std::string bad_color_;
  std::vector<uint32_t> face_sizes_;
};

// A texture map statement of an MTL file as the MTL specification reads
// it: options, then the file name (which may hold blanks; backslashes read
// as slashes), found beside the MTL file or else the OBJ. tinyobjloader
// reads -o, -s and -t as three numbers and takes the file name for a
// missing third (the specification lets v and w be left out), losing the
// map; this reading gives the name and the placement instead.
struct MtlMap {
  std::string file;
  ObjMaterial::MapPlacement placement;
};
// (material name, map index 0-4: kd, ks, ns, bump, d) -> its statement.
using MtlMaps = std::map<std::pair<std::string, int>, MtlMap>;
// (material name, 0-4: Kd, Ks, Ke, Tf, Ka) -> a colour given as one number.
using MtlGreys = std::map<std::pair<std::string, int>, float>;

int map_index(const std::string& key) {
  if (key == "map_Kd") return 0;
  if (key == "map_Ks") return 1;
  if (key == "map_Ns") return 2;
  if (key == "map_bump" || key == "map_Bump" || key == "bump") return 3;
  if (key == "map_d") return 4;
  return -1;
}

bool is_number(const std::string& t) {
  double v;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

// `t`: the statement's tokens (t[0] the keyword). Options Luz does not
// apply are said in a warning.
MtlMap parse_map(const std::vector<std::string>& t, const std::string& mtl, int line, std::vector<ObjWarning>& warnings) {
  MtlMap m;
  size_t i = 1;
  std::string ignored;
  while (i < t.size() && t[i].size() > 1 && t[i][0] == '-' && !is_number(t[i])) {
    const std::string o = t[i++];
    if (o == "-o" || o == "-s" || o == "-t") {
      float v[3] = {o == "-s" ? 1.f : 0.f, o == "-s" ? 1.f : 0.f, o == "-s" ? 1.f : 0.f};
      int n = 0;
      for (; n < 3 && i < t.size() && is_number(t[i]); ++n) v[n] = std::strtof(t[i++].c_str(), nullptr);
      if (n == 0) throw InputError(mtl, line, "'" + t[0] + "': " + o + " needs a number");
      if (o == "-o") m.placement.ou = v[0], m.placement.ov = v[1];
      else if (o == "-s") m.placement.su = v[0], m.placement.sv = v[1];
      else ignored += " -t";
      continue;
    }
    int args = o == "-mm" ? 2 : (o == "-bm" || o == "-blendu" || o == "-blendv" || o == "-clamp" || o == "-cc" ||
                                 o == "-boost" || o == "-texres" || o == "-imfchan" || o == "-type")
                                    ? 1
                                    : -1;
    if (args < 0) throw InputError(mtl, line, "'" + t[0] + "': unknown option " + o);
    if (i + size_t(args) > t.size()) throw InputError(mtl, line, "'" + t[0] + "': " + o + " needs " + std::to_string(args) + " value(s)");
    if (o != "-bm" && !(o == "-clamp" && t[i] == "off") && !((o == "-blendu" || o == "-blendv") && t[i] == "on")) ignored += " " + o;
    i += size_t(args);
  }
  for (; i < t.size(); ++i) m.file += (m.file.empty() ? "" : " ") + t[i];
  if (m.file.find('\0') != std::string::npos) throw InputError(mtl, line, "'" + t[0] + "': the file name holds a NUL byte");
  std::replace(m.file.begin(), m.file.end(), '\\', '/');  // Windows paths, as Mitsuba 0.6 reads them
  // Beside the MTL file where it is there (Blender's importer), else
  // beside the OBJ (obj_mesh).
  std::error_code ec;
  const std::filesystem::path beside = std::filesystem::path(mtl).parent_path() / m.file;
  if (!m.file.empty() && std::filesystem::exists(beside, ec)) m.file = std::filesystem::absolute(beside, ec).string();
  if (!ignored.empty()) warnings.push_back({mtl, line, "'" + t[0] + "': option(s)" + ignored + " not supported: ignored"});
  return m;
}

// The MTL files an OBJ names, checked the same way: tinyobjloader reads an
// unparsable or non-finite colour or exponent as 0 without a word.
// Missing files are warnings (the faces get the default material).
void check_mtl_files(const std::string& obj_path, const std::string& obj_text, std::vector<ObjWarning>& warnings, MtlMaps& maps,
                     MtlGreys& greys, std::string& all_mtl) {
  std::vector<std::filesystem::path> read;  // each file once
  int obj_line = 0;
  for (size_t pos = 0; pos < obj_text.size();) {
    std::string line = next_line(obj_text, pos);
    ++obj_line;
    std::vector<std::string> tok = split(line.substr(0, line.find('#')));
    if (tok.size() < 2 || tok[0] != "mtllib") continue;
    for (size_t k = 1; k < tok.size(); ++k) {
      std::filesystem::path mtl = std::filesystem::path(obj_path).parent_path() / tok[k];
      std::error_code ec;
      if (!std::filesystem::exists(mtl, ec)) {
        warnings.push_back({obj_path, obj_line, "mtllib '" + tok[k] + "' not found: its materials are diffuse 0.5"});
        continue;
      }
      // A FIFO or a device (/dev/zero) would block or never end, here and in tinyobjloader.
      if (!std::filesystem::is_regular_file(mtl, ec))
        throw InputError(obj_path, obj_line, "mtllib '" + tok[k] + "' is not a regular file");
      std::ifstream in(mtl, std::ios::binary);
      if (!in) continue;
      std::stringstream ss;
      ss << in.rdbuf();
      const std::string mtl_text = ss.str();
      bool again = false;
      for (const std::filesystem::path& r : read) again = again || std::filesystem::equivalent(r, mtl, ec);
      if (again) continue;
      read.push_back(mtl);
      all_mtl += mtl_text + "\n";
      int n = 0;
      std::string material;
      for (size_t mpos = 0; mpos < mtl_text.size();) {
        std::string ml = next_line(mtl_text, mpos);
        ++n;
        std::vector<std::string> t = split(ml.substr(0, ml.find('#')));
        if (t.empty()) continue;
        if (t[0] == "newmtl") material = t.size() > 1 ? t[1] : "";
        if (const int k = map_index(t[0]); k >= 0) {
          maps[{material, k}] = parse_map(t, mtl.string(), n, warnings);
          continue;
        }
        // Statements Luz does not read, said rather than dropped.
        static const char* kIgnored[] = {"map_Ke", "map_Ka", "refl", "disp", "decal", "norm", "map_Pr", "map_Pm",
                                         "Pr", "Pm", "Ps", "Pc", "Pcr", "aniso", "anisor", "sharpness"};
        bool ignored = false;
        for (const char* key : kIgnored) ignored = ignored || t[0] == key;
        if (ignored) {
          warnings.push_back({mtl.string(), n, "'" + t[0] + "' is not supported: ignored"});
          continue;
        }
        static const char* kNumeric[] = {"Kd", "Ks", "Ke", "Ka", "Tf", "Ns", "Ni", "d", "Tr", "illum"};
        bool numeric = false;
        for (const char* key : kNumeric) numeric = numeric || t[0] == key;
        if (!numeric) continue;
        if (t.size() < 2) throw InputError(mtl.string(), n, "'" + t[0] + "' needs a value");
        for (size_t j = 1; j < t.size(); ++j) check_number(mtl.string(), t[j], n, t[0]);
        // One number is a grey (the MTL specification: g and b default to r),
        // which tinyobjloader reads as red (g = b = 0): kept here for obj_mesh.
        const bool colour = t[0] == "Kd" || t[0] == "Ks" || t[0] == "Ke" || t[0] == "Ka" || t[0] == "Tf";
        if (colour && t.size() == 2) {
          const int k = t[0] == "Kd" ? 0 : t[0] == "Ks" ? 1 : t[0] == "Ke" ? 2 : t[0] == "Tf" ? 3 : 4;
          greys[{material, k}] = std::strtof(t[1].c_str(), nullptr);
        } else if (colour && t.size() != 4) {
          throw InputError(mtl.string(), n, "'" + t[0] + "' needs 3 numbers (r g b) or one (a grey)");
        }
        // Ranges Luz needs, reported at their line (load_obj_scene scales Kd + Ks above 1 per material).
        for (size_t j = 1; j < t.size(); ++j) {
          double v = std::strtod(t[j].c_str(), nullptr);
          if ((t[0] == "Ke" || t[0] == "Ns" || t[0] == "Tf" || t[0] == "Kd" || t[0] == "Ks") && !(v >= 0))
            throw InputError(mtl.string(), n, "'" + t[0] + "': '" + t[j] + "' must not be negative");
          if ((t[0] == "d" || t[0] == "Tr") && !(v >= 0 && v <= 1))
            throw InputError(mtl.string(), n, "'" + t[0] + "': '" + t[j] + "' must lie in [0, 1]");
          if (t[0] == "Ni" && !(v > 0))
            throw InputError(mtl.string(), n, "'Ni': '" + t[j] + "' must be positive");
        }
      }
    }
  }
}

// `usemtl` names no material of the MTL files, or one of an mtllib given
// only after it (tinyobjloader reads materials as the lines come): a
// warning at its line (the faces get the default material).
void unknown_materials(const std::string& path, const std::string& text, const std::vector<tinyobj::material_t>& mats,
                       std::vector<ObjWarning>& warnings) {
  int line_no = 0;
  bool library = false;  // an mtllib seen
  for (size_t pos = 0; pos < text.size();) {
    const std::vector<std::string> tok = split(next_line(text, pos));
    ++line_no;
    library |= !tok.empty() && tok[0] == "mtllib";
    if (tok.size() < 2 || tok[0] != "usemtl") continue;
    bool known = false;
    for (const tinyobj::material_t& m : mats) known = known || m.name == tok[1];
    if (!known) warnings.push_back({path, line_no, "usemtl '" + tok[1] + "': no such material: diffuse 0.5"});
    else if (!library)
      warnings.push_back({path, line_no, "usemtl '" + tok[1] + "' comes before any mtllib: its faces get diffuse 0.5"});
  }
}

std::string read_text(const std::string& path) {
  std::error_code ec;
  std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st)) throw InputError(path, 0, "cannot open file: no such file");
  if (std::filesystem::is_directory(st)) throw InputError(path, 0, "cannot open file: is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

// An OBJ file read, checked and parsed: read_obj before de-indexing.
struct ObjFile {
  std::string path, text;
  bool with_materials = false;
  tinyobj::ObjReader reader;
  std::vector<ObjWarning> warnings;
  MtlMaps maps;    // the MTL files' map statements as Luz reads them
  MtlGreys greys;  // and their one-number colours
  size_t colored_vertices = 0;  // `v` lines with a colour (then attrib.colors holds one per vertex)
  int bad_color_line = 0;       // the first colour outside [0, 1], or 0
  std::string bad_color;
  // The faces as triangles (triangulate()), each with its face's material
  // and smoothing group.
  struct Triangle {
    tinyobj::index_t corner[3];
    int material;
    unsigned group;
  };
  std::vector<Triangle> triangles;
};

namespace {

// A polygon's triangles as corner numbers, in its winding: a fan where it
// is convex (every corner turns the same way; a quad split along its
// shorter diagonal), else ear clipping in the plane of its Newell normal,
// so that concave faces (tinyobjloader's own triangulation fills their
// notches or drops parts) come out whole. A polygon that is not simple
// falls back to a fan of what remains.
void triangulate(const std::vector<Vec3>& p, std::vector<std::array<uint32_t, 3>>& out) {
  const size_t n = p.size();
  double nx = 0, ny = 0, nz = 0;  // Newell's normal
  for (size_t i = 0; i < n; ++i) {
    const Vec3 a = p[i], b = p[(i + 1) % n];
    nx += double(a.y - b.y) * (a.z + b.z), ny += double(a.z - b.z) * (a.x + b.x), nz += double(a.x - b.x) * (a.y + b.y);
  }
  // Project out the normal's largest axis; `sign` makes the winding counter-clockwise.
  const int k = std::fabs(nx) >= std::fabs(ny) && std::fabs(nx) >= std::fabs(nz) ? 0 : std::fabs(ny) >= std::fabs(nz) ? 1 : 2;
  const double sign = (k == 0 ? nx : k == 1 ? ny : nz) < 0 ? -1.0 : 1.0;
  std::vector<double> u(n), v(n);
  for (size_t i = 0; i < n; ++i) u[i] = p[i][(k + 1) % 3], v[i] = p[i][(k + 2) % 3];
  auto turn = [&](size_t a, size_t b, size_t c) {
    return sign * ((u[b] - u[a]) * (v[c] - v[b]) - (v[b] - v[a]) * (u[c] - u[b]));
  };
  bool convex = true;
  for (size_t i = 0; i < n && convex; ++i) convex = turn(i, (i + 1) % n, (i + 2) % n) >= 0.0;
  auto fan = [&](const std::vector<uint32_t>& ring) {
    for (size_t i = 1; i + 1 < ring.size(); ++i) out.push_back({ring[0], ring[i], ring[i + 1]});
  };
  if (convex && n == 4) {  // along the shorter diagonal, as tinyobjloader splits quads
    const Vec3 d02 = p[2] - p[0], d13 = p[3] - p[1];
    if (dot(d02, d02) < dot(d13, d13)) out.push_back({0, 1, 2}), out.push_back({0, 2, 3});
    else out.push_back({0, 1, 3}), out.push_back({1, 2, 3});
    return;
  }
  std::vector<uint32_t> ring(n);
  for (size_t i = 0; i < n; ++i) ring[i] = uint32_t(i);
  if (convex || n == 3) return fan(ring);
  // Ear clipping: a convex corner whose triangle holds no other corner.
  auto inside = [&](uint32_t q, uint32_t a, uint32_t b, uint32_t c) {
    return turn(a, b, q) >= 0.0 && turn(b, c, q) >= 0.0 && turn(c, a, q) >= 0.0;
  };
  size_t i = 0, misses = 0;
  while (ring.size() > 3) {
    const size_t m = ring.size();
    const uint32_t a = ring[(i + m - 1) % m], b = ring[i % m], c = ring[(i + 1) % m];
    bool ear = turn(a, b, c) > 0.0;
    for (size_t j = 0; ear && j < m; ++j) {
      const uint32_t q = ring[j];
      if (q != a && q != b && q != c && turn(ring[(j + m - 1) % m], q, ring[(j + 1) % m]) <= 0.0 && inside(q, a, b, c))
        ear = false;  // only a reflex corner can lie inside an ear
    }
    if (ear) {
      out.push_back({a, b, c});
      ring.erase(ring.begin() + std::ptrdiff_t(i % m));
      misses = 0;
      i %= m;  // the ring shifted down: b's successor is at i now (at 0 when b was last)
    } else if (++misses > m) {
      return fan(ring);  // no ear: not a simple polygon
    } else {
      i = (i + 1) % m;
    }
  }
  out.push_back({ring[0], ring[1], ring[2]});
}

std::shared_ptr<ObjFile> parse_obj(const std::string& path, bool with_materials) {
  auto file = std::make_shared<ObjFile>();
  file->path = path;
  file->text = read_text(path);
  file->with_materials = with_materials;
  const std::string& text = file->text;
  ObjChecker checker(path, text);
  checker.check();
  // Every MTL file the OBJ names, in order: tinyobjloader reads only the
  // first it finds of an mtllib line naming several.
  std::string all_mtl;
  if (with_materials) check_mtl_files(path, text, file->warnings, file->maps, file->greys, all_mtl);
  tinyobj::ObjReaderConfig config;
  config.triangulate = false;  // triangulate() below
  file->colored_vertices = checker.colored_vertices();
  file->bad_color_line = checker.bad_color_line();
  file->bad_color = checker.bad_color();
  config.vertex_color = file->colored_vertices > 0;  // white where a `v` line has none
  tinyobj::ObjReader& reader = file->reader;
  // From the text read already; materials from all_mtl (empty without materials), read at the first mtllib.
  if (!reader.ParseFromString(text, all_mtl, config)) {
    std::string e = reader.Error();
    while (!e.empty() && (e.back() == '\n' || e.back() == '\r')) e.pop_back();
    for (char& c : e)
      if (c == '\n') c = ' ';
    throw InputError(path, 0, "malformed OBJ: " + e);
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  // Checked above already; kept as a guard so no bad value or index gets past.
  for (float x : attrib.vertices)
    if (!std::isfinite(x)) throw InputError(path, 0, "vertex coordinate is not a finite number");
  for (float x : attrib.normals)
    if (!std::isfinite(x)) throw InputError(path, 0, "normal is not a finite number");
  for (float x : attrib.texcoords)
    if (!std::isfinite(x)) throw InputError(path, 0, "texture coordinate is not a finite number");
  const size_t nv = attrib.vertices.size() / 3, nn = attrib.normals.size() / 3, nt = attrib.texcoords.size() / 2;
  if (file->colored_vertices > 0 && attrib.colors.size() != attrib.vertices.size())
    throw InputError(path, 0, "the vertex colours tinyobjloader read differ from the file's 'v' lines");
  std::vector<Vec3> polygon;
  std::vector<std::array<uint32_t, 3>> tris;
  const std::vector<uint32_t>& sizes = checker.face_sizes();
  size_t face = 0;  // in the file's order, across the shapes
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    for (const tinyobj::index_t& idx : shape.mesh.indices)
      if (idx.vertex_index < 0 || size_t(idx.vertex_index) >= nv ||
          (idx.normal_index >= 0 && size_t(idx.normal_index) >= nn) ||
          (idx.texcoord_index >= 0 && size_t(idx.texcoord_index) >= nt))
        throw InputError(path, 0, "face index out of range");
    size_t first = 0;
    for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      const size_t n = face < sizes.size() ? sizes[face++] : 0;
      if (n % 256 != shape.mesh.num_face_vertices[f] || first + n > shape.mesh.indices.size() || n < 3)
        throw InputError(path, 0, "the faces tinyobjloader read differ from the file's 'f' lines");
      const tinyobj::index_t* c = &shape.mesh.indices[first];
      first += n;
      polygon.resize(n);
      for (size_t j = 0; j < n; ++j) {
        const float* q = &attrib.vertices[3 * size_t(c[j].vertex_index)];
        polygon[j] = {q[0], q[1], q[2]};
      }
      tris.clear();
      triangulate(polygon, tris);
      const int mat = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
      const unsigned group = f < shape.mesh.smoothing_group_ids.size() ? shape.mesh.smoothing_group_ids[f] : 0u;
      for (const auto& t : tris) file->triangles.push_back({{c[t[0]], c[t[1]], c[t[2]]}, mat, group});
    }
    if (first != shape.mesh.indices.size()) throw InputError(path, 0, "the faces tinyobjloader read differ from the file's 'f' lines");
  }
  if (face != sizes.size()) throw InputError(path, 0, "the faces tinyobjloader read differ from the file's 'f' lines");
  return file;
}

}  // namespace

std::shared_ptr<const ObjFile> read_obj_file(const std::string& path) { return parse_obj(path, false); }

ObjMesh read_obj(const std::string& path, bool with_materials, ObjTexcoords texcoords, ObjSmoothing smoothing) {
  return obj_mesh(*parse_obj(path, with_materials), texcoords, smoothing);
}

ObjMesh obj_mesh(const ObjFile& file, ObjTexcoords texcoords, ObjSmoothing smoothing) {
  const std::string& path = file.path;
  const std::string& text = file.text;
  const bool with_materials = file.with_materials;
  const tinyobj::ObjReader& reader = file.reader;
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  ObjMesh mesh;
  mesh.warnings = file.warnings;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  auto texture = [&](const std::string& name) { return name.empty() ? name : (dir / name).string(); };
  bool textured = false;
  if (with_materials) {
    for (const tinyobj::material_t& m : reader.GetMaterials()) {
      ObjMaterial om;
      om.name = m.name;
      om.kd = {m.diffuse[0], m.diffuse[1], m.diffuse[2]};
      om.ks = {m.specular[0], m.specular[1], m.specular[2]};
      om.ke = {m.emission[0], m.emission[1], m.emission[2]};
      Color* greyed[4] = {&om.kd, &om.ks, &om.ke, &om.tf};
      om.ns = m.shininess;
      om.illum = m.illum;
      om.ni = m.ior;
      om.tf = {m.transmittance[0], m.transmittance[1], m.transmittance[2]};
      for (int k = 0; k < 4; ++k)
        if (auto it = file.greys.find({m.name, k}); it != file.greys.end()) *greyed[k] = {it->second, it->second, it->second};
      om.d = m.dissolve;
      std::string* names[5] = {&om.map_kd, &om.map_ks, &om.map_ns, &om.map_bump, &om.map_d};
      const std::string* tiny[5] = {&m.diffuse_texname, &m.specular_texname, &m.specular_highlight_texname, &m.bump_texname,
                                    &m.alpha_texname};
      for (int k = 0; k < 5; ++k) {
        auto it = file.maps.find({m.name, k});
        *names[k] = texture(it != file.maps.end() ? it->second.file : *tiny[k]);
        if (it != file.maps.end()) om.placement[k] = it->second.placement;
      }
      om.bump_multiplier = m.bump_texopt.bump_multiplier;
      textured |= !(om.map_kd + om.map_ks + om.map_ns + om.map_bump + om.map_d).empty();
      mesh.materials.push_back(om);
    }
    unknown_materials(path, text, reader.GetMaterials(), mesh.warnings);
  }

  // Normals and texture coordinates per face corner, as Blender's importer
  // reads them: a corner without a normal takes its face's (flat), one
  // without texture coordinates (0, 0), with a warning, where other
  // corners of the file have them. With ObjSmoothing::Groups, a corner
  // without a normal on a face of smoothing group g != 0 takes the
  // area-weighted mean of the normals of group g's faces at its position.
  const bool want_texcoords = texcoords == ObjTexcoords::Yes || (texcoords == ObjTexcoords::IfTextured && textured);
  const bool any_texcoords = want_texcoords && !attrib.texcoords.empty();
  auto position = [&](int v) {
    const float* p = &attrib.vertices[3 * size_t(v)];
    return Vec3{p[0], p[1], p[2]};
  };
  auto group_of = [&](const ObjFile::Triangle& t) { return smoothing == ObjSmoothing::Groups ? t.group : 0u; };
  struct PairHash {
    size_t operator()(const std::pair<unsigned, int>& k) const {
      return size_t((uint64_t(k.first) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(uint32_t(k.second)) * 0xC2B2AE3D27D4EB4Full));
    }
  };
  std::unordered_map<std::pair<unsigned, int>, Vec3, PairHash> group_normal;  // (group, position) -> sum of area-weighted normals
  for (const ObjFile::Triangle& t : file.triangles) {
    const unsigned g = group_of(t);
    if (g == 0) continue;
    const tinyobj::index_t* c = t.corner;
    if (c[0].normal_index >= 0 && c[1].normal_index >= 0 && c[2].normal_index >= 0) continue;
    const Vec3 n = cross(position(c[1].vertex_index) - position(c[0].vertex_index),
                         position(c[2].vertex_index) - position(c[0].vertex_index));
    if (!is_finite(n)) continue;
    for (int j = 0; j < 3; ++j) group_normal[{g, c[j].vertex_index}] += n;
  }
  const bool any_normals = !attrib.normals.empty() || !group_normal.empty();
  size_t flat_faces = 0, bare_faces = 0;
  // Vertex colours: sRGB-encoded, as exporters write them (Blender's, MeshLab's, three.js's).
  // Colours outside [0, 1] (exporters of 0-255 values): none is used.
  if (file.bad_color_line > 0)
    mesh.colors_dropped = {path, file.bad_color_line,
                           "vertex colour '" + file.bad_color + "' is not within [0, 1]: the file's vertex colours are not used"};
  const bool colored = file.colored_vertices > 0 && file.bad_color_line == 0;
  if (colored && file.colored_vertices < attrib.vertices.size() / 3)
    mesh.warnings.push_back({path, 0, std::to_string(attrib.vertices.size() / 3 - file.colored_vertices) +
                                          " vertices lack a colour where others have one: white"});

  // De-indexing: one vertex per distinct (position, normal, uv) index
  // triple; a corner without a normal is its face's own vertex (normal
  // index -2 - face), one without texture coordinates has uv index -1.
  struct TripleHash {
    size_t operator()(const std::tuple<long long, long long, long long>& k) const {
      const uint64_t a = uint64_t(std::get<0>(k)), b = uint64_t(std::get<1>(k)), c = uint64_t(std::get<2>(k));
      return size_t((a * 0x9E3779B97F4A7C15ull) ^ (b * 0xC2B2AE3D27D4EB4Full) ^ (c * 0x165667B19E3779F9ull));
    }
  };
  std::unordered_map<std::tuple<long long, long long, long long>, uint32_t, TripleHash> remap;
  remap.reserve(attrib.vertices.size() / 3);
  long long face_number = 0;
  for (const ObjFile::Triangle& tri : file.triangles) {
    ++face_number;
    const tinyobj::index_t* corner = tri.corner;
    const unsigned group = group_of(tri);
    bool flat = false, bare = false;
    Vec3 face_normal{0.f, 0.f, 1.f};
    if (any_normals && (corner[0].normal_index < 0 || corner[1].normal_index < 0 || corner[2].normal_index < 0)) {
      const Vec3 n = cross(position(corner[1].vertex_index) - position(corner[0].vertex_index),
                           position(corner[2].vertex_index) - position(corner[0].vertex_index));
      if (length(n) > 0.f && is_finite(n)) face_normal = normalize(n);
    }
    for (int j = 0; j < 3; ++j) {
      const tinyobj::index_t& idx = corner[j];
      const bool has_normal = any_normals && idx.normal_index >= 0, has_uv = any_texcoords && idx.texcoord_index >= 0;
      const bool smooth = any_normals && !has_normal && group != 0;
      flat |= any_normals && !has_normal && !smooth && !attrib.normals.empty();
      bare |= any_texcoords && !has_uv;
      // Normal key: the file's index; a smoothing group's -(2^40 + g); a flat face's own -2 - face.
      std::tuple<long long, long long, long long> key{
          idx.vertex_index,
          has_normal ? idx.normal_index : smooth ? -(1ll << 40) - group : any_normals ? -2 - face_number : -1,
          has_uv ? idx.texcoord_index : -1};
      auto it = remap.find(key);
      if (it == remap.end()) {
        it = remap.emplace(key, uint32_t(mesh.positions.size())).first;
        const float* v = &attrib.vertices[3 * size_t(idx.vertex_index)];
        mesh.positions.push_back({v[0], v[1], v[2]});
        if (any_normals) {
          Vec3 normal = face_normal;
          if (has_normal) {
            const float* n = &attrib.normals[3 * size_t(idx.normal_index)];
            normal = {n[0], n[1], n[2]};
          } else if (smooth) {
            auto sum = group_normal.find({group, idx.vertex_index});  // none where every face there is degenerate
            if (sum != group_normal.end() && length(sum->second) > 0.f) normal = normalize(sum->second);
          }
          mesh.normals.push_back(normal);
        }
        if (any_texcoords) {
          const float* t = has_uv ? &attrib.texcoords[2 * size_t(idx.texcoord_index)] : nullptr;
          mesh.texcoords.push_back(t ? Vec2{t[0], 1.f - t[1]} : Vec2{0.f, 1.f});  // vt (0, 0), v flipped
        }
        if (colored) {
          const float* c = &attrib.colors[3 * size_t(idx.vertex_index)];
          mesh.colors.push_back({float(srgb_to_linear(c[0])), float(srgb_to_linear(c[1])), float(srgb_to_linear(c[2]))});
        }
      }
      mesh.indices.push_back(it->second);
    }
    flat_faces += flat;
    bare_faces += bare;
    mesh.face_material.push_back(with_materials ? tri.material : -1);
  }
  if (flat_faces > 0)
    mesh.warnings.push_back({path, 0, std::to_string(flat_faces) + " triangles lack normals (vn) where others have them: shaded flat"});
  if (bare_faces > 0)
    mesh.warnings.push_back({path, 0, std::to_string(bare_faces) +
                                          " triangles lack texture coordinates (vt) where others have them: read as (0, 0)"});
  if (mesh.indices.empty()) throw InputError(path, 0, "mesh has no faces");
  if (file.bad_color_line > 0) mesh.warnings.push_back(mesh.colors_dropped);
  return mesh;
}

}  // namespace luz
