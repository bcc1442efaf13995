// Light selection side by side: the light BVH and power selection at the
// same spp on one of two layouts of N small emitters (default 10,000),
// their radiance spread over three decades:
//   room (the default): the bundled box with its ceiling light off and the
//     triangles 1 unit off its walls, floor and ceiling, facing into the
//     room: every light about as far from every point (the BVH's worst case);
//   street: bench/scenes/street.xml's floor 1 km long under a grid of city
//     blocks and lamps facing down 4-8 m above the streets and squares
//     between them, a few metres apart, seen along the main street: lights
//     spread hundreds of times wider than the distance to the nearest ones.
// CPU time (the process's, all threads: the machine is shared), samples per
// CPU second, relMSE against a converged reference (rendered once with the
// sampler that converges faster on the layout, power in the room and the BVH
// in the street, and cached outside the repository), the relMSE each would
// reach in the other's time, and efficiency 1 / (relMSE × time). With
// --rounds R the variants alternate R times (seeds 7, 8, ...) and the rows
// give the means.
//
// relMSE as bench/envmap_bench.cpp: the mean over pixels and channels of
// (x - r)² / (r² + 0.01), less the reference's own variance term.
//
// Prints one markdown row per variant, starting with '|'.
#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "luz/io/load.h"
#include "luz/scene/scene_info.h"
#include "reference.h"

using namespace luz;
using namespace luz_bench;

namespace {

struct Args {
  std::string layout = "room";
  uint32_t spp = 32, ref_spp = 1024, lights = 10000;
  int threads = 0, rounds = 1;
  uint64_t walks = 0;
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


// The street's city: blocks on a grid of 60 m cells, 40 m square with 20 m
// streets between (the main street along z at x = 0), one cell in five left
// open as a square; 6-36 m tall.
struct Block {
  float x0, z0, x1, z1, h;
};
std::vector<Block> city_blocks() {
  std::vector<Block> b;
  for (int i = -3; i < 3; ++i)
    for (int j = 0; j < 17; ++j) {
      const uint64_t cell = uint64_t(i + 3) * 17 + uint64_t(j);
      if (rnd(cell, 20) < 0.2f) continue;
      b.push_back({60.f * i + 10.f, 60.f * j + 10.f, 60.f * i + 50.f, 60.f * j + 50.f, 6.f + 30.f * rnd(cell, 21)});
    }
  return b;
}

// The blocks as boxes (no floor: the file's), and `n` lamps: triangles facing
// down at hashed points of x in [-180, 180], z in [0, 1020] outside the blocks.
void add_street(Scene& s, uint32_t n) {
  const std::vector<Block> blocks = city_blocks();
  for (const Block& b : blocks) {
    std::vector<Vec3> p;
    for (int k = 0; k < 8; ++k) p.push_back({k & 1 ? b.x1 : b.x0, k & 2 ? b.h : 0.f, k & 4 ? b.z1 : b.z0});
    // Four walls and the roof, wound outward.
    s.add_mesh(p, {}, {0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 2, 3, 1, 2, 1, 0}, 0,
               nullptr);
  }
  auto inside = [&](float x, float z) {
    for (const Block& b : blocks)
      if (x > b.x0 - 1.f && x < b.x1 + 1.f && z > b.z0 - 1.f && z < b.z1 + 1.f) return true;
    return false;
  };
  for (uint32_t k = 0; k < n; ++k) {
    float x = 0, z = 0;
    for (uint32_t d = 0; d < 64; d += 2) {  // the first try outside every block
      x = -180.f + 360.f * rnd(k, 30 + d);
      z = 1020.f * rnd(k, 31 + d);
      if (!inside(x, z)) break;
    }
    const Vec3 c{x, 4.f + 4.f * rnd(k, 1), z};
    const float size = 0.2f + 0.4f * rnd(k, 4);
    std::vector<Vec3> p(3);
    for (int v = 0; v < 3; ++v) {
      const float a = 2.f * kPi * (float(v) / 3.f + 0.2f * rnd(k, 5 + v));
      p[v] = c + Vec3{std::cos(a) * size, 0.f, std::sin(a) * size};
    }
    if (cross(p[1] - p[0], p[2] - p[0]).y > 0.f) std::swap(p[1], p[2]);  // facing down
    const float level = 100.f * std::pow(10.f, 3.f * rnd(k, 8) - 1.5f);
    const Color e{level * (0.6f + 0.4f * rnd(k, 9)), level * (0.6f + 0.4f * rnd(k, 10)), level * (0.6f + 0.4f * rnd(k, 11))};
    s.add_mesh(p, {}, {0, 1, 2}, 0, &e);
  }
  s.compile();
}

// --walks N: the selection alone, one thread: N calls of sample() (then
// pmf() of the light chosen) at 4096 points on the scene's non-emissive
// surfaces (area-weighted, hemisphere and normal their face's, flipped
// toward the room's centre in the room), each variant by turns three times,
// ns per call. Prints a checksum of the pmfs so no call is left out.
void time_walks(const Scene& s, uint64_t n, bool room) {
  std::vector<double> cdf;
  std::vector<uint32_t> tris;
  double area = 0;
  for (uint32_t t = 0; t < s.tri_emitter.size(); ++t) {
    if (s.tri_emitter[t] >= 0) continue;
    const Vec3 a = s.positions[s.indices[3 * t]], b = s.positions[s.indices[3 * t + 1]], c = s.positions[s.indices[3 * t + 2]];
    area += 0.5 * double(length(cross(b - a, c - a)));
    cdf.push_back(area);
    tris.push_back(t);
  }
  std::vector<LightSampleContext> ctx(4096);
  for (uint64_t i = 0; i < ctx.size(); ++i) {
    const size_t k = size_t(std::lower_bound(cdf.begin(), cdf.end(), rnd(i, 40) * area) - cdf.begin());
    const uint32_t t = tris[std::min(k, tris.size() - 1)];
    const Vec3 a = s.positions[s.indices[3 * t]], b = s.positions[s.indices[3 * t + 1]], c = s.positions[s.indices[3 * t + 2]];
    float u = rnd(i, 41), v = rnd(i, 42);
    if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
    const Vec3 p = a + (b - a) * u + (c - a) * v;
    Vec3 nrm = normalize(cross(b - a, c - a));
    if (room && dot(nrm, Vec3{278, 274, 280} - p) < 0.f) nrm = nrm * -1.f;
    ctx[i] = {p, nrm, nrm, nrm};
  }
  Scene sc = s;
  for (int rep = 0; rep < 3; ++rep)
    for (LightSamplerType type : {LightSamplerType::Bvh, LightSamplerType::Power}) {
      sc.settings.light_sampler = type;
      const LightSampler ls = sc.view().lights.sampler;
      double sum = 0;
      const double t0 = cpu_seconds();
      for (uint64_t i = 0; i < n; ++i) {
        float u = rnd(i, 43);
        const LightSampleContext& c = ctx[i & 4095];
        const SampledLight l = ls.sample(c, u);
        sum += l.pmf > 0.f ? double(ls.pmf(c, l.light)) : 0.0;
      }
      std::printf("walks %s: %.1f ns per sample() + pmf() (checksum %.6e)\n", light_sampler_name(type),
                  (cpu_seconds() - t0) / double(n) * 1e9, sum);
    }
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
    else if (arg == "--rounds") a.rounds = std::max(1, std::stoi(next()));
    else if (arg == "--layout") a.layout = next();
    else if (arg == "--walks") a.walks = std::stoull(next());
    else {
      std::fprintf(stderr, "manylight_bench: unknown argument %s\n", arg.c_str());
      return 2;
    }
  }
  const bool street = a.layout == "street";
  if (!street && a.layout != "room") {
    std::fprintf(stderr, "manylight_bench: --layout must be room or street\n");
    return 2;
  }
  const std::string scene = street ? "bench/scenes/street.xml" : "scenes/cornell-box.xml";
  Scene base = load_scene(scene, {{"res", std::to_string(a.res)}});
  if (street) add_street(base, a.lights);
  else add_lights(base, a.lights);
  base.settings.sampler = SamplerType::Independent;
  if (a.walks) {
    time_walks(base, a.walks, !street);
    return 0;
  }

  // The reference, cached by layout, scene file contents, light count,
  // resolution and spp.
  char name[112];
  std::snprintf(name, sizeof name, "manylight-%sref-%016" PRIx64 "-%u-%d-%u.pfm", street ? "street-" : "",
                file_hash(scene), a.lights, a.res, a.ref_spp);
  Scene ref_scene = base;
  ref_scene.settings.light_sampler = street ? LightSamplerType::Bvh : LightSamplerType::Power;
  ref_scene.settings.spp = a.ref_spp;
  ref_scene.settings.seed = 9001;
  const Reference ref = cached_reference(name, ref_scene, a.threads);

  struct Variant {
    const char* name;
    LightSamplerType type;
    double seconds = 0, rel = 0;
  } variants[] = {{"bvh", LightSamplerType::Bvh}, {"power", LightSamplerType::Power}};
  for (int round = 0; round < a.rounds; ++round)
    for (Variant& v : variants) {
      Scene s = base;
      s.settings.light_sampler = v.type;
      s.settings.spp = a.spp;
      s.settings.seed = 7 + uint64_t(round);
      double wall = 0;
      const double cpu0 = cpu_seconds();
      const Film f = render(s, a.threads, wall);
      v.seconds += (cpu_seconds() - cpu0) / a.rounds;
      v.rel += (rel_mse(f, ref.mean) - ref.noise) / a.rounds;
    }
  std::printf("scene %s (%s layout) + %u emissive triangles (%zu lights), %dx%d, %u spp, %d round%s; reference %u spp "
              "(%s), its own relMSE %.2e\n",
              scene.c_str(), a.layout.c_str(), a.lights, base.lights.size(), a.res, a.res, a.spp, a.rounds,
              a.rounds > 1 ? "s" : "", a.ref_spp, street ? "bvh" : "power", ref.noise);
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
