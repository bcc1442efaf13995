// Texture coordinates of the built-in shapes that have none in a file
// (geometry/shapes.h sphere_uv, the Mitsuba reader's cube), against the
// source renderers' definitions:
// - Mitsuba 3's sphere: uv = (φ / 2π, θ / π) of the hit in the sphere's
//   object space (to_world · translate(center) · scale(radius)), so a
//   rotation, and a mirror, in to_world turn the texture;
// - pbrt-v4's full sphere: u = φ / 2π, v = (θ − θzmin) / (θzmax − θzmin)
//   in the CTM's object space, which Luz holds as (u, 1 − v) as for every
//   pbrt shape (texture.h's convention);
// - Mitsuba 3's cube: every face onto [0, 1]², laid out as its cube plugin's
//   vertex table.
// Each at hits found by tracing (Embree) toward many points of the shape,
// and through SceneView::hit_uv; a sphere's uv also through the alpha test
// (material/opacity.h) of both tracers: a mask's checkerboard of opacity 0
// and 1 cuts the squares it says.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "luz/accel/bvh_build.h"
#include "luz/accel/embree_tracer.h"
#include "luz/io/load.h"
#include "geometry_helpers.h"
#include "sphere_helpers.h"
#include "temp_dir.h"

using namespace luz;
using luz_test::Affine;
using luz_test::Duv;
using luz_test::Dvec;

namespace {

const std::string kTextured = R"(<bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf>)";

std::string mitsuba_scene(const std::string& shapes) {
  return R"(<scene version="3.0.0"><sensor type="perspective"/>)" + shapes + "</scene>";
}

// u differs across the seam φ = 0: compare on the circle.
double u_distance(double a, double b) {
  const double d = std::fabs(a - b);
  return std::fmin(d, 1.0 - d);
}

// Traces toward `count` points of the sphere (object-space directions from a
// fixed random sequence, plus the poles and points of the equator) and
// expects SceneView::hit_uv and the alpha test's uv to be `want` of each
// point's object-space direction.
void expect_sphere_uv(const Scene& s, const Affine& object_to_world, Duv (*want)(Dvec), bool pbrt_flip, int count) {
  ASSERT_EQ(s.spheres.size(), 1u);
  EmbreeScene embree(s);
  const EmbreeTracer tracer = embree.tracer();
  const SceneView v = s.view();
  luz_test::Rng rng(7);
  const Dvec c = object_to_world.point({});
  int checked = 0;
  double worst = 0;
  for (int k = 0; k < count + 6; ++k) {
    Dvec l;
    if (k < 2) l = {0, 0, k == 0 ? 1.0 : -1.0};  // the poles
    else if (k < 6) l = luz_test::sphere_dir(M_PI / 2, (k - 2) * M_PI / 2 + 0.3);
    else l = luz_test::sphere_dir(std::acos(1 - 2 * double(rng.uniform())), 2 * M_PI * double(rng.uniform()));
    const Dvec p = object_to_world.point(l), n = luz_test::unit(p - c);
    Ray ray;
    ray.o = luz_test::vec3(p + 3.0 * n);
    ray.d = luz_test::vec3(-1.0 * n);
    Hit hit;
    ASSERT_TRUE(tracer.intersect(ray, hit)) << k;
    ASSERT_EQ(hit.kind, PrimKind::Sphere);
    const Interaction it = v.interaction(ray, hit);
    const Vec2 uv = v.hit_uv(hit, it.p);
    Duv w = want(l);
    if (pbrt_flip) w.v = 1.0 - w.v;
    // Float rounding of the hit point moves the angles by ~1e-7 / sin θ; at
    // a pole u is undefined (any φ) and v off by the square root of it.
    const double sin_theta = std::sqrt(l.x * l.x + l.y * l.y), tol = 2e-5 + 1e-6 / std::fmax(sin_theta, 1e-3);
    const bool pole = k < 2;
    const double du = u_distance(uv.x, w.u), dv = std::fabs(uv.y - w.v);
    worst = std::fmax(worst, std::fmax(pole ? 0.0 : du, dv));
    if (!pole) EXPECT_LT(du, tol) << "point " << k << ": u " << uv.x << " vs " << w.u;
    EXPECT_LT(dv, tol) << "point " << k << ": v " << uv.y << " vs " << w.v;
    ++checked;
  }
  std::printf("%d sphere points, worst uv error %.2g\n", checked, worst);
}

}  // namespace

using ShapeUv = TempDirTest;

// A sphere of center c and radius r under a rotation, a uniform scale and a
// translation (and the same with a mirror): the uv is the object space's.
TEST_F(ShapeUv, MitsubaSphereUvIsTheObjectSpaceAngles) {
  const Dvec center{0.3, -0.2, 0.5};
  const double radius = 0.7;
  for (bool mirror : {false, true}) {
    SCOPED_TRACE(mirror ? "mirrored to_world" : "rotated to_world");
    Affine to_world = Affine::translate({1, -2, 3}) * Affine::scale({1.5, 1.5, 1.5}) *
                      Affine::rotate({1, 2, 0.5}, 50) * Affine::rotate({0, 0, 1}, 20);
    if (mirror) to_world = to_world * Affine::scale({1, -1, 1});
    char cr[160];
    std::snprintf(cr, sizeof cr, R"(<point name="center" x="%.17g" y="%.17g" z="%.17g"/><float name="radius" value="%.17g"/>)",
                  center.x, center.y, center.z, radius);
    const Scene s = load_scene(
        write("s.xml", mitsuba_scene("<shape type=\"sphere\">" + std::string(cr) + to_world.mitsuba() + kTextured + "</shape>")));
    // Mitsuba 3: to_world · translate(center) · scale(radius).
    const Affine object_to_world = to_world * Affine::translate(center) * Affine::scale({radius, radius, radius});
    expect_sphere_uv(s, object_to_world, luz_test::mitsuba_sphere_uv, false, 400);
  }
  // Without a to_world the axes are the world's: a direct check of the convention.
  const Scene s = load_scene(write("p.xml", mitsuba_scene("<shape type=\"sphere\">" + kTextured + "</shape>")));
  const SceneView v = s.view();
  Hit hit;
  hit.kind = PrimKind::Sphere;
  EXPECT_NEAR(v.hit_uv(hit, {0, 1, 0}).x, 0.25f, 1e-6f);  // φ = π/2
  EXPECT_NEAR(v.hit_uv(hit, {0, 1, 0}).y, 0.5f, 1e-6f);
  EXPECT_NEAR(v.hit_uv(hit, {-0.6f, 0, 0.8f}).x, 0.5f, 1e-6f);  // φ = π, cos θ = 0.8
  EXPECT_NEAR(v.hit_uv(hit, {-0.6f, 0, 0.8f}).y, std::acos(0.8) / M_PI, 1e-6);
  EXPECT_NEAR(v.hit_uv(hit, {0, -1, 0}).x, 0.75f, 1e-6f);
}

// pbrt-v4: the CTM (translate, rotate, uniform scale, applied right to left
// to the object) places the sphere of `radius` at the origin; v is
// pbrt's flipped. A mirroring CTM mirrors the uv too.
TEST_F(ShapeUv, PbrtSphereUvIsTheObjectSpaceAnglesWithVFlipped) {
  for (bool mirror : {false, true}) {
    SCOPED_TRACE(mirror ? "mirrored CTM" : "rotated CTM");
    const std::string file = write("s.pbrt", std::string(R"(Camera "perspective"
WorldBegin
Texture "c" "spectrum" "checkerboard"
Material "diffuse" "texture reflectance" "c"
AttributeBegin
Translate 1 -2 3
Rotate 50 1 2 0.5
Scale 1.5 1.5 1.5
)") + (mirror ? "Scale 1 -1 1\n" : "") + R"(Shape "sphere" "float radius" 0.7
AttributeEnd
)");
    const Scene s = load_scene(file);
    Affine ctm = Affine::translate({1, -2, 3}) * Affine::rotate({1, 2, 0.5}, 50) * Affine::scale({1.5, 1.5, 1.5});
    if (mirror) ctm = ctm * Affine::scale({1, -1, 1});
    expect_sphere_uv(s, ctm * Affine::scale({0.7, 0.7, 0.7}), luz_test::pbrt_sphere_uv, true, 400);
  }
}

// Mitsuba 3's cube (src/shapes/cube.cpp): per face, the object-space corner
// at uv (0, 0) and those at (1, 0) and (0, 1), read off its vertex table.
TEST_F(ShapeUv, MitsubaCubeUvIsMitsuba3sLayout) {
  struct Face {
    Dvec normal, o, u, v;
  } faces[] = {
      {{0, -1, 0}, {-1, -1, -1}, {-1, -1, 1}, {1, -1, -1}},
      {{0, 1, 0}, {1, 1, 1}, {-1, 1, 1}, {1, 1, -1}},
      {{1, 0, 0}, {1, -1, 1}, {1, 1, 1}, {1, -1, -1}},
      {{0, 0, 1}, {-1, -1, 1}, {-1, 1, 1}, {1, -1, 1}},
      {{-1, 0, 0}, {-1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}},
      {{0, 0, -1}, {-1, 1, -1}, {-1, -1, -1}, {1, 1, -1}},
  };
  // Any affine to_world: the uv stays the object-space layout's.
  const Affine to_world = Affine::translate({0.5, 1, -2}) * Affine::rotate({0.3, -1, 2}, 70) * Affine::scale({2, 1, 0.5});
  const Scene s = load_scene(write("c.xml", mitsuba_scene("<shape type=\"cube\">" + to_world.mitsuba() + kTextured + "</shape>")));
  ASSERT_EQ(s.num_triangles(), 12u);
  ASSERT_EQ(s.uvs.size(), s.positions.size());
  EmbreeScene embree(s);
  const EmbreeTracer tracer = embree.tracer();
  const SceneView v = s.view();
  luz_test::Rng rng(3);
  int seen[6] = {};
  for (int f = 0; f < 6; ++f)
    for (int k = 0; k < 40; ++k) {
      const Face& fc = faces[f];
      const double a = 0.02 + 0.96 * rng.uniform(), b = 0.02 + 0.96 * rng.uniform();
      const Dvec q = fc.o + a * (fc.u - fc.o) + b * (fc.v - fc.o);  // at uv (a, b) on Mitsuba's face
      const Dvec p = to_world.point(q), out = to_world.point(q + 0.5 * fc.normal);
      Ray ray;
      ray.o = luz_test::vec3(out);
      ray.d = luz_test::vec3(p - out);
      Hit hit;
      ASSERT_TRUE(tracer.intersect(ray, hit));
      const Vec2 uv = v.hit_uv(hit, v.interaction(ray, hit).p);
      EXPECT_NEAR(uv.x, a, 1e-5) << "face " << f;
      EXPECT_NEAR(uv.y, b, 1e-5) << "face " << f;
      ++seen[f];
    }
  for (int f = 0; f < 6; ++f) EXPECT_EQ(seen[f], 40);
}

// A sphere masked by a checkerboard (opacity 0 in color0 squares, 1 in
// color1's; to_uv 4×2) under a rotated to_world: a ray toward a point of
// an opaque square stops there, one toward a cut-away square passes it
// (hitting the far side, or nothing), with Embree and with Luz's BVH.
TEST_F(ShapeUv, MaskOnASphereCutsWhereItsUvSays) {
  const Affine to_world = Affine::translate({0.2, 0.1, -0.3}) * Affine::rotate({1, 1, 0.2}, 80);
  const Scene s = load_scene(write("m.xml", mitsuba_scene(
      "<shape type=\"sphere\">" + to_world.mitsuba() +
      R"(<bsdf type="mask"><texture type="checkerboard" name="opacity"><float name="color0" value="0"/>
         <float name="color1" value="1"/><transform name="to_uv"><scale x="4" y="2"/></transform></texture>
         <bsdf type="diffuse"/></bsdf></shape>)")));
  EmbreeScene embree(s);
  const EmbreeTracer et = embree.tracer();
  const Bvh bvh = build_bvh(s.view());
  const BvhTracer bt = make_bvh_tracer(bvh, s.view());
  luz_test::Rng rng(29);
  int seen[2] = {};
  for (int k = 0; k < 400; ++k) {
    const Dvec l = luz_test::sphere_dir(std::acos(1 - 2 * double(rng.uniform())), 2 * M_PI * double(rng.uniform()));
    const Duv uv = luz_test::mitsuba_sphere_uv(l);
    const double a = 4 * uv.u - std::floor(4 * uv.u), b = 2 * uv.v - std::floor(2 * uv.v);
    auto near_edge = [](double f) { return std::fabs(f - 0.5) < 0.01 || f < 0.01 || f > 0.99; };
    if (near_edge(a) || near_edge(b)) continue;
    const bool opaque = (a > 0.5) == (b > 0.5);  // color1
    // Obliquely (the alpha test's uv must come from the hit, not the ray).
    const Dvec p = to_world.point(l), n = luz_test::unit(to_world.vector(l));
    const Dvec w = luz_test::unit(n + 0.8 * luz_test::unit(luz_test::cross(n, {0.3, 0.5, 0.8})));
    Ray ray;
    ray.o = luz_test::vec3(p + 3.0 * w);
    ray.d = luz_test::vec3(-1.0 * w);
    for (int tracer = 0; tracer < 2; ++tracer) {
      Hit hit;
      const bool found = tracer == 0 ? et.intersect(ray, hit) : bt.intersect(ray, hit);
      const bool at_point = found && std::fabs(hit.t - 3.f) < 1e-3f;  // the front, 3 along the ray
      EXPECT_EQ(at_point, opaque) << (tracer ? "bvh" : "embree") << ", point " << k << " uv " << uv.u << ", " << uv.v;
    }
    ++seen[opaque];
  }
  EXPECT_GT(seen[0], 100);
  EXPECT_GT(seen[1], 100);
}
