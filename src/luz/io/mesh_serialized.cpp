#include "luz/io/mesh_serialized.h"

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "luz/core/memory.h"
#include "luz/io/error.h"

namespace luz {

namespace {

constexpr uint16_t kFormat = 0x041C;
constexpr uint32_t kHasNormals = 0x0001, kHasUvs = 0x0002, kHasColors = 0x0008, kFaceNormals = 0x0010,
                   kSingle = 0x1000, kDouble = 0x2000;
// Deflate expands at most 1032:1: a count that needs more than that from the
// bytes left is a lie, refused before anything is allocated.
constexpr uint64_t kMaxInflateRatio = 1032;
constexpr size_t kMaxNameLength = 1 << 16;

template <typename T>
T little_endian(const uint8_t* p) {
  T v = 0;
  for (size_t i = 0; i < sizeof(T); ++i) v = T(v | (T(p[i]) << (8 * i)));
  return v;
}

class Reader {
 public:
  Reader(const std::string& name, const uint8_t* data, size_t size) : name_(name), data_(data), size_(size) {}
  ~Reader() {
    if (open_) inflateEnd(&z_);
  }

  [[noreturn]] void fail(size_t byte, const std::string& problem) const {
    throw InputError(name_, 0, "byte " + std::to_string(byte) + ": " + problem);
  }
  // The decompressed stream's problems name the shape's header byte and the
  // offset in its decompressed data.
  [[noreturn]] void fail_data(const std::string& problem) const {
    fail(start_, "shape " + std::to_string(shape_) + ", decompressed byte " + std::to_string(z_.total_out) + ": " +
                     problem);
  }

  SerializedMesh read(uint32_t shape_index) {
    shape_ = shape_index;
    if (size_ < 4) fail(0, "truncated header (a .serialized file starts with 0x041C and a version)");
    if (little_endian<uint16_t>(data_) != kFormat) fail(0, "not a Mitsuba .serialized file (format is not 0x041C)");
    const uint16_t version = little_endian<uint16_t>(data_ + 2);
    if (version != 3 && version != 4) fail(2, "unsupported version " + std::to_string(version) + " (3 or 4)");
    start_ = shape_index == 0 ? 0 : shape_offset(shape_index, version);
    if (start_ + 4 > size_) fail(start_, "shape " + std::to_string(shape_index) + " starts beyond the file's end");
    if (little_endian<uint16_t>(data_ + start_) != kFormat || little_endian<uint16_t>(data_ + start_ + 2) != version)
      fail(start_, "shape " + std::to_string(shape_index) + " has no header 0x041C, version " + std::to_string(version));

    std::memset(&z_, 0, sizeof z_);
    if (inflateInit(&z_) != Z_OK) fail(start_, "zlib cannot start");
    open_ = true;
    z_.next_in = const_cast<Bytef*>(data_ + start_ + 4);
    const size_t avail = size_ - start_ - 4;
    z_.avail_in = uInt(std::min<size_t>(avail, UINT32_MAX));

    SerializedMesh m;
    const uint32_t flags = get<uint32_t>();
    if ((flags & kSingle) && (flags & kDouble)) fail_data("flags claim both single and double precision");
    if (version == 4) {
      for (char c; (c = char(get<uint8_t>())) != 0;) {
        if (m.name.size() >= kMaxNameLength) fail_data("shape name longer than 65536 bytes");
        m.name += c;
      }
    }
    const uint64_t nv = get<uint64_t>(), nt = get<uint64_t>();
    if (nv > UINT32_MAX) fail_data("more than 2^32 - 1 vertices");
    if (nt > UINT32_MAX / 3) fail_data("more than (2^32 - 1) / 3 triangles");
    const uint64_t fsize = (flags & kDouble) ? 8 : 4;
    const uint64_t per_vertex =
        3 + ((flags & kHasNormals) ? 3 : 0) + ((flags & kHasUvs) ? 2 : 0) + ((flags & kHasColors) ? 3 : 0);
    const uint64_t need = nv * per_vertex * fsize + nt * 12;
    if (need > kMaxInflateRatio * avail + 64)
      fail_data(std::to_string(nv) + " vertices and " + std::to_string(nt) +
                " triangles need more data than the file's remaining " + std::to_string(avail) + " bytes can hold");

    // In memory: Vec3 positions, normals, colours, Vec2 uvs, the indices and
    // their raw bytes.
    const uint64_t resident = nv * (sizeof(Vec3) * (1 + bool(flags & kHasNormals) + bool(flags & kHasColors)) +
                                    ((flags & kHasUvs) ? sizeof(Vec2) : 0)) +
                              nt * 24;
    require_memory(resident, name_, "shape " + std::to_string(shape_) + "'s " + std::to_string(nv) + " vertices and " +
                                        std::to_string(nt) + " triangles");
    m.positions = vectors<Vec3>(size_t(nv), flags & kDouble, "position");
    if (flags & kHasNormals) m.normals = vectors<Vec3>(size_t(nv), flags & kDouble, "normal");
    if (flags & kHasUvs) m.uvs = vectors<Vec2>(size_t(nv), flags & kDouble, "texture coordinate");
    if (flags & kHasColors) m.colors = vectors<Vec3>(size_t(nv), flags & kDouble, "colour");
    m.indices.resize(size_t(nt) * 3);
    std::vector<uint8_t> raw(m.indices.size() * 4);
    fill(raw.data(), raw.size());
    for (size_t i = 0; i < m.indices.size(); ++i) {
      m.indices[i] = little_endian<uint32_t>(raw.data() + 4 * i);
      if (m.indices[i] >= nv)
        fail_data("triangle " + std::to_string(i / 3) + " names vertex " + std::to_string(m.indices[i]) + " of " +
                  std::to_string(nv));
    }
    finish();
    m.face_normals = flags & kFaceNormals;
    return m;
  }

 private:
  // The byte where shape `index` starts, from the table at the file's end.
  size_t shape_offset(uint32_t index, uint16_t version) const {
    if (size_ < 8) fail(size_ > 4 ? 4 : 0, "truncated: no shape table at the end");
    const uint32_t count = little_endian<uint32_t>(data_ + size_ - 4);
    if (index >= count)
      fail(size_ - 4, "shape_index " + std::to_string(index) + " is out of range (the file holds " +
                          std::to_string(count) + " shapes)");
    const size_t entry = version == 4 ? 8 : 4;
    if (uint64_t(count) * entry + 4 > size_) fail(size_ - 4, "a table of " + std::to_string(count) + " shapes does not fit the file");
    const size_t at = size_ - 4 - entry * (count - index);
    const uint64_t offset = version == 4 ? little_endian<uint64_t>(data_ + at) : little_endian<uint32_t>(data_ + at);
    if (offset >= size_) fail(at, "shape " + std::to_string(index) + "'s offset " + std::to_string(offset) + " lies beyond the file's end");
    return size_t(offset);
  }

  // Exactly n decompressed bytes into dst.
  void fill(uint8_t* dst, size_t n) {
    while (n > 0) {
      const uInt chunk = uInt(std::min<size_t>(n, 1u << 30));
      z_.next_out = dst;
      z_.avail_out = chunk;
      while (z_.avail_out > 0) {
        const uInt before = z_.avail_out;
        int r = inflate(&z_, Z_NO_FLUSH);
        if (r == Z_STREAM_END && z_.avail_out > 0) fail_data("the compressed data end early (truncated shape)");
        if (r != Z_OK && r != Z_STREAM_END) {
          if (r == Z_BUF_ERROR && z_.avail_in == 0) fail_data("truncated compressed data");
          fail_data(std::string("corrupt compressed data (zlib: ") + (z_.msg ? z_.msg : "error") + ")");
        }
        if (z_.avail_out == before && z_.avail_in == 0) fail_data("truncated compressed data");
      }
      dst += chunk;
      n -= chunk;
    }
  }
  // The stream must end here (its checksum verified): no data after the triangles.
  void finish() {
    uint8_t extra;
    z_.next_out = &extra;
    z_.avail_out = 1;
    const int r = inflate(&z_, Z_FINISH);
    if (r == Z_STREAM_END && z_.avail_out == 1) return;
    if (z_.avail_out == 0) fail_data("data after the last triangle");
    if (r == Z_DATA_ERROR) fail_data(std::string("corrupt compressed data (zlib: ") + (z_.msg ? z_.msg : "error") + ")");
    fail_data("truncated compressed data");
  }
  template <typename T>
  T get() {
    uint8_t b[sizeof(T)];
    fill(b, sizeof b);
    return little_endian<T>(b);
  }
  // n vectors of V's size, from floats or doubles; every value finite.
  template <typename V>
  std::vector<V> vectors(size_t n, bool dbl, const char* what) {
    static_assert(sizeof(V) % sizeof(float) == 0);
    constexpr size_t dim = sizeof(V) / sizeof(float);
    const size_t fs = dbl ? 8 : 4;
    std::vector<uint8_t> raw(n * dim * fs);
    fill(raw.data(), raw.size());
    std::vector<V> out(n);
    if (n == 0) return out;
    float* dst = &out.data()->x;  // Vec2 and Vec3 are plain arrays of floats
    for (size_t i = 0; i < n; ++i)
      for (size_t k = 0; k < dim; ++k) {
        const uint8_t* p = raw.data() + (i * dim + k) * fs;
        double v;
        if (dbl) {
          const uint64_t bits = little_endian<uint64_t>(p);
          std::memcpy(&v, &bits, 8);
        } else {
          const uint32_t bits = little_endian<uint32_t>(p);
          float f;
          std::memcpy(&f, &bits, 4);
          v = f;
        }
        if (!std::isfinite(float(v)))
          fail_data(std::string(what) + " " + std::to_string(i) + " is not finite");
        dst[i * dim + k] = float(v);
      }
    return out;
  }

  std::string name_;
  const uint8_t* data_;
  size_t size_;
  size_t start_ = 0;
  uint32_t shape_ = 0;
  z_stream z_{};
  bool open_ = false;
};

}  // namespace

SerializedMesh read_serialized_memory(const std::string& name, const uint8_t* data, size_t size, uint32_t shape_index) {
  return Reader(name, data, size).read(shape_index);
}

std::vector<uint8_t> read_binary_file(const std::string& path) {
  // A directory, a FIFO or a device would fail mid-read, block or never end.
  std::error_code ec;
  if (path.find('\0') != std::string::npos) throw InputError(path, 0, "the file name holds a NUL byte");
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw InputError(path, 0, "not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, std::string("cannot open: ") + std::strerror(errno));
  std::vector<uint8_t> data;
  try {
    data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::ios_base::failure&) {
    throw InputError(path, 0, "read error");
  }
  if (in.bad()) throw InputError(path, 0, "read error");
  return data;
}

SerializedMesh read_serialized(const std::string& path, uint32_t shape_index) {
  const std::vector<uint8_t> data = read_binary_file(path);
  return read_serialized_memory(path, data.data(), data.size(), shape_index);
}

}  // namespace luz
