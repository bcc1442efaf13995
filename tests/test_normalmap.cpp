// Mitsuba's normalmap and bumpmap (SceneView::perturbed_frame) against
// closed forms.
//
// A diffuse quad (albedo ρ, Mitsuba's rectangle: uv (0,0) at its (-1,-1)
// corner, u along its x, v along its y) seen from straight above, lit by one
// directional light of irradiance E from direction d, direct light only: a
// pixel's radiance is ρ/π · E · max(0, n'·(-d)), n' the perturbed normal.
// With a constant map n' is the same everywhere and the render has no
// randomness left (a delta light, one BSDF value), so every pixel must match
// to float rounding.
//   normalmap: n' = normalize(2 rgb - 1) in the frame (s, t, n), s = dp/du
//     normalised, t = n × s: tilting along u and along v on a rotated quad
//     tells the two tangents (and their signs) apart.
//   bumpmap: a height h rising linearly in u (a 4×1 float bitmap, clamp
//     wrap, bilinear: linear between the first and last texel centres) tilts
//     n' away from the rise by atan(scale · dh/du · |du/dp|).
// A flat map (0.5, 0.5, 1), or a constant height, renders the same image as
// no map, bit for bit. Bad input: one file:line error each.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "luz/io/image.h"
#include "luz/io/load.h"
#include "geometry_helpers.h"
#include "scene_helpers.h"
#include "sphere_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

constexpr int kRes = 16;
constexpr double kAlbedo = 0.5, kE = 2.0;
constexpr double kQuadScale = 10.0;  // the rectangle spans ±10: |dp/du| = |dp/dv| = 20

struct D3 {
  double x, y, z;
};
D3 operator+(D3 a, D3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
D3 operator*(double s, D3 a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
D3 unit(D3 a) { return (1.0 / std::sqrt(dot(a, a))) * a; }

// `bsdf`: the quad's bsdf element; the light shines along `dir`; the quad is
// turned by `rot_deg` about z.
std::string scene_xml(const std::string& bsdf, D3 dir, double rot_deg = 0.0) {
  char light[256];
  std::snprintf(light, sizeof light,
                R"(<emitter type="directional"><vector name="direction" x="%.9g" y="%.9g" z="%.9g"/>
    <rgb name="irradiance" value="%g"/></emitter>)",
                dir.x, dir.y, dir.z, kE);
  return R"(<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value=")" +
         std::to_string(kRes) + R"("/><integer name="height" value=")" + std::to_string(kRes) + R"("/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value=")" +
         std::to_string(kQuadScale) + R"("/><rotate z="1" angle=")" + std::to_string(rot_deg) + R"("/></transform>
    )" + bsdf + R"(
  </shape>
  )" + light + "\n</scene>\n";
}

const std::string kDiffuse = R"(<bsdf type="diffuse"><rgb name="reflectance" value=")" + std::to_string(kAlbedo) + R"("/></bsdf>)";

std::string normalmap(const std::string& file) {
  return R"(<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><string name="filename" value=")" + file +
         R"("/><boolean name="raw" value="true"/></texture>)" + kDiffuse + "</bsdf>";
}
std::string bumpmap(const std::string& file, double scale) {
  return R"(<bsdf type="bumpmap"><texture name="map" type="bitmap"><string name="filename" value=")" + file +
         R"("/><string name="wrap_mode" value="clamp"/></texture><float name="scale" value=")" + std::to_string(scale) +
         R"("/>)" + kDiffuse + "</bsdf>";
}

class NormalMap : public TempDirTest {
 protected:
  // A float bitmap (PFM: linear, exact) of w×h texels, texel (i, j) = f(i, j).
  std::string write_map(const std::string& name, int w, int h, const std::function<D3(int, int)>& f) {
    Image img;
    img.width = w, img.height = h;
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) {
        const D3 c = f(i, j);
        img.rgb.insert(img.rgb.end(), {float(c.x), float(c.y), float(c.z)});
      }
    const std::string path = (dir / name).string();
    write_image(path, img);
    return name;
  }
  // A constant normal map encoding the unit vector n (tangent frame).
  std::string write_normal(const std::string& name, D3 n) {
    return write_map(name, 2, 2, [&](int, int) { return D3{(n.x + 1) / 2, (n.y + 1) / 2, (n.z + 1) / 2}; });
  }
  Film render(const std::string& bsdf, D3 light_dir, double rot_deg = 0.0) {
    Scene s = load_scene(write("scene.xml", scene_xml(bsdf, light_dir, rot_deg)));
    return luz_test::render_finite(s);
  }
  // Every pixel equals ρ/π · E · max(0, n·(-d)) to float rounding.
  static void expect_uniform(const Film& f, double want) {
    for (size_t i = 0; i < f.count.size(); ++i)
      for (int c = 0; c < 3; ++c) {
        const double mean = f.sum[3 * i + c] / f.count[i];
        ASSERT_NEAR(mean, want, 1e-5 * want + 1e-9) << "pixel " << i % kRes << "," << i / kRes;
      }
  }
  static double lambert(D3 n, D3 light_dir) { return kAlbedo / M_PI * kE * std::max(0.0, -dot(unit(n), unit(light_dir))); }
  // The shading frame at hits on the quad's two triangles, seen from
  // straight above, within the ramp's linear part (u in (0.15, 0.85)): its
  // normal is `want`, it.ns follows it (light sampling reads it), and its
  // tangent stays along dp/du, within `tilt` of it.
  static void expect_frame(const Scene& s, D3 want, double tilt) {
    const SceneView v = s.view();
    ASSERT_EQ(v.num_triangles, 2u);
    int checked = 0;
    for (uint32_t prim = 0; prim < 2; ++prim)
      for (float bu : {0.2f, 0.45f})
        for (float bv : {0.1f, 0.3f}) {
          Hit hit;
          hit.prim = prim, hit.u = bu, hit.v = bv, hit.t = 4.f;
          Ray ray{{0, 0, 4}, {0, 0, -1}};
          Interaction it = v.interaction(ray, hit);
          const Vec2 uv = v.hit_uv(hit, it.p);
          if (!(uv.x > 0.15f && uv.x < 0.85f)) continue;
          const Frame fr = v.shading_frame(it, hit);
          EXPECT_NEAR(fr.n.x, want.x, 1e-5) << prim << " " << bu << " " << bv;
          EXPECT_NEAR(fr.n.y, want.y, 1e-5);
          EXPECT_NEAR(fr.n.z, want.z, 1e-5);
          EXPECT_EQ(it.ns.x, fr.n.x);
          EXPECT_NEAR(dot(fr.s, fr.n), 0.f, 1e-6f);
          EXPECT_GT(fr.s.x, 0.99f * std::cos(tilt));
          ++checked;
        }
    EXPECT_GE(checked, 4);
  }
};

}  // namespace

TEST_F(NormalMap, FlatMapsRenderTheSameImageAsNone) {
  const D3 d{0.3, -0.2, -1.0};
  const Film plain = render(kDiffuse, d);
  const Film flat = render(normalmap(write_normal("flat.pfm", {0, 0, 1})), d);
  const Film level = render(bumpmap(write_map("level.pfm", 4, 1, [](int, int) { return D3{0.3, 0.3, 0.3}; }), 5.0), d);
  EXPECT_EQ(plain.sum, flat.sum);
  EXPECT_EQ(plain.sum, level.sum);
  expect_uniform(plain, lambert({0, 0, 1}, d));
}

// Tilts of 30° along +u, +v and -u on a quad turned 35° about z: s = (cos 35°,
// sin 35°, 0), t = (-sin 35°, cos 35°, 0). The light has different s and t
// components, so a swapped or reversed tangent changes the cosine.
TEST_F(NormalMap, TiltedNormalFollowsTheTangentFrame) {
  const double rot = 35.0 * M_PI / 180.0, th = 30.0 * M_PI / 180.0;
  const D3 s{std::cos(rot), std::sin(rot), 0}, t{-std::sin(rot), std::cos(rot), 0}, n{0, 0, 1};
  const D3 d = unit(-1.0 * (0.6 * s + 0.15 * t + n));  // the light comes from above, towards +s, a little +t
  struct Case {
    const char* name;
    D3 local;
  } cases[] = {{"u", {std::sin(th), 0, std::cos(th)}},
               {"v", {0, std::sin(th), std::cos(th)}},
               {"minus_u", {-std::sin(th), 0, std::cos(th)}},
               {"minus_v", {0, -std::sin(th), std::cos(th)}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Film f = render(normalmap(write_normal(std::string(c.name) + ".pfm", c.local)), d, 35.0);
    const D3 world = c.local.x * s + c.local.y * t + c.local.z * n;
    expect_uniform(f, lambert(world, d));
  }
  // The four differ from each other and from the flat quad: the test sees the frame.
  EXPECT_GT(std::fabs(lambert({std::sin(th), 0, std::cos(th)}, {-0.6, -0.15, -1}) -
                      lambert({0, std::sin(th), std::cos(th)}, {-0.6, -0.15, -1})),
            0.05);
}

// h(u) = 0.25 i at texel i's centre ((i + 0.5) / 4): dh/du = 1 between the
// first and last centres, where the whole view lies (u in [0.38, 0.62]).
// tan(tilt) = scale · 1 / |dp/du| = scale / 20, away from the rise (-x).
TEST_F(NormalMap, BumpRampTiltsTheNormalByItsSlope) {
  const double scale = 20.0 * std::tan(25.0 * M_PI / 180.0);
  const std::string ramp = write_map("ramp.pfm", 4, 1, [](int i, int) { return D3{0.25 * i, 0.25 * i, 0.25 * i}; });
  const std::string xml = scene_xml(bumpmap(ramp, scale), {0, 0, -1});
  const D3 want = unit({-scale / 20.0, 0, 1});
  expect_frame(load_scene(write("frame.xml", xml)), want, 25.0 * M_PI / 180.0);
  // Rendered: lit from the side the normal turns to, and from the other.
  for (D3 d : {D3{0.5, 0.1, -1}, D3{-0.4, 0.2, -1}}) {
    const Film f = render(bumpmap(ramp, scale), d);
    expect_uniform(f, lambert(want, d));
  }
}

// On a sphere (radius r, rotated and moved by to_world) the maps use
// sphere_uv's parametrisation (Mitsuba 3's sphere): at the object-space
// direction l = (θ, φ), with N the outward normal, φ̂ and θ̂ the unit
// directions of growing φ and θ (R: to_world's rotation),
//   dp/du = 2π r sin θ φ̂,  dp/dv = π r θ̂.
// normalmap: n' = a φ̂ + b (N × φ̂) + c N for the map's (a, b, c);
// bumpmap: n' ∝ N − g_u dp/du / |dp/du|² − g_v dp/dv / |dp/dv|² (the
// surface gradient of the height, dp/du ⟂ dp/dv), g the scaled height's uv
// gradient: a ramp along u (4×1) or along v (1×4), slope 1 per unit of uv
// between the first and last texel centres. At many points, and finite at
// the poles, where dp/du vanishes.
class SphereMaps : public NormalMap {
 protected:
  const luz_test::Affine to_world =
      luz_test::Affine::translate({0.3, -0.4, 0.2}) * luz_test::Affine::rotate({1, 0.6, -0.2}, 65);
  static constexpr double kRadius = 0.8;

  Scene sphere_scene(const std::string& bsdf, bool rotated = true) {
    const std::string xml = R"(<scene version="3.0.0"><sensor type="perspective"/><shape type="sphere">
      <float name="radius" value="0.8"/>)" + (rotated ? to_world.mitsuba() : std::string()) + bsdf + "</shape></scene>";
    return load_scene(write("sphere.xml", xml));
  }
  // The shading frame at the sphere's point of object-space angles (θ, φ)
  // against `want`(N, φ̂, θ̂, sin θ); uv within (0.15, 0.85) along `axis`
  // (0: u, 1: v) or anywhere (-1).
  void expect_sphere_frame(const Scene& s, int axis,
                           const std::function<luz_test::Dvec(luz_test::Dvec, luz_test::Dvec, luz_test::Dvec, double)>& want) {
    const SceneView v = s.view();
    luz_test::Rng rng(23);
    int checked = 0;
    for (int k = 0; k < 300; ++k) {
      const double theta = std::acos(1 - 2 * double(rng.uniform())), phi = 2 * M_PI * double(rng.uniform());
      const luz_test::Dvec l = luz_test::sphere_dir(theta, phi);
      const luz_test::Duv uv = luz_test::mitsuba_sphere_uv(l);
      if (axis >= 0 && !((axis ? uv.v : uv.u) > 0.15 && (axis ? uv.v : uv.u) < 0.85)) continue;
      if (std::sin(theta) < 0.05) continue;  // the float hit point's φ is too uncertain there
      const luz_test::Dvec N = luz_test::unit(to_world.vector(l));
      const luz_test::Dvec e_phi = luz_test::unit(to_world.vector({-std::sin(phi), std::cos(phi), 0}));
      const luz_test::Dvec e_theta = luz_test::unit(
          to_world.vector({std::cos(theta) * std::cos(phi), std::cos(theta) * std::sin(phi), -std::sin(theta)}));
      Ray ray;
      Hit hit;
      luz_test::sphere_hit_at(0, to_world.point(kRadius * l), N, ray, hit);
      Interaction it = v.interaction(ray, hit);
      const Frame fr = v.shading_frame(it, hit);
      const luz_test::Dvec w = luz_test::unit(want(N, e_phi, e_theta, std::sin(theta)));
      ASSERT_NEAR(fr.n.x, w.x, 2e-5) << k << " theta " << theta << " phi " << phi;
      ASSERT_NEAR(fr.n.y, w.y, 2e-5) << k;
      ASSERT_NEAR(fr.n.z, w.z, 2e-5) << k;
      ASSERT_EQ(it.ns.x, fr.n.x);
      ++checked;
    }
    EXPECT_GT(checked, 100);
  }
  // At both poles of an unrotated sphere (local x = y = 0 exactly): a unit,
  // finite frame whose normal keeps the map's angle to N where `cos_tilt` is
  // given.
  void expect_finite_poles(const Scene& s, double cos_tilt) {
    const SceneView v = s.view();
    for (double z : {1.0, -1.0}) {
      Ray ray;
      Hit hit;
      luz_test::sphere_hit_at(0, {0, 0, kRadius * z}, {0, 0, z}, ray, hit);
      Interaction it = v.interaction(ray, hit);
      const Frame fr = v.shading_frame(it, hit);
      for (Vec3 a : {fr.s, fr.t, fr.n}) {
        ASSERT_TRUE(std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z)) << "pole " << z;
        EXPECT_NEAR(length(a), 1.f, 1e-5f) << "pole " << z;
      }
      if (cos_tilt > -2) EXPECT_NEAR(fr.n.z * z, cos_tilt, 1e-5) << "pole " << z;
    }
  }
};

TEST_F(SphereMaps, NormalMapTiltsAlongTheSpheresTangents) {
  const double th = 30.0 * M_PI / 180.0;
  struct Case {
    const char* name;
    D3 local;
  } cases[] = {{"u", {std::sin(th), 0, std::cos(th)}}, {"v", {0, std::sin(th), std::cos(th)}},
               {"minus_u", {-std::sin(th), 0, std::cos(th)}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string map = normalmap(write_normal(std::string(c.name) + ".pfm", c.local));
    expect_sphere_frame(sphere_scene(map), -1, [&](luz_test::Dvec N, luz_test::Dvec e_phi, luz_test::Dvec, double) {
      return c.local.x * e_phi + c.local.y * luz_test::cross(N, e_phi) + c.local.z * N;
    });
    expect_finite_poles(sphere_scene(map, false), std::cos(th));
  }
}

TEST_F(SphereMaps, BumpRampsTiltAlongDpDuAndDpDv) {
  const double scale = 0.6;
  const std::string along_u = write_map("u.pfm", 4, 1, [](int i, int) { return D3{0.25 * i, 0.25 * i, 0.25 * i}; });
  const std::string along_v = write_map("v.pfm", 1, 4, [](int, int j) { return D3{0.25 * j, 0.25 * j, 0.25 * j}; });
  {
    SCOPED_TRACE("ramp along u");
    expect_sphere_frame(sphere_scene(bumpmap(along_u, scale)), 0,
                        [&](luz_test::Dvec N, luz_test::Dvec e_phi, luz_test::Dvec, double sin_theta) {
                          return N - (scale / (2 * M_PI * kRadius * sin_theta)) * e_phi;
                        });
    expect_finite_poles(sphere_scene(bumpmap(along_u, scale), false), -3);
  }
  {
    SCOPED_TRACE("ramp along v");
    expect_sphere_frame(sphere_scene(bumpmap(along_v, scale)), 1,
                        [&](luz_test::Dvec N, luz_test::Dvec, luz_test::Dvec e_theta, double) {
                          return N - (scale / (M_PI * kRadius)) * e_theta;
                        });
    expect_finite_poles(sphere_scene(bumpmap(along_v, scale), false), -3);
  }
}

// pbrt-v4's displacement is the same bump map at scale 1 (io/pbrt/scene.cpp),
// of its float texture: the first channel (as pbrt-v4's float image textures
// read it; green and blue differ here and must not count) times the
// imagemap's `scale`. The quad's uv spans it as the rectangle's does above:
// tan(tilt) = scale · 1 / 20.
TEST_F(NormalMap, PbrtDisplacementIsTheBumpOfItsFloatTexture) {
  write_map("red.pfm", 4, 1, [](int i, int) { return D3{0.25 * i, 0.9, 0.1 * i}; });
  for (double scale : {1.0, 8.0}) {
    const std::string file = write("bump.pbrt", R"(LookAt 0 0 4  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 16 "integer yresolution" 16
WorldBegin
LightSource "distant" "point3 from" [0 0 1] "point3 to" [0 0 0]
Texture "h" "float" "imagemap" "string filename" "red.pfm" "string wrap" "clamp" "float scale" )" +
                                                std::to_string(scale) + R"(
Material "diffuse" "texture displacement" "h"
Shape "trianglemesh" "point3 P" [-10 -10 0  10 -10 0  10 10 0  -10 10 0] "integer indices" [0 1 2  0 2 3]
  "point2 uv" [0 0  1 0  1 1  0 1]
)");
    Scene s = load_scene(file);
    EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
    SCOPED_TRACE("scale " + std::to_string(scale));
    expect_frame(s, unit({-scale / 20.0, 0, 1}), std::atan(scale / 20.0));
  }
}

// A normal map wins over displacement (pbrt-v4 uses it alone): said in a warning.
TEST_F(NormalMap, PbrtNormalMapWinsOverDisplacement) {
  write_map("h.pfm", 4, 1, [](int i, int) { return D3{0.25 * i, 0.25 * i, 0.25 * i}; });
  write_normal("n.pfm", unit({0.3, 0, 1}));
  const std::string file = write("both.pbrt", R"(Camera "perspective"
WorldBegin
LightSource "distant"
Texture "h" "float" "imagemap" "string filename" "h.pfm"
Material "diffuse" "texture displacement" "h" "string normalmap" "n.pfm"
Shape "trianglemesh" "point3 P" [-1 -1 0  1 -1 0  1 1 0] "integer indices" [0 1 2] "point2 uv" [0 0  1 0  1 1]
)");
  Scene s = load_scene(file);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("both.pbrt:5: warning: displacement is ignored: the material has a normalmap"),
            std::string::npos)
      << s.warnings[0];
  int mapped = 0;
  for (const Material& m : s.materials)
    if (m.normal_map >= 0) {
      EXPECT_LT(m.bump_map, 0);
      ++mapped;
    }
  EXPECT_EQ(mapped, 1);
}

TEST_F(NormalMap, BadInputIsRefused) {
  const std::string nm = write_normal("n.pfm", {0, 0, 1});
  const std::string ramp = write_map("ramp.pfm", 4, 1, [](int i, int) { return D3{0.25 * i, 0.25 * i, 0.25 * i}; });
  Image png;
  png.width = png.height = 2;
  png.rgb.assign(12, 0.5f);
  write_image((dir / "n.png").string(), png);
  const std::string tex = R"(<texture name="normalmap" type="bitmap"><string name="filename" value="n.pfm"/></texture>)";
  const std::string height = R"(<texture name="map" type="bitmap"><string name="filename" value="ramp.pfm"/></texture>)";
  struct Bad {
    std::string bsdf, problem;
  } bad[] = {
      {"<bsdf type=\"normalmap\">" + tex + "</bsdf>", "normalmap needs exactly one nested bsdf"},
      {"<bsdf type=\"normalmap\">" + kDiffuse + "</bsdf>", "normalmap needs a <texture name=\"normalmap\">"},
      {"<bsdf type=\"bumpmap\">" + height + "</bsdf>", "bumpmap needs exactly one nested bsdf"},
      {"<bsdf type=\"bumpmap\">" + kDiffuse + "</bsdf>", "bumpmap needs exactly one nested texture"},
      {R"(<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><string name="filename" value="n.png"/></texture>)" +
           kDiffuse + "</bsdf>",
       "the normalmap bitmap must be raw"},
      {R"(<bsdf type="bumpmap"><texture name="map" type="checkerboard"/>)" + kDiffuse + "</bsdf>",
       "bumpmap needs a bitmap height map"},
      {"<bsdf type=\"twosided\"><bsdf type=\"normalmap\">" + tex + kDiffuse + "</bsdf></bsdf>",
       "a normalmap or bumpmap inside a twosided is not supported"},
      {"<bsdf type=\"blendbsdf\"><bsdf type=\"bumpmap\">" + height + kDiffuse + "</bsdf>" + kDiffuse + "</bsdf>",
       "a normalmap or bumpmap inside a blendbsdf is not supported"},
      {"<bsdf type=\"bumpmap\">" + height + "<bsdf type=\"normalmap\">" + tex + kDiffuse + "</bsdf></bsdf>",
       "a normalmap or bumpmap inside another is not supported"},
  };
  int k = 0;
  for (const Bad& b : bad) {
    SCOPED_TRACE(b.problem);
    const std::string xml = scene_xml(b.bsdf, {0, 0, -1});
    const std::string file = "bad" + std::to_string(k++) + ".xml";
    luz_test::expect_load_refused(write(file, xml), file, b.problem);
  }
}

// A map around a twosided or a blendbsdf (what Luz supports) loads and renders.
TEST_F(NormalMap, MapAroundTwosidedAndBlendLoads) {
  const std::string nm = write_normal("n.pfm", {0, 0, 1});
  const std::string tex = R"(<texture name="normalmap" type="bitmap"><string name="filename" value="n.pfm"/><boolean name="raw" value="true"/></texture>)";
  for (const std::string& inner : {"<bsdf type=\"twosided\">" + kDiffuse + "</bsdf>",
                                   "<bsdf type=\"blendbsdf\">" + kDiffuse + kDiffuse + "</bsdf>"}) {
    Scene s = load_scene(write("ok.xml", scene_xml("<bsdf type=\"normalmap\">" + tex + inner + "</bsdf>", {0, 0, -1})));
    ASSERT_FALSE(s.materials.empty());
    EXPECT_GE(s.materials.back().normal_map, 0);
    expect_uniform(luz_test::render_finite(s), lambert({0, 0, 1}, {0, 0, -1}));
  }
}
