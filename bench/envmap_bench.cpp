// Environment-map sampling, side by side: the env-lit benchmark scene
// rendered with the envmap's importance sampling (luminance × sin θ per
// cell, as Luz does) and with uniform sampling of the sphere (the same
// cells weighted by solid angle only), each at the same spp: time,
// samples/s, relMSE against a converged reference (rendered once with
// importance sampling and cached outside the repository), and efficiency
// 1 / (relMSE × time), with the relMSE each would reach in the other's time.
//
// relMSE: the mean over pixels and channels of (x - r)² / (r² + 0.01), minus
// the reference's own contribution (its variance of the mean over the same
// denominator, printed so that it can be seen to be small).
//
// Prints one markdown row per variant, starting with '|'.
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/io/image.h"
#include "luz/io/scene_loader.h"
#include "luz/math/hash.h"

using namespace luz;
namespace fs = std::filesystem;

namespace {

constexpr double kEps = 0.01;

struct Args {
  std::string scene = "bench/scenes/envmap-spheres.xml";
  uint32_t spp = 64, ref_spp = 4096;
  int threads = 0;
  int res = 128;
};

double rel_mse(const Film& f, const std::vector<double>& ref) {
  const std::vector<float> m = f.mean();
  double acc = 0;
  for (size_t k = 0; k < m.size(); ++k) acc += (m[k] - ref[k]) * (m[k] - ref[k]) / (ref[k] * ref[k] + kEps);
  return acc / double(m.size());
}

// Index of the scene's envmap light; exits if there is none.
size_t envmap_index(const Scene& s) {
  for (size_t k = 0; k < s.lights.size(); ++k)
    if (s.lights[k].type == LightType::Envmap) return k;
  std::fprintf(stderr, "envmap_bench: the scene has no envmap\n");
  std::exit(2);
}

// The same envmap, its cells weighted by solid angle only (∫ sin θ over
// the cell's rows): uniform sampling of the sphere, cell by cell.
void make_uniform(Scene& s) {
  EnvmapLight& l = s.lights[envmap_index(s)].envmap;
  std::vector<double> w(size_t(l.width) * (l.height - 1));
  for (uint32_t j = 0; j + 1 < l.height; ++j)
    for (uint32_t i = 0; i < l.width; ++i)
      w[size_t(j) * l.width + i] = std::cos(j * M_PI / (l.height - 1)) - std::cos((j + 1) * M_PI / (l.height - 1));
  l.cells = build_distribution2d(w, l.width, l.height - 1, s.light_data);
  s.compile();
}

Film render(const Scene& s, int threads, double& seconds) {
  CpuRenderOptions opt;
  opt.threads = threads;
  RenderStats stats;
  Film f = render_cpu(s, opt, stats);
  seconds = stats.seconds;
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "envmap_bench: %s needs a value\n", arg.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--spp") a.spp = uint32_t(std::stoul(next()));
    else if (arg == "--ref-spp") a.ref_spp = uint32_t(std::stoul(next()));
    else if (arg == "--threads") a.threads = std::stoi(next());
    else if (arg == "--res") a.res = std::stoi(next());
    else if (arg[0] != '-') a.scene = arg;
    else {
      std::fprintf(stderr, "envmap_bench: unknown argument %s\n", arg.c_str());
      return 2;
    }
  }
  const Defines defines{{"res", std::to_string(a.res)}};
  Scene base = load_scene(a.scene, defines);
  envmap_index(base);

  // The reference, cached by scene file contents, resolution and spp.
  const char* cache_home = std::getenv("XDG_CACHE_HOME");
  const char* home = std::getenv("HOME");
  const fs::path cache = cache_home ? fs::path(cache_home) / "luz" : fs::path(home ? home : "/tmp") / ".cache" / "luz";
  fs::create_directories(cache);
  std::FILE* sf = std::fopen(a.scene.c_str(), "rb");
  uint64_t h = 0x6c757a;
  for (int c; sf && (c = std::fgetc(sf)) != EOF;) h = mix64(h ^ uint64_t(c));
  if (sf) std::fclose(sf);
  char name[96];
  std::snprintf(name, sizeof name, "envmap-ref-%016" PRIx64 "-%d-%u.pfm", h, a.res, a.ref_spp);
  const fs::path ref_path = cache / name;
  const fs::path ref_var_path = cache / (std::string(name) + ".var.pfm");
  std::vector<double> ref, ref_var;
  if (fs::exists(ref_path) && fs::exists(ref_var_path)) {
    const Image r = read_pfm(ref_path.string()), v = read_pfm(ref_var_path.string());
    ref.assign(r.rgb.begin(), r.rgb.end());
    ref_var.assign(v.rgb.begin(), v.rgb.end());
    std::printf("reference: %s (cached)\n", ref_path.c_str());
  } else {
    Scene s = base;
    s.settings.spp = a.ref_spp;
    s.settings.seed = 9001;
    double t = 0;
    const Film f = render(s, a.threads, t);
    const std::vector<float> m = f.mean();
    ref.assign(m.begin(), m.end());
    ref_var = f.variance_of_mean();
    Image r{f.width, f.height, m}, v{f.width, f.height, std::vector<float>(ref_var.begin(), ref_var.end())};
    write_image(ref_path.string(), r);
    write_image(ref_var_path.string(), v);
    std::printf("reference: %u spp in %.1f s, cached as %s\n", a.ref_spp, t, ref_path.c_str());
  }
  double ref_noise = 0;
  for (size_t k = 0; k < ref.size(); ++k) ref_noise += ref_var[k] / (ref[k] * ref[k] + kEps);
  ref_noise /= double(ref.size());

  struct Variant {
    const char* name;
    bool uniform;
    double seconds = 0, rel = 0;
  } variants[] = {{"importance", false}, {"uniform", true}};
  for (Variant& v : variants) {
    Scene s = base;
    if (v.uniform) make_uniform(s);
    s.settings.spp = a.spp;
    s.settings.seed = 7;
    const Film f = render(s, a.threads, v.seconds);
    v.rel = rel_mse(f, ref) - ref_noise;
  }
  std::printf("scene %s, %dx%d, %u spp; reference %u spp, its own relMSE %.2e\n", a.scene.c_str(), a.res, a.res, a.spp,
              a.ref_spp, ref_noise);
  const double pixels = double(a.res) * a.res;
  for (const Variant& v : variants) {
    const Variant& other = v.uniform ? variants[0] : variants[1];
    std::printf("| %s | %dx%d | %u | %.3f | %.3f | %.3e | %.3e | %.1f |\n", v.name, a.res, a.res, a.spp, v.seconds,
                pixels * a.spp / v.seconds * 1e-6, v.rel, v.rel * v.seconds / other.seconds, 1.0 / (v.rel * v.seconds));
  }
  std::printf("efficiency importance / uniform: %.2fx\n",
              (1.0 / (variants[0].rel * variants[0].seconds)) / (1.0 / (variants[1].rel * variants[1].seconds)));
  return 0;
}
