// Host side of the CUDA renderer: device checks, uploads, the pass loop and
// the film. The kernel itself is in kernels.cu; the seam is launch.h.
//
// Memory: every SceneView array and the BVH (nodes, references; the
// objects' trees and the instances of a two-level one) is copied
// once into its own cudaMalloc'd buffer; a device SceneView and BvhTracer hold
// those pointers and travel to the kernel by value, as its parameter. Two
// output slots (device + pinned host, 28 bytes per pixel each) let the GPU
// render pass p+1 while the host adds pass p into the double Film.
//
// Every CUDA call is checked; a failure becomes a one-line CudaError naming
// what was being done and CUDA's own name and text for the error. Buffers,
// stream and events are RAII, so nothing leaks when one is thrown.
#include "luz/device/cuda/render_cuda.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <utility>
#include <vector>

#include "luz/accel/bvh_build.h"
#include "luz/device/cuda/launch.h"
#include "luz/device/progress.h"
#include "luz/io/error.h"
#include "luz/light/env_guide_build.h"

#ifndef LUZ_CUDA_ARCHITECTURES
#define LUZ_CUDA_ARCHITECTURES "?"
#endif

namespace luz {

CudaError::CudaError(Kind kind, const std::string& message)
    : std::runtime_error(InputError::one_line(message)), kind_(kind) {}

namespace {

// Splatting's squares of one pass on the device, at most (a pass takes
// fewer samples where more would not fit).
constexpr size_t kSplatBufferBytes = size_t(256) << 20;

std::string describe(cudaError_t e) { return std::string(cudaGetErrorName(e)) + ": " + cudaGetErrorString(e); }

std::string version_string(int v) { return std::to_string(v / 1000) + "." + std::to_string(v % 1000 / 10); }

std::string mib(size_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f MiB", double(bytes) / (1024.0 * 1024.0));
  return buf;
}

CudaError::Kind kind_of(cudaError_t e) {
  switch (e) {
    case cudaErrorMemoryAllocation:
      return CudaError::Kind::OutOfMemory;
    case cudaErrorNoDevice:
    case cudaErrorInsufficientDriver:
    case cudaErrorNoKernelImageForDevice:
    case cudaErrorInvalidDeviceFunction:
    case cudaErrorInvalidDevice:
    case cudaErrorDevicesUnavailable:
      return CudaError::Kind::Unavailable;
    default:
      return CudaError::Kind::Failure;
  }
}

// Throws on failure: "<what>: cudaErrorX: text".
void check(cudaError_t e, const std::string& what) {
  if (e == cudaSuccess) return;
  (void)cudaGetLastError();  // clear the error where it is not sticky
  if (e == cudaErrorMemoryAllocation) {
    size_t free_b = 0, total_b = 0;
    std::string extra;
    if (cudaMemGetInfo(&free_b, &total_b) == cudaSuccess)
      extra = " (" + mib(free_b) + " free of " + mib(total_b) + ")";
    else
      (void)cudaGetLastError();
    throw CudaError(CudaError::Kind::OutOfMemory, "out of GPU memory: " + what + extra);
  }
  throw CudaError(kind_of(e), what + ": " + describe(e));
}

// Whether device `device` can run our kernels; the reason when not.
bool probe(int device, std::string& why, cudaDeviceProp* props) {
  int driver = 0, runtime = 0;
  cudaError_t e = cudaDriverGetVersion(&driver);
  if (e != cudaSuccess || driver == 0) {
    (void)cudaGetLastError();
    why = "no NVIDIA driver found (libcuda.so is not installed)";
    return false;
  }
  if (cudaRuntimeGetVersion(&runtime) != cudaSuccess) runtime = CUDART_VERSION;
  if (driver / 1000 < runtime / 1000) {
    why = "the NVIDIA driver is too old: it supports CUDA " + version_string(driver) + ", this build needs CUDA " +
          version_string(runtime) + " (update the driver)";
    return false;
  }
  int count = 0;
  e = cudaGetDeviceCount(&count);
  if (e == cudaErrorNoDevice || (e == cudaSuccess && count == 0)) {
    (void)cudaGetLastError();
    why = "no CUDA-capable GPU found";
    return false;
  }
  if (e == cudaErrorInsufficientDriver) {
    (void)cudaGetLastError();
    why = "the NVIDIA driver is too old: it supports CUDA " + version_string(driver) + ", this build needs CUDA " +
          version_string(runtime) + " (update the driver)";
    return false;
  }
  if (e != cudaSuccess) {
    (void)cudaGetLastError();
    why = "cannot query CUDA devices: " + describe(e);
    return false;
  }
  if (device < 0 || device >= count) {
    why = "no CUDA device " + std::to_string(device) + " (" + std::to_string(count) + " found)";
    return false;
  }
  cudaDeviceProp p{};
  if ((e = cudaGetDeviceProperties(&p, device)) != cudaSuccess || (e = cudaSetDevice(device)) != cudaSuccess) {
    (void)cudaGetLastError();
    why = "cannot use CUDA device " + std::to_string(device) + ": " + describe(e);
    return false;
  }
  // Loads the module, creating the context: fails when this build holds no
  // code the GPU can run.
  cudaFuncAttributes attr{};
  e = cuda::render_pass_attributes(&attr);
  if (e != cudaSuccess) {
    (void)cudaGetLastError();
    std::string arch = std::to_string(p.major) + std::to_string(p.minor);
    if (e == cudaErrorNoKernelImageForDevice || e == cudaErrorInvalidDeviceFunction ||
        e == cudaErrorUnsupportedPtxVersion)
      why = std::string(p.name) + " is sm_" + arch + ", but this build's kernels are for CUDA architectures " +
            LUZ_CUDA_ARCHITECTURES + " (rebuild with -DCMAKE_CUDA_ARCHITECTURES=" + arch + ")";
    else
      why = "cannot load the CUDA kernels on " + std::string(p.name) + ": " + describe(e);
    return false;
  }
  if (props) *props = p;
  return true;
}

// A cudaMalloc'd array, freed on scope exit.
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(size_t bytes, const std::string& what) : bytes_(bytes) {
    if (bytes) check(cudaMalloc(&ptr_, bytes), "cudaMalloc of " + mib(bytes) + " for " + what);
  }
  DeviceBuffer(DeviceBuffer&& o) noexcept : ptr_(std::exchange(o.ptr_, nullptr)), bytes_(o.bytes_) {}
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    std::swap(ptr_, o.ptr_);
    std::swap(bytes_, o.bytes_);
    return *this;
  }
  ~DeviceBuffer() {
    if (ptr_) cudaFree(ptr_);
  }
  void* get() const { return ptr_; }
  size_t bytes() const { return bytes_; }

 private:
  void* ptr_ = nullptr;
  size_t bytes_ = 0;
};

// Page-locked host memory (asynchronous copies need it), freed on scope exit.
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  PinnedBuffer(size_t bytes, const std::string& what) {
    if (bytes) check(cudaMallocHost(&ptr_, bytes), "cudaMallocHost of " + mib(bytes) + " for " + what);
  }
  PinnedBuffer(PinnedBuffer&& o) noexcept : ptr_(std::exchange(o.ptr_, nullptr)) {}
  PinnedBuffer& operator=(PinnedBuffer&& o) noexcept {
    std::swap(ptr_, o.ptr_);
    return *this;
  }
  ~PinnedBuffer() {
    if (ptr_) cudaFreeHost(ptr_);
  }
  void* get() const { return ptr_; }

 private:
  void* ptr_ = nullptr;
};

class Stream {
 public:
  Stream() { check(cudaStreamCreateWithFlags(&s_, cudaStreamNonBlocking), "cudaStreamCreate"); }
  ~Stream() {
    // Let enqueued work finish before buffers it uses are freed (on an
    // exception mid-render); errors are already being reported.
    cudaStreamSynchronize(s_);
    cudaStreamDestroy(s_);
  }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return s_; }

 private:
  cudaStream_t s_ = nullptr;
};

class Event {
 public:
  explicit Event(unsigned flags = cudaEventDisableTiming) {
    check(cudaEventCreateWithFlags(&e_, flags), "cudaEventCreate");
  }
  ~Event() { cudaEventDestroy(e_); }
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  cudaEvent_t get() const { return e_; }

 private:
  cudaEvent_t e_ = nullptr;
};

// The uploads: one buffer per array, kept alive for the render.
class Uploader {
 public:
  template <class T>
  const T* upload(const T* host, size_t n, const char* what) {
    if (n == 0 || host == nullptr) return nullptr;
    buffers_.emplace_back(n * sizeof(T), what);
    check(cudaMemcpy(buffers_.back().get(), host, n * sizeof(T), cudaMemcpyHostToDevice),
          std::string("cudaMemcpy of ") + what + " to the GPU");
    return static_cast<const T*>(buffers_.back().get());
  }
  template <class T>
  const T* upload(const std::vector<T>& v, const char* what) {
    return upload(v.data(), v.size(), what);
  }

 private:
  std::vector<DeviceBuffer> buffers_;
};

// Luz's BVH on the GPU, over geometry and instances already uploaded.
BvhTracer upload_tracer(Uploader& up, const Bvh& bvh, const Vec3* positions, const uint32_t* indices,
                        const Sphere* spheres, const OpacityView& opacity, const InstancesView& instances) {
  BvhTracer tracer;
  if (!bvh.objects.empty()) {
    tracer.instancing.nodes = up.upload(bvh.object_nodes.data(), bvh.object_nodes.size(), "the objects' BVH nodes");
    tracer.instancing.prims = up.upload(bvh.object_prims.data(), bvh.object_prims.size(), "the objects' BVH references");
    tracer.instancing.objects = up.upload(bvh.objects, "the objects' BVHs");
    tracer.instancing.instances = instances.list;
    tracer.instancing.count = instances.count;
  }
  tracer.bvh.nodes = up.upload(bvh.nodes.data(), bvh.nodes.size(), "BVH nodes");
  tracer.bvh.num_nodes = uint32_t(bvh.nodes.size());
  tracer.bvh.prims = up.upload(bvh.prims.data(), bvh.prims.size(), "BVH primitive references");
  tracer.bvh.num_prims = uint32_t(bvh.prims.size());
  tracer.geometry.positions = positions;
  tracer.geometry.indices = indices;
  tracer.geometry.spheres = spheres;
  tracer.geometry.opacity = opacity;
  return tracer;
}

// One output slot: the pass's float sums, squares and counts, on both sides.
struct Slot {
  DeviceBuffer device;
  PinnedBuffer host;
  PassOutput dev_out, host_out;
  uint32_t first_sample = 0, num_samples = 0;
  bool pending = false;
};

PassOutput carve(void* base, size_t pixels) {
  PassOutput o;
  o.sum = static_cast<float*>(base);
  o.sum_sq = o.sum + 3 * pixels;
  o.count = reinterpret_cast<uint32_t*>(o.sum_sq + 3 * pixels);
  return o;
}

}  // namespace

bool cuda_available(std::string* why) {
  std::string reason;
  bool ok = probe(0, reason, nullptr);
  if (!ok && why) *why = reason;
  return ok;
}

std::string cuda_device_name() {
  std::string why;
  cudaDeviceProp p{};
  if (!probe(0, why, &p)) return "";
  char buf[sizeof p.name + 64];
  std::snprintf(buf, sizeof buf, "%s (sm_%d%d, %.1f GiB)", p.name, p.major, p.minor,
                double(p.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0));
  return buf;
}

Film render_cuda(const Scene& scene, const CudaRenderOptions& options, RenderStats& stats) {
  std::string why;
  if (!probe(options.device, why, nullptr)) throw CudaError(CudaError::Kind::Unavailable, why);

  const SceneView host = scene.view();
  const Camera& cam = host.camera;
  const RenderSettings& rs = scene.settings;
  const SamplerDesc desc = make_sampler_desc(rs.sampler, rs.spp, rs.seed);
  const size_t pixels = size_t(cam.width) * size_t(cam.height);
  const uint32_t first_sample = options.first_sample, end_sample = options.end_sample ? options.end_sample : desc.spp;
  const uint32_t range = end_sample > first_sample ? end_sample - first_sample : 0;
  Film film = options.start ? *options.start : Film(cam.width, cam.height);

  // The BVH, built on the host (binned SAH, TBB), then everything uploaded.
  const Bvh bvh = build_bvh(host);
  // The environment's guide, traced on the host through the same BVH.
  EnvGuideData guide;
  if (wants_env_guide(host, rs.env_guide))
    guide = build_env_guide(host, make_bvh_tracer(bvh, host), env_guide_options(uint64_t(pixels) * desc.spp));
  Uploader up;
  SceneView dev = host;  // counts, camera, bounds, environment index as they are
  dev.positions = up.upload(scene.positions, "vertex positions");
  dev.normals = up.upload(scene.normals, "vertex normals");  // null when empty: flat shading
  dev.indices = up.upload(scene.indices, "triangle indices");
  dev.tri_material = up.upload(scene.tri_material, "triangle materials");
  dev.tri_emitter = up.upload(scene.tri_emitter, "triangle emitters");
  dev.uvs = up.upload(scene.uvs, "texture coordinates");  // null when empty: no textures
  dev.colors = up.upload(scene.colors, "vertex colours");  // null when empty: none
  dev.tri_normals = nullptr;  // the GPU computes each hit's normal (not measured there with a table yet)
  dev.spheres = up.upload(scene.spheres, "spheres");
  dev.instances.list = up.upload(scene.instances, "instances");
  dev.instances.objects = up.upload(scene.objects, "objects");
  dev.materials.list = up.upload(scene.materials, "materials");
  dev.materials.bindings = up.upload(scene.texture_bindings, "texture bindings");
  dev.textures.list = up.upload(scene.textures, "textures");
  dev.textures.texels8 = up.upload(scene.texels8, "8-bit texels");
  dev.textures.texelsf = up.upload(scene.texelsf, "float texels");
  dev.textures.srgb_table = up.upload(scene.srgb_table, "the sRGB decoding table");
  dev.lights.list = up.upload(scene.lights, "lights");
  dev.lights.sampler.power.table.entries = up.upload(scene.light_alias, "the light alias table");
  dev.lights.sampler.power.table.pmfs = up.upload(scene.light_pmf, "the light PMF");
  dev.lights.sampler.bvh.nodes = up.upload(scene.light_bvh.nodes, "the light BVH");
  dev.lights.sampler.bvh.trails = up.upload(scene.light_bvh.trails, "the light BVH's bit trails");
  dev.lights.sampler.bvh.infinite = up.upload(scene.light_bvh.infinite, "the infinite lights");
  dev.lights.sampler.bvh.infinite_weight = up.upload(scene.light_bvh.infinite_weight, "the infinite lights' weights");
  dev.lights.data.floats = up.upload(scene.light_data, "environment maps");
  dev.lights.data.textures = dev.textures;
  if (guide.view.regions) {
    EnvGuide on_device = guide.view;  // its grid; its arrays on the device
    on_device.regions = up.upload(guide.regions, "the environment guide's regions");
    on_device.cdf = up.upload(guide.cdf, "the environment guide's distributions");
    dev.lights.data.guide = up.upload(&on_device, 1, "the environment guide");
  }
  const BvhTracer tracer = upload_tracer(up, bvh, dev.positions, dev.indices, dev.spheres, dev.opacity(), dev.instances);

  // Splatting (pass.h): the squares of the image and its border take the
  // samples, their radiance kept on the device for the pass's gather.
  const bool splat = splats(rs.reconstruction, rs.filter);
  if (splat && options.wavefront)
    throw std::invalid_argument("render_cuda: the wavefront variant has filter sampling only (Reconstruction::FilterSampling)");
  const int reach = splat ? filter_reach(rs.filter) : 0;
  const size_t squares = (size_t(cam.width) + 2 * size_t(reach)) * (size_t(cam.height) + 2 * size_t(reach));
  uint32_t per_pass = options.samples_per_pass
                          ? std::max(1u, std::min(std::min(options.samples_per_pass, kMaxSamplesPerPass), range))
                          : default_samples_per_pass(pixels, range);
  if (splat)  // the squares' buffer within kSplatBufferBytes where a sample a pass allows
    per_pass = uint32_t(std::clamp<size_t>(kSplatBufferBytes / (squares * sizeof(Color)), 1, per_pass));
  // Threads per pixel, or per square when splatting.
  const uint32_t threads = options.wavefront ? 1u  // the wavefront sums a pixel's samples in one thread
                           : options.threads_per_pixel ? std::min(options.threads_per_pixel, per_pass)
                                                       : default_threads_per_pixel(splat ? squares : pixels, per_pass);
  const uint32_t out_slices = splat ? 1u : threads;  // the gather sums a pixel's samples in one thread
  const size_t slices = pixels * out_slices;  // output entries: one slice of `pixels` per thread share
  const size_t slot_bytes = slices * (6 * sizeof(float) + sizeof(uint32_t));
  Slot slots[2];
  for (Slot& s : slots) {
    s.device = DeviceBuffer(slot_bytes, "the film's pass buffers");
    s.host = PinnedBuffer(slot_bytes, "the film's pass buffers");
    s.dev_out = carve(s.device.get(), slices);
    s.host_out = carve(s.host.get(), slices);
  }
  DeviceBuffer squares_buf(splat ? squares * per_pass * sizeof(Color) : 0, "the splatted squares' samples");
  DeviceBuffer rays_buf(sizeof(unsigned long long), "the ray counter");
  auto* rays = static_cast<unsigned long long*>(rays_buf.get());
  check(cudaMemset(rays, 0, sizeof(unsigned long long)), "cudaMemset of the ray counter");
  // Pageable uploads may still be in flight when cudaMemcpy returns, and the
  // memset is asynchronous: all of it completes before the first pass.
  check(cudaDeviceSynchronize(), "uploading the scene to the GPU");
  // The wavefront's path state, for a whole pass (pixels × samples per pass).
  const size_t max_paths = options.wavefront ? pixels * per_pass : 0;
  DeviceBuffer wf_state(max_paths * sizeof(PathState), "the wavefront's path states"),
      wf_sampler(max_paths * sizeof(Sampler), "the wavefront's samplers"),
      wf_hit(max_paths * sizeof(Hit), "the wavefront's hits"), wf_found(max_paths, "the wavefront's hit flags"),
      wf_shadow(max_paths * sizeof(ShadowQuery), "the wavefront's shadow rays"),
      wf_alive(options.wavefront ? sizeof(unsigned long long) : 0, "the wavefront's live-path counter");
  PinnedBuffer wf_alive_host(options.wavefront ? sizeof(unsigned long long) : 0, "the wavefront's live-path counter");
  Stream stream;
  Event done[2];

  PassParams params;
  params.scene = dev;
  params.tracer = tracer;
  params.sampler = desc;
  params.integrator = rs.integrator;
  params.filter = rs.filter;
  params.threads_per_pixel = threads;
  params.reach = reach;
  params.squares = static_cast<Color*>(squares_buf.get());

  std::atomic<uint64_t> discarded{0};
  uint32_t spp_done = 0, passes_done = 0;
  // Waits for a slot's pass and adds it into the film (all cores).
  auto reduce = [&](Slot& s, int index) {
    if (!s.pending) return;
    check(cudaEventSynchronize(done[index].get()), "rendering samples " + std::to_string(s.first_sample) + ".." +
                                                       std::to_string(s.first_sample + s.num_samples - 1));
    const PassOutput& o = s.host_out;
    const uint32_t n = s.num_samples;
    uint64_t bad = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, pixels, 4096), uint64_t(0),
        [&](const tbb::blocked_range<size_t>& r, uint64_t acc) {
          return acc + accumulate_pass(film, o.sum, o.sum_sq, o.count, n, r.begin(), r.end(), out_slices);
        },
        [](uint64_t a, uint64_t b) { return a + b; });
    discarded += bad;
    s.pending = false;
    spp_done += n;
    ++passes_done;
    if (options.pass_done) {
      RenderStats so_far;
      so_far.samples = uint64_t(pixels) * spp_done;
      so_far.spp = spp_done;
      so_far.passes = passes_done;
      so_far.discarded = discarded;
      options.pass_done(film, so_far);
    }
  };

  auto start = std::chrono::steady_clock::now();
  {
    ProgressBar progress(options.progress, uint64_t(pixels) * range);
    int p = 0;
    for (uint32_t first = first_sample; first < end_sample; first += per_pass, ++p) {
      if (options.stop && options.stop()) break;
      const int k = p & 1;
      Slot& s = slots[k];
      reduce(s, k);  // normally done already, one pass ago
      s.first_sample = first;
      s.num_samples = std::min(per_pass, end_sample - first);
      params.first_sample = s.first_sample;
      params.num_samples = s.num_samples;
      params.out = s.dev_out;
      if (options.wavefront) {
        WavefrontParams wp;
        wp.pass = params;
        wp.num_paths = uint32_t(pixels * s.num_samples);
        wp.state = static_cast<PathState*>(wf_state.get());
        wp.sampler = static_cast<Sampler*>(wf_sampler.get());
        wp.hit = static_cast<Hit*>(wf_hit.get());
        wp.found = static_cast<uint8_t*>(wf_found.get());
        wp.shadow = static_cast<ShadowQuery*>(wf_shadow.get());
        check(cuda::launch_wavefront_pass(wp, rays, static_cast<unsigned long long*>(wf_alive.get()),
                                          static_cast<unsigned long long*>(wf_alive_host.get()), stream.get()),
              "running the wavefront pass (" + std::to_string(cam.width) + "x" + std::to_string(cam.height) + ")");
      } else if (splat) {
        check(cuda::launch_splat_pass(params, rays, stream.get()),
              "launching the splatting kernels (" + std::to_string(cam.width) + "x" + std::to_string(cam.height) + ")");
      } else {
        check(cuda::launch_render_pass(params, rays, stream.get()),
              "launching the render kernel (" + std::to_string(cam.width) + "x" + std::to_string(cam.height) + ")");
      }
      check(cudaMemcpyAsync(s.host.get(), s.device.get(), slot_bytes, cudaMemcpyDeviceToHost, stream.get()),
            "cudaMemcpyAsync of a pass to the host");
      check(cudaEventRecord(done[k].get(), stream.get()), "cudaEventRecord");
      s.pending = true;
      // While the GPU renders this pass, the previous one joins the film.
      Slot& prev = slots[k ^ 1];
      if (prev.pending) {
        uint64_t n = uint64_t(pixels) * prev.num_samples;
        reduce(prev, k ^ 1);
        progress.advance(n);
      }
    }
    for (int k = 0; k < 2; ++k)
      if (slots[k].pending) {
        uint64_t n = uint64_t(pixels) * slots[k].num_samples;
        reduce(slots[k], k);
        progress.advance(n);
      }
  }
  unsigned long long total_rays = 0;
  check(cudaMemcpy(&total_rays, rays, sizeof total_rays, cudaMemcpyDeviceToHost), "cudaMemcpy of the ray counter");
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stats.samples = uint64_t(pixels) * spp_done;
  stats.rays = total_rays;
  stats.discarded = discarded.load();
  stats.passes = passes_done;
  stats.spp = spp_done;
  return film;
}

void sample_bsdf_cuda(const Bsdf& bsdf, Vec3 wo, uint64_t seed, uint32_t n, std::vector<Vec3>& wi,
                      std::vector<uint8_t>& ok) {
  std::string why;
  if (!probe(0, why, nullptr)) throw CudaError(CudaError::Kind::Unavailable, why);
  Uploader up;
  BsdfBatchParams p;
  p.bsdf = up.upload(&bsdf, 1, "the BSDF");
  p.wo = wo;
  p.seed = seed;
  p.n = n;
  DeviceBuffer wi_buf(size_t(n) * sizeof(Vec3), "sampled directions"), ok_buf(n, "sample flags");
  p.wi = static_cast<Vec3*>(wi_buf.get());
  p.ok = static_cast<uint8_t*>(ok_buf.get());
  check(cuda::launch_bsdf_samples(p, nullptr), "launching the BSDF sampling kernel");
  check(cudaDeviceSynchronize(), "sampling the BSDF on the GPU");
  wi.resize(n);
  ok.resize(n);
  check(cudaMemcpy(wi.data(), p.wi, size_t(n) * sizeof(Vec3), cudaMemcpyDeviceToHost), "cudaMemcpy of directions");
  check(cudaMemcpy(ok.data(), p.ok, n, cudaMemcpyDeviceToHost), "cudaMemcpy of sample flags");
}

double trace_rays_cuda(const Scene& scene, const std::vector<Ray>& rays, const std::vector<uint8_t>& shadow,
                       int repeat, uint64_t* hits) {
  std::string why;
  if (!probe(0, why, nullptr)) throw CudaError(CudaError::Kind::Unavailable, why);
  if (shadow.size() != rays.size()) throw CudaError(CudaError::Kind::Failure, "trace_rays_cuda: shadow flags != rays");
  const Bvh bvh = build_bvh(scene.view());
  Uploader up;
  RayBatchParams p;
  InstancesView instances = scene.view().instances;
  instances.list = up.upload(scene.instances, "instances");
  instances.objects = up.upload(scene.objects, "objects");
  p.tracer = upload_tracer(up, bvh, up.upload(scene.positions, "vertex positions"),
                           up.upload(scene.indices, "triangle indices"), up.upload(scene.spheres, "spheres"),
                           OpacityView{}, instances);  // no materials here: masks are not tested
  p.rays = up.upload(rays, "rays");
  p.shadow = up.upload(shadow, "ray kinds");
  p.n = uint32_t(rays.size());
  DeviceBuffer hit_buf(rays.size(), "ray results");
  p.hit = static_cast<uint8_t*>(hit_buf.get());
  check(cudaDeviceSynchronize(), "uploading rays to the GPU");
  Event start(cudaEventDefault), stop(cudaEventDefault);
  // Each timed round launches the batch often enough to trace ≥ 2^23 rays, so
  // that small batches are not timed at the resolution of one launch.
  const uint32_t launches = uint32_t(std::max<size_t>(1, (size_t(1) << 23) / std::max<size_t>(rays.size(), 1)));
  double best = 1e30;
  for (int k = 0; k < std::max(repeat, 1); ++k) {
    check(cudaEventRecord(start.get(), nullptr), "cudaEventRecord");
    for (uint32_t l = 0; l < launches; ++l)
      check(cuda::launch_trace_rays(p, nullptr), "launching the ray tracing kernel");
    check(cudaEventRecord(stop.get(), nullptr), "cudaEventRecord");
    check(cudaEventSynchronize(stop.get()), "tracing rays on the GPU");
    float ms = 0.f;
    check(cudaEventElapsedTime(&ms, start.get(), stop.get()), "cudaEventElapsedTime");
    best = std::min(best, double(ms) * 1e-3 / launches);
  }
  if (hits) {
    std::vector<uint8_t> h(rays.size());
    check(cudaMemcpy(h.data(), p.hit, h.size(), cudaMemcpyDeviceToHost), "cudaMemcpy of ray results");
    *hits = uint64_t(std::count(h.begin(), h.end(), uint8_t(1)));
  }
  return best;
}

}  // namespace luz
