// efficiency_bench: noise per second on one scene, variants side by side.
//
//   efficiency_bench SCENE [-D name=value]... [--res WxH] [--spp N] [--ref-factor K]
//       [--samplers LIST] [--rounds R] [--first-round K] [--threads N] [--label L] [--filter box|tent|gaussian]
//       [--skip-emitters] [--profile | --compare IMAGE]
//
// Each variant (a sampler; LIST is comma-separated from scene, independent,
// stratified, sobol; `scene` is the one the scene file names; a suffix /rrN
// sets Russian roulette's first depth, as sobol/rr2; a suffix /fis
// applies the pixel filter by filter sampling instead of splatting, as
// scene/fis; a last suffix /noguide turns off the constant environment's
// guide, as scene/noguide or scene/fis/noguide; a very last suffix /power or
// /bvh picks the light sampler, as scene/power, else the scene's) is rendered R
// times, the variants interleaved round by round so that they share the
// machine's changing speed (round k renders with seed K + k + 1). For each: seconds (the device's builds and the passes), relMSE against a
// converged reference, efficiency = 1 / (relMSE × seconds); also the
// process's CPU seconds (user + system, all threads: less sensitive than the
// wall clock to other work on a shared machine) and the efficiency by them. The reference
// (K × spp, independent sampler, another seed) is rendered once and cached
// outside the repository (reference.h); its own noise is subtracted and
// printed. Prints one markdown row per variant, starting with '|'.
//
// --profile: where rays and variance go, with path.h's probe hooks (this
// binary's instantiation only): rays per sample by kind, what became of the
// next-event samples, Russian roulette by depth, how paths end, and the
// radiance and variance each path length contributes (per-pixel sums of each
// length's share of a sample, independent sampler so that the per-sample
// variance is the variance of the mean × n). Prints markdown.
//
// --skip-emitters: relMSE over the pixels that see no emitter directly (none
// within 2 pixels in a max_depth 1 render): one antialiasing sample on a
// small bright light otherwise outweighs the rest of the image (Veach MIS).
//
// --compare IMAGE: the relMSE of another renderer's image (bench/cycles)
// against the same reference. --filter replaces the scene's pixel filter
// (Cycles has no tent), in the reference too.
#include <sys/resource.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "luz/accel/embree_tracer.h"
#include "luz/camera/camera.h"
#include "luz/integrator/path.h"
#include "luz/io/error.h"
#include "luz/io/load.h"
#include "luz/light/env_guide_build.h"
#include "luz/scene/scene_info.h"
#include "reference.h"

using namespace luz;
using namespace luz_bench;

namespace {

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Args {
  std::string scene, label, samplers = "scene,sobol", compare, filter;
  Defines defines;
  int width = 0, height = 0, threads = 0, rounds = 2, first_round = 0;
  uint32_t spp = 64, ref_factor = 16;
  bool profile = false, skip_emitters = false;
};

bool parse_sampler(const std::string& s, SamplerType& t) {
  for (SamplerType c : {SamplerType::Independent, SamplerType::Stratified, SamplerType::Sobol})
    if (s == sampler_name(c)) return t = c, true;
  return false;
}

// The cache name of the reference: the scene file's bytes, the defines, size,
// depth, spp and seed (no commit: a reference stays valid while the
// estimator stays unbiased).
std::string reference_name(const Args& a, const Scene& ref) {
  uint64_t h = file_hash(a.scene);
  std::string key;
  for (const auto& [k, v] : a.defines) key += k + "=" + v + ";";
  if (!a.filter.empty()) key += "filter=" + a.filter + ";";  // else the file's
  char tail[160];
  std::snprintf(tail, sizeof tail, "%dx%d;depth=%d;rr=%d;spp=%u;seed=%" PRIu64, ref.camera.width, ref.camera.height,
                ref.settings.integrator.max_depth, ref.settings.integrator.rr_depth, ref.settings.spp,
                ref.settings.seed);
  key += tail;
  for (char c : key) h = mix64(h ^ uint64_t(uint8_t(c)));
  char name[64];
  std::snprintf(name, sizeof name, "efficiency-%016" PRIx64 ".pfm", h);
  return name;
}

// --- The profile -----------------------------------------------------------

constexpr int kLengths = 21;  // path lengths 1..19, then 20 and longer
constexpr int kNee = 5, kEnds = 5;

struct Counts {
  uint64_t rays[3] = {}, nee[kNee] = {};
  uint64_t rr_tried[kLengths] = {}, rr_survived[kLengths] = {}, vertices[kLengths] = {};
  uint64_t ends[kEnds] = {};
  void add(const Counts& o) {
    for (int k = 0; k < 3; ++k) rays[k] += o.rays[k];
    for (int k = 0; k < kNee; ++k) nee[k] += o.nee[k];
    for (int k = 0; k < kEnds; ++k) ends[k] += o.ends[k];
    for (int k = 0; k < kLengths; ++k)
      rr_tried[k] += o.rr_tried[k], rr_survived[k] += o.rr_survived[k], vertices[k] += o.vertices[k];
  }
};

int bucket(int length) { return std::clamp(length, 1, kLengths - 1); }

// path.h's hooks, writing to the calling thread's counters and to the
// current sample's radiance per path length.
struct Probe {
  static constexpr bool kEnabled = true;
  static thread_local Counts* counts;
  static thread_local std::array<Color, kLengths> by_length;
  static void ray(RayKind k) { ++counts->rays[uint32_t(k)]; }
  static void nee(NeeOutcome o) { ++counts->nee[uint32_t(o)]; }
  static void roulette(int depth, bool survived) {
    ++counts->rr_tried[bucket(depth)];
    counts->rr_survived[bucket(depth)] += survived;
  }
  static void end(int depth, PathEnd e) {
    ++counts->ends[uint32_t(e)];
    ++counts->vertices[bucket(depth)];  // paths whose last vertex is at `depth`
  }
  static void radiance(int length, const Color& c) { by_length[bucket(length)] += c; }
};
thread_local Counts* Probe::counts = nullptr;
thread_local std::array<Color, kLengths> Probe::by_length;

void profile(const Args& a, Scene s, const Reference& ref) {
  s.settings.sampler = SamplerType::Independent;
  s.settings.spp = a.spp;
  s.settings.seed = 77;
  const int w = s.camera.width, h = s.camera.height;
  const size_t px = size_t(w) * h;
  // Per pixel, channel and length: sums of that length's share, and its square;
  // then the whole sample's.
  std::vector<double> s1(px * kLengths * 3), s2(px * kLengths * 3), t1(px * 3), t2(px * 3);
  EmbreeScene embree(s);
  const EmbreeTracer tracer = embree.tracer();
  SceneView view = s.view();
  const SamplerDesc desc = make_sampler_desc(s.settings.sampler, s.settings.spp, s.settings.seed);
  tbb::enumerable_thread_specific<Counts> per_thread;
  tbb::task_arena arena(a.threads > 0 ? a.threads : tbb::task_arena::automatic);
  // The constant environment's guide, as the CPU device builds it.
  EnvGuideData guide;
  if (wants_env_guide(view, s.settings.env_guide)) {
    arena.execute([&] { guide = build_env_guide(view, tracer, env_guide_options(uint64_t(px) * desc.spp)); });
    if (guide.view.regions) view.lights.data.guide = &guide.view;
  }
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
      Probe::counts = &per_thread.local();
      for (int y = rows.begin(); y != rows.end(); ++y)
        for (int x = 0; x < w; ++x) {
          const size_t p = size_t(y) * w + x;
          for (uint32_t i = 0; i < desc.spp; ++i) {
            Sampler sampler;
            sampler.start(desc, uint32_t(x), uint32_t(y), i);
            const Ray r = camera_sample(s.camera, uint32_t(x), uint32_t(y), sampler, s.settings.filter);
            Probe::by_length.fill(Color{});
            uint64_t n = 0;
            const Color L = path_li<EmbreeTracer, Probe>(view, tracer, r, sampler, s.settings.integrator, n);
            for (int c = 0; c < 3; ++c) {
              t1[3 * p + c] += L[c];
              t2[3 * p + c] += double(L[c]) * L[c];
              for (int k = 0; k < kLengths; ++k) {
                const double v = Probe::by_length[k][c];
                s1[(p * kLengths + k) * 3 + c] += v;
                s2[(p * kLengths + k) * 3 + c] += v * v;
              }
            }
          }
        }
    });
  });
  Counts all;
  for (const Counts& c : per_thread) all.add(c);
  const double n = desc.spp, samples = double(px) * n;

  // relVar: the relMSE a term's noise alone gives at n spp (its variance of
  // the mean over r² + kEps, averaged over pixels and channels).
  auto rel_var = [&](double a1, double a2, size_t k) {
    const double m = a1 / n, var = std::max(0.0, a2 / n - m * m) / n;
    return var / (ref.mean[k] * ref.mean[k] + kEps);
  };
  std::array<double, kLengths> var_len{}, mean_len{};
  double var_total = 0, mean_total = 0;
  for (size_t p = 0; p < px; ++p)
    for (int c = 0; c < 3; ++c) {
      const size_t k = 3 * p + c;
      var_total += rel_var(t1[k], t2[k], k);
      mean_total += t1[k] / n;
      for (int l = 0; l < kLengths; ++l) {
        var_len[l] += rel_var(s1[(p * kLengths + l) * 3 + c], s2[(p * kLengths + l) * 3 + c], k);
        mean_len[l] += s1[(p * kLengths + l) * 3 + c] / n;
      }
    }
  const double cells = double(px) * 3;
  var_total /= cells;
  double var_sum = 0;
  for (double& v : var_len) v /= cells, var_sum += v;

  std::printf("Profile of %s: %dx%d, %u spp, independent sampler, max_depth %d, rr_depth %d\n\n", a.label.c_str(), w,
              h, desc.spp, s.settings.integrator.max_depth, s.settings.integrator.rr_depth);
  std::printf("| rays per sample | camera | continuation | shadow | all |\n|---|---|---|---|---|\n");
  std::printf("| | %.3f | %.3f | %.3f | %.3f |\n\n", all.rays[0] / samples, all.rays[1] / samples,
              all.rays[2] / samples, (all.rays[0] + all.rays[1] + all.rays[2]) / samples);
  uint64_t nee = 0;
  for (uint64_t v : all.nee) nee += v;
  std::printf("| next-event samples | per sample | no sample (pdf 0) | below the geometric surface | f = 0 (below the "
              "shading hemisphere) | occluded | contributed |\n|---|---|---|---|---|---|---|\n");
  std::printf("| | %.3f |", nee / samples);
  for (uint64_t v : all.nee) std::printf(" %.1f%% |", 100.0 * v / std::max<uint64_t>(nee, 1));
  std::printf("\n\n");
  uint64_t ends = 0;
  for (uint64_t v : all.ends) ends += v;
  std::printf("| paths end by | escaped | max depth | BSDF sample invalid | wrong side | roulette |\n|---|---|---|---|---|---|\n| |");
  for (uint64_t v : all.ends) std::printf(" %.1f%% |", 100.0 * v / std::max<uint64_t>(ends, 1));
  std::printf("\n\n");
  std::printf("| depth (path length in segments) | paths ending at this vertex | roulette survival | radiance share | relVar "
              "(its noise alone at %u spp) | share of Σ relVar |\n|---|---|---|---|---|---|\n",
              desc.spp);
  for (int l = 1; l < kLengths; ++l) {
    if (all.vertices[l] == 0 && mean_len[l] == 0) continue;
    char rr[32] = "-";
    if (all.rr_tried[l]) std::snprintf(rr, sizeof rr, "%.3f", double(all.rr_survived[l]) / all.rr_tried[l]);
    std::printf("| %d%s | %.2f%% | %s | %.2f%% | %.3e | %.1f%% |\n", l, l == kLengths - 1 ? "+" : "",
                100.0 * all.vertices[l] / std::max<uint64_t>(ends, 1), rr, 100.0 * mean_len[l] / mean_total,
                var_len[l], 100.0 * var_len[l] / var_sum);
  }
  std::printf("\nrelVar of the whole sample %.3e; Σ over lengths %.3e (the rest: covariance between lengths)\n",
              var_total, var_sum);
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto next = [&] { return flag_value("efficiency_bench", argc, argv, i); };
    if (arg == "-D") {
      const std::string d = next();
      const size_t eq = d.find('=');
      a.defines[d.substr(0, eq)] = eq == std::string::npos ? "" : d.substr(eq + 1);
    } else if (arg == "--res") {
      const std::string r = next();
      if (std::sscanf(r.c_str(), "%dx%d", &a.width, &a.height) != 2 || a.width < 1 || a.height < 1) {
        std::fprintf(stderr, "efficiency_bench: --res %s: expected WIDTHxHEIGHT\n", r.c_str());
        return 2;
      }
    } else if (arg == "--spp") a.spp = uint32_t(std::stoul(next()));
    else if (arg == "--ref-factor") a.ref_factor = uint32_t(std::stoul(next()));
    else if (arg == "--samplers") a.samplers = next();
    else if (arg == "--rounds") a.rounds = std::max(1, std::stoi(next()));
    else if (arg == "--first-round") a.first_round = std::max(0, std::stoi(next()));
    else if (arg == "--threads") a.threads = std::stoi(next());
    else if (arg == "--label") a.label = next();
    else if (arg == "--profile") a.profile = true;
    else if (arg == "--compare") a.compare = next();
    else if (arg == "--filter") a.filter = next();
    else if (arg == "--skip-emitters") a.skip_emitters = true;
    else if (arg[0] != '-' && a.scene.empty()) a.scene = arg;
    else {
      std::fprintf(stderr, "efficiency_bench: unknown argument %s\n", arg.c_str());
      return 2;
    }
  }
  if (a.scene.empty()) {
    std::fprintf(stderr, "usage: efficiency_bench SCENE [-D name=value]... [--res WxH] [--spp N] [--ref-factor K] "
                         "[--samplers scene,independent,stratified,sobol] [--rounds R] [--threads N] [--label L] "
                         "[--skip-emitters] [--profile | --compare IMAGE]\n");
    return 2;
  }
  if (a.label.empty()) a.label = a.scene;
  try {
    Scene base = load_scene(a.scene, a.defines);
    if (a.width > 0) base.set_resolution(a.width, a.height);
    const SamplerType own = base.settings.sampler;
    if (!a.filter.empty()) {
      const char* names[] = {"box", "tent", "gaussian"};
      const auto at = std::find(std::begin(names), std::end(names), a.filter);
      if (at == std::end(names)) {
        std::fprintf(stderr, "efficiency_bench: --filter must be box, tent or gaussian\n");
        return 2;
      }
      base.settings.filter = FilterKind(at - std::begin(names));
    }

    Scene ref_scene = base;
    ref_scene.settings.sampler = SamplerType::Independent;  // its variance estimate needs independent samples
    ref_scene.settings.spp = a.spp * a.ref_factor;
    ref_scene.settings.seed = 9001;
    Reference ref = cached_reference(reference_name(a, ref_scene), ref_scene, a.threads);
    PixelMask keep;
    if (a.skip_emitters) {
      Scene direct = base;
      direct.settings.integrator.max_depth = 1;
      direct.settings.spp = 1024;  // camera rays only: cheap; finds lights a fraction of a pixel wide
      double t = 0;
      const std::vector<float> e = render(direct, a.threads, t).mean();
      // Every pixel within 2 of one that sees an emitter (the pixel filter's reach).
      const int w = base.camera.width, h = base.camera.height;
      keep.assign(size_t(w) * h, 1);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const float* c = &e[3 * (size_t(y) * w + x)];
          if (c[0] > 0 || c[1] > 0 || c[2] > 0)
            for (int v = std::max(y - 2, 0); v <= std::min(y + 2, h - 1); ++v)
              for (int u = std::max(x - 2, 0); u <= std::min(x + 2, w - 1); ++u) keep[size_t(v) * w + u] = 0;
        }
      const size_t left_out = size_t(std::count(keep.begin(), keep.end(), 0));
      ref.noise = ref.noise_over(keep);
      std::printf("--skip-emitters: %zu of %zu pixels see an emitter and are left out of relMSE\n", left_out,
                  keep.size());
    }
    std::printf("scene %s: %dx%d, %u spp, max_depth %d; reference %u spp (independent), its own relMSE %.2e "
                "(subtracted)%s\n",
                a.label.c_str(), base.camera.width, base.camera.height, a.spp, base.settings.integrator.max_depth,
                ref_scene.settings.spp, ref.noise, a.skip_emitters ? "; pixels that see an emitter left out" : "");
    if (!a.compare.empty()) {
      const Image im = read_image_linear(a.compare);
      if (im.width != base.camera.width || im.height != base.camera.height) {
        std::fprintf(stderr, "efficiency_bench: %s is %dx%d, the reference %dx%d\n", a.compare.c_str(), im.width,
                     im.height, base.camera.width, base.camera.height);
        return 2;
      }
      std::printf("relMSE %.4e\n", rel_mse(im.rgb, ref.mean, keep) - ref.noise);
      return 0;
    }
    if (a.profile) {
      profile(a, base, ref);
      return 0;
    }

    struct Variant {
      std::string name;
      SamplerType sampler;
      int rr_depth;
      bool fis;  // filter sampling instead of the default splatting
      bool guide;  // the constant environment's guide (the default)
      LightSamplerType light;
      std::vector<double> seconds, cpu, rel;
    };
    std::vector<Variant> variants;
    for (size_t at = 0; at <= a.samplers.size();) {
      const size_t comma = std::min(a.samplers.find(',', at), a.samplers.size());
      const std::string item = a.samplers.substr(at, comma - at);
      at = comma + 1;
      std::string base_item = item;
      LightSamplerType light = base.settings.light_sampler;
      bool light_named = false;
      for (const auto& [suffix, t] : {std::pair{"/power", LightSamplerType::Power}, {"/bvh", LightSamplerType::Bvh}}) {
        const size_t len = std::strlen(suffix);
        if (base_item.size() > len && base_item.compare(base_item.size() - len, len, suffix) == 0) {
          base_item.resize(base_item.size() - len);
          light = t, light_named = true;
          break;
        }
      }
      const bool guide = !(base_item.size() > 8 && base_item.compare(base_item.size() - 8, 8, "/noguide") == 0);
      if (!guide) base_item.resize(base_item.size() - 8);
      const bool fis = base_item.size() > 4 && base_item.compare(base_item.size() - 4, 4, "/fis") == 0;
      if (fis) base_item.resize(base_item.size() - 4);
      const size_t slash = base_item.find("/rr");
      const std::string v = base_item.substr(0, slash);
      int rr = base.settings.integrator.rr_depth;
      SamplerType t = own;
      if ((v != "scene" && !parse_sampler(v, t)) || (slash != std::string::npos && (rr = std::atoi(&base_item[slash + 3])) < 1)) {
        std::fprintf(stderr, "efficiency_bench: --samplers: unknown variant '%s'\n", item.c_str());
        return 2;
      }
      std::string name = v == "scene" ? std::string("scene's (") + sampler_name(own) + ")" : v;
      if (slash != std::string::npos) name += ", rr_depth " + std::to_string(rr);
      if (fis) name += ", filter sampling";
      if (!guide) name += ", no env guide";
      if (light_named) name += std::string(", ") + light_sampler_name(light) + " light sampler";
      variants.push_back({name, t, rr, fis, guide, light, {}, {}, {}});
    }
    for (int round = 0; round < a.rounds; ++round)
      for (Variant& v : variants) {
        Scene s = base;
        s.settings.sampler = v.sampler;
        s.settings.integrator.rr_depth = v.rr_depth;
        s.settings.spp = a.spp;
        s.settings.seed = uint64_t(a.first_round + round) + 1;
        double t = 0;
        const double cpu0 = cpu_seconds();
        if (v.fis) s.settings.reconstruction = Reconstruction::FilterSampling;
        s.settings.env_guide = v.guide;
        s.settings.light_sampler = v.light;
        // The passes and what the device builds first (the environment's
        // guide: part of a variant's cost; Embree's build: the same for all).
        const auto t0 = std::chrono::steady_clock::now();
        const std::vector<float> img = render(s, a.threads, t).mean();
        t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        v.cpu.push_back(cpu_seconds() - cpu0);
        v.seconds.push_back(t);
        v.rel.push_back(rel_mse(img, ref.mean, keep) - ref.noise);
      }
    auto mean = [](const std::vector<double>& x) {
      double m = 0;
      for (double v : x) m += v;
      return m / double(x.size());
    };
    const double eff0 = 1.0 / (mean(variants[0].rel) * mean(variants[0].seconds));
    const double eff0_cpu = 1.0 / (mean(variants[0].rel) * mean(variants[0].cpu));
    for (const Variant& v : variants) {
      const double t = mean(v.seconds), cpu = mean(v.cpu), rel = mean(v.rel), eff = 1.0 / (rel * t);
      const auto [tmin, tmax] = std::minmax_element(v.seconds.begin(), v.seconds.end());
      const auto [rmin, rmax] = std::minmax_element(v.rel.begin(), v.rel.end());
      std::printf("| %s | %s | %dx%d | %u | %.2f (%.2f-%.2f) | %.2f | %.3e (%.2e-%.2e) | %.2f / %.3f | %.2fx / %.2fx |\n",
                  a.label.c_str(), v.name.c_str(), base.camera.width, base.camera.height, a.spp, t, *tmin, *tmax, cpu,
                  rel, *rmin, *rmax, eff, 1.0 / (rel * cpu), eff / eff0, 1.0 / (rel * cpu) / eff0_cpu);
    }
    return 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "efficiency_bench: error: %s\n", e.what());
    return 2;
  }
}
