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
#include <string>
#include <vector>

#include "luz/io/load.h"
#include "reference.h"

using namespace luz;
using namespace luz_bench;

namespace {

struct Args {
  std::string scene = "bench/scenes/envmap-spheres.xml";
  uint32_t spp = 64, ref_spp = 4096;
  int threads = 0;
  int res = 128;
};

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

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto next = [&] { return flag_value("envmap_bench", argc, argv, i); };
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
  char name[96];
  std::snprintf(name, sizeof name, "envmap-ref-%016" PRIx64 "-%d-%u.pfm", file_hash(a.scene), a.res, a.ref_spp);
  Scene ref_scene = base;
  ref_scene.settings.spp = a.ref_spp;
  ref_scene.settings.seed = 9001;
  const Reference ref = cached_reference(name, ref_scene, a.threads);

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
    v.rel = rel_mse(f, ref.mean) - ref.noise;
  }
  std::printf("scene %s, %dx%d, %u spp; reference %u spp, its own relMSE %.2e\n", a.scene.c_str(), a.res, a.res, a.spp,
              a.ref_spp, ref.noise);
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
