// luz: the command-line renderer.
//   luz render SCENE [-o out.exr|.pfm|.png]... [--spp N] [--threads N] [--seed S]
//       [--max-depth D] [--sampler independent|stratified|sobol]
//       [--integrator path|bsdf|light] [--light-sampler power|bvh]
//       [--device cpu|cuda|auto] [--time-limit SECONDS] [-D name=value]...
//       [--checkpoint PATH [--checkpoint-every SECONDS]] [-q]
//   luz render --resume CHECKPOINT [-o ...] [--threads N] [--time-limit SECONDS]
//   luz info SCENE;  luz --version
//
// --device: cpu (the default: all cores, Embree), cuda (the first NVIDIA GPU;
// without a usable one, a one-line error naming why, exit status 2, before
// the scene is even read), auto (cuda when a GPU is usable, else the CPU
// with a one-line warning). Same flags, same image, same stats line on each.
//
// Nothing is lost: outputs are checked before the render; SIGINT/SIGTERM
// stop it within a pass and write the image so far and a checkpoint (exit
// 130/143); a resumed render is bit-identical to one never stopped.
#include <CLI/CLI.hpp>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <new>
#include <map>
#include <optional>
#include <set>
#include <string>

#include "luz/core/memory.h"
#include "luz/core/version.h"
#include "luz/device/cuda/render_cuda.h"
#include "luz/device/progress.h"
#include "luz/io/atomic_file.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/scene/scene_info.h"
#include "luz/scene/serialize.h"
#include "luz/render/aov.h"
#include "luz/render/checkpoint.h"
#include "luz/render/mpi.h"
#include "luz/render/render.h"

namespace {

namespace fs = std::filesystem;

constexpr int kExitBadInput = 2;
// Seconds between checkpoints when only --checkpoint PATH is given.
constexpr double kDefaultCheckpointEvery = 300;
// Camera rays per pixel, and BSDF samples per hit, of the --aov layers.
constexpr uint32_t kAovSamples = 4, kAovBsdfSamples = 8;

// The outputs must be writable before hours of rendering are spent: a known
// format, and a file the directory takes (io/atomic_file.h's probe).
void check_output(const std::string& out) {
  if (!luz::is_supported_image_extension(out)) {
    std::string e = fs::path(out).extension().string();
    throw luz::InputError(out, 0,
                          (e.empty() ? std::string("no image extension") : "unknown image format '" + e + "'") +
                              " (use .exr, .pfm or .png)");
  }
  luz::probe_writable(out);
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

// What `luz render` was asked: the flags, as parsed. A checkpoint keeps them
// (paths made absolute) so that `--resume` asks again for the same render.
struct RenderOptions {
  std::string scene;
  std::vector<std::string> outs;
  int spp = 0, threads = 0, max_depth = 0;
  long long seed = -1;
  std::string sampler, integrator, light_sampler, reconstruction, env_guide, device = "cpu";
  double time_limit = 0, scale = 0;
  std::string res;
  std::vector<std::string> defines, search;
  std::string checkpoint;
  double checkpoint_every = -1;  // < 0: the default
  bool quiet = false;
  bool broadcast = false;  // an MPI render: rank 0 loads the scene and sends it
  std::string camera;      // a glTF camera by name
  double mpi_timeout = 600;  // seconds a rank may load the scene or hold a unit before it is taken as lost
  std::vector<std::string> aovs;  // albedo, normal, depth, variance

  // Name/value pairs, flattened; only what a resume asks again (not the
  // threads, time limit or quiet of one run).
  std::vector<std::string> to_args() const {
    std::vector<std::string> a;
    auto put = [&](const std::string& k, const std::string& v) { a.push_back(k), a.push_back(v); };
    auto abs = [](const std::string& p) { return fs::absolute(p).lexically_normal().string(); };
    auto exact = [](double v) {  // read back to the same double
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.17g", v);
      return std::string(buf);
    };
    put("scene", abs(scene));
    for (const std::string& o : outs) put("output", abs(o));
    put("spp", std::to_string(spp));
    put("seed", std::to_string(seed));
    put("max-depth", std::to_string(max_depth));
    put("sampler", sampler);
    put("integrator", integrator);
    put("light-sampler", light_sampler);
    put("reconstruction", reconstruction);
    put("env-guide", env_guide);
    put("device", device);
    put("res", res);
    put("scale", exact(scale));
    for (const std::string& d : defines) put("define", d);
    for (const std::string& d : search) put("search", abs(d));
    put("camera", camera);
    put("checkpoint", abs(checkpoint));
    put("checkpoint-every", exact(checkpoint_every));
    for (const std::string& v : aovs) put("aov", v);
    return a;
  }
  // The options a checkpoint recorded; throws InputError(path) when they do not parse.
  static RenderOptions from_args(const std::vector<std::string>& a, const std::string& path) {
    RenderOptions o;
    auto bad = [&](const std::string& why) -> luz::InputError {
      return luz::InputError(path, 0, "the checkpoint's render options are corrupted (" + why + ")");
    };
    if (a.size() % 2) throw bad("an odd count");
    auto num = [&](const std::string& k, const std::string& v, auto& out) {
      auto r = std::from_chars(v.data(), v.data() + v.size(), out);
      if (r.ec != std::errc() || r.ptr != v.data() + v.size()) throw bad(k + " = '" + v + "'");
    };
    for (size_t i = 0; i < a.size(); i += 2) {
      const std::string &k = a[i], &v = a[i + 1];
      if (k == "scene") o.scene = v;
      else if (k == "output") o.outs.push_back(v);
      else if (k == "spp") num(k, v, o.spp);
      else if (k == "seed") num(k, v, o.seed);
      else if (k == "max-depth") num(k, v, o.max_depth);
      else if (k == "sampler") o.sampler = v;
      else if (k == "integrator") o.integrator = v;
      else if (k == "light-sampler") o.light_sampler = v;
      else if (k == "reconstruction") o.reconstruction = v;
      else if (k == "env-guide") o.env_guide = v;
      else if (k == "device") o.device = v;
      else if (k == "res") o.res = v;
      else if (k == "scale") num(k, v, o.scale);
      else if (k == "define") o.defines.push_back(v);
      else if (k == "search") o.search.push_back(v);
      else if (k == "camera") o.camera = v;
      else if (k == "checkpoint") o.checkpoint = v;
      else if (k == "checkpoint-every") num(k, v, o.checkpoint_every);
      else if (k == "aov") o.aovs.push_back(v);
      else throw bad("unknown option '" + k + "'");
    }
    if (o.scene.empty()) throw bad("no scene");
    return o;
  }
};

// Errors are one line on stderr; the last is kept for an MPI job, whose
// rank 0 prints the first failing rank's (the others' stderr is closed).
std::string g_error_line;

int report(const std::string& line, int status) {
  std::fprintf(stderr, "%s\n", line.c_str());
  g_error_line = line;
  return status;
}

// SIGINT and SIGTERM: the first stops the render after its whole passes
// (the image and a checkpoint are written, then exit 128 + signal); a second
// exits at once, leaving no temporary file.
std::atomic<bool> g_cancel{false};
std::atomic<int> g_signal{0};

extern "C" void on_signal(int sig) {
  int expected = 0;
  if (g_signal.compare_exchange_strong(expected, sig)) {
    g_cancel.store(true);
    static const char kMsg[] = "\nluz: interrupted: stopping, then writing the image so far and a checkpoint "
                               "(interrupt again to quit at once)\n";
    [[maybe_unused]] ssize_t n = ::write(2, kMsg, sizeof kMsg - 1);
    return;
  }
  luz::remove_pending_temporary();
  ::_exit(128 + sig);
}

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
}

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", s);
  return buf;
}

// A scene path must name a regular file: a FIFO would hang the reader, a
// device such as /dev/zero be read until memory runs out.
void check_scene_file(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) return;  // the reader says why it cannot open it
  if (S_ISDIR(st.st_mode)) throw luz::InputError(path, 0, "is a directory, not a scene file");
  if (!S_ISREG(st.st_mode)) throw luz::InputError(path, 0, "is not a regular file (a pipe or a device?)");
}

// The films (the render's, the next pass's, a checkpoint's copy), the image
// and the acceleration structure must fit in the memory available. Embree's
// BVH takes 60-80 bytes a triangle as Luz builds it (a 2-million-triangle
// grid: 150 MB); 64 keeps the estimate from refusing a render that fits.
void check_memory(const luz::Scene& scene) {
  const int width = scene.camera.width, height = scene.camera.height;
  const uint64_t film = 6 * sizeof(double) + sizeof(uint32_t);  // sums, sums of squares, count
  const uint64_t films = uint64_t(width) * uint64_t(height) * (3 * film + 3 * sizeof(float));
  const uint64_t triangles = scene.tri_material.size(), bvh = triangles * 64;
  const uint64_t avail = luz::available_memory();
  if (avail > 0 && films + bvh > avail)
    throw luz::InputError("the render needs " + luz::memory_text(films + bvh) + " of memory (the films of the " +
                          std::to_string(width) + "×" + std::to_string(height) + " image: " + luz::memory_text(films) +
                          ", the acceleration structure of " + std::to_string(triangles) +
                          " triangles: " + luz::memory_text(bvh) + "); " + luz::memory_text(avail) + " are available");
}

// Applies --res or --scale.
void resize(luz::Scene& scene, const RenderOptions& o) {
  if (o.res.empty() && !(o.scale > 0)) return;
  long long w = 0, h = 0;
  if (!o.res.empty()) {
    const size_t x = o.res.find('x');
    auto whole = [](const std::string& t, long long& v) {
      auto r = std::from_chars(t.data(), t.data() + t.size(), v);
      return !t.empty() && r.ec == std::errc() && r.ptr == t.data() + t.size();
    };
    if (x == std::string::npos || !whole(o.res.substr(0, x), w) || !whole(o.res.substr(x + 1), h))
      throw luz::InputError("--res " + o.res + ": expected WIDTHxHEIGHT, as 640x480");
  } else {
    w = std::llround(scene.camera.width * o.scale);
    h = std::llround(scene.camera.height * o.scale);
  }
  if (w < 1 || h < 1 || w > 65536 || h > 65536)
    throw luz::InputError((o.res.empty() ? "--scale: " : "--res " + o.res + ": ") + std::string("the image would be ") +
                          std::to_string(w) + "×" + std::to_string(h) + "; each side must be between 1 and 65536");
  scene.set_resolution(int(w), int(h));
}

// The flags onto the scene's settings; a one-line warning for each that
// changes the image the scene file's render converges to (the depth, the
// estimator), not for those that change only its noise (spp, seed, sampler).
void apply_flags(luz::RenderSettings& s, const RenderOptions& o, std::vector<std::string>& warnings) {
  const luz::RenderSettings was = s;
  if (o.sampler == "independent") s.sampler = luz::SamplerType::Independent;
  else if (o.sampler == "stratified") s.sampler = luz::SamplerType::Stratified;
  else if (o.sampler == "sobol") s.sampler = luz::SamplerType::Sobol;
  if (o.integrator == "path") s.integrator.type = luz::IntegratorType::Path;
  else if (o.integrator == "bsdf") s.integrator.type = luz::IntegratorType::Bsdf;
  else if (o.integrator == "light") s.integrator.type = luz::IntegratorType::Light;
  if (o.light_sampler == "bvh") s.light_sampler = luz::LightSamplerType::Bvh;
  else if (o.light_sampler == "power") s.light_sampler = luz::LightSamplerType::Power;
  if (o.reconstruction == "splat") s.reconstruction = luz::Reconstruction::Splat;
  else if (o.reconstruction == "filter") s.reconstruction = luz::Reconstruction::FilterSampling;
  if (!o.env_guide.empty()) s.env_guide = o.env_guide == "on";
  if (o.spp > 0) s.spp = uint32_t(o.spp);
  if (o.seed >= 0) s.seed = uint64_t(o.seed);
  if (o.max_depth != 0) s.integrator.max_depth = o.max_depth;
  auto warn = [&](const char* flag, const std::string& now, const std::string& before) {
    if (now != before) warnings.push_back("luz: warning: " + std::string(flag) + " " + now + " overrides the scene's " + before);
  };
  warn("--max-depth", std::to_string(s.integrator.max_depth), std::to_string(was.integrator.max_depth));
  warn("--integrator", luz::integrator_name(s.integrator.type), luz::integrator_name(was.integrator.type));
}


// A frame sequence: every scene given, each with every value of --frames
// NAME=V1,V2,... or NAME=A..B (whole numbers, both ends included) as
// `-D NAME=value`, numbered from 1 in that order. Each run of '#' in an
// output or checkpoint name becomes the frame number, zero-padded to the
// run's length; several frames need one in each name.
std::vector<RenderOptions> frame_list(const RenderOptions& o, const std::vector<std::string>& scenes,
                                      const std::string& spec) {
  std::string name;
  std::vector<std::string> values;
  if (!spec.empty()) {
    const size_t eq = spec.find('=');
    if (eq == 0 || eq == std::string::npos || eq + 1 == spec.size())
      throw luz::InputError("--frames " + spec + ": expected NAME=V1,V2,... or NAME=A..B");
    name = spec.substr(0, eq);
    const std::string list = spec.substr(eq + 1);
    long long a = 0, b = 0;
    const size_t dots = list.find("..");
    auto whole = [](const std::string& t, long long& v) {
      auto r = std::from_chars(t.data(), t.data() + t.size(), v);
      return !t.empty() && r.ec == std::errc() && r.ptr == t.data() + t.size();
    };
    if (dots != std::string::npos) {
      if (!whole(list.substr(0, dots), a) || !whole(list.substr(dots + 2), b) || b < a || b - a >= 1000000)
        throw luz::InputError("--frames " + spec + ": a range is A..B, whole numbers with A <= B, at most 1000000 frames");
      for (long long v = a; v <= b; ++v) values.push_back(std::to_string(v));
    } else {
      for (size_t at = 0; at <= list.size();) {
        const size_t comma = std::min(list.find(',', at), list.size());
        if (comma == at) throw luz::InputError("--frames " + spec + ": an empty value");
        values.push_back(list.substr(at, comma - at));
        at = comma + 1;
      }
    }
  }
  if (values.empty()) values.push_back("");
  std::vector<std::string> paths = scenes;
  if (paths.empty()) paths.push_back(o.scene);
  const size_t n = paths.size() * values.size();
  auto number = [](const std::string& pattern, size_t frame, size_t frames, const std::string& what) {
    if (pattern.find('#') == std::string::npos) {
      if (frames > 1)
        throw luz::InputError(what + " " + pattern + ": " + std::to_string(frames) +
                              " frames need a '#' in the name for the frame number (e.g. out_###.exr)");
      return pattern;
    }
    std::string out;
    for (size_t i = 0; i < pattern.size();) {
      if (pattern[i] != '#') {
        out += pattern[i++];
        continue;
      }
      size_t run = 0;
      while (i < pattern.size() && pattern[i] == '#') ++run, ++i;
      const std::string digits = std::to_string(frame);
      out += std::string(run > digits.size() ? run - digits.size() : 0, '0') + digits;
    }
    return out;
  };
  std::vector<RenderOptions> frames;
  std::set<std::string> written;
  for (const std::string& path : paths)
    for (const std::string& value : values) {
      RenderOptions f = o;
      const size_t k = frames.size() + 1;
      f.scene = path;
      if (!name.empty()) f.defines.push_back(name + "=" + value);
      const bool named = !f.outs.empty();  // else one per scene, numbered when a scene has several frames
      if (!named && !path.empty())
        f.outs.push_back(fs::path(path).stem().string() + (values.size() > 1 ? "_####" : "") + ".exr");
      for (std::string& out : f.outs) {
        out = number(out, k, named ? n : 1, "-o");
        if (n > 1 && !written.insert(fs::absolute(out).lexically_normal().string()).second)
          throw luz::InputError("-o " + out + ": two frames would write it");
      }
      if (!f.checkpoint.empty()) f.checkpoint = number(f.checkpoint, k, n, "--checkpoint");
      frames.push_back(std::move(f));
    }
  return frames;
}

// `resume`: a checkpoint to continue ("" for a new render); `o` holds the
// flags given now, which on a resume replace the checkpoint's (`given`
// names them).
// `job`: the MPI job this process is a rank of, or null.
int render(RenderOptions o, const std::string& resume, const std::set<std::string>& given, luz::MpiJob* job) {
  const bool root = !job || job->rank() == 0;  // the rank that writes
  if (job && o.threads == 0) o.threads = job->default_threads();
  if (job && o.broadcast && !root) {
    // The scene comes from rank 0 once every rank agrees that it loaded.
    if (!job->agree("", o.threads).empty()) return kExitBadInput;
    std::string bytes;
    job->broadcast(bytes);
    install_signal_handlers();
    std::optional<luz::Scene> scene;
    std::string error;
    try {
      scene = luz::deserialize_scene(bytes);
    } catch (const std::exception& e) {
      error = std::string("the broadcast scene: ") + e.what();
    }
    bytes = std::string();
    return job->work(scene ? &*scene : nullptr, o.threads, &g_cancel, error);
  }
  std::optional<luz::Checkpoint> ckpt;
  if (!resume.empty()) {
    ckpt = luz::read_checkpoint(resume);
    RenderOptions was = RenderOptions::from_args(ckpt->args, resume);
    auto keep = [&](const char* flag, auto& field, const auto& old) {
      if (!given.count(flag)) field = old;
    };
    keep("scene", o.scene, was.scene);
    keep("-o", o.outs, was.outs);
    keep("--spp", o.spp, was.spp);
    keep("--seed", o.seed, was.seed);
    keep("--max-depth", o.max_depth, was.max_depth);
    keep("--sampler", o.sampler, was.sampler);
    keep("--integrator", o.integrator, was.integrator);
    keep("--light-sampler", o.light_sampler, was.light_sampler);
    keep("--reconstruction", o.reconstruction, was.reconstruction);
    keep("--env-guide", o.env_guide, was.env_guide);
    keep("--device", o.device, was.device);
    keep("--res", o.res, was.res);
    keep("--scale", o.scale, was.scale);
    keep("-D", o.defines, was.defines);
    keep("-a", o.search, was.search);
    keep("--checkpoint-every", o.checkpoint_every, was.checkpoint_every);
    keep("--aov", o.aovs, was.aovs);
    keep("--camera", o.camera, was.camera);
    if (!given.count("--checkpoint")) o.checkpoint = resume;  // the same file goes on
  }
  if (o.scene.empty()) throw luz::InputError("no scene given (luz render SCENE, or luz render --resume CHECKPOINT)");
  const luz::Defines defines = parse_defines(o.defines);
  if (o.outs.empty()) o.outs.push_back(fs::path(o.scene).stem().string() + ".exr");
  if (root)
    for (const std::string& out : o.outs) check_output(out);
  if (!o.aovs.empty() && std::none_of(o.outs.begin(), o.outs.end(), [](const std::string& f) {
        return luz::lower_extension(f) == ".exr";
      }))
    throw luz::InputError("--aov: the layers go into an OpenEXR output; give one (-o out.exr)");
  // Where a checkpoint goes when a signal stops a render that names none.
  const bool explicit_checkpoint = !o.checkpoint.empty();
  if (!explicit_checkpoint && root) {
    // Beside the first output, named after it when the name fits.
    o.checkpoint = o.outs.front() + ".checkpoint";
    try {
      luz::probe_writable(o.checkpoint);
    } catch (const luz::InputError&) {
      o.checkpoint = (fs::path(o.outs.front()).parent_path() / ("luz-" + std::to_string(::getpid()) + ".checkpoint")).string();
    }
  }
  if (root) luz::probe_writable(o.checkpoint);
  if (o.checkpoint_every < 0) o.checkpoint_every = kDefaultCheckpointEvery;

  // The device is settled before the scene is read: `--device cuda` without a
  // usable GPU fails at once. auto's fallback warning waits until the scene
  // has loaded, so that bad input still gives exactly one line.
  bool use_cuda = o.device == "cuda";
  std::string no_gpu;
  if (job && o.device != "cpu")
    throw luz::InputError("--device " + o.device + ": an MPI render runs on the CPU of each rank (CUDA ranks are not built yet)");
  if (o.device == "cuda" || o.device == "auto") {
    use_cuda = luz::cuda_available(&no_gpu);
    if (!use_cuda && o.device == "cuda") throw luz::InputError("--device cuda: " + no_gpu);
  }

  if (job) job->set_timeout(o.mpi_timeout);  // for the wait until every rank has loaded the scene
  check_scene_file(o.scene);
  const auto load_start = std::chrono::steady_clock::now();
  luz::Scene scene = luz::load_scene(o.scene, defines, o.search, o.camera);
  const double load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
  resize(scene, o);
  luz::RenderSettings& s = scene.settings;
  apply_flags(s, o, scene.warnings);
  check_memory(scene);
  const luz::RenderDevice device = use_cuda ? luz::RenderDevice::Cuda : luz::RenderDevice::Cpu;
  const luz::RenderFields fields = luz::render_fields(scene, device);
  if (ckpt) {
    const std::string differs = luz::fields_mismatch(ckpt->fields, fields);
    if (!differs.empty()) throw luz::InputError(resume, 0, "cannot resume: " + differs);
  }

  // Every rank has loaded and checked the scene: bad input on any fails the
  // job here, before any rendering.
  if (job) {
    const std::string failed = job->agree("", o.threads);
    if (!failed.empty()) return root ? report(failed, kExitBadInput) : kExitBadInput;
    if (!root) {
      install_signal_handlers();
      return job->work(&scene, o.threads, &g_cancel);
    }
    if (o.broadcast) {
      std::string bytes = luz::serialize_scene(scene);
      job->broadcast(bytes);
    }
  } else if (o.broadcast) {
    scene.warnings.push_back("luz: warning: --broadcast: not started by an MPI launcher (mpirun); nothing to send");
  }
  for (const std::string& w : scene.warnings) std::fprintf(stderr, "%s\n", w.c_str());
  if (o.device == "auto" && !use_cuda)
    std::fprintf(stderr, "luz: warning: --device auto: no usable GPU (%s); rendering on the CPU\n", no_gpu.c_str());
  if (!o.quiet)
    std::fprintf(stderr, "luz: %s: %d×%d, %u spp, %u triangle%s%s, %zu sphere%s, %zu light%s, loaded in %.2f s, on %s%s\n",
                 o.scene.c_str(), scene.camera.width, scene.camera.height, s.spp, scene.num_triangles(),
                 scene.num_triangles() == 1 ? "" : "s",
                 scene.instances.empty()
                     ? ""
                     : (" + " + std::to_string(scene.num_instanced_triangles()) + " placed by " +
                        std::to_string(scene.instances.size()) + " instances")
                           .c_str(),
                 scene.spheres.size(), scene.spheres.size() == 1 ? "" : "s", scene.lights.size(),
                 scene.lights.size() == 1 ? "" : "s", load_seconds,
                 use_cuda ? luz::cuda_device_name().c_str()
                 : job    ? (std::to_string(job->size()) + " MPI rank" + (job->size() == 1 ? "" : "s") + " (" +
                          std::to_string(o.threads) + " threads on rank 0)")
                             .c_str()
                          : "the CPU",
                 ckpt ? (", resuming at sample " + std::to_string(ckpt->next_sample)).c_str() : "");
  if (!scene.lights_emit)
    std::fprintf(stderr, "luz: warning: %s: the scene has no light that emits, so the image will be black\n",
                 o.scene.c_str());

  luz::RenderRequest req;
  req.device = device;
  req.threads = o.threads;
  req.time_limit = o.time_limit;
  req.cancel = &g_cancel;
  luz::RenderStats before;  // of the runs before this one
  if (ckpt) {
    req.first_sample = ckpt->next_sample;
    req.start = &ckpt->film;
    before = ckpt->stats;
  }
  const std::vector<std::string> args = o.to_args();
  auto checkpoint_of = [&](const luz::RenderStats& st) {
    luz::Checkpoint c;
    c.fields = fields;
    c.args = args;
    c.next_sample = req.first_sample + st.spp;
    c.stats = before;
    c.stats.seconds += st.seconds;
    c.stats.samples += st.samples;
    c.stats.rays += st.rays;
    c.stats.discarded += st.discarded;
    c.stats.passes += st.passes;
    c.stats.spp += st.spp;
    return c;
  };
  auto last_checkpoint = std::chrono::steady_clock::now();
  if (explicit_checkpoint)
    req.pass_done = [&](const luz::Film& film, const luz::RenderStats& st) {
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - last_checkpoint).count() < o.checkpoint_every) return;
      luz::Checkpoint c = checkpoint_of(st);
      c.film = film;
      try {
        luz::write_checkpoint(o.checkpoint, c);
      } catch (const luz::InputError& e) {  // the render goes on; the last good checkpoint stays
        std::fprintf(stderr, "\n%s: warning: %s\n", e.file().c_str(), e.problem().c_str());
      }
      last_checkpoint = std::chrono::steady_clock::now();
    };
  install_signal_handlers();
  luz::RenderResult result;
  {
    const uint64_t total = uint64_t(scene.camera.width) * scene.camera.height * (s.spp - req.first_sample);
    using Mode = luz::ProgressBar::Mode;
    luz::ProgressBar bar(o.quiet ? Mode::Off : ::isatty(2) ? Mode::Bar : Mode::Lines, total, s.spp);
    bar.set_spp_done(req.first_sample);
    req.progress = [&](const luz::RenderProgress& p) { bar.set(p.samples_done, req.first_sample + p.spp_done); };
    result = job ? job->render(scene, req) : luz::render(scene, req);
  }
  const int sig = g_signal.load();
  const luz::RenderStats& stats = result.stats;
  luz::Checkpoint done = checkpoint_of(stats);
  const uint32_t spp_done = done.next_sample;
  // Where it stopped: the spp every pixel has, and the share of all samples
  // when blocks stopped at different samples (an MPI render's units).
  std::string reached = std::to_string(spp_done) + " of " + std::to_string(s.spp) + " spp";
  if (!result.film.next.empty()) {
    double held = 0;
    for (uint32_t n : result.film.next) held += n;
    char share[64];
    std::snprintf(share, sizeof share, " (%.1f%% of the samples)", 100.0 * held / (double(s.spp) * double(result.film.next.size())));
    reached += share;
  }
  if (!result.complete && sig)
    std::fprintf(stderr, "luz: %s ended the render at %s\n", sig == SIGINT ? "SIGINT" : "SIGTERM", reached.c_str());
  else if (!result.complete)
    std::fprintf(stderr, "luz: the time limit of %g s ended the render at %s\n", o.time_limit, reached.c_str());

  const luz::Film& film = result.film;
  luz::Image img{film.width, film.height, film.mean()};
  const luz::ImageMetadata meta = {
      {"luz:version", std::string(luz::version()) + " (" + luz::commit() + ")"},
      {"luz:scene", fs::absolute(o.scene).lexically_normal().string()},
      {"luz:spp", std::to_string(spp_done)},
      {"luz:sppRequested", std::to_string(s.spp)},
      {"luz:seed", std::to_string(s.seed)},
      {"luz:integrator", luz::integrator_name(s.integrator.type)},
      {"luz:maxDepth", std::to_string(s.integrator.max_depth)},
      {"luz:sampler", luz::sampler_name(s.sampler)},
      {"luz:lightSampler", luz::light_sampler_name(s.light_sampler)},
      {"luz:renderSeconds", seconds_text(done.stats.seconds)},
      {"luz:discardedSamples", std::to_string(done.stats.discarded)},
  };
  // Auxiliary layers, into the OpenEXR outputs.
  std::vector<luz::ImageLayer> layers;
  if (!o.aovs.empty()) {
    const luz::AovImages aov = luz::render_aovs(scene, kAovSamples, kAovBsdfSamples, o.threads);
    for (const std::string& name : o.aovs) {
      if (name == "albedo") layers.push_back({"albedo", {"R", "G", "B"}, aov.albedo});
      else if (name == "normal") layers.push_back({"normal", {"X", "Y", "Z"}, aov.normal});
      else if (name == "depth") layers.push_back({"depth", {"Z"}, aov.depth});
      else if (name == "variance") {
        const std::vector<double> v = film.variance_of_mean();
        layers.push_back({"variance", {"R", "G", "B"}, std::vector<float>(v.begin(), v.end())});
      }
    }
  }
  // Every output is tried: one that fails does not keep the others unwritten.
  std::string written;
  int status = 0;
  for (const std::string& out : o.outs) {
    try {
      const bool exr = luz::lower_extension(out) == ".exr";
      luz::write_image(out, img, scene.settings.exr_format, meta, exr ? layers : std::vector<luz::ImageLayer>{});
      written += (written.empty() ? "" : ", ") + out;
    } catch (const luz::InputError& e) {
      std::fprintf(stderr, "%s: error: %s\n", e.file().c_str(), e.problem().c_str());
      status = 1;
    }
  }
  // A render not finished, or whose images did not all reach the disk, leaves
  // a checkpoint to finish it from; a finished one removes its own.
  std::string kept;
  if (!result.complete || status != 0) {
    if (explicit_checkpoint || sig || status != 0) {
      done.film = std::move(result.film);
      try {
        luz::write_checkpoint(o.checkpoint, done);
        kept = o.checkpoint;
      } catch (const luz::InputError& e) {
        std::fprintf(stderr, "%s: error: %s\n", e.file().c_str(), e.problem().c_str());
        status = 1;
      }
    }
  } else if (explicit_checkpoint || ckpt) {
    std::error_code ec;
    fs::remove(o.checkpoint, ec);
  }
  if (!o.quiet || status != 0)
    std::fprintf(stderr, "luz: %.3f s, %.3f Msamples/s, %.2f Mrays/s, %llu non-finite samples discarded, wrote %s%s\n",
                 stats.seconds, stats.samples / stats.seconds * 1e-6, stats.rays / stats.seconds * 1e-6,
                 (unsigned long long)stats.discarded, written.empty() ? "no image" : written.c_str(),
                 kept.empty() ? "" : ("; to continue: luz render --resume " + kept).c_str());
  if (status != 0) return status;
  return sig ? 128 + sig : 0;  // a signal even after the last pass: the caller asked to stop
}

int run(int argc, char** argv, luz::MpiJob* job) {
  CLI::App app{"Luz: a physically based path tracer"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("luz ") + luz::version() + " (" + luz::commit() + ")");
  CLI::App* rc = app.add_subcommand("render", "render a scene (Mitsuba 3 XML, pbrt-v4, glTF 2.0, OBJ or PLY) to an image");
  RenderOptions o;
  std::string resume;
  std::vector<std::string> scenes;
  std::string frames_spec;
  rc->add_option("scene", scenes,
                 "scene file (.xml, .pbrt, .gltf, .glb, .obj or .ply); several: a frame each; not with --resume");
  rc->add_option("--frames", frames_spec,
                 "a frame per value of a scene <default>: NAME=V1,V2,... or NAME=A..B; '#' in -o names numbers them");
  rc->add_option("-o,--output", o.outs, "output image: .exr (float), .pfm, or .png (sRGB); may repeat")
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
  rc->add_option("--spp", o.spp, "samples per pixel (overrides the scene)")
      ->check(integer_in(1, 1 << 24, "a sample count from 1 to 16777216"));
  rc->add_option("--threads", o.threads, "worker threads (default: all cores)")
      ->check(integer_in(0, 4096, "a thread count from 0 (all cores) to 4096"));
  rc->add_option("--seed", o.seed, "random seed")
      ->check(integer_in(0, std::numeric_limits<long long>::max(), "a seed from 0 to 9223372036854775807"));
  rc->add_option("--max-depth", o.max_depth, "longest path, Mitsuba's max_depth (-1: unbounded)")
      ->check(integer_in(1, luz::kMaxDepthLimit,
                         "-1 (unbounded) or a depth from 1 to " + std::to_string(luz::kMaxDepthLimit), true));
  rc->add_option("--sampler", o.sampler, "sample generator (default: the scene's, else sobol)")->check(CLI::IsMember({"independent", "stratified", "sobol"}));
  rc->add_option("--integrator", o.integrator, "estimator")->check(CLI::IsMember({"path", "bsdf", "light"}));
  rc->add_option("--light-sampler", o.light_sampler,
                 "light selection: bvh (default: a light BVH, by power, distance and orientation) or power (by power alone)")
      ->check(CLI::IsMember({"power", "bvh"}));
  rc->add_option("--reconstruction", o.reconstruction,
                 "how samples make pixels: splat (default, as Mitsuba: each sample weighed into every pixel its filter "
                 "reaches; less noise) or filter (as pbrt-v4: filter importance sampling, each sample in one pixel, "
                 "pixels' noise independent); the same for the box filter")
      ->check(CLI::IsMember({"splat", "filter"}));
  rc->add_option("--env-guide", o.env_guide,
                 "a constant environment's light samples aimed where the sky is seen from each region (default on; "
                 "traced before the render), or off: over each point's hemisphere")
      ->check(CLI::IsMember({"on", "off"}));
  rc->add_option("--device", o.device, "where to render: cpu (default), cuda (an NVIDIA GPU), auto (cuda if usable)")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  rc->add_option("--res", o.res, "render at WIDTHxHEIGHT instead of the scene's size (the field of view kept along the scene's axis)");
  // Decimal numbers in (lo, hi], or [lo, hi] with lo_in.
  auto number_in = [](double lo, bool lo_in, double hi, std::string what, std::string name) {
    return CLI::Validator(
        [=](std::string& t) -> std::string {
          double v = 0;
          auto r = std::from_chars(t.data(), t.data() + t.size(), v);
          if (r.ec == std::errc() && r.ptr == t.data() + t.size() && (v > lo || (lo_in && v == lo)) && v <= hi)
            return std::string();
          return "'" + t + "' is not " + what;
        },
        name);
  };
  rc->add_option("--scale", o.scale, "render at F times the scene's width and height")
      ->check(number_in(0, false, 65536, "a scale above 0 and at most 65536", "F"));
  rc->add_option("--time-limit", o.time_limit,
                 "stop after about this many seconds of rendering, with the whole passes done (default: none)")
      ->check(number_in(0, false, 1e9, "a number of seconds above 0 and at most 1e9", "SECONDS"));
  rc->add_option("-D", o.defines, "override a scene <default>: name=value")->allow_extra_args(false);
  rc->add_option("-a", o.search, "a folder where files a Mitsuba scene names are also looked for (as Mitsuba's -a)")
      ->allow_extra_args(false);
  rc->add_option("--checkpoint", o.checkpoint,
                 "write the render's state to this file as it goes, to continue it with --resume after a stop or a crash");
  rc->add_option("--checkpoint-every", o.checkpoint_every, "seconds between checkpoints (default 300; 0: after every pass)")
      ->check(number_in(0, true, 1e9, "a number of seconds from 0 to 1e9", "SECONDS"));
  rc->add_option("--resume", resume,
                 "continue the render a checkpoint holds (its scene and settings; -o, --threads, --time-limit may change)");
  rc->add_option("--aov", o.aovs,
                 "auxiliary layers in the OpenEXR outputs, comma-separated: albedo and normal (of the first hit, as "
                 "Open Image Denoise expects), depth (along the view axis), variance (of each pixel's mean)")
      ->delimiter(',')
      ->check(CLI::IsMember({"albedo", "normal", "depth", "variance"}));
  rc->add_option("--camera", o.camera, "the camera to render, by name (glTF files name theirs; default: the first)");
  rc->add_option("--mpi-timeout", o.mpi_timeout,
                 "under mpirun: seconds a rank may hold a work unit, or take to build its scene, before it is taken "
                 "as lost and its units go to the others, or take to load the scene before the job ends (default 600)")
      ->check(number_in(0, false, 1e9, "a number of seconds above 0 and at most 1e9", "SECONDS"));
  rc->add_flag("--broadcast", o.broadcast,
              "under mpirun: rank 0 loads the scene and sends it to the other ranks (for files only its machine has)");
  rc->add_flag("-q,--quiet", o.quiet, "no progress bar and no stats lines (warnings and errors still print)");
  CLI::App* ic = app.add_subcommand("info", "what a scene holds, without rendering: shapes, lights, materials, camera, warnings");
  std::string info_scene;
  std::vector<std::string> info_defines;
  ic->add_option("scene", info_scene, "scene file (.xml, .pbrt, .gltf, .glb, .obj or .ply)")->required();
  ic->add_option("-D", info_defines, "override a scene <default>: name=value")->allow_extra_args(false);
  std::string info_camera;
  ic->add_option("--camera", info_camera, "the camera to describe, by name (glTF)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help (and the like) print to stdout and succeed; a real parse error is
    // one line on stderr (CLI11's own printer adds a second "Run with --help").
    if (e.get_exit_code() == 0) return app.exit(e);
    const char* help = ic->parsed() ? "luz info --help" : rc->parsed() ? "luz render --help" : "luz --help";
    return report("luz: error: " + luz::InputError::one_line(e.what()) + " (see " + help + ")", kExitBadInput);
  }
  // Every error is one line: "file:line: error: problem" when it concerns a
  // file, "luz: error: problem" otherwise.
  try {
    if (ic->parsed()) {
      check_scene_file(info_scene);
      const auto start = std::chrono::steady_clock::now();
      const luz::Scene s = luz::load_scene(info_scene, parse_defines(info_defines), {}, info_camera);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::printf("scene: %s (loaded in %.3f s)\n%s", info_scene.c_str(), seconds, luz::describe_scene(s).c_str());
      return 0;
    }
    std::set<std::string> given;
    for (const char* flag : {"scene", "-o", "--spp", "--seed", "--max-depth", "--sampler", "--integrator",
                             "--light-sampler", "--reconstruction", "--env-guide", "--device", "--res", "--scale", "-D", "-a", "--checkpoint",
                             "--checkpoint-every", "--aov", "--camera"})
      if (rc->get_option(flag)->count() > 0) given.insert(flag);
    if (!resume.empty() && given.count("scene"))
      throw luz::InputError("--resume " + resume + ": the checkpoint names its scene; give no scene file with it");
    if (!resume.empty() && !frames_spec.empty())
      throw luz::InputError("--resume " + resume + ": a checkpoint continues one frame; give no --frames with it");
    // Frame by frame; under MPI every rank renders each frame's units, and
    // rank 0's status after a frame decides for all whether the next starts.
    const std::vector<RenderOptions> frames = resume.empty() ? frame_list(o, scenes, frames_spec)
                                                             : std::vector<RenderOptions>{o};
    if (frames.size() > 1 && (!job || job->rank() == 0))  // every frame's outputs before the first render
      for (const RenderOptions& f : frames)
        for (const std::string& out : f.outs) check_output(out);
    for (size_t k = 0;; ++k) {
      const int status = render(frames[k], resume, given, job);
      if (status != 0 || k + 1 == frames.size() || (job && job->lost_ranks())) return status;
      if (job) job->end_frame(status);
    }
  } catch (const luz::InputError& e) {
    if (e.file().empty()) return report("luz: error: " + e.problem(), kExitBadInput);
    if (e.line() > 0)
      return report(e.file() + ":" + std::to_string(e.line()) + ": error: " + e.problem(), kExitBadInput);
    return report(e.file() + ": error: " + e.problem(), kExitBadInput);
  } catch (const luz::CudaError& e) {
    // No usable GPU is the user's setup (2); a GPU that fails mid-render, 1.
    return report(std::string("luz: error: CUDA: ") + e.what(),
                  e.kind() == luz::CudaError::Kind::Unavailable ? kExitBadInput : 1);
  } catch (const std::bad_alloc&) {
    return report("luz: error: out of memory", 1);
  } catch (const std::exception& e) {
    return report("luz: error: " + luz::InputError::one_line(e.what()), 1);
  }
}

}  // namespace

// Under an MPI launcher every rank runs the same command; render() splits
// the work (render/mpi.h) and finish() ends every rank with rank 0's status.
int main(int argc, char** argv) {
  std::optional<luz::MpiJob> job;
  if (luz::mpi_launched()) {
    try {
      job.emplace(argc, argv);
    } catch (const std::exception& e) {
      if (luz::mpi_launched_rank() == 0) std::fprintf(stderr, "luz: error: %s\n", e.what());
      return kExitBadInput;
    }
  }
  const int status = run(argc, argv, job ? &*job : nullptr);
  if (!job) return status;
  if (g_signal.load() != 0) {
    // A signal (the launcher ending the job after a rank died, or Ctrl-C):
    // the outputs and checkpoint are written; waiting on the other ranks, a
    // dead one among them, would only stall until the launcher's SIGKILL.
    std::fflush(stdout);
    std::fflush(stderr);
    ::_exit(status != 0 ? status : 128 + g_signal.load());
  }
  int job_status = job->finish(status, g_error_line);
  if (job->timed_out()) {
    // A rank never finished loading: it would hold MPI_Finalize too.
    std::fflush(stdout);
    std::fflush(stderr);
    ::_exit(job_status);
  }
  if (job->lost_ranks()) {
    // MPI_Finalize would wait for the lost rank: rank 0 ends without it,
    // its outputs written, and the launcher ends the others.
    std::fprintf(stderr, "luz: error: a rank was lost (its units were rendered by the others); "
                         "ending the job without it\n");
    std::fflush(stdout);
    std::fflush(stderr);
    ::_exit(job_status != 0 ? job_status : 1);
  }
  // The job is over: a launcher that stops the ranks still finalising,
  // because one already exited non-zero, must not make rank 0 speak again.
  ::signal(SIGINT, SIG_IGN);
  ::signal(SIGTERM, SIG_IGN);
  return job_status;
}
