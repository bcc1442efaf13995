// luz_bench: path tracer throughput on a scene, and raw Embree throughput on
// rays of the same kind (recorded from the path tracer itself: camera,
// bounce and shadow rays in the proportions the integrator produces them),
// measured side by side in one run.
//
//   luz_bench SCENE [-D name=value]... [--spp N] [--threads N] [--repeat K] [--label L]
// Also Luz's own BVH on the same rays (host traversal), and its build speed
// and size. Prints one human-readable block and, last, one markdown table row.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "luz/accel/bvh_build.h"
#include "luz/accel/embree_tracer.h"
#include "luz/device/cpu/render.h"
#include "luz/device/cuda/render_cuda.h"
#include "luz/io/error.h"
#include "luz/io/load.h"

namespace {

struct RecordedRay {
  luz::Ray ray;
  bool shadow;
  bool camera = false;  // the first ray of its path
};

// A Tracer that answers through Embree and keeps a copy of every query.
struct RecordingTracer {
  luz::EmbreeTracer inner;
  std::vector<RecordedRay>* out;
  bool intersect(const luz::Ray& r, luz::Hit& h) const {
    out->push_back({r, false});
    return inner.intersect(r, h);
  }
  bool occluded(const luz::Ray& r) const {
    out->push_back({r, true});
    return inner.occluded(r);
  }
};

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

}  // namespace

int main(int argc, char** argv) {
  std::string scene_path, label;
  luz::Defines defines;
  int threads = 0, repeat = 3, spp = 0;
  std::string device = "cpu";
  int gpu_tpp = 0;  // CudaRenderOptions::threads_per_pixel (0: the default)
  bool gpu_wavefront = false;  // CudaRenderOptions::wavefront
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "-D" && i + 1 < argc) {
      std::string d = argv[++i];
      size_t eq = d.find('=');
      defines[d.substr(0, eq)] = eq == std::string::npos ? "" : d.substr(eq + 1);
    } else if (a == "--threads" && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (a == "--spp" && i + 1 < argc) {
      spp = std::atoi(argv[++i]);
    } else if (a == "--repeat" && i + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--device" && i + 1 < argc) {
      device = argv[++i];
      if (device != "cpu" && device != "cuda") {
        std::fprintf(stderr, "luz_bench: --device must be cpu or cuda, not '%s'\n", device.c_str());
        return 2;
      }
    } else if (a == "--gpu-wavefront") {
      gpu_wavefront = true;
    } else if (a == "--gpu-threads-per-pixel" && i + 1 < argc) {
      gpu_tpp = std::atoi(argv[++i]);
    } else if (a == "--label" && i + 1 < argc) {
      label = argv[++i];
    } else if (scene_path.empty()) {
      scene_path = a;
    } else {
      std::fprintf(stderr, "luz_bench: unexpected argument '%s'\n", a.c_str());
      return 2;
    }
  }
  if (scene_path.empty()) {
    std::fprintf(stderr, "usage: luz_bench SCENE [-D name=value]... [--threads N] [--repeat K] [--label L] [--device cpu|cuda] [--gpu-threads-per-pixel T] [--gpu-wavefront]\n");
    return 2;
  }
  std::string why;
  if (device == "cuda" && !luz::cuda_available(&why)) {
    std::fprintf(stderr, "luz_bench: error: --device cuda: %s\n", why.c_str());
    return 2;
  }
  try {
    luz::Scene scene = luz::load_scene(scene_path, defines);
    if (spp > 0) scene.settings.spp = uint32_t(spp);
    if (label.empty()) label = scene_path;
    const luz::Camera& cam = scene.camera;

    // 1. Record the rays of up to 4 samples per pixel (camera, bounce and
    //    shadow rays as the integrator makes them), to trace them alone.
    luz::EmbreeScene embree(scene);
    luz::SceneView view = scene.view();
    luz::SamplerDesc desc = luz::make_sampler_desc(scene.settings.sampler, scene.settings.spp, scene.settings.seed);
    std::vector<RecordedRay> rays;
    RecordingTracer rec{embree.tracer(), &rays};
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x)
        for (uint32_t s = 0; s < std::min<uint32_t>(desc.spp, 4); ++s) {
          luz::Sampler sampler;
          sampler.start(desc, uint32_t(x), uint32_t(y), s);
          const luz::Ray r = luz::camera_sample(cam, uint32_t(x), uint32_t(y), sampler, scene.settings.filter);
          uint64_t n = 0;
          const size_t first = rays.size();
          luz::path_li(view, rec, r, sampler, scene.settings.integrator, n);
          if (rays.size() > first) rays[first].camera = true;
        }
    size_t shadow = size_t(std::count_if(rays.begin(), rays.end(), [](const RecordedRay& r) { return r.shadow; }));
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    // Seconds to trace every recorded ray `passes` times with `tracer`.
    auto trace_passes = [&](const auto& tracer, int passes) {
      std::vector<unsigned char> sink(rays.size());
      double t0 = now();
      for (int p = 0; p < passes; ++p)
        arena.execute([&] {
          tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t i = r.begin(); i != r.end(); ++i) {
              luz::Hit h;
              sink[i] = rays[i].shadow ? tracer.occluded(rays[i].ray) : tracer.intersect(rays[i].ray, h);
            }
          });
        });
      return now() - t0;
    };
    // Best time over `repeat` passes.
    auto time_rays = [&](const auto& tracer) {
      double best_t = 1e30;
      for (int k = 0; k < repeat; ++k) best_t = std::min(best_t, trace_passes(tracer, 1));
      return best_t;
    };

    // 2. The path tracer against raw Embree, in `repeat` paired rounds: each
    //    round renders the whole frame, then traces the recorded rays with
    //    Embree alone for about as long. This VM-friendly pairing keeps both
    //    in the same stretch of machine speed and gives both runs the same
    //    length (a best-of over short bursts flatters the shorter one). The
    //    ratio is the median over rounds; the rates are the best round's.
    const double one_pass = time_rays(embree.tracer());
    luz::CpuRenderOptions opt;
    opt.threads = threads;
    double best = 1e30, raw_rps = 0.0;
    luz::RenderStats stats;
    std::vector<double> ratios;
    for (int k = 0; k < repeat; ++k) {
      luz::RenderStats s;
      luz::render_cpu(scene, opt, s);
      if (s.seconds < best) best = s.seconds, stats = s;
      const int passes = std::clamp(int(s.seconds / one_pass + 0.5), 1, 10000);
      const double raw_k = double(rays.size()) * passes / trace_passes(embree.tracer(), passes);
      raw_rps = std::max(raw_rps, raw_k);
      ratios.push_back(double(s.rays) / s.seconds / raw_k);
    }
    std::sort(ratios.begin(), ratios.end());
    const size_t nr = ratios.size();
    const double ratio = nr % 2 ? ratios[nr / 2] : 0.5 * (ratios[nr / 2 - 1] + ratios[nr / 2]);
    double sps = stats.samples / stats.seconds, rps = stats.rays / stats.seconds;

    // 3. Luz's own BVH: build speed (1 thread, and all), size, and host
    //    traversal of the same recorded rays.
    //    A fresh build maps new memory, whose first touch the kernel pays
    //    for (zeroing, mapping); a rebuild into the same Bvh and
    //    BvhScratch reuses theirs: the builder's own speed.
    double build1 = 1e30, build_all = 1e30, rebuild1 = 1e30;
    luz::Bvh bvh, again;
    luz::BvhScratch scratch;
    for (int k = 0; k < repeat; ++k) {
      luz::BvhBuildOptions o;
      o.threads = 1;
      double t0 = now();
      bvh = luz::build_bvh(view, o);
      build1 = std::min(build1, now() - t0);
      t0 = now();
      luz::build_bvh(view, o, again, scratch);
      if (k > 0) rebuild1 = std::min(rebuild1, now() - t0);  // the first: fresh memory too
      o.threads = 0;
      t0 = now();
      arena.execute([&] { bvh = luz::build_bvh(view, o); });
      build_all = std::min(build_all, now() - t0);
    }
    const unsigned nthreads = unsigned(threads > 0 ? threads : tbb::this_task_arena::max_concurrency());
    luz::BvhTracer bvh_tracer = luz::make_bvh_tracer(bvh, view);
    double bvh_best = time_rays(bvh_tracer);
    double bvh_rps = rays.size() / bvh_best;
    double prims = double(scene.num_triangles() + scene.spheres.size());

    std::printf("scene        %s (%d×%d, %u spp, max_depth %d, %u threads)\n", label.c_str(), cam.width, cam.height,
                scene.settings.spp, scene.settings.integrator.max_depth,
                unsigned(threads > 0 ? threads : tbb::this_task_arena::max_concurrency()));
    std::printf("path tracer  %.3f s  %.3f Msamples/s  %.2f Mrays/s  (%.2f rays/sample)\n", stats.seconds, sps * 1e-6,
                rps * 1e-6, double(stats.rays) / stats.samples);
    std::printf("raw embree   %.2f Mrays/s on %zu recorded rays (%.0f%% shadow)\n", raw_rps * 1e-6, rays.size(),
                100.0 * shadow / rays.size());
    std::printf("ratio        path tracer rays/s = %.2f × raw Embree rays/s (median of %d paired rounds: %.2f–%.2f)\n",
                ratio, repeat, ratios.front(), ratios.back());
    std::printf("luz bvh      %.2f Mrays/s host traversal of the same rays (%.2f × Embree)\n", bvh_rps * 1e-6,
                bvh_rps / raw_rps);
    if (repeat < 2) rebuild1 = build1;
    std::printf("bvh build    %.0f primitives: %.1f ms on 1 thread (%.2f Mprims/s; rebuilding into reused memory "
                "%.1f ms, %.2f Mprims/s), %.1f ms on %u (%.2f Mprims/s per thread); %zu nodes, %.1f bytes/primitive, "
                "SAH cost %.2f\n",
                prims, build1 * 1e3, prims / build1 * 1e-6, rebuild1 * 1e3, prims / rebuild1 * 1e-6, build_all * 1e3,
                nthreads,
                prims / build_all / nthreads * 1e-6, bvh.nodes.size(), double(bvh.bytes()) / std::max(prims, 1.0),
                luz::bvh_sah_cost(bvh));
    std::printf("| %s | %d×%d | %u | %.3f | %.2f | %.2f | %.2f | %.2f | %.2f / %.2f | %.1f |\n", label.c_str(),
                cam.width, cam.height, scene.settings.spp, sps * 1e-6, rps * 1e-6, raw_rps * 1e-6, ratio,
                bvh_rps * 1e-6, prims / build1 * 1e-6, prims / rebuild1 * 1e-6,
                double(bvh.bytes()) / std::max(prims, 1.0));

    // 4. With --device cuda: the same render on the GPU (best of `repeat`),
    //    and Luz's BVH on the GPU tracing the recorded rays. One "G|" row:
    //    GPU and CPU figures of this run side by side.
    if (device == "cuda") {
      // The wavefront has filter sampling only (the megakernel splats as the CPU).
      if (gpu_wavefront) scene.settings.reconstruction = luz::Reconstruction::FilterSampling;
      luz::RenderStats gstats;
      double gbest = 1e30;
      for (int k = 0; k < repeat; ++k) {
        luz::RenderStats s;
        luz::CudaRenderOptions gopt;
        gopt.threads_per_pixel = uint32_t(std::max(gpu_tpp, 0));
        gopt.wavefront = gpu_wavefront;
        luz::render_cuda(scene, gopt, s);
        if (s.seconds < gbest) gbest = s.seconds, gstats = s;
      }
      std::vector<luz::Ray> ray_list(rays.size());
      std::vector<uint8_t> kinds(rays.size());
      for (size_t i = 0; i < rays.size(); ++i) ray_list[i] = rays[i].ray, kinds[i] = rays[i].shadow ? 1 : 0;
      uint64_t ghits = 0;
      double gtrace = luz::trace_rays_cuda(scene, ray_list, kinds, std::max(repeat, 5), &ghits);
      // The incoherent part alone: closest-hit rays after a BSDF sample (no
      // camera rays, no shadow rays).
      std::vector<luz::Ray> bounce;
      for (const RecordedRay& r : rays)
        if (!r.camera && !r.shadow) bounce.push_back(r.ray);
      double gbounce = bounce.empty() ? 0.0
                                      : luz::trace_rays_cuda(scene, bounce, std::vector<uint8_t>(bounce.size(), 0),
                                                             std::max(repeat, 5), nullptr);
      double gbounce_rps = gbounce > 0.0 ? bounce.size() / gbounce : 0.0;
      double gsps = gstats.samples / gstats.seconds, grps = gstats.rays / gstats.seconds;
      double gtrace_rps = rays.size() / gtrace;
      const std::string gpu = luz::cuda_device_name();
      std::printf("gpu          %s\n", gpu.c_str());
      std::printf("gpu path     %.3f s  %.3f Msamples/s  %.2f Mrays/s  (%.1f × the CPU's samples/s)\n", gstats.seconds,
                  gsps * 1e-6, grps * 1e-6, gsps / sps);
      std::printf("gpu bvh      %.1f Mrays/s tracing the %zu recorded rays (%.0f%% shadow)\n", gtrace_rps * 1e-6,
                  rays.size(), 100.0 * shadow / rays.size());
      std::printf("gpu bounce   %.1f Mrays/s tracing the %zu bounce rays alone (no camera or shadow rays)\n",
                  gbounce_rps * 1e-6, bounce.size());
      std::printf("G| %s | %d×%d | %u | %.2f | %.1f | %.3f | %.1f | %.1f | %.1f | %.2f / %.2f | %.1f |\n",
                  label.c_str(), cam.width, cam.height, scene.settings.spp, gsps * 1e-6, grps * 1e-6, sps * 1e-6,
                  gsps / sps, gtrace_rps * 1e-6, gbounce_rps * 1e-6, prims / build1 * 1e-6, prims / rebuild1 * 1e-6,
                  double(bvh.bytes()) / std::max(prims, 1.0));
    }
    return 0;
  } catch (const luz::CudaError& e) {
    std::fprintf(stderr, "luz_bench: error: %s\n", e.what());
    return 2;
  } catch (const luz::InputError& e) {
    std::fprintf(stderr, "luz_bench: error: %s\n", e.what());
    return 2;
  }
}
