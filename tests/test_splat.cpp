// Splatting (film/splat.h), against what it must equal:
//  * its weights are the filter's density: each integrates to 1 over a
//    pixel's reach, and at the points of a unit lattice the tent's sum to 1
//    (so a region of constant radiance is exact) and the gaussian's to
//    within 3%;
//  * a constant-radiance image comes out exact (tent) or within the
//    gaussian's lattice ripple, every pixel, the border ones included;
//  * it converges to the image filter sampling converges to: block means of
//    many independent images of each, compared by the spread across images
//    (which holds although splatted pixels share samples), for the tent and
//    the gaussian, the image's border blocks included; a 3% bias fails it.
// Bit-identity with its plain definition, for any thread count and pass
// schedule: test_render.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/film/splat.h"
#include "luz/io/load.h"
#include "scene_helpers.h"
#include "stat_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

const char* kCornell = LUZ_SOURCE_DIR "/scenes/cornell-box.xml";

TEST(Splat, WeightsAreTheFilterDensity) {
  for (FilterKind k : {FilterKind::Tent, FilterKind::Gaussian}) {
    const int r = filter_reach(k);
    // ∫ w over [-r - 0.5, r + 0.5] by the midpoint rule (w is piecewise smooth).
    double integral = 0;
    const int n = 200000;
    const double a = -r - 0.5, h = (2.0 * r + 1) / n;
    for (int i = 0; i < n; ++i) integral += filter_weight_1d(k, float(a + (i + 0.5) * h)) * h;
    EXPECT_NEAR(integral, 1.0, 1e-4) << int(k);
    // The lattice sums behind S_p,k's weights, over offsets u in [0, 1).
    double lo = 1e9, hi = -1e9;
    for (int i = 0; i < 1000; ++i) {
      const Vec2 u{(i + 0.5f) / 1000.f, 0.5f};
      const SplatWeights w = splat_weights(k, r, u);
      double sum = 0;
      for (int j = 0; j <= 2 * r; ++j) sum += w.wx[j];
      lo = std::min(lo, sum), hi = std::max(hi, sum);
    }
    if (k == FilterKind::Tent) {
      EXPECT_NEAR(lo, 1.0, 1e-6);
      EXPECT_NEAR(hi, 1.0, 1e-6);
    } else {
      EXPECT_GT(lo, 0.97);
      EXPECT_LT(hi, 1.03);
    }
  }
}

class SplatScene : public TempDirTest {};

// A camera that sees only a constant environment (max_depth 1; the one
// shape a scene needs is behind it): every
// radiance sample is the same, so a weighted mean of them is too.
TEST_F(SplatScene, ConstantRadianceComesOutExact) {
  for (const char* filter : {"tent", "gaussian"}) {
    const std::string xml = std::string(R"(<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="1"/></integrator>
  <sensor type="perspective"><float name="fov" value="60"/>
    <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/>
      <rfilter type=")") + filter + R"("/></film></sensor>
  <emitter type="constant"><rgb name="radiance" value="0.5, 1, 2"/></emitter>
  <shape type="sphere"><point name="center" x="0" y="0" z="-100"/><float name="radius" value="0.01"/></shape>
</scene>)";
    Scene s = load_scene(write("c.xml", xml));
    ASSERT_EQ(s.settings.reconstruction, Reconstruction::Splat);
    const Film f = luz_test::render_finite(s);
    const std::vector<double> m = luz_test::pixel_means(f);
    const double tol = std::string(filter) == "tent" ? 1e-5 : 0.03;
    for (size_t i = 0; i < f.count.size(); ++i) {
      ASSERT_EQ(f.count[i], 8u);
      EXPECT_NEAR(m[3 * i + 0], 0.5, 0.5 * tol) << filter << " pixel " << i;
      EXPECT_NEAR(m[3 * i + 1], 1.0, 1.0 * tol) << filter << " pixel " << i;
      EXPECT_NEAR(m[3 * i + 2], 2.0, 2.0 * tol) << filter << " pixel " << i;
    }
  }
}

// Block means over `images` independent renders (seeds from `seed0`), and
// the variance of each mean from their spread.
struct Replicates {
  std::vector<double> mean, var;
};

Replicates replicate(Scene s, Reconstruction rec, int images, uint64_t seed0, int block) {
  s.settings.reconstruction = rec;
  const int bw = s.camera.width / block, bh = s.camera.height / block;
  std::vector<double> sum(size_t(bw) * bh * 3, 0.0), sum_sq(sum.size(), 0.0);
  for (int i = 0; i < images; ++i) {
    s.settings.seed = seed0 + uint64_t(i);
    CpuRenderOptions opt;
    opt.threads = 2;
    RenderStats stats;
    const Film f = render_cpu(s, opt, stats);
    EXPECT_EQ(stats.discarded, 0u);
    const std::vector<double> m = luz_test::pixel_means(f);
    std::vector<double> b(sum.size(), 0.0);
    for (int y = 0; y < bh * block; ++y)
      for (int x = 0; x < bw * block; ++x)
        for (int c = 0; c < 3; ++c)
          b[(size_t(y / block) * bw + x / block) * 3 + c] += m[(size_t(y) * f.width + x) * 3 + c] / (block * block);
    for (size_t k = 0; k < b.size(); ++k) sum[k] += b[k], sum_sq[k] += b[k] * b[k];
  }
  Replicates r;
  r.mean.resize(sum.size());
  r.var.resize(sum.size());
  for (size_t k = 0; k < sum.size(); ++k) {
    r.mean[k] = sum[k] / images;
    r.var[k] = std::max(0.0, (sum_sq[k] - images * r.mean[k] * r.mean[k]) / (images - 1)) / images;
  }
  return r;
}

// The worst |t| of splatting's block means (times `scale`) against filter
// sampling's, over blocks and channels.
double worst_t(const Replicates& a, const Replicates& b, double scale) {
  double worst = 0;
  for (size_t k = 0; k < a.mean.size(); ++k) {
    const double m = 0.5 * (a.mean[k] + b.mean[k]), floor = luz_test::rounding_floor(m);
    const double t = std::fabs(scale * a.mean[k] - b.mean[k]) /
                     std::sqrt(scale * scale * a.var[k] + b.var[k] + 2 * floor * floor);
    worst = std::max(worst, t);
  }
  return worst;
}

// 64 images of 32×32 at 16 spp each way (independent sampler), blocks of 4×4
// (the border blocks hold the pixels whose reach leaves the image). The
// statistic is Welch's t with about 126 degrees of freedom: its Šidák
// threshold is the normal one raised by the first Cornish–Fisher term,
// z + (z³ + z) / (4ν).
TEST(Splat, ConvergesToTheFilterSamplingImage) {
  for (FilterKind k : {FilterKind::Tent, FilterKind::Gaussian}) {
    Scene s = load_scene(kCornell, {{"res", "32"}, {"spp", "16"}});
    s.settings.sampler = SamplerType::Independent;
    s.settings.filter = k;
    const int images = 64, block = 4;
    const Replicates sp = replicate(s, Reconstruction::Splat, images, 1000, block);
    const Replicates fs = replicate(s, Reconstruction::FilterSampling, images, 5000, block);
    const double z = luz_test::sidak_z(1e-3, 2.0 * double(sp.mean.size())), nu = 2.0 * (images - 1);
    const double thr = z + (z * z * z + z) / (4 * nu);
    const double t = worst_t(sp, fs, 1.0), biased = worst_t(sp, fs, 1.03);
    std::printf("[splat %s] worst block |t| %.2f, with a 3%% bias %.2f; threshold %.2f\n",
                k == FilterKind::Tent ? "tent" : "gaussian", t, biased, thr);
    EXPECT_LT(t, thr);
    EXPECT_GT(biased, thr) << "the test cannot see a 3% bias";
  }
}

}  // namespace
