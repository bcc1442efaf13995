// The cameras (src/luz/camera/): the thin lens against the thin-lens formula
// (a point in the focal plane images to one film point for every lens
// sample, a point off it to its circle of confusion), a thin lens of radius 0
// against the pinhole bit for bit, the orthographic camera's rays and its
// rendered image of a quad against the exact area fractions, the perspective
// principal point offset as a shift of the image, and the Mitsuba loader's
// sensors with their errors (one line, exit 2, through the binary). The
// camera seen from the scene (importance.h): a point on a camera ray
// connects back to that ray's film position and lens point, and the
// importance integrates to one over the directions through the film.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "cli_helpers.h"
#include "luz/camera/camera.h"
#include "luz/camera/importance.h"
#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/load.h"
#include "temp_dir.h"

namespace {

using luz::Camera;
using luz::CameraType;
using luz::Ray;
using luz::Vec2;
using luz::Vec3;

struct D3 {
  double x, y, z;
};
D3 to_d3(Vec3 v) { return {v.x, v.y, v.z}; }
double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
D3 sub(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }

// A thin-lens camera in a tilted frame (orthonormal, Mitsuba's lookat
// handedness), 64×48 pixels, 50° across.
Camera tilted_lens(float radius, float focus) {
  Camera c;
  c.type = CameraType::ThinLens;
  const Vec3 dir = luz::normalize(Vec3{0.3f, -0.2f, 1.f}), up{0.f, 1.f, 0.f};
  c.x_axis = luz::normalize(luz::cross(up, dir));
  c.y_axis = luz::cross(dir, c.x_axis);
  c.z_axis = dir;
  c.origin = {1.f, 2.f, -3.f};
  c.width = 64;
  c.height = 48;
  c.tan_half_x = float(std::tan(25.0 * M_PI / 180.0));
  c.tan_half_y = c.tan_half_x * 48.f / 64.f;
  c.lens.aperture_radius = radius;
  c.lens.focus_distance = focus;
  return c;
}

// A world point in the camera's (orthonormal) camera space.
D3 to_camera(const Camera& c, D3 p) {
  const D3 v = sub(p, to_d3(c.origin));
  return {dot(v, to_d3(c.x_axis)), dot(v, to_d3(c.y_axis)), dot(v, to_d3(c.z_axis))};
}

// Where ray r meets the camera-space plane z = depth, in camera x and y.
Vec2 hit_at_depth(const Camera& c, const Ray& r, double depth, double out[2]) {
  const D3 o = to_camera(c, to_d3(r.o));
  const D3 d = {dot(to_d3(r.d), to_d3(c.x_axis)), dot(to_d3(r.d), to_d3(c.y_axis)), dot(to_d3(r.d), to_d3(c.z_axis))};
  const double t = (depth - o.z) / d.z;
  out[0] = o.x + t * d.x;
  out[1] = o.y + t * d.y;
  return {float(out[0]), float(out[1])};
}

// The film position (pixels) whose ray for lens sample u passes through the
// camera-space point (px, py, depth): where the ray meets that plane is an
// affine function of the film position, so three rays give it exactly.
void image_of(const Camera& c, Vec2 u, double px, double py, double depth, double f[2]) {
  double h0[2], hx[2], hy[2];
  hit_at_depth(c, c.generate_ray(32.f, 24.f, u), depth, h0);
  hit_at_depth(c, c.generate_ray(33.f, 24.f, u), depth, hx);
  hit_at_depth(c, c.generate_ray(32.f, 25.f, u), depth, hy);
  const double a = hx[0] - h0[0], b = hy[0] - h0[0], cc = hx[1] - h0[1], d = hy[1] - h0[1];
  const double rx = px - h0[0], ry = py - h0[1], det = a * d - b * cc;
  f[0] = 32.0 + (d * rx - b * ry) / det;
  f[1] = 24.0 + (a * ry - cc * rx) / det;
}

// Lens samples: a grid over the square, its edges included (they map to the
// lens's rim), and the centre.
std::vector<Vec2> lens_samples() {
  std::vector<Vec2> u;
  for (int i = 0; i <= 8; ++i)
    for (int j = 0; j <= 8; ++j) u.push_back({std::min(i / 8.f, 0.99999994f), std::min(j / 8.f, 0.99999994f)});
  return u;
}
bool on_rim(Vec2 u) { return u.x == 0.f || u.y == 0.f || u.x > 0.9999f || u.y > 0.9999f; }

TEST(ThinLens, FocalPlanePointImagesToOnePoint) {
  const float focus = 4.f;
  const Camera c = tilted_lens(0.25f, focus);
  // Film points across the image; each one's rays, whatever the lens sample,
  // meet the focal plane at one point: its image is that film point.
  for (float fx : {0.5f, 17.3f, 40.f, 63.5f})
    for (float fy : {0.5f, 20.7f, 47.5f}) {
      double p0[2];
      hit_at_depth(c, c.generate_ray(fx, fy, {0.5f, 0.5f}), focus, p0);
      for (Vec2 u : lens_samples()) {
        double f[2];
        image_of(c, u, p0[0], p0[1], focus, f);
        EXPECT_LT(std::hypot(f[0] - fx, f[1] - fy), 1e-2) << "film (" << fx << ", " << fy << ") lens (" << u.x << ", "
                                                          << u.y << ")";
      }
    }
}

TEST(ThinLens, OffFocusPointImagesToCircleOfConfusion) {
  const float radius = 0.25f, focus = 4.f;
  const Camera c = tilted_lens(radius, focus);
  const double px_per_unit = c.width / (2.0 * c.tan_half_x);  // film pixels per unit on the plane z = 1
  for (double depth : {1.5, 2.5, 7.0, 30.0}) {
    // Thin-lens formula: on the plane z = 1 the image spreads over a disk of
    // radius R · |1/focus − 1/z| around the pinhole image.
    const double coc = radius * std::fabs(1.0 / focus - 1.0 / depth) * px_per_unit;
    const double px = 0.21 * depth, py = -0.13 * depth;  // a point inside the view
    double pin[2];
    image_of(c, {0.5f, 0.5f}, px, py, depth, pin);
    EXPECT_NEAR(pin[0], (1.0 - px / depth / c.tan_half_x) * c.width / 2, 1e-3);
    double widest = 0;
    for (Vec2 u : lens_samples()) {
      double f[2];
      image_of(c, u, px, py, depth, f);
      const double r = std::hypot(f[0] - pin[0], f[1] - pin[1]);
      widest = std::max(widest, r);
      if (on_rim(u))
        EXPECT_NEAR(r, coc, 1e-3 * coc) << "depth " << depth << " lens (" << u.x << ", " << u.y << ")";
      else
        EXPECT_LT(r, coc * (1 + 1e-4)) << "depth " << depth;
    }
    EXPECT_GT(coc, 1.0) << "test bug: the circle should span pixels";
    EXPECT_NEAR(widest, coc, 1e-3 * coc);
  }
}

TEST(ThinLens, ZeroApertureIsThePinholeBitForBit) {
  Camera lens = tilted_lens(0.f, 3.f), pin = lens;
  pin.type = CameraType::Perspective;
  EXPECT_FALSE(lens.has_lens());
  for (float fx = 0.f; fx <= 64.f; fx += 0.37f)
    for (float fy = 0.f; fy <= 48.f; fy += 0.41f) {
      const Vec2 u{std::fmod(fx * 0.173f, 1.f), std::fmod(fy * 0.291f, 1.f)};
      const Ray a = lens.generate_ray(fx, fy, u), b = pin.generate_ray(fx, fy);
      ASSERT_EQ(std::memcmp(&a.d, &b.d, sizeof a.d), 0) << fx << ", " << fy;
      ASSERT_EQ(std::memcmp(&a.o, &b.o, sizeof a.o), 0) << fx << ", " << fy;
    }
}

// ------------------------------------------------------------ scenes through the loader

// A one-sided emitting rectangle (radiance 1) seen by `sensor`; max_depth 1:
// each pixel is the fraction of its box-filtered footprint on the rectangle.
std::string quad_scene(const std::string& sensor_type, const std::string& sensor_body, const std::string& quad_transform,
                       int w, int h, int spp, const std::string& sampler = "independent") {
  return "<scene version=\"3.0.0\">\n<integrator type=\"path\"><integer name=\"max_depth\" value=\"1\"/></integrator>\n"
         "<sensor type=\"" +
         sensor_type + "\">\n" + sensor_body + "<sampler type=\"" + sampler +
         "\"><integer name=\"sample_count\" value=\"" + std::to_string(spp) +
         "\"/></sampler>\n<film type=\"hdrfilm\"><integer name=\"width\" value=\"" + std::to_string(w) +
         "\"/><integer name=\"height\" value=\"" + std::to_string(h) +
         "\"/><rfilter type=\"box\"/></film>\n</sensor>\n<shape type=\"rectangle\"><transform name=\"to_world\">" +
         quad_transform +
         "</transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n</scene>\n";
}

class CameraScenes : public TempDirTest {
 protected:
  luz::Scene load(const std::string& text) { return luz::load_mitsuba(write("scene.xml", text), {}); }
  static std::vector<float> render(const luz::Scene& s) {
    luz::CpuRenderOptions opt;
    opt.threads = 2;
    luz::RenderStats stats;
    return luz::render_cpu(s, opt, stats).mean();
  }
};

// Area of the convex polygon `poly` (counter-clockwise or not) inside the
// square [x0, x0+1] × [y0, y0+1]: Sutherland–Hodgman clipping, then the
// shoelace formula.
double area_in_pixel(std::vector<std::pair<double, double>> poly, double x0, double y0) {
  auto clip = [&](int axis, double bound, bool keep_above) {
    std::vector<std::pair<double, double>> out;
    auto inside = [&](const std::pair<double, double>& p) {
      const double v = axis == 0 ? p.first : p.second;
      return keep_above ? v >= bound : v <= bound;
    };
    for (size_t i = 0; i < poly.size(); ++i) {
      const auto a = poly[i], b = poly[(i + 1) % poly.size()];
      if (inside(a)) out.push_back(a);
      if (inside(a) != inside(b)) {
        const double va = axis == 0 ? a.first : a.second, vb = axis == 0 ? b.first : b.second;
        const double t = (bound - va) / (vb - va);
        out.push_back({a.first + t * (b.first - a.first), a.second + t * (b.second - a.second)});
      }
    }
    poly = out;
  };
  clip(0, x0, true);
  clip(0, x0 + 1, false);
  clip(1, y0, true);
  clip(1, y0 + 1, false);
  double a = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const auto p = poly[i], q = poly[(i + 1) % poly.size()];
    a += p.first * q.second - q.first * p.second;
  }
  return std::fabs(a) / 2;
}

TEST_F(CameraScenes, OrthographicRaysAreParallelAndSpanTheScaledFilm) {
  // Mitsuba's example: to_world = lookat · scale, the film [-1, 1] ×
  // [-1/aspect, 1/aspect] scaled by 3 and 2 in camera x and y.
  const luz::Scene s = load(quad_scene("orthographic",
                                       "<transform name=\"to_world\"><scale x=\"3\" y=\"2\"/><lookat origin=\"1, 2, 3\" "
                                       "target=\"1, 2, -1\" up=\"0, 1, 0\"/></transform>\n",
                                       "", 20, 10, 1));
  const Camera& c = s.camera;
  EXPECT_EQ(c.type, CameraType::Orthographic);
  for (float fx : {0.f, 5.5f, 20.f})
    for (float fy : {0.f, 3.25f, 10.f}) {
      const Ray r = c.generate_ray(fx, fy);
      EXPECT_EQ(r.d.x, 0.f);
      EXPECT_EQ(r.d.y, 0.f);
      EXPECT_EQ(r.d.z, -1.f);
      // Camera x (the image's left) is world −x; the origin at near_clip 0.01.
      EXPECT_NEAR(r.o.x, 1.0 - 3.0 * (1.0 - 2.0 * fx / 20), 1e-5);
      EXPECT_NEAR(r.o.y, 2.0 + 2.0 * (1.0 - 2.0 * fy / 10) / 2.0, 1e-5);
      EXPECT_NEAR(r.o.z, 3.0 - 0.01, 1e-6);
    }
}

TEST_F(CameraScenes, OrthographicImageOfAQuadIsItsAreaFraction) {
  // Camera: looks down −z from z = 5, film 16×12 spanning world x ∈ [-2, 2]
  // (scale 2) and y ∈ [-1.5, 1.5] (aspect 4/3); camera x is world −x.
  constexpr int w = 16, h = 12, spp = 1024;
  // The rectangle [-1, 1]², scaled to 1.3 × 0.7, turned 30° about z, moved:
  // edges across pixels at all angles but none along them.
  const double ax = 1.3, ay = 0.7, th = 30.0 * M_PI / 180.0, tx = 0.31, ty = -0.17;
  const luz::Scene s = load(quad_scene("orthographic",
                                       "<transform name=\"to_world\"><scale x=\"2\" y=\"2\"/><lookat origin=\"0, 0, 5\" "
                                       "target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n",
                                       "<scale x=\"1.3\" y=\"0.7\"/><rotate z=\"1\" angle=\"30\"/><translate x=\"0.31\" "
                                       "y=\"-0.17\"/>",
                                       w, h, spp));
  std::vector<std::pair<double, double>> poly;  // the corners in film pixels
  for (auto [cx, cy] : {std::pair{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}}) {
    const double x = cx * ax * std::cos(th) - cy * ay * std::sin(th) + tx;
    const double y = cx * ax * std::sin(th) + cy * ay * std::cos(th) + ty;
    // camera x = −x / 2 = 1 − 2 fx / w; camera y = y / 2 = (1 − 2 fy / h) / aspect.
    poly.push_back({(1.0 + x / 2.0) * w / 2.0, (1.0 - y / 2.0 * w / h) * h / 2.0});
  }
  const std::vector<float> img = render(s);
  double total = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double f = area_in_pixel(poly, x, y), v = img[3 * (y * w + x)];
      total += f;
      // Independent samples: the pixel is a binomial proportion of spp draws;
      // 5 standard deviations, plus one sample for the nearly empty corners.
      const double bound = 5.0 * std::sqrt(f * (1 - f) / spp) + 1.0 / spp;
      EXPECT_NEAR(v, f, bound) << "pixel (" << x << ", " << y << ")";
    }
  EXPECT_NEAR(total, 4 * ax * ay * (w / 4.0) * (w / 4.0), 1e-9) << "test bug: the quad's area in pixels";
}

// The x centroid of an image's first channel.
double centroid_x(const std::vector<float>& img, int w, int h) {
  double s = 0, sx = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      s += img[3 * (y * w + x)];
      sx += img[3 * (y * w + x)] * (x + 0.5);
    }
  return sx / s;
}

TEST_F(CameraScenes, PrincipalPointOffsetShiftsTheImage) {
  // Mitsuba: the film position (x/w + offset_x, y/h + offset_y) of the
  // centred camera, so pixel x shows what pixel x + offset_x · w showed: the
  // image moves left by offset_x · w pixels (and up by offset_y · h).
  constexpr int w = 32, h = 24;
  const std::string view =
      "<float name=\"fov\" value=\"40\"/><transform name=\"to_world\"><lookat origin=\"0, 0, 6\" target=\"0, 0, 0\" "
      "up=\"0, 1, 0\"/></transform>\n";
  const std::string quad = "<scale value=\"0.6\"/>";
  const luz::Scene plain = load(quad_scene("perspective", view, quad, w, h, 256, "sobol"));
  const luz::Scene shifted =
      load(quad_scene("perspective",
                      view + "<float name=\"principal_point_offset_x\" value=\"0.25\"/>"
                             "<float name=\"principal_point_offset_y\" value=\"-0.125\"/>\n",
                      quad, w, h, 256, "sobol"));
  for (float fx : {0.f, 7.5f, 31.f})
    for (float fy : {0.f, 12.25f, 24.f}) {
      const Ray a = shifted.camera.generate_ray(fx, fy), b = plain.camera.generate_ray(fx + 8.f, fy - 3.f);
      EXPECT_NEAR(a.d.x, b.d.x, 1e-6);
      EXPECT_NEAR(a.d.y, b.d.y, 1e-6);
      EXPECT_NEAR(a.d.z, b.d.z, 1e-6);
    }
  EXPECT_NEAR(centroid_x(render(shifted), w, h), centroid_x(render(plain), w, h) - 8.0, 0.02);
}

// hdrfilm's crop_offset_x/y and crop_width/height: a film of the crop's
// size whose pixels see what the whole film's pixels there saw; a crop that
// leaves the film is refused at the film's line.
TEST_F(CameraScenes, MitsubaFilmCropRendersItsPixels) {
  const std::string view =
      "<float name=\"fov\" value=\"40\"/><transform name=\"to_world\"><lookat origin=\"0, 0, 6\" target=\"0, 0, 0\" "
      "up=\"0, 1, 0\"/></transform>\n";
  const std::string text = quad_scene("perspective", view, "<scale value=\"0.6\"/>", 32, 24, 4);
  const luz::Scene whole = load(text);
  auto cropped = [&](const std::string& crop) {
    std::string t = text;
    const size_t at = t.find("<rfilter");
    return t.insert(at, crop);
  };
  const luz::Scene part = load(cropped("<integer name=\"crop_offset_x\" value=\"8\"/><integer name=\"crop_offset_y\" "
                                       "value=\"5\"/><integer name=\"crop_width\" value=\"16\"/><integer "
                                       "name=\"crop_height\" value=\"10\"/>"));
  ASSERT_EQ(part.camera.width, 16);
  ASSERT_EQ(part.camera.height, 10);
  for (float fx : {0.f, 7.5f, 16.f})
    for (float fy : {0.f, 4.25f, 10.f}) {
      const Ray a = part.camera.generate_ray(fx, fy), b = whole.camera.generate_ray(fx + 8.f, fy + 5.f);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.d[k], b.d[k], 1e-6f);
    }
  EXPECT_EQ(load(cropped("<integer name=\"crop_offset_x\" value=\"30\"/>")).camera.width, 2);  // the rest of the row
  try {
    load(cropped("<integer name=\"crop_offset_x\" value=\"20\"/><integer name=\"crop_width\" value=\"16\"/>"));
    ADD_FAILURE() << "a crop beyond the film was accepted";
  } catch (const luz::InputError& e) {
    EXPECT_EQ(e.line(), 6) << e.what();  // the <film>
    EXPECT_NE(std::string(e.what()).find("the crop window [20, 36) × [0, 24) is empty or leaves the 32×24 film"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(CameraScenes, ThinLensLoadsMitsubaParameters) {
  const std::string view =
      "<float name=\"fov\" value=\"40\"/><transform name=\"to_world\"><lookat origin=\"0, 0, 6\" target=\"0, 0, 0\" "
      "up=\"0, 1, 0\"/></transform>\n";
  luz::Scene s = load(quad_scene(
      "thinlens", view + "<float name=\"aperture_radius\" value=\"0.2\"/><float name=\"focus_distance\" value=\"5\"/>", "",
      8, 8, 1));
  EXPECT_EQ(s.camera.type, CameraType::ThinLens);
  EXPECT_EQ(s.camera.lens.aperture_radius, 0.2f);
  EXPECT_EQ(s.camera.lens.focus_distance, 5.f);
  EXPECT_TRUE(s.camera.has_lens());
  // Mitsuba's default focus_distance: far_clip.
  s = load(quad_scene("thinlens", view + "<float name=\"aperture_radius\" value=\"0.2\"/><float name=\"far_clip\" value=\"50\"/>",
                      "", 8, 8, 1));
  EXPECT_EQ(s.camera.lens.focus_distance, 50.f);
}

TEST_F(CameraScenes, ThinLensOfRadiusZeroRendersThePinholeImageBitForBit) {
  const std::string view =
      "<float name=\"fov\" value=\"40\"/><transform name=\"to_world\"><lookat origin=\"0, 0.5, 6\" target=\"0, 0, 0\" "
      "up=\"0, 1, 0\"/></transform>\n";
  for (const char* sampler : {"independent", "stratified", "sobol"}) {
    const std::vector<float> pin = render(load(quad_scene("perspective", view, "<scale value=\"0.6\"/>", 16, 12, 16, sampler)));
    const std::vector<float> lens = render(load(quad_scene(
        "thinlens", view + "<float name=\"aperture_radius\" value=\"0\"/><float name=\"focus_distance\" value=\"2\"/>",
        "<scale value=\"0.6\"/>", 16, 12, 16, sampler)));
    ASSERT_EQ(pin.size(), lens.size());
    EXPECT_EQ(std::memcmp(pin.data(), lens.data(), pin.size() * sizeof(float)), 0) << sampler;
  }
}

TEST_F(CameraScenes, ThinLensRenderFocusesItsFocalPlaneAndBlursTheRest) {
  // The quad 6 units away; a lens of radius 0.3. Focused on it, the image is
  // the pinhole's but for noise; focused at 3 units, its circle of confusion
  // is 0.3 · (1/3 − 1/6) on the plane z = 1, 1.37 pixels (32 pixels over
  // 2 tan 20°): the edges spread, and the light is only moved, not lost.
  constexpr int w = 32, h = 24, spp = 256;
  const std::string view =
      "<float name=\"fov\" value=\"40\"/><transform name=\"to_world\"><lookat origin=\"0, 0, 6\" target=\"0, 0, 0\" "
      "up=\"0, 1, 0\"/></transform>\n";
  const std::string quad = "<scale value=\"0.6\"/>";
  auto lens = [&](const char* focus) {
    return view + "<float name=\"aperture_radius\" value=\"0.3\"/><float name=\"focus_distance\" value=\"" + focus +
           "\"/>";
  };
  const std::vector<float> pin = render(load(quad_scene("perspective", view, quad, w, h, spp, "sobol")));
  const std::vector<float> sharp = render(load(quad_scene("thinlens", lens("6"), quad, w, h, spp, "sobol")));
  const std::vector<float> blurred = render(load(quad_scene("thinlens", lens("3"), quad, w, h, spp, "sobol")));
  double sum_pin = 0, sum_blur = 0, worst_sharp = 0, worst_blur = 0;
  for (size_t i = 0; i < pin.size(); i += 3) {
    sum_pin += pin[i];
    sum_blur += blurred[i];
    worst_sharp = std::max(worst_sharp, double(std::fabs(sharp[i] - pin[i])));
    worst_blur = std::max(worst_blur, double(std::fabs(blurred[i] - pin[i])));
  }
  EXPECT_LT(worst_sharp, 0.05);
  EXPECT_GT(worst_blur, 0.2);
  EXPECT_NEAR(sum_blur, sum_pin, 0.01 * sum_pin);
}

// The lens sample is a second stream of the film sample's dimension: for
// every sampler, uniform and uncorrelated with the film sample.
TEST(CameraSample, LensSampleIsIndependentOfTheFilmSample) {
  for (luz::SamplerType type : {luz::SamplerType::Independent, luz::SamplerType::Stratified, luz::SamplerType::Sobol}) {
    const luz::SamplerDesc desc = luz::make_sampler_desc(type, 64, 7);
    double n = 0, mean[4] = {}, prod[4] = {}, sq[4] = {};
    for (uint32_t px = 0; px < 64; ++px) {
      luz::Sampler s;
      s.start(desc, px, 3, 0);
      for (uint32_t k = 0; k < desc.spp; ++k) {
        s.set_sample(k);
        const Vec2 lens = s.aux_2d(0), film = s.next_2d();
        const double v[4] = {film.x, film.y, lens.x, lens.y};
        for (int i = 0; i < 4; ++i) {
          mean[i] += v[i];
          sq[i] += v[i] * v[i];
        }
        prod[0] += v[0] * v[2];
        prod[1] += v[1] * v[3];
        prod[2] += v[0] * v[3];
        prod[3] += v[1] * v[2];
        n += 1;
      }
    }
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(mean[i] / n, 0.5, 5 * std::sqrt(1.0 / 12 / n)) << int(type);
    const int pairs[4][2] = {{0, 2}, {1, 3}, {0, 3}, {1, 2}};
    for (int k = 0; k < 4; ++k) {
      const int a = pairs[k][0], b = pairs[k][1];
      const double cov = prod[k] / n - mean[a] / n * mean[b] / n;
      const double corr = cov / std::sqrt((sq[a] / n - mean[a] * mean[a] / n / n) * (sq[b] / n - mean[b] * mean[b] / n / n));
      EXPECT_LT(std::fabs(corr), 5 / std::sqrt(n)) << "sampler " << int(type) << " pair " << k;
    }
  }
}

// ------------------------------------------------------------ bad sensors, through the binary

class CameraCli : public luz_test::LuzCliTest {
 protected:
  // The sensor `type` with `params` in an otherwise valid scene (the
  // parameters on line 3) must exit 2 with one line naming line 3 and `problem`.
  void expect_bad(const std::string& type, const std::string& params, const std::string& problem) {
    const std::string xml = write("bad.xml", "<scene version=\"3.0.0\">\n<sensor type=\"" + type + "\">\n" + params +
                                                 "\n</sensor>\n<shape type=\"sphere\"/>\n</scene>\n");
    const luz_test::CliResult r = run({"render", xml, "-o", "out.pfm"});
    SCOPED_TRACE(type + " " + params + "\nstderr: " + r.err);
    ASSERT_TRUE(r.exited) << "killed by signal " << r.signal;
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "stderr must be exactly one line";
    EXPECT_EQ(r.err.rfind(xml + ":", 0), 0u) << "the message must start with the file";
    const size_t at = r.err.find(": error: ");
    ASSERT_NE(at, std::string::npos);
    const int line = std::atoi(r.err.c_str() + xml.size() + 1);
    EXPECT_TRUE(line == 2 || line == 3) << "the sensor's or the parameter's line";
    EXPECT_NE(r.err.find(problem), std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(dir / "out.pfm"));
  }
  static std::string f(const std::string& name, const std::string& value) {
    return "<float name=\"" + name + "\" value=\"" + value + "\"/>";
  }
};

TEST_F(CameraCli, BadSensorsExit2WithOneLine) {
  const std::string r = f("aperture_radius", "0.1");
  expect_bad("thinlens", f("aperture_radius", "-0.1"), "aperture_radius must be ≥ 0");
  expect_bad("thinlens", f("aperture_radius", "nan"), "not a finite number");
  expect_bad("thinlens", f("aperture_radius", "inf"), "not a finite number");
  expect_bad("thinlens", f("aperture_radius", "1e999"), "not a finite number");
  expect_bad("thinlens", "", "needs an aperture_radius");
  expect_bad("thinlens", r + f("focus_distance", "0"), "focus_distance must be > 0");
  expect_bad("thinlens", r + f("focus_distance", "-2"), "focus_distance must be > 0");
  expect_bad("thinlens", r + f("focus_distance", "-inf"), "not a finite number");
  expect_bad("thinlens", r + f("apperture", "1"), "unknown parameter 'apperture'");
  expect_bad("thinlens", r + f("fov", "180"), "fov must be");
  expect_bad("perspective", f("principal_point_offset_x", "nan"), "not a finite number");
  expect_bad("perspective", f("principal_point_offset_y", "2e6"), "principal_point_offset_x/y must lie in");
  expect_bad("perspective", f("focus_distance", "0"), "focus_distance must be > 0");
  expect_bad("perspective", f("aperture_radius", "0.1"), "unknown parameter 'aperture_radius'");
  expect_bad("orthographic", f("fov", "30"), "unknown parameter 'fov'");
  expect_bad("orthographic", f("principal_point_offset_x", "0.1"), "unknown parameter 'principal_point_offset_x'");
  expect_bad("orthographic", f("near_clip", "0"), "near_clip");
  expect_bad("fisheye", "", "unknown sensor 'fisheye' (supported: perspective, thinlens, orthographic)");
}

// ---- the camera seen from the scene (importance.h) ----

// A pinhole of 90° across with its principal point moved, and the tilted
// thin lens; `scaled`: the pinhole's frame stretched (x_axis × 2, y_axis ×
// 0.75), which changes the directions its film sees and |det M| (1.5).
Camera offset_pinhole(bool scaled) {
  Camera c = tilted_lens(0.f, 1.f);
  c.type = CameraType::Perspective;
  c.tan_half_x = 1.f;
  c.tan_half_y = 0.75f;
  c.edge_x = 1.f - 2.f * 0.1f;
  c.edge_y = 1.f - 2.f * -0.05f;
  if (scaled) {
    c.x_axis = c.x_axis * 2.f;
    c.y_axis = c.y_axis * 0.75f;
  }
  return c;
}

// A point on the camera ray of film position (fx, fy) and lens sample u
// connects back to that film position, through the ray's own lens point.
TEST(CameraImportance, ConnectionFindsTheFilmPositionOfItsRay) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  for (const Camera& cam : {offset_pinhole(false), offset_pinhole(true), tilted_lens(0.2f, 5.f)}) {
    double worst = 0;
    for (int k = 0; k < 2000; ++k) {
      const float fx = uni(rng) * cam.width, fy = uni(rng) * cam.height;
      const Vec2 u{uni(rng), uni(rng)};
      const Ray r = cam.generate_ray(fx, fy, u);
      const Vec3 x = r.o + r.d * (0.5f + 20.f * uni(rng));
      const luz::CameraConnection c = luz::camera_connect(cam, x, u);
      ASSERT_TRUE(c.valid) << k;
      EXPECT_GT(c.importance, 0.f);
      worst = std::max({worst, std::fabs(double(c.fx) - fx), std::fabs(double(c.fy) - fy)});
      EXPECT_LT(luz::length(c.p_lens - r.o), 1e-5f);
      EXPECT_LT(luz::length(c.wi + r.d), 1e-4f);
    }
    EXPECT_LT(worst, 2e-3) << "pixels, type " << int(cam.type);
  }
  // Behind the lens, and the orthographic camera: no connection.
  const Camera pin = offset_pinhole(false);
  EXPECT_FALSE(luz::camera_connect(pin, pin.origin - pin.z_axis).valid);
  Camera ortho = pin;
  ortho.type = CameraType::Orthographic;
  EXPECT_FALSE(luz::camera_connect(ortho, ortho.origin + ortho.z_axis).valid);
}

// Film-normalised importance: over the directions from a lens point, the
// importance (times dist², per steradian) integrates to one. Directions
// uniform in a cone of half-angle 75° about the axis, which holds every
// film here; the estimate's own standard error sets the bound (z < 4.5).
TEST(CameraImportance, IntegratesToOneOverTheFilm) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  const double cos_max = std::cos(75.0 * M_PI / 180.0), cone = 2 * M_PI * (1 - cos_max);
  for (const Camera& cam : {offset_pinhole(false), offset_pinhole(true), tilted_lens(0.2f, 5.f)}) {
    constexpr int kN = 400000;
    double sum = 0, sum2 = 0;
    for (int k = 0; k < kN; ++k) {
      const Vec2 u{uni(rng), uni(rng)};
      const double z = 1 - uni(rng) * (1 - cos_max), phi = 2 * M_PI * uni(rng), r = std::sqrt(1 - z * z);
      // The cone about the camera's axis (the unit direction M (0, 0, 1)).
      const Vec3 axis = luz::normalize(cam.z_axis), t = luz::normalize(luz::cross(axis, Vec3{0.f, 1.f, 0.f})),
                 b = luz::cross(axis, t);
      const Vec3 w = t * float(r * std::cos(phi)) + b * float(r * std::sin(phi)) + axis * float(z);
      const luz::CameraConnection probe = luz::camera_connect(cam, cam.origin + cam.z_axis, u);
      const float dist = 3.f;
      const luz::CameraConnection c = luz::camera_connect(cam, probe.p_lens + w * dist, u);
      const double v = c.valid ? double(c.importance) * dist * dist * cone : 0.0;
      sum += v;
      sum2 += v * v;
    }
    const double mean = sum / kN, se = std::sqrt(std::max(0.0, sum2 / kN - mean * mean) / kN);
    EXPECT_LT(std::fabs(mean - 1), 4.5 * se) << "type " << int(cam.type) << ": " << mean << " ± " << se;
    EXPECT_LT(se, 0.01);  // the test can tell a cos⁴ Jacobian from cos³ (a few percent here)
  }
}

}  // namespace

// A crop window keeps its pixels' rays: the cropped film's position (fx,
// fy) sees what (fx + x0, fy + y0) saw, for the thin lens (lens samples
// too), a pinhole with its principal point moved, and the orthographic view.
TEST(Camera, CropKeepsItsPixelsRays) {
  Camera ortho = offset_pinhole(true);
  ortho.type = CameraType::Orthographic;
  for (const Camera& full : {tilted_lens(0.2f, 4.f), offset_pinhole(false), ortho}) {
    Camera c = full;
    c.crop(5, 7, 20, 11);
    ASSERT_EQ(c.width, 20);
    ASSERT_EQ(c.height, 11);
    for (float fx : {0.f, 3.25f, 20.f})
      for (float fy : {0.f, 10.5f, 11.f})
        for (Vec2 u : {Vec2{0.5f, 0.5f}, Vec2{0.1f, 0.8f}}) {
          const Ray a = c.generate_ray(fx, fy, u), b = full.generate_ray(fx + 5.f, fy + 7.f, u);
          for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(a.d[k], b.d[k], 2e-6f) << fx << " " << fy;
            EXPECT_NEAR(a.o[k], b.o[k], 2e-6f) << fx << " " << fy;
          }
        }
  }
}
