// Light selection side by side: the bundled box with its ceiling light off
// and N small emissive triangles (default 10,000) on its walls, floor and
// ceiling, facing into the room, their radiance spread over three decades,
// rendered with the light BVH and with power selection at the same spp:
// CPU time (the process's, all threads: the machine is shared), samples per
// CPU second, relMSE against a converged reference (rendered once with
// power selection, the faster per sample, and cached outside the repository), the relMSE each would reach in
// the other's time, and efficiency 1 / (relMSE × time).
//
// relMSE as bench/envmap_bench.cpp: the mean over pixels and channels of
// (x - r)² / (r² + 0.01), less the reference's own variance term.
//
// Prints one markdown row per variant, starting with '|'.
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "luz/io/load.h"
#include "reference.h"

using namespace luz;
using namespace luz_bench;

namespace {

struct Args {
  std::string scene = "scenes/cornell-box.xml";
  uint32_t spp = 32, ref_spp = 1024, lights = 10000;
  int threads = 0;
  int res = 128;
};

double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

float rnd(uint64_t i, uint32_t d) { return to_unit_float(hash_combine(hash_combine(mix64(0x6d616e79), i), d)); }

// The box's own light off; `n` triangles, 1 unit off the five walls, facing in.
void add_lights(Scene& s, uint32_t n) {
  for (Light& l : s.lights)
    if (l.type == LightType::Parallelogram) l.parallelogram.radiance = {};
    else if (l.type == LightType::Triangle) l.triangle.radiance = {};
  const Vec3 lo{0, 0, 0}, hi{556, 548, 559};
  for (uint32_t k = 0; k < n; ++k) {
    const int wall = int(rnd(k, 0) * 5);  // floor, ceiling, back, left, right
    const int axis = wall < 2 ? 1 : wall == 2 ? 2 : 0;
    const bool at_hi = wall == 1 || wall == 2 || wall == 3;
    Vec3 c{lo.x + (hi.x - lo.x) * rnd(k, 1), lo.y + (hi.y - lo.y) * rnd(k, 2), lo.z + (hi.z - lo.z) * rnd(k, 3)};
    Vec3 inward{};
    (&inward.x)[axis] = at_hi ? -1.f : 1.f;
    (&c.x)[axis] = at_hi ? (&hi.x)[axis] - 1.f : (&lo.x)[axis] + 1.f;
    const float size = 2.f + 6.f * rnd(k, 4);
    std::vector<Vec3> p(3);
    for (int v = 0; v < 3; ++v) {
      const float a = 2.f * kPi * (float(v) / 3.f + 0.2f * rnd(k, 5 + v));
      Vec3 d{};
      (&d.x)[(axis + 1) % 3] = std::cos(a) * size;
      (&d.x)[(axis + 2) % 3] = std::sin(a) * size;
      p[v] = c + d;
    }
    if (dot(cross(p[1] - p[0], p[2] - p[0]), inward) < 0.f) std::swap(p[1], p[2]);
    const float level = 20.f * std::pow(10.f, 3.f * rnd(k, 8) - 1.5f);
    const Color e{level * (0.6f + 0.4f * rnd(k, 9)), level * (0.6f + 0.4f * rnd(k, 10)), level * (0.6f + 0.4f * rnd(k, 11))};
    s.add_mesh(p, {}, {0, 1, 2}, 0, &e);
  }
  s.compile();
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto next = [&] { return flag_value("manylight_bench", argc, argv, i); };
    if (arg == "--spp") a.spp = uint32_t(std::stoul(next()));
    else if (arg == "--ref-spp") a.ref_spp = uint32_t(std::stoul(next()));
    else if (arg == "--lights") a.lights = uint32_t(std::stoul(next()));
    else if (arg == "--threads") a.threads = std::stoi(next());
    else if (arg == "--res") a.res = std::stoi(next());
    else {
      std::fprintf(stderr, "manylight_bench: unknown argument %s\n", arg.c_str());
      return 2;
    }
  }
  Scene base = load_scene(a.scene, {{"res", std::to_string(a.res)}});
  add_lights(base, a.lights);
  base.settings.sampler = SamplerType::Independent;

  // The reference, cached by scene file contents, light count, resolution and spp.
  char name[112];
  std::snprintf(name, sizeof name, "manylight-ref-%016" PRIx64 "-%u-%d-%u.pfm", file_hash(a.scene), a.lights, a.res,
                a.ref_spp);
  Scene ref_scene = base;
  ref_scene.settings.light_sampler = LightSamplerType::Power;
  ref_scene.settings.spp = a.ref_spp;
  ref_scene.settings.seed = 9001;
  const Reference ref = cached_reference(name, ref_scene, a.threads);

  struct Variant {
    const char* name;
    LightSamplerType type;
    double seconds = 0, rel = 0;
  } variants[] = {{"bvh", LightSamplerType::Bvh}, {"power", LightSamplerType::Power}};
  for (Variant& v : variants) {
    Scene s = base;
    s.settings.light_sampler = v.type;
    s.settings.spp = a.spp;
    s.settings.seed = 7;
    double wall = 0;
    const double cpu0 = cpu_seconds();
    const Film f = render(s, a.threads, wall);
    v.seconds = cpu_seconds() - cpu0;
    v.rel = rel_mse(f, ref.mean) - ref.noise;
  }
  std::printf("scene %s + %u emissive triangles (%zu lights), %dx%d, %u spp; reference %u spp, its own relMSE %.2e\n",
              a.scene.c_str(), a.lights, base.lights.size(), a.res, a.res, a.spp, a.ref_spp, ref.noise);
  const double pixels = double(a.res) * a.res;
  for (const Variant& v : variants) {
    const Variant& other = &v == &variants[0] ? variants[1] : variants[0];
    std::printf("| %s | %u | %dx%d | %u | %.3f | %.3f | %.3e | %.3e | %.1f |\n", v.name, a.lights, a.res, a.res, a.spp,
                v.seconds, pixels * a.spp / v.seconds * 1e-6, v.rel, v.rel * v.seconds / other.seconds,
                1.0 / (v.rel * v.seconds));
  }
  std::printf("efficiency bvh / power: %.2fx\n",
              (1.0 / (variants[0].rel * variants[0].seconds)) / (1.0 / (variants[1].rel * variants[1].seconds)));
  return 0;
}
