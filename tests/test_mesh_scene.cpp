// Mesh files as scenes (OBJ, PLY) and a scene rendered at another size.
#include <gtest/gtest.h>

#include <array>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "scene_helpers.h"
#include "luz/io/image.h"
#include "luz/io/mesh_obj.h"
#include "luz/scene/scene_info.h"
#include "temp_dir.h"

namespace {

const std::string kBunny = LUZ_SHARED_DIR "/scenes/bunny/bun_zipper.ply";

// The bunny as a scene: all its triangles, a camera that frames it, the
// white sky announced by one warning, and an image with no lost sample in
// which the bunny covers the centre (darker than the sky around it).
TEST(MeshScene, PlyRendersUnderAWhiteSky) {
  luz::Scene s = luz::load_scene(kBunny);
  EXPECT_EQ(s.num_triangles(), 69451u);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("bun_zipper.ply: warning: no light in the file"), std::string::npos) << s.warnings[0];
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].type, luz::LightType::Constant);
  EXPECT_EQ(s.settings.sampler, luz::SamplerType::Sobol);  // the default where a scene names none
  s.set_resolution(32, 32);
  s.settings.spp = 4;
  luz::Film f = luz_test::render_finite(s);
  const std::vector<float> img = f.mean();
  auto at = [&](int x, int y) { return img[3 * size_t(y * 32 + x) + 1]; };
  EXPECT_EQ(at(0, 0), 1.f);           // the sky, seen directly: radiance 1
  EXPECT_LT(at(16, 18), 0.9f);        // the bunny: a diffuse 0.5 surface under it
}

// set_resolution keeps the field of view along the scene's axis and refits
// the other; at the same aspect ratio it changes nothing but the pixel count.
TEST(MeshScene, SetResolutionKeepsTheFieldOfViewAxis) {
  luz::Scene s;
  s.camera.width = 400, s.camera.height = 200;
  for (luz::FovAxis axis : {luz::FovAxis::X, luz::FovAxis::Y, luz::FovAxis::Diagonal, luz::FovAxis::Smaller,
                            luz::FovAxis::Larger}) {
    s.fov_axis = axis;
    s.camera.width = 400, s.camera.height = 200;
    luz::fit_fov(axis, 0.5, 400, 200, s.camera.tan_half_x, s.camera.tan_half_y);
    const float x0 = s.camera.tan_half_x, y0 = s.camera.tan_half_y;
    s.set_resolution(800, 400);
    EXPECT_FLOAT_EQ(s.camera.tan_half_x, x0);
    EXPECT_FLOAT_EQ(s.camera.tan_half_y, y0);
    s.set_resolution(100, 300);
    EXPECT_EQ(s.camera.width, 100);
    EXPECT_EQ(s.camera.height, 300);
    EXPECT_FLOAT_EQ(s.camera.tan_half_x / s.camera.tan_half_y, 100.f / 300.f);
    const double diag = std::hypot(double(s.camera.tan_half_x), double(s.camera.tan_half_y));
    switch (axis) {
      case luz::FovAxis::X: EXPECT_FLOAT_EQ(s.camera.tan_half_x, x0); break;
      case luz::FovAxis::Y: EXPECT_FLOAT_EQ(s.camera.tan_half_y, y0); break;
      case luz::FovAxis::Diagonal: EXPECT_NEAR(diag, 0.5, 1e-6); break;
      case luz::FovAxis::Smaller: EXPECT_FLOAT_EQ(s.camera.tan_half_x, 0.5f); break;  // was y, now x
      case luz::FovAxis::Larger: EXPECT_FLOAT_EQ(s.camera.tan_half_y, 0.5f); break;
    }
  }
}

class MeshSceneFiles : public TempDirTest {
 protected:
  // STEM.obj: one triangle per material of STEM.mtl (`mtl`), in the order of
  // `names` (with texture coordinates when `uvs`), loaded: its first three
  // materials are those.
  luz::Scene three_faces(const std::string& stem, const std::string& mtl, const std::array<std::string, 3>& names,
                         bool uvs) {
    write(stem + ".mtl", mtl);
    std::string obj = "mtllib " + stem + ".mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n" + (uvs ? "vt 0 0\nvt 1 0\nvt 0 1\n" : "");
    for (const std::string& n : names) obj += "usemtl " + n + (uvs ? "\nf 1/1 2/2 3/3\n" : "\nf 1 2 3\n");
    return luz::load_scene(write(stem + ".obj", obj));
  }
};

// A PLY scene's errors come from the reader, naming the file.
TEST_F(MeshSceneFiles, BadPlyIsRefused) {
  const std::string p = write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n");
  luz_test::expect_load_refused(p, "bad.ply", "face");
}

}  // namespace

namespace {

// An MTL's illum models, constants and maps as Luz materials: illum 5 the
// specification's Kd diffuse plus a Ks mirror (a blend: w = 0.9 / 0.91 of
// the largest values, each part divided by its weight), a mirror alone
// without Kd, diffuse without Ks; illum 7 and 6 glass; Blender's default
// Kd 0.8 + Ks 0.5 scaled to 1 with a warning.
// A PLY file with vertex colours rendered on its own: its diffuse
// reflectance is the colour interpolated at the hit (a float colour as
// written); without colours the default grey.
TEST_F(MeshSceneFiles, PlyVertexColoursAreItsReflectance) {
  const std::string p = write("c.ply",
                              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                              "property float z\nproperty float red\nproperty float green\nproperty float blue\n"
                              "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                              "0 0 0 1 0 0\n1 0 0 0 1 0\n0 1 0 0.2 0.4 0.6\n3 0 1 2\n");
  luz::Scene s = luz::load_scene(p);
  ASSERT_EQ(s.colors.size(), 3u);
  EXPECT_NE(luz::describe_scene(s).find("shapes: 1 triangle, 0 spheres, 0 instances, with vertex colours"), std::string::npos)
      << luz::describe_scene(s);
  const luz::SceneView v = s.view();
  luz::Hit hit;
  hit.prim = 0;
  hit.u = 0.25f, hit.v = 0.5f;  // weights 0.25, 0.25, 0.5 of vertices 0, 1, 2
  const luz::Bsdf b = v.materials.bsdf(s.tri_material[0], v.textures, {}, v.hit_color(hit));
  EXPECT_NEAR(b.diffuse.reflectance.x, 0.25f + 0.1f, 1e-6f);
  EXPECT_NEAR(b.diffuse.reflectance.y, 0.25f + 0.2f, 1e-6f);
  EXPECT_NEAR(b.diffuse.reflectance.z, 0.3f, 1e-6f);
  luz::Scene plain = luz::load_scene(write("p.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                          "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_TRUE(plain.colors.empty());
  EXPECT_EQ(plain.materials[plain.tri_material[0]].bsdf.diffuse.reflectance.y, 0.5f);
}

// OBJ vertex colours (`v x y z r g b`, sRGB-encoded as exporters write
// them): the faces without a material take them, decoded and interpolated,
// as their diffuse reflectance; a face with an MTL material keeps its Kd,
// with a warning; a `v` line without a colour is white (warned), one whose
// colour leaves [0, 1] is an error at its line.
TEST_F(MeshSceneFiles, ObjVertexColoursOnFacesWithoutAMaterial) {
  auto srgb = [](double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
  write("m.mtl", "newmtl red\nKd 0.6 0.1 0.1\n");
  // (A seventh number, an alpha, is ignored, as tinyobjloader reads it.)
  luz::Scene s = luz::load_scene(write("c.obj", "mtllib m.mtl\nv 0 0 0 1 0 0.2\nv 1 0 0 0 0.5 0.2 0.7\nv 0 1 0 0 0 1\nv 1 1 0\n"
                                                "f 1 2 3\nusemtl red\nf 2 4 3\n"));
  EXPECT_TRUE(luz_test::has_warning(s, "1 vertices lack a colour where others have one: white"));
  EXPECT_TRUE(luz_test::has_warning(s, "1 triangles have an MTL material: the vertex colours are not used there"));
  const luz::SceneView v = s.view();
  int seen = 0;
  for (uint32_t t = 0; t < s.num_triangles(); ++t) {
    luz::Hit hit;
    hit.prim = t;
    hit.u = 0.25f, hit.v = 0.5f;
    const luz::Bsdf b = v.materials.bsdf(s.tri_material[t], v.textures, {}, v.hit_color(hit));
    const luz::Vec3 p = s.positions[s.indices[3 * t]];
    if (p.x == 0.f && p.y == 0.f) {  // the first face: corners (1, 0, 0.2), (0, 0.5, 0.2), (0, 0, 1) in sRGB
      ++seen;
      EXPECT_NEAR(b.diffuse.reflectance.x, 0.25 * srgb(1), 1e-6);
      EXPECT_NEAR(b.diffuse.reflectance.y, 0.25 * srgb(0.5), 1e-6);
      EXPECT_NEAR(b.diffuse.reflectance.z, 0.25 * srgb(0.2) + 0.25 * srgb(0.2) + 0.5 * srgb(1), 1e-6);
    } else {
      EXPECT_EQ(b.phong.kd.x, 0.6f);  // the MTL's modified Phong
    }
  }
  EXPECT_EQ(seen, 1);
  // Colours outside [0, 1] (0-255 exporters): the file loads without them, with a warning.
  luz::Scene bad = luz::load_scene(write("bad.obj", "v 0 0 0\nv 1 0 0 0.5 255 0\nv 0 1 0\nf 1 2 3\n"));
  EXPECT_TRUE(bad.colors.empty());
  EXPECT_TRUE(luz_test::has_warning(bad, "bad.obj:2: warning: vertex colour '255' is not within [0, 1]: the file's vertex colours are not used"));
  // A PLY of face colours alone: each triangle shows its face's.
  luz::Scene faces = luz::load_scene(write("f.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                                    "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                                                    "property float r\nproperty float g\nproperty float b\nend_header\n"
                                                    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 1 0 0\n3 0 2 3 0 0.5 1\n"));
  ASSERT_EQ(faces.colors.size(), 6u);
  EXPECT_EQ(faces.colors[2].x, 1.f);
  EXPECT_EQ(faces.colors[3].y, 0.5f);
  EXPECT_EQ(faces.positions[4].y, 1.f);  // the second face (0, 2, 3): its own copy of corner (1, 1)
}

TEST_F(MeshSceneFiles, MtlIllumModelsAndConstants) {
  luz::Scene s = three_faces("m", "newmtl mirror\nKd 0.01 0.01 0.01\nKs 0.9 0.8 0.7\nillum 5\n"
                                  "newmtl glass\nKs 0.3 0.3 0.3\nTf 0.5 0.6 0.7\nNi 1.7\nillum 7\n"
                                  "newmtl cut\nKd 0.4\nd 0.25\n",
                             {"mirror", "glass", "cut"}, false);
  ASSERT_GE(s.materials.size(), 3u);
  const luz::Bsdf& mirror = s.materials[0].bsdf;
  const float w = 0.9f / 0.91f;
  ASSERT_TRUE(mirror.blend);
  EXPECT_FLOAT_EQ(mirror.blend_weight, w);
  EXPECT_EQ(mirror.type, luz::BsdfType::Diffuse);
  EXPECT_EQ(mirror.second.type, luz::BsdfType::SmoothConductor);
  // The blend is Kd/π + Ks δ: each part times its weight gives back Kd and Ks, both parts within [0, 1].
  EXPECT_NEAR((1 - mirror.blend_weight) * mirror.diffuse.reflectance.x, 0.01f, 1e-6f);
  EXPECT_NEAR(mirror.blend_weight * mirror.second.smooth_conductor.specular_reflectance.y, 0.8f, 1e-6f);
  EXPECT_LE(mirror.diffuse.reflectance.x, 1.f);
  EXPECT_LE(mirror.second.smooth_conductor.specular_reflectance.x, 1.f);
  const luz::Bsdf& glass = s.materials[1].bsdf;
  EXPECT_EQ(glass.type, luz::BsdfType::SmoothDielectric);
  EXPECT_FLOAT_EQ(glass.smooth_dielectric.specular_transmittance.z, 0.7f);
  EXPECT_FLOAT_EQ(glass.smooth_dielectric.specular_reflectance.x, 0.3f);
  EXPECT_FLOAT_EQ(glass.smooth_dielectric.eta, 1.7f);
  const luz::Material& cut = s.materials[2];
  EXPECT_EQ(cut.bsdf.type, luz::BsdfType::Diffuse);
  EXPECT_FLOAT_EQ(cut.bsdf.diffuse.reflectance.z, 0.4f);  // one number: a grey (tinyobjloader read g = b = 0)
  EXPECT_FLOAT_EQ(cut.opacity, 0.25f);

  luz::Scene t = three_faces("n", "newmtl pure\nKd 0 0 0\nKs 0.9 0.9 0.9\nillum 3\n"
                                  "newmtl plain\nKd 0.6 0.1 0.1\nKs 0 0 0\nillum 3\n"
                                  "newmtl spec8\nKd 0 0 0\nKs 0 0 0\nTf 1 1 1\nNi 1.2\nillum 6\n",
                             {"pure", "plain", "spec8"}, false);
  EXPECT_EQ(t.materials[0].bsdf.type, luz::BsdfType::SmoothConductor);
  EXPECT_FALSE(t.materials[0].bsdf.blend);
  EXPECT_FLOAT_EQ(t.materials[0].bsdf.smooth_conductor.specular_reflectance.x, 0.9f);
  EXPECT_EQ(t.materials[1].bsdf.type, luz::BsdfType::Diffuse);
  EXPECT_FLOAT_EQ(t.materials[1].bsdf.diffuse.reflectance.x, 0.6f);
  EXPECT_EQ(t.materials[2].bsdf.type, luz::BsdfType::SmoothDielectric);  // the MTL specification's example 8
  EXPECT_FLOAT_EQ(t.materials[2].bsdf.smooth_dielectric.eta, 1.2f);

  luz::Scene b = three_faces("b", "newmtl Material\nNs 250\nKa 1 1 1\nKd 0.8 0.8 0.8\nKs 0.5 0.5 0.5\nKe 0 0 0\n"
                                  "Ni 1.45\nd 1\nillum 2\n",
                             {"Material", "Material", "Material"}, false);
  EXPECT_EQ(b.materials[0].bsdf.type, luz::BsdfType::Phong);
  EXPECT_FLOAT_EQ(b.materials[0].bsdf.phong.kd.x, 0.8f / 1.3f);
  EXPECT_FLOAT_EQ(b.materials[0].bsdf.phong.ks.x, 0.5f / 1.3f);
  std::string all;
  for (const std::string& warning : b.warnings) all += warning + "\n";
  EXPECT_NE(all.find("material 'Material': Kd + Ks reaches 1.3"), std::string::npos) << all;
}

// A missing mtllib, an unknown usemtl and one before its mtllib are warnings
// at their lines; an mtllib line naming two files reads both.
TEST_F(MeshSceneFiles, MissingMaterialsAreWarnings) {
  const std::string obj = write("w.obj", "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl ghost\nf 1 2 3\n");
  luz::Scene s = luz::load_scene(obj);
  ASSERT_GE(s.warnings.size(), 2u);
  EXPECT_NE(s.warnings[0].find("w.obj:1: warning: mtllib 'none.mtl' not found"), std::string::npos) << s.warnings[0];
  EXPECT_NE(s.warnings[1].find("w.obj:5: warning: usemtl 'ghost': no such material"), std::string::npos)
      << s.warnings[1];
  // Two MTL files on one mtllib line: both read (tinyobjloader alone reads the first).
  write("one.mtl", "newmtl a\nKd 0.1 0.1 0.1\n");
  write("two.mtl", "newmtl b\nKd 0.2 0.2 0.2\n");
  luz::Scene both = luz::load_scene(write("both.obj", "mtllib one.mtl two.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n"
                                                      "usemtl b\nf 1 3 2\n"));
  ASSERT_GE(both.materials.size(), 2u);
  EXPECT_FLOAT_EQ(both.materials[0].bsdf.diffuse.reflectance.x, 0.1f);
  EXPECT_FLOAT_EQ(both.materials[1].bsdf.diffuse.reflectance.x, 0.2f);
  EXPECT_FALSE(luz_test::has_warning(both, "no such material"));
  write("late.mtl", "newmtl red\nKd 1 0 0\n");
  luz::Scene late = luz::load_scene(write("late.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\nmtllib late.mtl\n"));
  EXPECT_TRUE(luz_test::has_warning(late, "late.obj:4: warning: usemtl 'red' comes before any mtllib"));
}

// map_Kd on a quad facing the camera under the white sky: the image's black
// left half gives exactly black pixels (reflectance 0), its white right half
// lit ones, on the sides the texture coordinates put them. Without texture
// coordinates the map is dropped with a warning.
TEST_F(MeshSceneFiles, MapKdFollowsTheTextureCoordinates) {
  luz::Image tex{16, 1, {}};
  for (int x = 0; x < 16; ++x) tex.rgb.insert(tex.rgb.end(), 3, x < 8 ? 0.f : 1.f);
  luz::write_image((dir / "t.png").string(), tex);
  write("t.mtl", "newmtl tex\nKd 1 1 1\nmap_Kd t.png\n");
  // frame_bounds looks down -z with the image's left at world -x; u = 0 at
  // world x = +1, so the texture's black left half lands on the image's right.
  const std::string quad = "mtllib t.mtl\nv 1 -1 0\nv -1 -1 0\nv -1 1 0\nv 1 1 0\n";
  const std::string obj = write("t.obj", quad + "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl tex\nf 1/1 2/2 3/3 4/4\n");
  luz::Scene s = luz::load_scene(obj);
  ASSERT_EQ(s.materials[0].num_bindings, 1u);
  s.set_resolution(32, 32);
  s.settings.spp = 4;
  const std::vector<float> img = luz_test::render_finite(s).mean();
  auto px = [&](int x, int y) { return img[3 * size_t(y * 32 + x)]; };
  for (int x = 20; x < 27; ++x) EXPECT_EQ(px(x, 16), 0.f) << x;
  for (int x = 5; x < 12; ++x) EXPECT_GT(px(x, 16), 0.2f) << x;

  const std::string bare = write("b.obj", quad + "usemtl tex\nf 1 2 3 4\n");
  luz::Scene b = luz::load_scene(bare);
  EXPECT_EQ(b.materials[0].num_bindings, 0u);
  bool warned = false;
  for (const std::string& w : b.warnings) warned |= w.find("texture maps are ignored") != std::string::npos;
  EXPECT_TRUE(warned);
}

// map_Ns multiplies Ns by the map's value (linear luminance) at each point:
// a map dark on its left half (64/255) and white on its right gives
// exponents 100 · 64/255 and 100. Maps a material cannot use are warnings.
TEST_F(MeshSceneFiles, MapNsScalesTheExponent) {
  luz::Image tex{2, 1, {64.f / 255.f, 64.f / 255.f, 64.f / 255.f, 1.f, 1.f, 1.f}};
  luz::write_image((dir / "ns.pfm").string(), tex);
  luz::Scene s = three_faces("ns", "newmtl gloss\nKd 0.3 0.3 0.3\nKs 0.5 0.5 0.5\nNs 100\nmap_Ns ns.pfm\n"
                                   "newmtl matte\nKd 0.5 0.5 0.5\nNs 100\nmap_Ns ns.pfm\n"
                                   "newmtl mirror\nKs 0.9 0.9 0.9\nillum 3\nmap_Kd ns.pfm\nmap_Ks ns.pfm\n",
                             {"gloss", "matte", "mirror"}, true);
  ASSERT_GE(s.materials.size(), 3u);
  ASSERT_EQ(s.materials[0].num_bindings, 1u);
  EXPECT_EQ(s.texture_bindings[s.materials[0].first_binding].param, luz::BsdfParam::Exponent);
  const luz::SceneView v = s.view();
  const luz::Bsdf left = v.materials.bsdf(0, v.textures, {0.25f, 0.5f});
  const luz::Bsdf right = v.materials.bsdf(0, v.textures, {0.75f, 0.5f});
  EXPECT_EQ(left.type, luz::BsdfType::Phong);
  EXPECT_NEAR(left.phong.exponent, 100.f * 64.f / 255.f, 1e-3f);
  EXPECT_NEAR(right.phong.exponent, 100.f, 1e-3f);
  EXPECT_NEAR(s.materials[0].bsdf.phong.exponent, 50.f * (1.f + 64.f / 255.f), 1e-2f);  // the map's mean
  EXPECT_EQ(s.materials[1].num_bindings, 0u);
  EXPECT_EQ(s.materials[2].num_bindings, 2u);  // illum 3: map_Kd on the diffuse part, map_Ks on the mirror
  std::string all;
  for (const std::string& w : s.warnings) all += w + "\n";
  EXPECT_NE(all.find("material 'matte': map_Ns is ignored: the material has no glossy part (Ks 0 and no map_Ks)"),
            std::string::npos) << all;
  EXPECT_NE(all.find("material 'mirror': Kd + Ks reaches 2"), std::string::npos) << all;  // both maps' white texels
}

// Normals and texture coordinates per face corner: a face without vn is
// shaded flat (its own normal, not the file's dropped everywhere), a face
// without vt reads (0, 0), each with a warning.
TEST_F(MeshSceneFiles, CornersWithoutNormalsOrCoordinates) {
  const std::string obj = write("mixed.obj",
                                "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\nvn 0.6 0 0.8\nvt 0.25 0.75\n"
                                "f 1/1/1 2/1/1 3/1/1\nf 2 4 3\n");
  const luz::ObjMesh m = luz::read_obj(obj, false, luz::ObjTexcoords::Yes);
  ASSERT_EQ(m.indices.size(), 6u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  ASSERT_EQ(m.texcoords.size(), m.positions.size());
  for (int k = 0; k < 3; ++k) {
    EXPECT_FLOAT_EQ(m.normals[m.indices[size_t(k)]].x, 0.6f);  // the file's
    EXPECT_FLOAT_EQ(m.texcoords[m.indices[size_t(k)]].y, 0.25f);  // 1 - vt.v
  }
  // (1,0,0), (1,1,1), (0,1,0): (0,1,1) × (-1,1,0) = (-1, -1, 1), over √3.
  const float r = 1.f / std::sqrt(3.f);
  for (int k = 3; k < 6; ++k) {
    const luz::Vec3 n = m.normals[m.indices[size_t(k)]];
    EXPECT_NEAR(n.x, -r, 1e-6f);
    EXPECT_NEAR(n.y, -r, 1e-6f);
    EXPECT_NEAR(n.z, r, 1e-6f);
    EXPECT_EQ(m.texcoords[m.indices[size_t(k)]].x, 0.f);
    EXPECT_EQ(m.texcoords[m.indices[size_t(k)]].y, 1.f);
  }
  std::string all;
  for (const luz::ObjWarning& w : m.warnings) all += w.message + "\n";
  EXPECT_NE(all.find("1 triangles lack normals (vn) where others have them: shaded flat"), std::string::npos) << all;
  EXPECT_NE(all.find("1 triangles lack texture coordinates (vt) where others have them: read as (0, 0)"), std::string::npos) << all;
}

// Smoothing groups (`s N`) on faces without vn: a group's faces share the
// area-weighted mean normal at each position; `s off` faces stay flat. A
// roof of two triangles of equal area, (0,0,0) (1,0,0) (0,1,1) with
// (1,0,0) × (0,1,1) = (0,-1,1) and (1,0,0) (1,1,0) (0,1,1) with
// (0,1,0) × (-1,1,1) = (1,0,1): smoothed, the shared corners (1,0,0) and
// (0,1,1) take (1,-1,2)/√6.
TEST_F(MeshSceneFiles, SmoothingGroupsShadeFacesWithoutNormals) {
  const std::string roof = "v 0 0 0\nv 1 0 0\nv 0 1 1\nv 1 1 0\n";
  auto shared_normal = [&](const std::string& name, const std::string& s) {
    const luz::ObjMesh m = luz::read_obj(write(name, roof + s + "\nf 1 2 3\nf 2 4 3\n"), true, luz::ObjTexcoords::No,
                                         luz::ObjSmoothing::Groups);
    EXPECT_EQ(m.indices.size(), 6u);
    return m.normals.empty() ? luz::Vec3{} : m.normals[m.indices[1]];  // the first face's corner (1,0,0)
  };
  const luz::Vec3 smooth = shared_normal("s1.obj", "s 1");
  const float r6 = 1.f / std::sqrt(6.f);
  EXPECT_NEAR(smooth.x, r6, 1e-6f);
  EXPECT_NEAR(smooth.y, -r6, 1e-6f);
  EXPECT_NEAR(smooth.z, 2 * r6, 1e-6f);
  EXPECT_EQ(length(shared_normal("off.obj", "s off")), 0.f);  // no normals: flat, as before
  // Mitsuba's obj shape reads no groups (ObjSmoothing::Ignore): its own smoothing rule applies.
  EXPECT_TRUE(luz::read_obj(write("s1b.obj", roof + "s 1\nf 1 2 3\nf 2 4 3\n"), false).normals.empty());
}

// Concave faces triangulated whole: the triangles' areas add up to the
// polygon's (the shoelace formula), each wound as the polygon (+z here), for
// a dart, a U, an eight-pointed star away from the origin (tinyobjloader's
// own triangulation filled the dart's notch and dropped half the star) and
// a comb of 700 corners.
TEST_F(MeshSceneFiles, ConcaveFacesAreTriangulatedWhole) {
  auto check = [&](const std::string& name, const std::vector<std::array<double, 2>>& pts) {
    std::string obj;
    double shoelace = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
      obj += "v " + std::to_string(pts[i][0]) + " " + std::to_string(pts[i][1]) + " 0\n";
      const auto& a = pts[i];
      const auto& b = pts[(i + 1) % pts.size()];
      shoelace += 0.5 * (a[0] * b[1] - b[0] * a[1]);
    }
    obj += "f";
    for (size_t i = 0; i < pts.size(); ++i) obj += " " + std::to_string(i + 1);
    const luz::ObjMesh m = luz::read_obj(write(name, obj + "\n"), false);
    EXPECT_EQ(m.indices.size(), 3 * (pts.size() - 2)) << name;
    double area = 0;
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const luz::Vec3 a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]], c = m.positions[m.indices[t + 2]];
      const double z = 0.5 * double(cross(b - a, c - a).z);
      EXPECT_GT(z, 0.0) << name << ": triangle " << t / 3 << " wound against the polygon";
      area += z;
    }
    EXPECT_NEAR(area, shoelace, 1e-4 * shoelace) << name;
  };
  check("dart.obj", {{0, 0}, {1, 1}, {2, 0}, {1, 4}});
  check("u.obj", {{0, 0}, {3, 0}, {3, 3}, {2, 3}, {2, 1}, {1, 1}, {1, 3}, {0, 3}});
  // An L with corners on its straight edges (as CAD files split edges).
  check("l.obj", {{0, 0}, {1, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {1, 3}, {0, 3}, {0, 2}, {0, 1}});
  std::vector<std::array<double, 2>> star;
  for (int i = 0; i < 16; ++i) {
    const double r = i % 2 ? 1.0 : 3.0, a = i * M_PI / 8;
    star.push_back({10 + r * std::cos(a), 10 + r * std::sin(a)});
  }
  check("star.obj", star);
  // A comb of 700 corners (tinyobjloader counts a face's corners modulo 256).
  std::vector<std::array<double, 2>> comb;
  for (int i = 0; i < 350; ++i) comb.push_back({double(i), -1.0});  // counter-clockwise: along the bottom, back along the teeth
  for (int i = 349; i >= 0; --i) comb.push_back({double(i), i % 2 ? 1.0 : 0.0});
  check("comb.obj", comb);
}

// map_d from an image with an alpha channel reads the alpha (an RGBA map,
// as Blender's importer): a dark opaque texel stays opaque, a white clear
// one is cut away; from a grey image without alpha, its luminance. A 2×1
// 32-bit TGA written here (BGRA, top-left origin).
TEST_F(MeshSceneFiles, MapDReadsTheAlphaOfAnRgbaImage) {
  const unsigned char tga[18 + 8] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 1, 0, 32, 8 | 0x20,
                                     25, 25, 25, 255,  // dark grey, opaque
                                     255, 255, 255, 0};  // white, clear
  write("leaf.tga", std::string(reinterpret_cast<const char*>(tga), sizeof tga));
  luz::write_image((dir / "grey.pfm").string(), luz::Image{2, 1, {0.25f, 0.25f, 0.25f, 1.f, 1.f, 1.f}});
  luz::Scene s = three_faces("alpha", "newmtl leaf\nKd 1 1 1\nmap_d leaf.tga\nnewmtl mask\nKd 1 1 1\nmap_d grey.pfm\n"
                                      "newmtl plain\nKd 1 1 1\n",
                             {"leaf", "mask", "plain"}, true);
  const luz::SceneView v = s.view();
  auto opacity = [&](int m, float u) {
    return luz::luminance(v.textures.eval(uint32_t(s.materials[size_t(m)].opacity_texture), {u, 0.5f}));
  };
  ASSERT_GE(s.materials[0].opacity_texture, 0);
  EXPECT_FLOAT_EQ(opacity(0, 0.25f), 1.f);
  EXPECT_FLOAT_EQ(opacity(0, 0.75f), 0.f);
  ASSERT_GE(s.materials[1].opacity_texture, 0);
  EXPECT_FLOAT_EQ(opacity(1, 0.25f), 0.25f);
  EXPECT_FLOAT_EQ(opacity(1, 0.75f), 1.f);
}

// Map statements as the MTL specification reads them: options before the
// file name, -o and -s with one to three numbers (tinyobjloader took the
// file name for a missing third number), placing the map (Luz's v is
// 1 - the file's: v' = s v + 1 - s - o); other options warned about and
// ignored; d multiplies map_d; an unknown option is an error at its line;
// statements Luz does not read (map_Ke) are warnings.
TEST_F(MeshSceneFiles, MapOptionsAndPlacement) {
  luz::Image tex{2, 1, {0.f, 0.f, 0.f, 1.f, 1.f, 1.f}};
  luz::write_image((dir / "t pic.pfm").string(), tex);
  luz::Scene s = three_faces("o", "newmtl a\nKd 1 1 1\nmap_Kd -o 0.5 0.25 t pic.pfm\n"
                                  "newmtl b\nKd 1 1 1\nmap_Kd -s 2 4 -clamp on t pic.pfm\n"
                                  "newmtl c\nKd 1 1 1\nd 0.5\nmap_d t pic.pfm\nmap_Ke t pic.pfm\n",
                             {"a", "b", "c"}, true);
  ASSERT_GE(s.materials.size(), 3u);
  auto kd = [&](int m) {
    EXPECT_EQ(s.materials[size_t(m)].num_bindings, 1u) << m;
    return s.textures[size_t(s.texture_bindings[s.materials[size_t(m)].first_binding].texture)];
  };
  const luz::Texture a = kd(0), b = kd(1);
  EXPECT_EQ(a.to_uv.a, 1.f);
  EXPECT_EQ(a.to_uv.c, 0.5f);
  EXPECT_EQ(a.to_uv.e, 1.f);
  EXPECT_EQ(a.to_uv.f, -0.25f);
  EXPECT_EQ(b.to_uv.a, 2.f);
  EXPECT_EQ(b.to_uv.e, 4.f);
  EXPECT_EQ(b.to_uv.f, -3.f);
  const luz::Material& c = s.materials[2];
  ASSERT_GE(c.opacity_texture, 0);
  const luz::SceneView v = s.view();
  EXPECT_FLOAT_EQ(luz::luminance(v.textures.eval(uint32_t(c.opacity_texture), {0.75f, 0.5f})), 0.5f);  // white texel × d
  std::string all;
  for (const std::string& w : s.warnings) all += w + "\n";
  EXPECT_NE(all.find("o.mtl:6: warning: 'map_Kd': option(s) -clamp not supported: ignored"), std::string::npos) << all;
  EXPECT_NE(all.find("o.mtl:11: warning: 'map_Ke' is not supported: ignored"), std::string::npos) << all;

  // A Windows path, beside the MTL file in a folder of its own.
  std::filesystem::create_directories(dir / "sub" / "img");
  luz::write_image((dir / "sub" / "img" / "t.pfm").string(), tex);
  write("sub/s.mtl", "newmtl a\nKd 1 1 1\nmap_Kd img\\t.pfm\n");
  luz::Scene w = luz::load_scene(write("w.obj", "mtllib sub/s.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n"));
  EXPECT_EQ(w.materials[0].num_bindings, 1u);
  write("bad.mtl", "newmtl a\nmap_Kd -zz 1 t.png\n");
  const std::string obj = write("badopt.obj", "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n");
  luz_test::expect_load_refused(obj, "bad.mtl:2", "'map_Kd': unknown option -zz");
}

// Bad MTL values are refused at their line.
TEST_F(MeshSceneFiles, BadMtlValues) {
  write("bad.mtl", "newmtl a\nd 1.5\n");
  const std::string obj = write("bad.obj", "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
  luz_test::expect_load_refused(obj, "bad.mtl:2", "'d': '1.5' must lie in [0, 1]");
  write("ni.mtl", "newmtl a\nNi 0\n");
  const std::string obj2 = write("ni.obj", "mtllib ni.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
  luz_test::expect_load_refused(obj2, "ni.mtl:2", "'Ni': '0' must be positive");
}

}  // namespace
