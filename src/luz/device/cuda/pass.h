// One pass of the CUDA renderer, written once for the device and the host:
// render_pixel_pass() is the body of the megakernel (kernels.cu) and also runs
// on the host, over host pointers, in tests/test_cuda.cpp, so the pass logic,
// the random-number order and the host reduction are tested on machines
// without a GPU.
//
// A pass renders samples [first_sample, first_sample + num_samples) of every
// pixel and OVERWRITES (does not accumulate) its output: per pixel, float sums
// and sums of squares of the finite samples (RGB) and their count. The host
// adds each pass into the double Film (accumulate_pass), so float only ever
// holds num_samples (≤ kMaxSamplesPerPass) samples: with one sample per pass
// the Film's sums are exactly the CPU's (for equal samples), its sums of
// squares within one float rounding of each square.
//
// Threads per pixel. One thread per pixel leaves a large GPU mostly idle on
// small frames (a 256² image is 65k threads; an H100 holds 270k), so a pass
// may split each pixel's samples among T threads: thread t takes the
// contiguous share [n·t/T, n·(t+1)/T) of the pass's n samples and writes its
// own sums to slice t of the output (T slices of `pixels` entries each);
// accumulate_pass adds the T slices in order. The samples are the same for
// any T, only the float grouping of their sums differs, and T is a function
// of the image size and the pass length (default_threads_per_pixel), so a
// render's film stays deterministic.
//
// Splatting (film/splat.h; PassParams::reach > 0): two kernels per pass.
// render_square_pass renders the pass's samples of every square of the image
// and of a border `reach` wide around it (T threads per square, as for
// pixels) into PassParams::squares, each square's samples in index order;
// gather_pixel_pass then forms each pixel's samples S_p,k from its
// neighbours' and sums them as render_pixel_pass does, one thread per pixel
// (one output slice). The samples are the CPU's (device/cpu splats the same
// squares at the same offsets and gathers in the same order).
//
// Two variants of each (kFull): the full one, and one for scenes without
// instances, masked materials or normal/bump maps (pass_is_plain) that
// leaves their code out of the traversal and the path loop. A kernel holds
// the registers of its most demanding point, taken or not, so code a scene
// never runs still costs it registers, spills and resident threads
// (bench/RESULTS.md, 2026-12-04).
#pragma once

#include <cstddef>

#include "luz/accel/bvh.h"
#include "luz/film/film.h"
#include "luz/film/filter.h"
#include "luz/film/splat.h"
#include "luz/integrator/path.h"

namespace luz {

inline constexpr uint32_t kMaxSamplesPerPass = 64;

struct PassOutput {
  float* sum = nullptr;     // 3 per pixel, RGB, rows top to bottom
  float* sum_sq = nullptr;  // 3 per pixel
  uint32_t* count = nullptr;  // finite samples per pixel
};

struct PassParams {
  SceneView scene;    // device pointers on the device
  BvhTracer tracer;   // likewise
  SamplerDesc sampler;
  IntegratorParams integrator;
  FilterKind filter = FilterKind::Box;
  uint32_t first_sample = 0, num_samples = 1;
  uint32_t threads_per_pixel = 1;  // T: the output holds T slices of `pixels` entries
  PassOutput out;
  // Splatting: the filter's reach in pixels (0: filter sampling), and the
  // squares' radiance, num_samples per square, squares in rows over the
  // image and its border ((width + 2 reach) × (height + 2 reach)).
  int reach = 0;
  Color* squares = nullptr;
};

// One thread's float sums of its finite samples, and their count, written
// to entry i of a pass output.
struct PassSums {
  float s0 = 0.f, s1 = 0.f, s2 = 0.f, q0 = 0.f, q1 = 0.f, q2 = 0.f;
  uint32_t n = 0;
  LUZ_INLINE void add(const Color& L) {
    if (!is_finite(L)) return;
    s0 += L.x;
    s1 += L.y;
    s2 += L.z;
    q0 += L.x * L.x;
    q1 += L.y * L.y;
    q2 += L.z * L.z;
    ++n;
  }
  LUZ_INLINE void write(const PassOutput& out, size_t i) const {
    out.sum[3 * i] = s0;
    out.sum[3 * i + 1] = s1;
    out.sum[3 * i + 2] = s2;
    out.sum_sq[3 * i] = q0;
    out.sum_sq[3 * i + 1] = q1;
    out.sum_sq[3 * i + 2] = q2;
    out.count[i] = n;
  }
};

// The scene has no instance, masked material or normal/bump map: the
// passes' kFull = false variants render it (the same samples).
LUZ_INLINE bool pass_is_plain(const PassParams& p) { return p.tracer.plain() && !p.scene.materials.mapped; }

// One path through the pass's tracer, in the variant kFull chooses (kFull
// is also path_li's kMaps).
template <bool kFull>
LUZ_FORCE_INLINE Color pass_path(const PassParams& p, const Ray& ray, Sampler& sampler, uint64_t& rays) {
  return path_li<BvhQueries<kFull>, NoPathProbe, kFull>(p.scene, BvhQueries<kFull>{p.tracer}, ray, sampler,
                                                        p.integrator, rays);
}

// Thread t's share of pixel (x, y)'s pass, exactly render_cpu's per-pixel
// loop: Sampler started at the pixel, set_sample per sample, camera_sample,
// then path_li. Returns the rays traced. kFull: see the top of the file.
template <bool kFull = true>
LUZ_FORCE_INLINE uint64_t render_pixel_pass(const PassParams& p, uint32_t x, uint32_t y, uint32_t t = 0) {
  const Camera& cam = p.scene.camera;
  const uint32_t T = p.threads_per_pixel;
  const uint32_t k0 = uint32_t(uint64_t(p.num_samples) * t / T), k1 = uint32_t(uint64_t(p.num_samples) * (t + 1) / T);
  Sampler sampler;
  sampler.start(p.sampler, x, y, p.first_sample + k0);
  PassSums sums;
  uint64_t rays = 0;
  for (uint32_t k = k0; k < k1; ++k) {
    sampler.set_sample(p.first_sample + k);
    const Ray ray = camera_sample(cam, x, y, sampler, p.filter);
    sums.add(pass_path<kFull>(p, ray, sampler, rays));
  }
  sums.write(p.out, size_t(t) * size_t(cam.width) * size_t(cam.height) + size_t(y) * size_t(cam.width) + x);
  return rays;
}

// Splatting, first kernel: thread t's share of square (sx, sy) of the
// bordered image (image pixel (sx - reach, sy - reach)), as the CPU's
// take_splat renders it. Returns the rays traced.
template <bool kFull = true>
LUZ_FORCE_INLINE uint64_t render_square_pass(const PassParams& p, uint32_t sx, uint32_t sy, uint32_t t = 0) {
  const Camera& cam = p.scene.camera;
  const int x = int(sx) - p.reach, y = int(sy) - p.reach;
  const size_t cw = size_t(cam.width) + 2 * size_t(p.reach);
  const uint32_t T = p.threads_per_pixel;
  const uint32_t k0 = uint32_t(uint64_t(p.num_samples) * t / T), k1 = uint32_t(uint64_t(p.num_samples) * (t + 1) / T);
  Color* out = p.squares + (size_t(sy) * cw + sx) * p.num_samples;
  Sampler sampler;
  sampler.start(p.sampler, uint32_t(x), uint32_t(y), p.first_sample + k0);  // squares outside: wrapped, distinct
  uint64_t rays = 0;
  for (uint32_t k = k0; k < k1; ++k) {
    sampler.set_sample(p.first_sample + k);
    const Ray ray = camera_sample_at(cam, x, y, sampler, splat_offset(p.sampler, p.first_sample + k));
    out[k] = pass_path<kFull>(p, ray, sampler, rays);
  }
  return rays;
}

// Splatting, second kernel: pixel (x, y)'s samples of the pass, each from
// the squares in reach, summed into output slice 0.
LUZ_INLINE void gather_pixel_pass(const PassParams& p, uint32_t x, uint32_t y) {
  const Camera& cam = p.scene.camera;
  const int r = p.reach;
  const size_t cw = size_t(cam.width) + 2 * size_t(r);
  const size_t n = p.num_samples;
  const Color* centre = p.squares + ((size_t(y) + r) * cw + (size_t(x) + r)) * n;
  PassSums sums;
  for (uint32_t k = 0; k < p.num_samples; ++k) {
    const SplatWeights w = splat_weights(p.filter, r, splat_offset(p.sampler, p.first_sample + k));
    sums.add(splat_gather(r, w, [&](int ox, int oy) { return centre[(ptrdiff_t(oy) * ptrdiff_t(cw) + ox) * ptrdiff_t(n) + k]; }));
  }
  sums.write(p.out, size_t(y) * size_t(cam.width) + x);
}

// Host: adds pixels [begin, end) of one pass (num_samples each, split over
// `slices` threads per pixel) into the Film, slice by slice in order.
// Returns the samples discarded there as non-finite.
inline uint64_t accumulate_pass(Film& film, const float* sum, const float* sum_sq, const uint32_t* count,
                                uint32_t num_samples, size_t begin, size_t end, uint32_t slices = 1) {
  const size_t pixels = film.count.size();
  uint64_t discarded = 0;
  for (size_t i = begin; i < end; ++i) {
    uint32_t n = 0;
    for (uint32_t t = 0; t < slices; ++t) {
      const size_t j = t * pixels + i;
      for (int k = 0; k < 3; ++k) {
        film.sum[3 * i + k] += double(sum[3 * j + k]);
        film.sum_sq[3 * i + k] += double(sum_sq[3 * j + k]);
      }
      n += count[j];
    }
    film.count[i] += n;
    discarded += num_samples - n;
  }
  return discarded;
}

// Samples per pass when the caller leaves it to us: enough pixel-samples per
// launch (~2^21) to fill a large GPU and amortise each pass's copy and
// reduction, never more than kMaxSamplesPerPass (float sums), nor than spp.
// A function of the image size alone, so a render's film is deterministic.
inline uint32_t default_samples_per_pass(uint64_t pixels, uint32_t spp) {
  uint64_t k = pixels ? ((uint64_t(1) << 21) + pixels - 1) / pixels : 1;
  if (k > kMaxSamplesPerPass) k = kMaxSamplesPerPass;
  if (k > spp) k = spp;
  return k < 1 ? 1 : uint32_t(k);
}

// Threads per pixel when the caller leaves it to us: enough threads per
// launch (~2^19, twice what an H100 keeps resident) to fill a large GPU, never
// more than the pass's samples. A function of the image size and pass length
// alone, so a render's film is deterministic.
inline uint32_t default_threads_per_pixel(uint64_t pixels, uint32_t num_samples) {
  uint64_t t = pixels ? ((uint64_t(1) << 19) + pixels - 1) / pixels : 1;
  if (t > num_samples) t = num_samples;
  return t < 1 ? 1 : uint32_t(t);
}

}  // namespace luz
