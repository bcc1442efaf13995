// A scene as bytes and back (scene/serialize.h, luz render --broadcast):
// every field survives, so the render fields (hashes of the camera,
// geometry, materials, textures and lights) agree and the image is the same
// bit for bit, on the bundled box, a textured envmap-lit scene, an
// instanced scene, a vertex-coloured one, the Wooden Staircase (pbrt-v4,
// PLY meshes) and DamagedHelmet (glTF, normal maps). Damaged bytes are refused.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "film_helpers.h"
#include "luz/io/load.h"
#include "luz/render/checkpoint.h"
#include "luz/render/render.h"
#include "luz/scene/serialize.h"
#include "sanitizer.h"
#include "temp_dir.h"

namespace {

using namespace luz;

void expect_round_trip(const std::string& path, const Defines& defines, bool instanced = false) {
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is not here";
  Scene s = load_scene(path, defines);
  EXPECT_EQ(s.instances.empty(), !instanced);
  s.set_resolution(24, 24);
  s.settings.spp = 2;
  const std::string bytes = serialize_scene(s);
  std::printf("%s: %.1f MB serialized\n", path.c_str(), double(bytes.size()) * 1e-6);  // what --broadcast sends
  const Scene t = deserialize_scene(bytes);
  EXPECT_EQ(render_fields(t, RenderDevice::Cpu), render_fields(s, RenderDevice::Cpu)) << path;
  EXPECT_EQ(t.warnings, s.warnings);
  EXPECT_EQ(serialize_scene(t), bytes) << path;
  RenderRequest req;
  req.threads = 1;
  expect_same_film(render(t, req).film, render(s, req).film, path);

  EXPECT_THROW(deserialize_scene(bytes.substr(0, bytes.size() / 2)), std::runtime_error);
  EXPECT_THROW(deserialize_scene(bytes + "x"), std::runtime_error);
  EXPECT_THROW(deserialize_scene("LUZSCNE0" + bytes.substr(8)), std::runtime_error);
}

TEST(SerializeScene, BundledBox) { expect_round_trip(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {}); }

TEST(SerializeScene, TexturedEnvmapScene) {
  expect_round_trip(LUZ_SOURCE_DIR "/bench/scenes/envmap-spheres.xml", {});
}

class SerializeSceneFile : public TempDirTest {};

TEST_F(SerializeSceneFile, InstancedScene) {
  const std::string path = write("instanced.xml", R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 1, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film>
  </sensor>
  <emitter type="constant"/>
  <shape type="shapegroup" id="group">
    <shape type="cube"><bsdf type="roughconductor"/></shape>
    <shape type="rectangle"><transform name="to_world"><translate y="1.5"/></transform></shape>
  </shape>
  <shape type="instance"><ref id="group"/><transform name="to_world"><translate x="-1.5"/></transform></shape>
  <shape type="instance"><ref id="group"/><transform name="to_world"><rotate y="1" angle="30"/><translate x="1.5"/></transform></shape>
</scene>
)");
  expect_round_trip(path, {}, true);
}

// Vertex colours (a PLY file's, read through mesh_attribute) survive too.
TEST_F(SerializeSceneFile, VertexColouredScene) {
  write("c.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                 "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
                 "property list uchar int vertex_indices\nend_header\n-1 -1 0 255 0 0\n1 -1 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n");
  const std::string path = write("colored.xml", R"(<scene version="3.0.0">
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film>
  </sensor>
  <emitter type="constant"/>
  <shape type="ply"><string name="filename" value="c.ply"/>
    <bsdf type="diffuse"><texture name="reflectance" type="mesh_attribute"><string name="name" value="vertex_color"/></texture></bsdf>
  </shape>
</scene>
)");
  ASSERT_EQ(load_scene(path).colors.size(), 3u);
  expect_round_trip(path, {});
}

TEST(SerializeScene, StaircasePbrt) {
  LUZ_SKIP_UNDER_SANITIZERS("the other round trips run the same code sanitized");
  expect_round_trip(LUZ_SHARED_DIR "/scenes/staircase/pbrt-v4/scene-v4.pbrt", {});
}

TEST(SerializeScene, DamagedHelmetGltf) {
  expect_round_trip(LUZ_SHARED_DIR "/scenes/gltf/DamagedHelmet/glTF/DamagedHelmet.gltf", {});
}

}  // namespace
