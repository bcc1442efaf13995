// SceneBuilder: the checks every format shares, each refusing with the
// place it was given; objects placed once flattened, others instanced.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "luz/io/error.h"
#include "luz/scene/scene_builder.h"
#include "luz/texture/texture.h"

namespace {

using luz::SceneBuilder;
using luz::SourceLoc;
using luz::TriangleMesh;

TriangleMesh quad() {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 2, 3, 0};
  return m;
}

// Runs f on a fresh builder; it must throw one InputError at file:7 naming `problem`.
template <class F>
void expect_refused(F f, const std::string& problem) {
  SceneBuilder b("scene.txt");
  try {
    f(b);
    ADD_FAILURE() << "accepted (wanted: " << problem << ")";
  } catch (const luz::InputError& e) {
    EXPECT_EQ(e.file(), "part.txt");
    EXPECT_EQ(e.line(), 7);
    EXPECT_NE(e.problem().find(problem), std::string::npos) << e.what() << " (wanted: " << problem << ")";
  }
}

const SourceLoc kAt{"part.txt", 7};

TEST(SceneBuilder, MeshChecks) {
  expect_refused([](SceneBuilder& b) {
    TriangleMesh m = quad();
    m.indices.push_back(0);
    b.add_mesh(kAt, m, b.default_material());
  }, "not a multiple of 3");
  expect_refused([](SceneBuilder& b) {
    TriangleMesh m = quad();
    m.indices[4] = 4;
    b.add_mesh(kAt, m, b.default_material());
  }, "index 4 (triangle 1) is out of range (4 vertices)");
  expect_refused([](SceneBuilder& b) {
    TriangleMesh m = quad();
    m.positions[2].y = NAN;
    b.add_mesh(kAt, m, b.default_material());
  }, "vertex 2 is not finite");
  expect_refused([](SceneBuilder& b) {
    TriangleMesh m = quad();
    m.positions[3].x = 2e18f;
    b.add_mesh(kAt, m, b.default_material());
  }, "vertex 3 is not finite or lies beyond 1e18");
  expect_refused([](SceneBuilder& b) {
    TriangleMesh m = quad();
    m.normals.resize(3);
    b.add_mesh(kAt, m, b.default_material());
  }, "normals for some vertices only");
  expect_refused([](SceneBuilder& b) { b.add_mesh(kAt, quad(), 5); }, "names no material");
}

TEST(SceneBuilder, TexturesNeedCoordinatesAndMasksDoNotEmit) {
  expect_refused([](SceneBuilder& b) {
    luz::MaterialDesc d;
    d.bindings.push_back({b.add_checkerboard(kAt, {0, 0, 0}, {1, 1, 1}, {}), luz::BsdfPart::Front,
                          luz::BsdfParam::Reflectance});
    b.add_mesh(kAt, quad(), b.add_material(kAt, d));
  }, "a textured material on a mesh without texture coordinates");
  expect_refused([](SceneBuilder& b) {
    luz::MaterialDesc d;
    d.opacity = 0.5f;
    luz::AreaEmission e;
    TriangleMesh m = quad();
    m.uvs.assign(4, {0.f, 0.f});
    b.add_mesh(kAt, m, b.add_material(kAt, d), &e);
  }, "a masked material on an emitting shape");
  expect_refused([](SceneBuilder& b) {
    luz::AreaEmission e;
    e.radiance.y = -1.f;
    b.add_mesh(kAt, quad(), b.default_material(), &e);
  }, "radiance must be finite and not negative");
  expect_refused([](SceneBuilder& b) {
    luz::AreaEmission e;
    e.texture = b.add_checkerboard(kAt, {0, 0, 0}, {1, 1, 1}, {});
    e.two_sided = true;
    b.add_sphere(kAt, {0, 0, 0}, 1.f, b.default_material(), &e);
  }, "a two-sided emitting sphere is not supported");
  // A sphere's object frame comes from its transform's columns: none from a singular one.
  expect_refused([](SceneBuilder& b) {
    luz::Matrix4 m;
    for (int c = 0; c < 3; ++c) m.m[0][c] = 1, m.m[1][c] = m.m[2][c] = 0;
    b.add_sphere(kAt, {0, 0, 0}, 1.f, b.default_material(), nullptr, false, m);
  }, "the sphere's transform is singular");
  expect_refused([](SceneBuilder& b) { b.add_checkerboard(kAt, {0, -1, 0}, {1, 1, 1}, {}); },
                 "checkerboard colours must be finite and not negative");
}

// Vertex colours: only on meshes that have them, in [0, 1], never read by
// an emitter, a normal or bump map or a spot light's projection.
TEST(SceneBuilder, VertexColourChecks) {
  auto colored = [](SceneBuilder& b, int32_t t) {
    luz::MaterialDesc d;
    d.bindings.push_back({t, luz::BsdfPart::Front, luz::BsdfParam::Reflectance});
    return b.add_material(kAt, d);
  };
  expect_refused([&](SceneBuilder& b) { b.add_mesh(kAt, quad(), colored(b, b.add_vertex_color_texture(kAt))); },
                 "a material reading vertex colours on a mesh without them");
  expect_refused([&](SceneBuilder& b) {
    TriangleMesh m = quad();
    m.colors.assign(4, {0.5f, 0.5f, 0.5f});
    m.colors[2].z = NAN;
    b.add_mesh(kAt, m, colored(b, b.add_vertex_color_texture(kAt)));
  }, "the colour of vertex 2 is not within [0, 1]");
  expect_refused([&](SceneBuilder& b) {
    TriangleMesh m = quad();
    m.colors.resize(3);
    b.add_mesh(kAt, m, b.default_material());
  }, "colours for some vertices only");
  expect_refused([&](SceneBuilder& b) {
    luz::MaterialDesc d;
    d.normal_map = b.add_vertex_color_texture(kAt);
    b.add_material(kAt, d);
  }, "a normal or bump map from vertex colours is not supported");
  expect_refused([&](SceneBuilder& b) {
    luz::AreaEmission e;
    e.texture = b.add_vertex_color_texture(kAt);
    TriangleMesh m = quad();
    m.colors.assign(4, {1.f, 1.f, 1.f});
    b.add_mesh(kAt, m, b.default_material(), &e);
  }, "an emitter's radiance from vertex colours is not supported");
  expect_refused([&](SceneBuilder& b) {
    luz::SpotLight spot;
    spot.texture = b.add_vertex_color_texture(kAt);
    b.add_light(kAt, luz::Light(spot));
  }, "a spot light's texture must be an image or checkerboard");
  expect_refused([](SceneBuilder& b) { b.add_vertex_color_texture(kAt, {1.f, -1.f, 1.f}); },
                 "a vertex colour's scale must be finite and not negative");
  // Accepted: colours on a mesh whose material does not read them (kept,
  // white elsewhere), and a reading material where they are.
  SceneBuilder b("scene.txt");
  TriangleMesh m = quad();
  m.colors.assign(4, {0.25f, 0.5f, 1.f});
  b.add_mesh(kAt, m, b.default_material());
  b.add_mesh(kAt, quad(), b.default_material());
  b.add_mesh(kAt, m, colored(b, b.add_vertex_color_texture(kAt)));
  EXPECT_EQ(b.scene().colors.size(), 12u);
  EXPECT_EQ(b.scene().colors[5].x, 1.f);
  EXPECT_EQ(b.scene().colors[9].x, 0.25f);
}

// Mix and product textures (pbrt's mix and scale) of two checkerboards, one
// of twice the other's frequency: over the unit square their patterns are
// independent, each colour on half of it, so the mean of a mix by w is the
// mix of the means and the mean of a product the product of the means; the
// bounds are the operands' (mix) and their interval product (product).
TEST(SceneBuilder, MixAndProductTexturesTheirStatistics) {
  SceneBuilder b("scene.txt");
  const luz::Color a0{0.2f, 0.4f, 0.6f}, a1{1.f, 0.f, 0.f}, b0{0.f, 0.f, 0.f}, b1{0.5f, 0.5f, 0.5f};
  const int32_t ta = b.add_checkerboard(kAt, a0, a1, {});
  const int32_t tb = b.add_checkerboard(kAt, b0, b1, {2.f, 0.f, 0.f, 0.f, 2.f, 0.f});
  const luz::Color ma = (a0 + a1) * 0.5f, mb = (b0 + b1) * 0.5f;
  const int32_t mix = b.add_mix_texture(kAt, {ta, {}}, {tb, {}}, {-1, {0.25f, 0.25f, 0.25f}});
  const int32_t prod = b.add_product_texture(kAt, {ta, {}}, {tb, {}});
  const int32_t half = b.add_scaled_texture(kAt, mix, {0.5f, 0.5f, 0.5f});
  const luz::TextureStats& sm = b.texture_stats(mix);
  const luz::TextureStats& sp = b.texture_stats(prod);
  const luz::TextureStats& sh = b.texture_stats(half);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(sm.mean[c], 0.75 * ma[c] + 0.25 * mb[c], 1e-6) << c;
    EXPECT_NEAR(sp.mean[c], ma[c] * mb[c], 1e-6) << c;
    EXPECT_NEAR(sh.mean[c], 0.5 * sm.mean[c], 1e-6) << c;
    EXPECT_EQ(sm.min[c], std::min({a0[c], a1[c], b0[c], b1[c]}));
    EXPECT_EQ(sm.max[c], std::max({a0[c], a1[c], b0[c], b1[c]}));
    EXPECT_EQ(sp.min[c], 0.f);  // b0 is black
    EXPECT_EQ(sp.max[c], std::max(a0[c], a1[c]) * 0.5f);
  }
  // The scaled mix evaluates to half the mix everywhere.
  const luz::Scene& scene = b.scene();
  luz::TextureView v;
  v.list = scene.textures.data();
  v.count = uint32_t(scene.textures.size());
  for (float u : {0.1f, 0.3f, 0.6f, 0.9f})
    for (float w : {0.2f, 0.7f}) {
      const luz::Color m = v.eval(uint32_t(mix), {u, w}), h = v.eval(uint32_t(half), {u, w});
      for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(h[c], 0.5f * m[c]);
    }

  expect_refused([](SceneBuilder& b) {
    const int32_t t = b.add_checkerboard(kAt, {0, 0, 0}, {1, 1, 1}, {});
    const int32_t m = b.add_mix_texture(kAt, {t, {}}, {-1, {1, 1, 1}}, {-1, {0.5f, 0.5f, 0.5f}});
    b.add_product_texture(kAt, {m, {}}, {t, {}});
  }, "a mix or scale texture whose operand is itself a mix or scale of textures is not supported");
  expect_refused([](SceneBuilder& b) {
    const int32_t t = b.add_checkerboard(kAt, {0, 0, 0}, {2, 2, 2}, {});
    b.add_mix_texture(kAt, {-1, {0, 0, 0}}, {-1, {1, 1, 1}}, {t, {}});
  }, "a mix texture's amount must lie in [0, 1]");
  expect_refused([](SceneBuilder& b) { b.add_mix_texture(kAt, {5, {}}, {-1, {1, 1, 1}}, {-1, {0.5f, 0.5f, 0.5f}}); },
                 "a texture operand names no texture");
}

TEST(SceneBuilder, LightsAndCamera) {
  expect_refused([](SceneBuilder& b) {
    b.add_light(kAt, luz::ConstantLight{});
    b.add_light(kAt, luz::ConstantLight{});
  }, "only one environment");
  expect_refused([](SceneBuilder& b) { b.add_sphere(kAt, {0, 0, 0}, -1.f, b.default_material()); },
                 "radius must be finite and positive");
  expect_refused([](SceneBuilder& b) {
    luz::Camera c;
    c.origin.x = INFINITY;
    b.set_camera(kAt, c);
  }, "too far from the origin");
  expect_refused([](SceneBuilder& b) {
    luz::Camera c;
    c.width = 0;
    b.set_camera(kAt, c);
  }, "film size");
  // A finished scene needs a shape and a camera; those errors name the scene file.
  SceneBuilder b("scene.txt");
  b.frame_bounds(16, 16);
  EXPECT_THROW(b.finish(), luz::InputError);
}

TEST(SceneBuilder, NonFiniteNormalsShadeFlatWithAWarning) {
  SceneBuilder b("scene.txt");
  TriangleMesh m = quad();
  m.normals.assign(4, {0, 0, 1});
  m.normals[1].x = NAN;
  b.add_mesh(kAt, m, b.default_material());
  b.frame_bounds(8, 8);
  luz::Scene s = b.finish();
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_EQ(s.warnings[0], "part.txt:7: warning: 1 vertex normal is not finite: shaded flat");
  EXPECT_EQ(s.normals[1].x, 0.f);
  EXPECT_EQ(s.normals[1].z, 0.f);
}

// An object placed once is flattened: the same positions (bit for bit) and
// normals as adding the transformed mesh directly.
TEST(SceneBuilder, AnObjectPlacedOnceIsItsFlattenedMeshes) {
  const luz::Matrix4 t = luz::Matrix4::translate({1, 2, 3}) * luz::Matrix4::rotate({0, 1, 1}, 30.0) *
                         luz::Matrix4::scale({2, 1, 0.5f});
  TriangleMesh m = quad();
  m.normals.assign(4, {0, 0, 1});

  SceneBuilder inst("a");
  const uint32_t mat = inst.default_material();
  const uint32_t obj = inst.begin_object(kAt, "quad");
  inst.add_object_mesh(kAt, obj, m, mat);
  inst.add_instance(kAt, obj, t);
  EXPECT_EQ(inst.num_instances(), 1u);
  inst.frame_bounds(8, 8);

  SceneBuilder flat("b");
  TriangleMesh m1 = m;
  for (luz::Vec3& p : m1.positions) p = t.point(p);
  for (luz::Vec3& n : m1.normals) n = t.normal(n);
  flat.add_mesh(kAt, m1, flat.default_material());
  flat.frame_bounds(8, 8);

  const luz::Scene a = inst.finish(), b = flat.finish();
  EXPECT_TRUE(a.objects.empty());
  EXPECT_EQ(a.flattened_instances, 1u);
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (size_t k = 0; k < a.positions.size(); ++k) {
    EXPECT_EQ(a.positions[k].x, b.positions[k].x);
    EXPECT_EQ(a.positions[k].y, b.positions[k].y);
    EXPECT_EQ(a.positions[k].z, b.positions[k].z);
    EXPECT_EQ(a.normals[k].x, b.normals[k].x);
    EXPECT_EQ(a.normals[k].z, b.normals[k].z);
  }
  EXPECT_EQ(a.indices, b.indices);
}

// An object placed twice is stored once and instanced; a placement by a
// singular map is flattened (it has no inverse to trace rays through).
TEST(SceneBuilder, AnObjectPlacedTwiceIsStoredOnce) {
  const luz::Matrix4 t = luz::Matrix4::translate({1, 2, 3}) * luz::Matrix4::rotate({0, 1, 1}, 30.0) *
                         luz::Matrix4::scale({-2, 1, 0.5f});
  SceneBuilder b("a");
  b.add_mesh(kAt, quad(), b.default_material());  // world triangles come first
  const uint32_t obj = b.begin_object(kAt, "quad");
  b.add_object_mesh(kAt, obj, quad(), b.default_material());
  b.add_instance(kAt, obj, t);
  b.add_instance(kAt, obj, luz::Matrix4::translate({0, 0, 5}));
  b.add_instance(kAt, obj, luz::Matrix4::scale({1, 0, 1}));
  b.frame_bounds(8, 8);
  const luz::Scene s = b.finish();
  EXPECT_EQ(s.num_triangles(), 2u + 2u);  // the world's quad and the flattened placement
  EXPECT_EQ(s.flattened_instances, 1u);
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].first_triangle, 4u);
  EXPECT_EQ(s.objects[0].num_triangles, 2u);
  EXPECT_EQ(s.objects[0].first_vertex, 8u);
  EXPECT_EQ(s.objects[0].num_vertices, 4u);
  EXPECT_EQ(s.num_instanced_triangles(), 4u);
  ASSERT_EQ(s.instances.size(), 2u);
  // to_object inverts to_world; the bounds hold every placed vertex.
  for (const luz::Instance& in : s.instances)
    for (uint32_t v = 8; v < 12; ++v) {
      const luz::Vec3 p = s.positions[v], w = in.to_world.point(p), back = in.to_object.point(w);
      EXPECT_NEAR(back.x, p.x, 1e-5f);
      EXPECT_NEAR(back.y, p.y, 1e-5f);
      EXPECT_NEAR(back.z, p.z, 1e-5f);
      EXPECT_GE(w.x, s.bounds_min.x);
      EXPECT_LE(w.z, s.bounds_max.z);
    }
  EXPECT_EQ(s.instances[1].to_world.m[2][3], 5.f);
  // Flattened, the instances become world triangles after the others.
  luz::Scene f = s;
  f.flatten_instances();
  f.compile();
  EXPECT_TRUE(f.objects.empty());
  EXPECT_EQ(f.num_triangles(), 8u);
  EXPECT_EQ(f.positions.size(), 16u);
  EXPECT_EQ(f.positions[12].z, 5.f);
  EXPECT_EQ(f.indices[3 * 6], 12u);
}

TEST(SceneBuilder, InstanceChecks) {
  expect_refused([](SceneBuilder& b) { b.add_instance(kAt, 0, luz::Matrix4{}); }, "no such object");
  expect_refused([](SceneBuilder& b) {
    const uint32_t o = b.begin_object(kAt, "o");
    b.add_instance(kAt, o, luz::Matrix4::translate({NAN, 0, 0}));
  }, "not finite");
  expect_refused([](SceneBuilder& b) {
    const uint32_t o = b.begin_object(kAt, "o");
    TriangleMesh m = quad();
    m.indices[2] = 9;
    b.add_object_mesh(kAt, o, m, b.default_material());
  }, "out of range");
  expect_refused([](SceneBuilder& b) {
    const uint32_t o = b.begin_object(kAt, "o");
    b.add_object_mesh(kAt, o, quad(), b.default_material());
    b.add_instance(kAt, o, luz::Matrix4::translate({0, 0, 2e18f}));
    b.add_instance(kAt, o, luz::Matrix4{});
    b.frame_bounds(8, 8);
  }, "beyond 1e18");
  {
    SceneBuilder e("scene.txt");
    const uint32_t o = e.begin_object(kAt, "empty");
    e.add_instance(kAt, o, luz::Matrix4{});
    e.add_instance(kAt, o, luz::Matrix4{});
    e.set_camera(kAt, luz::Camera{});
    EXPECT_THROW(e.finish(), luz::InputError);  // "scene.txt: the scene has no shapes"
  }
  // An empty object placed twice beside a mesh: an instance with nothing in it.
  SceneBuilder b("a");
  const uint32_t o = b.begin_object(kAt, "empty");
  b.add_instance(kAt, o, luz::Matrix4{});
  b.add_instance(kAt, o, luz::Matrix4::translate({1, 0, 0}));
  b.add_mesh(kAt, quad(), b.default_material());
  b.frame_bounds(8, 8);
  const luz::Scene s = b.finish();
  EXPECT_EQ(s.instances.size(), 2u);
  EXPECT_EQ(s.num_instanced_triangles(), 0u);
  EXPECT_EQ(s.bounds_max.x, 1.f);  // the quad's alone
}

}  // namespace
