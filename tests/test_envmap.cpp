// Environment maps (light/envmap.h).
//
//  * Mapping: radiance toward the direction of texel (i, j), by Mitsuba 3's
//    uv_to_direction written out here, is that texel times scale; halfway
//    between two texels it is their mean (bilinear), also across the seam.
//  * Sampling: chi-square of sampled directions over the map's cells (the
//    bins are the cells, found from each direction by the mapping written
//    here in double), against cell probabilities computed here from the
//    texels (mean luminance of the four corners times ∫ sin θ over the
//    cell's rows); at every sample, pdf_li and the sample's own pdf equal
//    that density over the Jacobian W (H - 1) / (2π² sin θ), and its radiance
//    is what le() gives for its direction (to float rounding of the (s, t)
//    round trip, ~1e-5 of a cell over sin θ, times the cell's largest texel). Three maps: smooth, a tiny bright
//    sun on a dim sky (and a dimmer one, so that the sky's cells count too),
//    and a rotated to_world.
//  * ∫ pdf_li dω = 1, by a quadrature whose points lie inside the cells.
//  * Images: a constant envmap renders the same image as `constant` (z-test
//    on block means, independent seeds); on an env-lit scene the path, bsdf
//    and light estimators agree within their error bars (the bsdf estimator
//    never uses the envmap's sampling, so a pdf inconsistent with it would
//    bias the other two).
//  * A diffuse sphere under an envmap against a quadrature of the map
//    computed here (see the test).
//  * Bad input: a missing image, a negative or non-finite texel, an image
//    below 2x3, a negative scale: one file:line error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "chi2.h"
#include "envmap_helpers.h"
#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/math/transform.h"
#include "scene_helpers.h"
#include "stat_helpers.h"
#include "temp_dir.h"

using namespace luz;
using chi2::D3;

namespace {

using namespace luz_test;

constexpr uint64_t kSamples = 200000;

double luminance(const Map& m, uint32_t i, uint32_t j) {
  const float* p = m.rgb.data() + (size_t(j) * m.w + i) * 3;
  return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
}
// Cell probabilities: W × (H - 1), row-major.
std::vector<double> cell_probabilities(const Map& m) {
  std::vector<double> p(size_t(m.w) * (m.h - 1));
  double total = 0;
  for (uint32_t j = 0; j + 1 < m.h; ++j)
    for (uint32_t i = 0; i < m.w; ++i) {
      const uint32_t i1 = (i + 1) % m.w;
      const double lum = (luminance(m, i, j) + luminance(m, i1, j) + luminance(m, i, j + 1) + luminance(m, i1, j + 1)) / 4;
      const double sin_integral = std::cos(j * M_PI / (m.h - 1)) - std::cos((j + 1) * M_PI / (m.h - 1));
      total += p[size_t(j) * m.w + i] = lum * sin_integral;
    }
  for (double& x : p) x /= total;
  return p;
}

TEST(Envmap, MitsubaMapping) {
  const Map m = smooth_map(8, 5);
  const float scale = 1.5f;
  auto s = env_scene(m, {}, scale);
  const LightData& data = s->view.lights.data;
  auto texel = [&](uint32_t i, uint32_t j, int c) { return m.rgb[(size_t(j) * m.w + i) * 3 + c]; };
  for (uint32_t j = 1; j + 1 < m.h; ++j)  // not the poles, where every column meets
    for (uint32_t i = 0; i < m.w; ++i) {
      const Color at = le(s->light(), chi2::to_vec3(uv_to_direction((i + 0.5) / m.w, double(j) / (m.h - 1))), data);
      // Halfway to the next column (across the seam for the last one).
      const Color mid = le(s->light(), chi2::to_vec3(uv_to_direction((i + 1.0) / m.w, double(j) / (m.h - 1))), data);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(at[c], scale * texel(i, j, c), 1e-4 * scale * texel(i, j, c)) << i << "," << j;
        const double want = scale * 0.5 * (texel(i, j, c) + texel((i + 1) % m.w, j, c));
        EXPECT_NEAR(mid[c], want, 1e-4 * want) << i << "," << j;
      }
    }
  // Straight up (+y) is the first row, down the last: all columns agree there
  // only if they are equal, so check a map whose pole rows are uniform.
  Map poles = m;
  for (uint32_t i = 0; i < m.w; ++i)
    for (int c = 0; c < 3; ++c) {
      poles.rgb[size_t(i) * 3 + c] = 3.f;
      poles.rgb[(size_t(m.h - 1) * m.w + i) * 3 + c] = 0.25f;
    }
  auto p = env_scene(poles);
  EXPECT_NEAR(le(p->light(), {0, 1, 0}, p->view.lights.data).y, 3.f, 1e-5f);
  EXPECT_NEAR(le(p->light(), {0, -1, 0}, p->view.lights.data).y, 0.25f, 1e-5f);
}

void check_sampling(const Map& m, const Matrix4& rotation, uint64_t seed, const char* what) {
  auto s = env_scene(m, rotation);
  const LightData& data = s->view.lights.data;
  const std::vector<double> prob = cell_probabilities(m);
  const size_t cells = prob.size();
  std::vector<double> observed(cells, 0.0);
  const LightSampleContext ctx{{0.3f, -0.2f, 0.1f}, {}, {}};
  double worst_pdf = 0, worst_li = 0, worst_radiance = 0;
  uint64_t failed = 0;
  for (uint64_t k = 0; k < kSamples; ++k) {
    const LightSample ls = sample_li(s->light(), ctx, chi2::rand2(seed, k, 0), data);
    if (!(ls.pdf > 0.f)) {
      ++failed;
      continue;
    }
    EXPECT_EQ(ls.dist, kInfinity);
    const D3 local = apply_transpose(rotation, chi2::normalized(chi2::to_d3(ls.wi)));
    double st_s, st_t;
    direction_to_grid(local, m.w, m.h, st_s, st_t);
    const uint32_t i = std::min(uint32_t(st_s), m.w - 1), j = std::min(uint32_t(st_t), m.h - 2);
    observed[size_t(j) * m.w + i] += 1;
    if (k % 8) continue;
    // Pointwise: the density of that cell over the Jacobian.
    const double sin_theta = std::sqrt(local.x * local.x + local.z * local.z);
    const double want = prob[size_t(j) * m.w + i] * m.w * (m.h - 1) / (2 * M_PI * M_PI * sin_theta);
    // Directions within float rounding of a cell edge may be binned either
    // way here: skip those for the pointwise check.
    const double fs = st_s - std::floor(st_s), ft = st_t - std::floor(st_t);
    if (fs < 1e-4 || fs > 1 - 1e-4 || ft < 1e-4 || ft > 1 - 1e-4) continue;
    worst_pdf = std::max(worst_pdf, std::fabs(ls.pdf - want) / want);
    worst_li = std::max(worst_li, std::fabs(pdf_li(s->light(), ctx, ls.wi, {}, data) - want) / want);
    // The sample's radiance is looked up at its (s, t), le's at the (s, t)
    // recomputed from its direction: float rounding of that round trip
    // (~1e-5 of a cell, over sin θ in s: azimuth is ill-conditioned near the
    // poles) moves a bilinear value by that fraction of the cell's largest
    // texel.
    const Color L = le(s->light(), ls.wi, data);
    float cell_max = 0.f;
    for (uint32_t dj = 0; dj < 2; ++dj)
      for (uint32_t di = 0; di < 2; ++di)
        for (int c = 0; c < 3; ++c) cell_max = std::max(cell_max, m.rgb[(size_t(j + dj) * m.w + (i + di) % m.w) * 3 + c]);
    for (int c = 0; c < 3; ++c)
      worst_radiance = std::max(worst_radiance, double(std::fabs(ls.radiance[c] - L[c]) / cell_max) * sin_theta);
  }
  std::vector<double> expected(cells);
  for (size_t c = 0; c < cells; ++c) expected[c] = prob[c] * double(kSamples - failed);
  const chi2::Result r = chi2::chi2_test(observed, expected);
  std::printf("%-28s %s; failed %llu; worst rel. error: pdf %.2g, pdf_li %.2g, radiance %.2g\n", what,
              r.summary().c_str(), (unsigned long long)failed, worst_pdf, worst_li, worst_radiance);
  EXPECT_TRUE(r.passes(chi2::sidak(chi2::kAlpha, 4))) << what << ": " << r.summary();
  EXPECT_LT(double(failed), 1e-4 * kSamples) << what;
  EXPECT_LT(worst_pdf, 1e-3) << what;
  EXPECT_LT(worst_li, 1e-3) << what;
  EXPECT_LT(worst_radiance, 1e-4) << what;
}

TEST(Envmap, SamplingChi2) {
  check_sampling(smooth_map(16, 9), {}, 1, "smooth 16x9");
  check_sampling(sun_map(64, 33, 41, 9), {}, 2, "tiny sun 64x33");
  check_sampling(sun_map(32, 17, 5, 14, 30.f), {}, 4, "dimmer sun 32x17, low");
  check_sampling(smooth_map(12, 7), Matrix4::rotate({0.3f, 1.f, -0.5f}, 70.0) * Matrix4::rotate({1, 0, 0}, -90.0), 3,
                 "smooth 12x7, rotated");
}

TEST(Envmap, PdfIntegratesToOne) {
  for (const Map& m : {smooth_map(16, 9), sun_map(64, 33, 41, 9)}) {
    const Matrix4 rotation = Matrix4::rotate({1.f, 0.2f, 0.f}, 33.0);
    auto s = env_scene(m, rotation);
    // Points at the midpoints of a k×k subdivision of every cell in (s, t):
    // each lies strictly inside its cell, where the density is constant in
    // (s, t), so the sum is the integral up to rounding.
    const int k = 4;
    double sum = 0;
    for (uint32_t j = 0; j + 1 < m.h; ++j)
      for (uint32_t i = 0; i < m.w; ++i)
        for (int b = 0; b < k; ++b)
          for (int a = 0; a < k; ++a) {
            const double gs = i + (a + 0.5) / k, gt = j + (b + 0.5) / k;
            const double u = (gs + 0.5) / m.w, v = gt / (m.h - 1);
            const D3 local = uv_to_direction(u, v);
            const double dw = (2 * M_PI / (m.w * k)) * (M_PI / ((m.h - 1) * k)) * std::sin(v * M_PI);
            sum += pdf_li(s->light(), {}, chi2::to_vec3(apply(rotation, local)), {}, s->view.lights.data) * dw;
          }
    // The midpoint rule in θ for the sin θ of dω: relative error ~ (Δθ)²/24.
    EXPECT_NEAR(sum, 1.0, 2e-3) << m.w << "x" << m.h;
  }
}

// ----------------------------------------------------------------- images

class EnvImages : public TempDirTest {
 protected:
  static std::string scene(const std::string& emitter, const std::string& integrator, int spp) {
    return R"(<scene version="3.0.0">
  <integrator type=")" + integrator + R"("><integer name="max_depth" value="3"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 1, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value=")" + std::to_string(spp) + R"("/></sampler>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/><rfilter type="box"/></film>
  </sensor>
  <shape type="sphere"><float name="radius" value="1"/><bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="1.2" y="0.3" z="1"/><float name="radius" value="0.4"/>
    <bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="-1"/></transform>
    <bsdf type="diffuse"/></shape>
)" + emitter + "\n</scene>\n";
  }
  Film render(const std::string& xml, uint64_t seed) {
    Scene s = load_scene(write("scene.xml", xml));
    s.settings.seed = seed;
    luz_test::independent_pixels(s);
    return luz_test::render_finite(s);
  }
  // Worst |z| over 4×4 blocks and channels between two independent images;
  // fails above the Šidák threshold for `pairs` comparisons.
  static void expect_agree(const Film& a, const Film& b, int pairs, const std::string& what) {
    const luz_test::Blocks A = luz_test::make_blocks(a, 4), B = luz_test::make_blocks(b, 4);
    const double thr = luz_test::sidak_z(1e-3, 3.0 * A.bw * A.bh * pairs);
    double worst = 0;
    for (size_t k = 0; k < A.mean.size(); ++k) {
      const double m = 0.5 * (A.mean[k] + B.mean[k]), floor = luz_test::rounding_floor(m);
      const double z = std::fabs(A.mean[k] - B.mean[k]) / std::sqrt(A.var[k] + B.var[k] + 2 * floor * floor);
      worst = std::max(worst, z);
    }
    std::printf("%s: worst |z| %.2f (threshold %.2f)\n", what.c_str(), worst, thr);
    EXPECT_LT(worst, thr) << what;
  }
  // Writes a PFM environment map.
  std::string write_map(const std::string& name, const Map& m) {
    Image img;
    img.width = int(m.w);
    img.height = int(m.h);
    img.rgb = m.rgb;
    const std::string path = (dir / name).string();
    write_image(path, img);
    return name;
  }
};

TEST_F(EnvImages, ConstantEnvmapMatchesConstant) {
  Map flat{24, 13, std::vector<float>(24 * 13 * 3)};
  for (size_t k = 0; k < flat.rgb.size(); ++k) flat.rgb[k] = k % 3 == 0 ? 0.8f : k % 3 == 1 ? 1.f : 1.3f;
  const std::string file = write_map("flat.pfm", flat);
  const Film c = render(scene(R"(<emitter type="constant"><rgb name="radiance" value="1.6, 2, 2.6"/></emitter>)", "path", 64), 1);
  const Film e = render(scene(R"(<emitter type="envmap"><string name="filename" value=")" + file +
                                  R"("/><float name="scale" value="2"/></emitter>)",
                              "path", 64),
                        2);
  expect_agree(c, e, 1, "constant vs constant envmap");
}

TEST_F(EnvImages, EstimatorsAgreeUnderAnEnvmap) {
  // A sun (a few bright texels) on a graded sky, rotated.
  Map m = smooth_map(32, 17);
  for (uint32_t dj = 0; dj < 2; ++dj)
    for (uint32_t di = 0; di < 2; ++di)
      for (int c = 0; c < 3; ++c) m.rgb[(size_t(5 + dj) * m.w + 11 + di) * 3 + c] = 300.f;
  const std::string file = write_map("sky.pfm", m);
  const std::string emitter = R"(<emitter type="envmap"><string name="filename" value=")" + file + R"("/>
    <transform name="to_world"><rotate y="1" angle="40"/></transform></emitter>)";
  const Film path = render(scene(emitter, "path", 256), 11), bsdf = render(scene(emitter, "bsdf", 1024), 12),
             light = render(scene(emitter, "light", 256), 13);
  expect_agree(path, bsdf, 3, "path vs bsdf");
  expect_agree(path, light, 3, "path vs light");
  expect_agree(bsdf, light, 3, "bsdf vs light");
}

// The envmap beside a lamp (a small rectangle overhead): the light BVH weighs
// the map by its mean irradiance against the lamp's importance at each
// point, and the path tracer's MIS by those pmfs must still agree with
// BSDF sampling alone.
TEST_F(EnvImages, EstimatorsAgreeUnderAnEnvmapAndALamp) {
  const std::string file = write_map("sky.pfm", smooth_map(32, 17));
  const std::string emitters = R"(<emitter type="envmap"><string name="filename" value=")" + file + R"("/>
    <float name="scale" value="0.3"/></emitter>
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/>
    <translate y="2.5"/></transform><emitter type="area"><rgb name="radiance" value="20, 16, 12"/></emitter></shape>)";
  const Film path = render(scene(emitters, "path", 256), 21), bsdf = render(scene(emitters, "bsdf", 1024), 22);
  expect_agree(path, bsdf, 1, "path vs bsdf, envmap and lamp");
}

// A lone diffuse sphere (albedo ρ) under an envmap, seen by an orthographic
// camera: a pixel inside the disk shows ρ/π · E(n), E(n) = ∫ L(ω) max(0, n·ω) dω
// for the normal n where the (parallel) rays meet the sphere; a convex
// sphere does not occlude its own upper hemisphere, so this is the whole
// answer. E is computed here by a midpoint quadrature over the map's cells
// (k×k points per cell, radiance by the mapping and bilinear lookup written
// in this file), averaged over 4×4 points of each pixel; the quadrature's
// and the pixel average's errors are estimated by halving each and added to
// the tolerance. Pixels crossing the silhouette are left out; those outside
// it see the map along the view direction, the same for every ray. 2048 spp:
// the small bright spot makes the estimator heavy-tailed, and at 256 spp the
// worst pixel's |z| was 4.3 of 4.8 on two of four seeds (all such pixels on
// the low side, as heavy tails make them); at 2048 spp 2.9-3.6 on six seeds,
// and the sum over the disk's pixels within its error bar on each.
TEST_F(EnvImages, DiffuseSphereMatchesQuadratureOfTheMap) {
  Map m = smooth_map(24, 13);
  for (int c = 0; c < 3; ++c) m.rgb[(size_t(4) * m.w + 7) * 3 + c] = 40.f;  // a bright spot above the horizon
  const std::string file = write_map("sky.pfm", m);
  constexpr int kRes = 16;
  constexpr double kHalf = 1.25, kAlbedo = 0.6;
  const std::string xml = R"(<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="orthographic">
    <transform name="to_world"><scale x="1.25" y="1.25"/><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="2048"/></sampler>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
  <shape type="sphere"><float name="radius" value="1"/><bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></shape>
  <emitter type="envmap"><string name="filename" value=")" + file + R"("/></emitter>
</scene>
)";
  const Film f = render(xml, 5);

  // Radiance from light-space direction d, by Mitsuba's mapping and bilinear lookup.
  auto radiance = [&](D3 d, int c) {
    double gs, gt;
    direction_to_grid(d, m.w, m.h, gs, gt);
    const uint32_t i = std::min(uint32_t(gs), m.w - 1), j = std::min(uint32_t(gt), m.h - 2), i1 = (i + 1) % m.w;
    const double fx = gs - i, fy = gt - j;
    auto t = [&](uint32_t a, uint32_t b) { return double(m.rgb[(size_t(b) * m.w + a) * 3 + c]); };
    return (1 - fy) * ((1 - fx) * t(i, j) + fx * t(i1, j)) + fy * ((1 - fx) * t(i, j + 1) + fx * t(i1, j + 1));
  };
  // Quadrature points over the sphere of directions: direction, solid angle, RGB radiance.
  struct Q {
    D3 w;
    double dw, L[3];
  };
  auto quadrature = [&](int k) {
    std::vector<Q> q;
    for (uint32_t j = 0; j + 1 < m.h; ++j)
      for (uint32_t i = 0; i < m.w; ++i)
        for (int b = 0; b < k; ++b)
          for (int a = 0; a < k; ++a) {
            const double gs = i + (a + 0.5) / k, gt = j + (b + 0.5) / k, v = gt / (m.h - 1);
            Q p;
            p.w = uv_to_direction((gs + 0.5) / m.w, v);
            p.dw = (2 * M_PI / (m.w * k)) * (M_PI / ((m.h - 1) * k)) * std::sin(v * M_PI);
            for (int c = 0; c < 3; ++c) p.L[c] = radiance(p.w, c);
            q.push_back(p);
          }
    return q;
  };
  const std::vector<Q> fine = quadrature(4), coarse = quadrature(2);
  auto irradiance = [](const std::vector<Q>& q, D3 n, double E[3]) {
    E[0] = E[1] = E[2] = 0;
    for (const Q& p : q) {
      const double cosine = chi2::dot(n, p.w);
      if (cosine > 0)
        for (int c = 0; c < 3; ++c) E[c] += p.L[c] * cosine * p.dw;
    }
  };
  // World point seen at film position (fx, fy): the image's left is -x, its top +y.
  auto film_point = [&](double fx, double fy) {
    return std::pair<double, double>{(2 * fx / kRes - 1) * kHalf, (1 - 2 * fy / kRes) * kHalf};
  };
  // Mean of ρ/π E(n) over a g×g grid of the pixel, with quadrature q.
  auto pixel = [&](int x, int y, int g, const std::vector<Q>& q, double out[3]) {
    out[0] = out[1] = out[2] = 0;
    for (int b = 0; b < g; ++b)
      for (int a = 0; a < g; ++a) {
        auto [px, py] = film_point(x + (a + 0.5) / g, y + (b + 0.5) / g);
        const D3 n{px, py, std::sqrt(std::max(0.0, 1 - px * px - py * py))};
        double E[3];
        irradiance(q, n, E);
        for (int c = 0; c < 3; ++c) out[c] += kAlbedo / M_PI * E[c] / (g * g);
      }
  };
  const double z = luz_test::sidak_z(1e-3, 3.0 * kRes * kRes);
  double worst = 0;
  int inside = 0, outside = 0;
  const std::vector<double> var = f.variance_of_mean();
  for (int y = 0; y < kRes; ++y)
    for (int x = 0; x < kRes; ++x) {
      double rmin = 1e9, rmax = 0;
      for (int cy = 0; cy < 2; ++cy)
        for (int cx = 0; cx < 2; ++cx) {
          auto [px, py] = film_point(x + cx, y + cy);
          rmin = std::min(rmin, std::hypot(px, py));
          rmax = std::max(rmax, std::hypot(px, py));
        }
      const size_t i = size_t(y) * kRes + x;
      double want[3], err[3];
      if (rmax < 1.0) {
        double a[3], b[3], c2[3];
        pixel(x, y, 4, fine, a);
        pixel(x, y, 2, fine, b);
        pixel(x, y, 4, coarse, c2);
        for (int c = 0; c < 3; ++c) {
          want[c] = a[c];
          err[c] = std::fabs(a[c] - b[c]) + std::fabs(a[c] - c2[c]);
        }
        ++inside;
      } else if (rmin > 1.0 && std::fabs(x + 0.5 - kRes / 2.0) > 1) {
        // Every ray of this pixel leaves along -z, and sees the map there.
        for (int c = 0; c < 3; ++c) want[c] = radiance({0, 0, -1}, c), err[c] = 1e-6 * want[c];
        ++outside;
      } else {
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        const double mean = f.sum[3 * i + c] / f.count[i];
        const double sd = std::sqrt(var[3 * i + c] + std::pow(luz_test::rounding_floor(want[c]), 2));
        const double excess = std::fabs(mean - want[c]) - err[c];
        worst = std::max(worst, excess / sd);
        EXPECT_LE(excess, z * sd) << "pixel " << x << "," << y << " channel " << c << ": " << mean << " vs " << want[c];
      }
    }
  std::printf("diffuse sphere under an envmap: %d pixels inside, %d outside, worst |z| %.2f (threshold %.2f)\n", inside,
              outside, worst, z);
  EXPECT_GT(inside, 100);
  EXPECT_GT(outside, 30);
}

TEST_F(EnvImages, BadEnvmapsAreRefused) {
  auto expect_refused = [&](const std::string& emitter, const std::string& problem) {
    luz_test::expect_load_refused(write("bad.xml", scene(emitter, "path", 4)), "bad.xml", problem);
  };
  Map m = smooth_map(8, 5);
  write_map("ok.pfm", m);
  m.rgb[7] = -1.f;
  write_map("negative.pfm", m);
  m.rgb[7] = NAN;
  write_map("nan.pfm", m);
  write_map("small.pfm", smooth_map(4, 2));
  write("garbage.hdr", "not an image");
  expect_refused(R"(<emitter type="envmap"><string name="filename" value="missing.exr"/></emitter>)", "no such file");
  expect_refused(R"(<emitter type="envmap"><string name="filename" value="negative.pfm"/></emitter>)", "pixel (2, 0) is negative");
  expect_refused(R"(<emitter type="envmap"><string name="filename" value="nan.pfm"/></emitter>)", "is not finite");
  expect_refused(R"(<emitter type="envmap"><string name="filename" value="small.pfm"/></emitter>)", "at least 2x3");
  expect_refused(R"(<emitter type="envmap"><string name="filename" value="garbage.hdr"/></emitter>)", "cannot read");
  expect_refused(R"(<emitter type="envmap"/>)", "needs a 'filename'");
  expect_refused(R"(<emitter type="envmap"><string name="filename" value="ok.pfm"/><float name="scale" value="-1"/></emitter>)",
                 "scale must be finite and not negative");
  expect_refused(R"(<emitter type="envmap"><string name="filename" value="ok.pfm"/></emitter>
    <emitter type="constant"/>)", "only one environment emitter");
}

}  // namespace
