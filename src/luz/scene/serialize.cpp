#include "luz/scene/serialize.h"

#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace luz {

namespace {

// A field added to Scene must be added to fields() below: this trips first
// (on the x86-64 libstdc++ build that CI runs).
#if defined(__x86_64__) && defined(__GLIBCXX__)
static_assert(sizeof(Scene) == 824, "Scene changed: list its new fields in serialize.cpp's fields()");
#endif

// Every member of a Scene, loaded and compiled, once for both directions.
template <class S, class F>
void fields(S& s, F&& f) {
  f(s.positions), f(s.normals), f(s.uvs), f(s.colors), f(s.indices), f(s.tri_material), f(s.tri_emitter), f(s.spheres);
  f(s.materials), f(s.texture_bindings), f(s.lights), f(s.textures), f(s.texels8), f(s.texelsf), f(s.srgb_table);
  f(s.camera), f(s.fov_axis), f(s.settings), f(s.objects), f(s.instances), f(s.flattened_instances), f(s.warnings);
  f(s.light_alias), f(s.light_pmf), f(s.light_bvh.nodes), f(s.light_bvh.trails), f(s.light_bvh.infinite);
  f(s.light_bvh.infinite_weight), f(s.light_bvh.infinite_total), f(s.lights_emit), f(s.light_data), f(s.tri_normals), f(s.environment);
  f(s.bounds_min), f(s.bounds_max);
}

constexpr char kMagic[8] = {'L', 'U', 'Z', 'S', 'C', 'N', 'E', '1'};

class Writer {
 public:
  std::string out;
  void bytes(const void* p, size_t n) { out.append(static_cast<const char*>(p), n); }
  template <class T>
  void operator()(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(&v, sizeof v);
  }
  template <class T>
  void operator()(const std::vector<T>& v) {
    (*this)(uint64_t(v.size()));
    if constexpr (std::is_same_v<T, std::string>) {
      for (const std::string& s : v) {
        (*this)(uint64_t(s.size()));
        bytes(s.data(), s.size());
      }
    } else {
      static_assert(std::is_trivially_copyable_v<T>);
      bytes(v.data(), v.size() * sizeof(T));
    }
  }
};

class Reader {
 public:
  explicit Reader(const std::string& in) : p_(in.data()), end_(in.data() + in.size()) {}
  void bytes(void* to, size_t n) {
    if (size_t(end_ - p_) < n) throw std::runtime_error("a broadcast scene ends early");
    if (n > 0) std::memcpy(to, p_, n);  // to may be null (an empty vector's data())
    p_ += n;
  }
  template <class T>
  void operator()(T& v) {
    bytes(&v, sizeof v);
  }
  template <class T>
  void operator()(std::vector<T>& v) {
    uint64_t n = 0;
    (*this)(n);
    if (n > uint64_t(end_ - p_)) throw std::runtime_error("a broadcast scene ends early");
    v.resize(n);
    if constexpr (std::is_same_v<T, std::string>) {
      for (std::string& s : v) {
        uint64_t k = 0;
        (*this)(k);
        if (k > uint64_t(end_ - p_)) throw std::runtime_error("a broadcast scene ends early");
        s.resize(k);
        bytes(s.data(), k);
      }
    } else {
      bytes(v.data(), n * sizeof(T));
    }
  }
  bool done() const { return p_ == end_; }

 private:
  const char* p_;
  const char* end_;
};

}  // namespace

std::string serialize_scene(const Scene& scene) {
  Writer w;
  w.bytes(kMagic, sizeof kMagic);
  fields(scene, w);
  return std::move(w.out);
}

Scene deserialize_scene(const std::string& bytes) {
  Reader r(bytes);
  char magic[sizeof kMagic];
  r.bytes(magic, sizeof magic);
  if (std::memcmp(magic, kMagic, sizeof magic) != 0) throw std::runtime_error("not a broadcast scene");
  Scene s;
  fields(s, r);
  if (!r.done()) throw std::runtime_error("a broadcast scene has bytes past its end");
  return s;
}

}  // namespace luz
