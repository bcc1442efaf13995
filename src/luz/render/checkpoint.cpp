#include "luz/render/checkpoint.h"

#include <sys/stat.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <new>
#include <type_traits>

#include "luz/core/version.h"
#include "luz/io/atomic_file.h"
#include "luz/io/error.h"
#include "luz/math/hash.h"
#include "luz/scene/scene_info.h"

static_assert(std::endian::native == std::endian::little, "checkpoints are written little-endian, as in memory");

namespace luz {

namespace {

constexpr char kMagic[8] = {'L', 'U', 'Z', 'C', 'K', 'P', 'T', '2'};
// Bounds a reader checks before it allocates.
constexpr uint32_t kMaxStrings = 1 << 16, kMaxString = 1 << 20;
constexpr uint32_t kMaxSide = 65536;

// zlib's crc32 over any length (its own takes a uInt).
uLong crc_update(uLong crc, const void* p, size_t n) {
  const Bytef* b = static_cast<const Bytef*>(p);
  while (n > 0) {
    const uInt k = uInt(std::min<size_t>(n, 1u << 30));
    crc = ::crc32(crc, b, k);
    b += k;
    n -= k;
  }
  return crc;
}

// 64-bit hash of bytes (whole 8-byte words through math/hash.h's mixer).
class Hasher {
 public:
  void bytes(const void* data, size_t n) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    h_ = hash_combine(h_, n);
    for (; n >= 8; n -= 8, p += 8) {
      uint64_t w;
      std::memcpy(&w, p, 8);
      h_ = hash_combine(h_, w);
    }
    uint64_t w = 0;
    if (n > 0) std::memcpy(&w, p, n);  // p may be null (an empty vector's data())
    h_ = hash_combine(h_, w);
  }
  // Structs hashed by value: padding bytes zeroed first, as they hold
  // whatever the memory held.
  template <class T>
  void values(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    count(v.size());
    for (const T& x : v) value(x);
  }
  template <class T>
  void value(const T& x) {
    static_assert(std::is_trivially_copyable_v<T>);
    alignas(T) unsigned char copy[sizeof(T)];
    std::memcpy(copy, &x, sizeof(T));
#if defined(__has_builtin)
#if __has_builtin(__builtin_clear_padding)
    __builtin_clear_padding(reinterpret_cast<T*>(copy));
#endif
#endif
    bytes(copy, sizeof(T));
  }
  // Tagged unions hashed by their live members: `make` builds a copy from
  // them alone into zeroed bytes (the rest of the union holds whatever the
  // memory held).
  template <class T, class Make>
  void live(const std::vector<T>& v, Make make) {
    count(v.size());
    for (const T& x : v) {
      alignas(T) unsigned char copy[sizeof(T)] = {};
      value(*make(static_cast<void*>(copy), x));
    }
  }
  template <class T>
  void array(const std::vector<T>& v) {  // types without padding
    static_assert(std::has_unique_object_representations_v<T> || std::is_floating_point_v<T> ||
                  std::is_same_v<T, Vec3> || std::is_same_v<T, Vec2>);
    bytes(v.data(), v.size() * sizeof(T));
  }
  std::string hex() const {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)h_);
    return std::string("#") + buf;  // '#': a hash, not a value to show
  }

 private:
  void count(size_t n) { h_ = hash_combine(h_, n); }
  uint64_t h_ = 0x4c757a;
};

// Writes through an AtomicFile, keeping the CRC-32 of what it wrote.
class Writer {
 public:
  explicit Writer(const std::string& path) : file_(path) {}
  void bytes(const void* p, size_t n) {
    file_.write(p, n);
    crc_ = crc_update(crc_, p, n);
  }
  template <class T>
  void pod(const T& v) {
    bytes(&v, sizeof v);
  }
  void str(const std::string& s) {
    pod(uint32_t(s.size()));
    bytes(s.data(), s.size());
  }
  template <class T>
  void array(const std::vector<T>& v) {
    bytes(v.data(), v.size() * sizeof(T));
  }
  void finish() {
    const uint32_t c = uint32_t(crc_);
    file_.write(&c, sizeof c);
    file_.commit();
  }

 private:
  AtomicFile file_;
  uLong crc_ = ::crc32(0, nullptr, 0);
};

class Reader {
 public:
  explicit Reader(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) throw InputError(path, 0, "cannot open the checkpoint: " + std::string(std::strerror(errno)));
    if (!S_ISREG(st.st_mode)) throw InputError(path, 0, "the checkpoint is not a regular file");
    if (!in_) throw InputError(path, 0, "cannot open the checkpoint: " + std::string(std::strerror(errno)));
    left_ = uint64_t(st.st_size);
  }
  [[noreturn]] void fail(const std::string& what) const { throw InputError(path_, 0, what); }
  void bytes(void* p, size_t n) {
    if (n > left_ || !in_.read(static_cast<char*>(p), std::streamsize(n)))
      fail("the checkpoint is truncated (the render that wrote it was stopped, or the file was cut)");
    left_ -= n;
    crc_ = crc_update(crc_, p, n);
  }
  template <class T>
  T pod() {
    T v;
    bytes(&v, sizeof v);
    return v;
  }
  std::string str() {
    const uint32_t n = pod<uint32_t>();
    if (n > kMaxString || n > left_) fail("the checkpoint is corrupted (a string of " + std::to_string(n) + " bytes)");
    std::string s(n, '\0');
    bytes(s.data(), n);
    return s;
  }
  template <class T>
  void array(std::vector<T>& v) {
    bytes(v.data(), v.size() * sizeof(T));
  }
  uint64_t left() const { return left_; }
  void finish() {
    const uint32_t expect = uint32_t(crc_);
    uint32_t stored;
    if (left_ != sizeof stored || !in_.read(reinterpret_cast<char*>(&stored), sizeof stored))
      fail(left_ < sizeof stored ? "the checkpoint is truncated" : "the checkpoint has bytes past its end");
    if (stored != expect) fail("the checkpoint is corrupted (its checksum does not match its contents)");
  }

 private:
  std::string path_;
  std::ifstream in_;
  uint64_t left_ = 0;
  uLong crc_ = ::crc32(0, nullptr, 0);
};

}  // namespace

RenderFields render_fields(const Scene& scene, RenderDevice device) {
  const RenderSettings& s = scene.settings;
  const Camera& c = scene.camera;
  RenderFields f;
  f.emplace_back("Luz version", std::string(version()) + " (" + commit() + ")");
  f.emplace_back("image size", std::to_string(c.width) + "x" + std::to_string(c.height));
  f.emplace_back("spp", std::to_string(s.spp));
  f.emplace_back("seed", std::to_string(s.seed));
  f.emplace_back("sampler", sampler_name(s.sampler));
  f.emplace_back("integrator", integrator_name(s.integrator.type));
  f.emplace_back("max depth", std::to_string(s.integrator.max_depth));
  f.emplace_back("Russian roulette depth", std::to_string(s.integrator.rr_depth));
  f.emplace_back("emitters seen directly", s.integrator.hide_emitters ? "hidden" : "shown");
  f.emplace_back("pixel filter", filter_name(s.filter));
  f.emplace_back("reconstruction", splats(s.reconstruction, s.filter) ? "splat" : "filter sampling");
  f.emplace_back("light sampler", light_sampler_name(s.light_sampler));
  f.emplace_back("environment guide", s.env_guide ? "on" : "off");
  f.emplace_back("device", device == RenderDevice::Cuda ? "cuda" : "cpu");
  Hasher camera;
  camera.value(c);
  f.emplace_back("camera", camera.hex());
  Hasher geometry;
  geometry.array(scene.positions);
  geometry.array(scene.normals);
  geometry.array(scene.uvs);
  if (!scene.colors.empty()) geometry.array(scene.colors);  // (the hash of a scene without is as before)
  geometry.array(scene.indices);
  geometry.array(scene.tri_material);
  geometry.array(scene.tri_emitter);
  geometry.values(scene.spheres);
  geometry.values(scene.objects);
  geometry.values(scene.instances);
  f.emplace_back("geometry", geometry.hex());
  Hasher materials;
  materials.live(scene.materials, [](void* at, const Material& m) {
    Material* c = new (at) Material;
    const Bsdf bsdf = c->bsdf;
    *c = m;
    c->bsdf = bsdf;
    c->bsdf.copy_live(m.bsdf);
    return c;
  });
  materials.values(scene.texture_bindings);
  materials.live(scene.textures, [](void* at, const Texture& t) {
    Texture* c = t.type == TextureType::Bitmap         ? new (at) Texture(t.bitmap)
                 : t.type == TextureType::Checkerboard ? new (at) Texture(t.checkerboard)
                 : t.type == TextureType::Mix          ? new (at) Texture(t.mix)
                                                       : new (at) Texture(t.vertex_color);
    c->to_uv = t.to_uv;
    c->scale = t.scale;
    c->offset = t.offset;
    return c;
  });
  materials.array(scene.texels8);
  materials.array(scene.texelsf);
  f.emplace_back("materials and textures", materials.hex());
  Hasher lights;
  lights.live(scene.lights, [](void* at, const Light& l) {
    return visit(l, [&](const auto& model) { return new (at) Light(model); });
  });
  lights.array(scene.light_data);
  f.emplace_back("lights", lights.hex());
  return f;
}

std::string fields_mismatch(const RenderFields& was, const RenderFields& now) {
  for (const auto& [name, value] : was) {
    // &n = name: clang before 16 cannot capture a structured binding.
    auto it = std::find_if(now.begin(), now.end(), [&n = name](const auto& p) { return p.first == n; });
    if (it == now.end()) return name + ": the checkpoint has " + value + ", this render none";
    if (it->second != value) {
      if (!value.empty() && value[0] == '#')
        return "the " + name + " differ" + (name.back() == 's' ? "" : "s") + " from the checkpoint's";
      return name + ": the checkpoint has " + value + ", this render " + it->second;
    }
  }
  for (const auto& [name, value] : now)
    if (std::none_of(was.begin(), was.end(), [&n = name](const auto& p) { return p.first == n; }))
      return name + ": the checkpoint has none, this render " + value;
  return "";
}

void write_checkpoint(const std::string& path, const Checkpoint& c) {
  const Film& film = c.film;
  const size_t pixels = size_t(film.width) * size_t(film.height);
  if (film.width <= 0 || film.height <= 0 || film.sum.size() != 3 * pixels || film.sum_sq.size() != 3 * pixels ||
      film.count.size() != pixels)
    throw InputError(path, 0, "cannot write a checkpoint of an empty or inconsistent film");
  if (!film.next.empty() && film.next.size() != pixels)
    throw InputError(path, 0, "cannot write a checkpoint of an inconsistent film (its per-pixel progress)");
  Writer w(path);
  w.bytes(kMagic, sizeof kMagic);
  w.pod(uint32_t(c.fields.size()));
  for (const auto& [name, value] : c.fields) {
    w.str(name);
    w.str(value);
  }
  w.pod(uint32_t(c.args.size()));
  for (const std::string& a : c.args) w.str(a);
  w.pod(c.next_sample);
  w.pod(c.stats.seconds);
  w.pod(c.stats.samples);
  w.pod(c.stats.rays);
  w.pod(c.stats.discarded);
  w.pod(c.stats.passes);
  w.pod(c.stats.spp);
  w.pod(uint32_t(film.width));
  w.pod(uint32_t(film.height));
  w.array(film.sum);
  w.array(film.sum_sq);
  w.array(film.count);
  w.pod(uint32_t(film.next.empty() ? 0 : 1));
  if (!film.next.empty()) w.array(film.next);
  w.finish();
}

Checkpoint read_checkpoint(const std::string& path) {
  Reader r(path);
  char magic[sizeof kMagic];
  if (r.left() < sizeof magic) r.fail("not a Luz checkpoint (too short)");
  r.bytes(magic, sizeof magic);
  if (std::memcmp(magic, kMagic, sizeof magic) != 0) r.fail("not a Luz checkpoint");
  Checkpoint c;
  const uint32_t nfields = r.pod<uint32_t>();
  if (nfields > kMaxStrings) r.fail("the checkpoint is corrupted (" + std::to_string(nfields) + " fields)");
  for (uint32_t k = 0; k < nfields; ++k) {
    std::string name = r.str();
    c.fields.emplace_back(std::move(name), r.str());
  }
  const uint32_t nargs = r.pod<uint32_t>();
  if (nargs > kMaxStrings) r.fail("the checkpoint is corrupted (" + std::to_string(nargs) + " arguments)");
  for (uint32_t k = 0; k < nargs; ++k) c.args.push_back(r.str());
  c.next_sample = r.pod<uint32_t>();
  c.stats.seconds = r.pod<double>();
  c.stats.samples = r.pod<uint64_t>();
  c.stats.rays = r.pod<uint64_t>();
  c.stats.discarded = r.pod<uint64_t>();
  c.stats.passes = r.pod<uint32_t>();
  c.stats.spp = r.pod<uint32_t>();
  const uint32_t w = r.pod<uint32_t>(), h = r.pod<uint32_t>();
  if (w == 0 || h == 0 || w > kMaxSide || h > kMaxSide)
    r.fail("the checkpoint is corrupted (a film of " + std::to_string(w) + "x" + std::to_string(h) + ")");
  const uint64_t pixels = uint64_t(w) * h, film_bytes = pixels * (6 * sizeof(double) + sizeof(uint32_t));
  auto check_size = [&](uint64_t need) {
    if (need != r.left())
      r.fail(need > r.left() ? "the checkpoint is truncated (the render that wrote it was stopped, or the file was cut)"
                             : "the checkpoint has bytes past its end");
  };
  if (film_bytes + sizeof(uint32_t) > r.left()) check_size(film_bytes + 2 * sizeof(uint32_t));
  c.film = Film(int(w), int(h));
  r.array(c.film.sum);
  r.array(c.film.sum_sq);
  r.array(c.film.count);
  const uint32_t per_pixel = r.pod<uint32_t>();
  if (per_pixel > 1) r.fail("the checkpoint is corrupted (its per-pixel progress flag)");
  check_size((per_pixel ? pixels * sizeof(uint32_t) : 0) + sizeof(uint32_t));
  if (per_pixel) {
    c.film.next.resize(pixels);
    r.array(c.film.next);
  }
  r.finish();
  for (size_t i = 0; i < pixels; ++i) {
    const uint32_t next = per_pixel ? c.film.next[i] : c.next_sample;
    if (next < c.next_sample) r.fail("the checkpoint is corrupted (a pixel behind the checkpoint's first sample)");
    if (c.film.count[i] > next) r.fail("the checkpoint is corrupted (a pixel has more samples than were taken)");
  }
  return c;
}

}  // namespace luz
