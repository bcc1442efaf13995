// luz: the command-line renderer.
//   luz render SCENE [-o out.exr|.pfm|.png] [--spp N] [--threads N] [--seed S]
//       [--max-depth D] [--sampler independent|stratified|sobol]
//       [--integrator path|bsdf|light] [--light-sampler power|bvh]
//       [--device cpu|cuda|auto] [--time-limit SECONDS] [-D name=value]...
//
// --device: cpu (the default: all cores, Embree), cuda (the first NVIDIA GPU;
// without a usable one, a one-line error naming why, exit status 2, before
// the scene is even read), auto (cuda when a GPU is usable, else the CPU
// with a one-line warning). Same flags, same image, same stats line on each.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <charconv>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <new>
#include <map>
#include <string>

#include "luz/device/cuda/render_cuda.h"
#include "luz/device/progress.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/scene/scene_info.h"
#include "luz/render/render.h"

namespace {

constexpr int kExitBadInput = 2;

// The outputs must be writable before hours of rendering are spent: a known
// format, an existing directory, not a directory itself.
void check_output(const std::string& out) {
  namespace fs = std::filesystem;
  if (!luz::is_supported_image_extension(out)) {
    std::string e = fs::path(out).extension().string();
    throw luz::InputError(out, 0,
                          (e.empty() ? std::string("no image extension") : "unknown image format '" + e + "'") +
                              " (use .exr, .pfm or .png)");
  }
  std::error_code ec;
  fs::path parent = fs::path(out).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec))
    throw luz::InputError(out, 0, "the directory '" + parent.string() + "' does not exist");
  if (fs::is_directory(out, ec)) throw luz::InputError(out, 0, "is a directory");
}

luz::Defines parse_defines(const std::vector<std::string>& defs) {
  luz::Defines defines;
  for (const std::string& d : defs) {
    size_t eq = d.find('=');
    if (eq == std::string::npos || eq == 0) throw luz::InputError("-D " + d + ": expected name=value");
    std::string name = d.substr(0, eq);
    if (defines.count(name)) throw luz::InputError("-D " + name + ": given twice");
    defines[name] = d.substr(eq + 1);
  }
  return defines;
}

int render(const std::string& scene_path, std::vector<std::string> outs, int spp, int threads, long long seed, int max_depth,
           const std::string& sampler, const std::string& integrator, const std::string& light_sampler,
           const std::string& device, double time_limit, const std::string& res, double scale,
           const std::vector<std::string>& defs, const std::vector<std::string>& search) {
  const luz::Defines defines = parse_defines(defs);
  if (outs.empty()) outs.push_back(std::filesystem::path(scene_path).stem().string() + ".exr");
  for (const std::string& out : outs) check_output(out);

  // The device is settled before the scene is read: `--device cuda` without a
  // usable GPU fails at once. auto's fallback warning waits until the scene
  // has loaded, so that bad input still gives exactly one line.
  bool use_cuda = device == "cuda";
  std::string no_gpu;
  if (device == "cuda" || device == "auto") {
    use_cuda = luz::cuda_available(&no_gpu);
    if (!use_cuda && device == "cuda") throw luz::InputError("--device cuda: " + no_gpu);
  }

  const auto load_start = std::chrono::steady_clock::now();
  luz::Scene scene = luz::load_scene(scene_path, defines, search);
  const double load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
  // Another size: --res WxH, or --scale F of the scene's own.
  if (!res.empty() || scale > 0) {
    long long w = 0, h = 0;
    if (!res.empty()) {
      const size_t x = res.find('x');
      auto whole = [](const std::string& t, long long& v) {
        auto r = std::from_chars(t.data(), t.data() + t.size(), v);
        return !t.empty() && r.ec == std::errc() && r.ptr == t.data() + t.size();
      };
      if (x == std::string::npos || !whole(res.substr(0, x), w) || !whole(res.substr(x + 1), h))
        throw luz::InputError("--res " + res + ": expected WIDTHxHEIGHT, as 640x480");
    } else {
      w = std::llround(scene.camera.width * scale);
      h = std::llround(scene.camera.height * scale);
    }
    if (w < 1 || h < 1 || w > 65536 || h > 65536)
      throw luz::InputError((res.empty() ? "--scale: " : "--res " + res + ": ") + std::string("the image would be ") +
                            std::to_string(w) + "×" + std::to_string(h) + "; each side must be between 1 and 65536");
    scene.set_resolution(int(w), int(h));
  }
  for (const std::string& w : scene.warnings) std::fprintf(stderr, "%s\n", w.c_str());
  luz::RenderSettings& s = scene.settings;
  if (spp > 0) s.spp = uint32_t(spp);
  if (seed >= 0) s.seed = uint64_t(seed);
  if (max_depth != 0) s.integrator.max_depth = max_depth;
  if (sampler == "independent") s.sampler = luz::SamplerType::Independent;
  else if (sampler == "stratified") s.sampler = luz::SamplerType::Stratified;
  else if (sampler == "sobol") s.sampler = luz::SamplerType::Sobol;
  if (integrator == "path") s.integrator.type = luz::IntegratorType::Path;
  else if (integrator == "bsdf") s.integrator.type = luz::IntegratorType::Bsdf;
  else if (integrator == "light") s.integrator.type = luz::IntegratorType::Light;
  if (light_sampler == "bvh") s.light_sampler = luz::LightSamplerType::Bvh;
  else if (light_sampler == "power") s.light_sampler = luz::LightSamplerType::Power;

  if (device == "auto" && !use_cuda)
    std::fprintf(stderr, "luz: warning: --device auto: no usable GPU (%s); rendering on the CPU\n", no_gpu.c_str());
  std::fprintf(stderr, "luz: %s: %d×%d, %u spp, %u triangles, %zu spheres, %zu light%s, loaded in %.2f s, on %s\n",
               scene_path.c_str(), scene.camera.width, scene.camera.height, s.spp, scene.num_triangles(),
               scene.spheres.size(), scene.lights.size(), scene.lights.size() == 1 ? "" : "s", load_seconds,
               use_cuda ? luz::cuda_device_name().c_str() : "the CPU");
  if (!scene.lights_emit)
    std::fprintf(stderr, "luz: warning: %s: the scene has no light that emits, so the image will be black\n",
                 scene_path.c_str());
  luz::RenderRequest req;
  req.device = use_cuda ? luz::RenderDevice::Cuda : luz::RenderDevice::Cpu;
  req.threads = threads;
  req.time_limit = time_limit;
  luz::RenderResult result;
  {
    luz::ProgressBar bar(::isatty(2), uint64_t(scene.camera.width) * scene.camera.height * s.spp);
    req.progress = [&](const luz::RenderProgress& p) { bar.set(p.samples_done); };
    result = luz::render(scene, req);
  }
  const luz::RenderStats& stats = result.stats;
  if (!result.complete)
    std::fprintf(stderr, "luz: the time limit of %g s ended the render at %u of %u spp\n", time_limit, stats.spp, s.spp);
  const luz::Film& film = result.film;
  luz::Image img{film.width, film.height, film.mean()};
  std::string written;
  for (const std::string& out : outs) {
    luz::write_image(out, img, scene.settings.exr_format);
    written += (written.empty() ? "" : ", ") + out;
  }
  std::printf("luz: %.3f s, %.3f Msamples/s, %.2f Mrays/s, %llu non-finite samples discarded, wrote %s\n",
              stats.seconds, stats.samples / stats.seconds * 1e-6, stats.rays / stats.seconds * 1e-6,
              (unsigned long long)stats.discarded, written.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Luz: a physically based path tracer"};
  app.require_subcommand(1);
  CLI::App* rc = app.add_subcommand("render", "render a scene (Mitsuba 3 XML, pbrt-v4, glTF 2.0, OBJ or PLY) to an image");
  std::string scene, sampler, integrator, light_sampler, device = "cpu";
  std::vector<std::string> outs;
  int spp = 0, threads = 0, max_depth = 0;
  long long seed = -1;
  double time_limit = 0, scale = 0;
  std::string res;
  std::vector<std::string> defines, search;
  rc->add_option("scene", scene, "scene file (.xml, .pbrt, .gltf, .glb, .obj or .ply)")->required();
  rc->add_option("-o,--output", outs, "output image: .exr (float), .pfm, or .png (sRGB); may repeat")
      ->allow_extra_args(false);
  // Whole decimal integers in a range, each flag with its own message (CLI11's
  // Range let "99999999999999999999" through as some other seed, "0x10" as 16,
  // and `Range & !IsMember({0})` said "check {0} succeeded improperly").
  auto integer_in = [](long long lo, long long hi, std::string what, bool minus_one = false) {
    return CLI::Validator(
        [=](std::string& s) -> std::string {
          long long v = 0;
          auto r = std::from_chars(s.data(), s.data() + s.size(), v);
          if (r.ec == std::errc() && r.ptr == s.data() + s.size() && ((v >= lo && v <= hi) || (minus_one && v == -1)))
            return std::string();
          return "'" + s + "' is not " + what;
        },
        minus_one ? "-1 or " + std::to_string(lo) + ".." + std::to_string(hi)
                  : std::to_string(lo) + ".." + std::to_string(hi));
  };
  rc->add_option("--spp", spp, "samples per pixel (overrides the scene)")
      ->check(integer_in(1, 1 << 24, "a sample count from 1 to 16777216"));
  rc->add_option("--threads", threads, "worker threads (default: all cores)")
      ->check(integer_in(0, 4096, "a thread count from 0 (all cores) to 4096"));
  rc->add_option("--seed", seed, "random seed")
      ->check(integer_in(0, std::numeric_limits<long long>::max(), "a seed from 0 to 9223372036854775807"));
  rc->add_option("--max-depth", max_depth, "longest path, Mitsuba's max_depth (-1: unbounded)")
      ->check(integer_in(1, 1 << 20, "-1 (unbounded) or a depth from 1 to 1048576", true));
  rc->add_option("--sampler", sampler, "sample generator")->check(CLI::IsMember({"independent", "stratified", "sobol"}));
  rc->add_option("--integrator", integrator, "estimator")->check(CLI::IsMember({"path", "bsdf", "light"}));
  rc->add_option("--light-sampler", light_sampler,
                 "light selection: power (default: by power alone) or bvh (a light BVH: also by distance and orientation)")
      ->check(CLI::IsMember({"power", "bvh"}));
  rc->add_option("--device", device, "where to render: cpu (default), cuda (an NVIDIA GPU), auto (cuda if usable)")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  rc->add_option("--res", res, "render at WIDTHxHEIGHT instead of the scene's size (the field of view kept along the scene's axis)");
  rc->add_option("--scale", scale, "render at F times the scene's width and height")
      ->check(CLI::Validator(
          [](std::string& t) -> std::string {
            double v = 0;
            auto r = std::from_chars(t.data(), t.data() + t.size(), v);
            if (r.ec == std::errc() && r.ptr == t.data() + t.size() && v > 0 && v <= 65536) return std::string();
            return "'" + t + "' is not a scale above 0 and at most 65536";
          },
          "F"));
  rc->add_option("--time-limit", time_limit,
                 "stop after about this many seconds of rendering, with the whole passes done (default: none)")
      ->check(CLI::Validator(
          [](std::string& s) -> std::string {
            double v = 0;
            auto r = std::from_chars(s.data(), s.data() + s.size(), v);
            if (r.ec == std::errc() && r.ptr == s.data() + s.size() && v > 0 && v <= 1e9) return std::string();
            return "'" + s + "' is not a number of seconds above 0 and at most 1e9";
          },
          "SECONDS"));
  rc->add_option("-D", defines, "override a scene <default>: name=value")->allow_extra_args(false);
  rc->add_option("-a", search, "a folder where files a Mitsuba scene names are also looked for (as Mitsuba's -a)")
      ->allow_extra_args(false);
  CLI::App* ic = app.add_subcommand("info", "what a scene holds, without rendering: shapes, lights, materials, camera, warnings");
  std::string info_scene;
  std::vector<std::string> info_defines;
  ic->add_option("scene", info_scene, "scene file (.xml, .pbrt, .gltf, .glb, .obj or .ply)")->required();
  ic->add_option("-D", info_defines, "override a scene <default>: name=value")->allow_extra_args(false);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help (and the like) print to stdout and succeed; a real parse error is
    // one line on stderr (CLI11's own printer adds a second "Run with --help").
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "luz: error: %s (see luz render --help)\n", luz::InputError::one_line(e.what()).c_str());
    return kExitBadInput;
  }
  // Every error is one line: "file:line: error: problem" when it concerns a
  // file, "luz: error: problem" otherwise.
  try {
    if (ic->parsed()) {
      const auto start = std::chrono::steady_clock::now();
      const luz::Scene s = luz::load_scene(info_scene, parse_defines(info_defines));
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::printf("scene: %s (loaded in %.3f s)\n%s", info_scene.c_str(), seconds, luz::describe_scene(s).c_str());
      return 0;
    }
    return render(scene, outs, spp, threads, seed, max_depth, sampler, integrator, light_sampler, device, time_limit, res, scale,
                  defines, search);
  } catch (const luz::InputError& e) {
    if (e.file().empty())
      std::fprintf(stderr, "luz: error: %s\n", e.problem().c_str());
    else if (e.line() > 0)
      std::fprintf(stderr, "%s:%d: error: %s\n", e.file().c_str(), e.line(), e.problem().c_str());
    else
      std::fprintf(stderr, "%s: error: %s\n", e.file().c_str(), e.problem().c_str());
    return kExitBadInput;
  } catch (const luz::CudaError& e) {
    // No usable GPU is the user's setup (2); a GPU that fails mid-render, 1.
    std::fprintf(stderr, "luz: error: CUDA: %s\n", e.what());
    return e.kind() == luz::CudaError::Kind::Unavailable ? kExitBadInput : 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "luz: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "luz: error: %s\n", luz::InputError::one_line(e.what()).c_str());
    return 1;
  }
}
