// What the side-by-side benches share: relMSE against a converged reference
// rendered once and cached outside the repository (XDG_CACHE_HOME/luz, else
// ~/.cache/luz), timed CPU renders, and their flags' values.
#pragma once

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/io/image.h"
#include "luz/math/hash.h"

namespace luz_bench {

// relMSE's denominator offset: (x - r)² / (r² + kEps).
constexpr double kEps = 0.01;

// The pixels a relMSE is taken over: a flag per pixel, or all when empty.
using PixelMask = std::vector<char>;

// The mean over the mask's values (3 a pixel) of term(k).
template <class Term>
double mean_over(const PixelMask& keep, size_t values, Term term) {
  double acc = 0;
  size_t n = 0;
  for (size_t k = 0; k < values; ++k)
    if (keep.empty() || keep[k / 3]) {
      acc += term(k);
      ++n;
    }
  return n ? acc / double(n) : 0.0;
}

inline double rel_mse(const std::vector<float>& m, const std::vector<double>& ref, const PixelMask& keep = {}) {
  return mean_over(keep, m.size(), [&](size_t k) { return (m[k] - ref[k]) * (m[k] - ref[k]) / (ref[k] * ref[k] + kEps); });
}
inline double rel_mse(const luz::Film& f, const std::vector<double>& ref, const PixelMask& keep = {}) {
  return rel_mse(f.mean(), ref, keep);
}

inline luz::Film render(const luz::Scene& s, int threads, double& seconds) {
  luz::CpuRenderOptions opt;
  opt.threads = threads;
  luz::RenderStats stats;
  luz::Film f = luz::render_cpu(s, opt, stats);
  seconds = stats.seconds;
  return f;
}

// A hash of a file's bytes, to name its cached reference.
inline uint64_t file_hash(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  uint64_t h = 0x6c757a;
  for (int c; f && (c = std::fgetc(f)) != EOF;) h = luz::mix64(h ^ uint64_t(c));
  if (f) std::fclose(f);
  return h;
}

// The reference's pixel means and the variance of each, and its own share of
// a relMSE (the mean of var / (r² + kEps)), to subtract.
struct Reference {
  std::vector<double> mean, var;
  double noise = 0;
  // Its share over the pixels of `keep`.
  double noise_over(const PixelMask& keep) const {
    return mean_over(keep, mean.size(), [&](size_t k) { return var[k] / (mean[k] * mean[k] + kEps); });
  }
};

// Loads `name` (.pfm, and its .var.pfm) from the cache, or renders `s` and
// stores it there.
inline Reference cached_reference(const std::string& name, const luz::Scene& s, int threads) {
  namespace fs = std::filesystem;
  const char* cache_home = std::getenv("XDG_CACHE_HOME");
  const char* home = std::getenv("HOME");
  const fs::path cache = cache_home ? fs::path(cache_home) / "luz" : fs::path(home ? home : "/tmp") / ".cache" / "luz";
  fs::create_directories(cache);
  const fs::path ref_path = cache / name, var_path = cache / (name + ".var.pfm");
  Reference r;
  if (fs::exists(ref_path) && fs::exists(var_path)) {
    const luz::Image m = luz::read_pfm(ref_path.string()), v = luz::read_pfm(var_path.string());
    r.mean.assign(m.rgb.begin(), m.rgb.end());
    r.var.assign(v.rgb.begin(), v.rgb.end());
    std::printf("reference: %s (cached)\n", ref_path.c_str());
  } else {
    double t = 0;
    const luz::Film f = render(s, threads, t);
    const std::vector<float> m = f.mean();
    r.mean.assign(m.begin(), m.end());
    r.var = f.variance_of_mean();
    luz::write_image(ref_path.string(), luz::Image{f.width, f.height, m});
    luz::write_image(var_path.string(), luz::Image{f.width, f.height, std::vector<float>(r.var.begin(), r.var.end())});
    std::printf("reference: %u spp in %.1f s, cached as %s\n", s.settings.spp, t, ref_path.c_str());
  }
  r.noise = r.noise_over({});
  return r;
}

// argv[++i], or exit 2 naming the flag that lacks it.
inline std::string flag_value(const char* tool, int argc, char** argv, int& i) {
  if (i + 1 >= argc) {
    std::fprintf(stderr, "%s: %s needs a value\n", tool, argv[i]);
    std::exit(2);
  }
  return argv[++i];
}

}  // namespace luz_bench
