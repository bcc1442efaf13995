// Files read ahead in parallel (io/read_ahead.h) change only the time a
// scene takes to load: the scene is the same bit for bit on one thread or
// many, a texture's statistics are those of a sequential read, and of two
// bad files the first in the scene file is the one reported, with the
// message a sequential read gives.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "sanitizer.h"
#include "temp_dir.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/io/read_ahead.h"
#include "luz/scene/scene_builder.h"

namespace fs = std::filesystem;

namespace {

const std::string kScenes = LUZ_SHARED_DIR "/scenes/";

// `f` run on one thread (TBB limited to one) and on all.
template <class F>
auto sequential(F f) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  return f();
}

// The message `f` throws ("" when it throws none).
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const luz::InputError& e) {
    return e.what();
  }
  return "";
}

template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// A BSDF's type and parameters (what a texture's mean sets; padding aside).
std::vector<float> parameters(luz::Bsdf b) {
  std::vector<float> out{float(b.type)};
  for (int k = 0; k <= int(luz::BsdfParam::ClearcoatRoughness); ++k) {
    if (const luz::Color* c = luz::color_param(b, luz::BsdfParam(k))) out.insert(out.end(), {c->x, c->y, c->z});
    if (const float* f = luz::float_param(b, luz::BsdfParam(k))) out.push_back(*f);
  }
  return out;
}

void expect_same_scene(const luz::Scene& a, const luz::Scene& b) {
  EXPECT_TRUE(same_bytes(a.positions, b.positions));
  EXPECT_TRUE(same_bytes(a.normals, b.normals));
  EXPECT_TRUE(same_bytes(a.uvs, b.uvs));
  EXPECT_TRUE(same_bytes(a.indices, b.indices));
  EXPECT_TRUE(same_bytes(a.tri_material, b.tri_material));
  EXPECT_TRUE(same_bytes(a.tri_emitter, b.tri_emitter));
  EXPECT_TRUE(same_bytes(a.texels8, b.texels8));
  EXPECT_TRUE(same_bytes(a.texelsf, b.texelsf));
  EXPECT_TRUE(same_bytes(a.light_pmf, b.light_pmf));
  EXPECT_EQ(a.warnings, b.warnings);
  ASSERT_EQ(a.textures.size(), b.textures.size());
  for (size_t k = 0; k < a.textures.size(); ++k) {
    const luz::BitmapTexture &x = a.textures[k].bitmap, &y = b.textures[k].bitmap;
    EXPECT_EQ(x.offset, y.offset);
    EXPECT_EQ(x.width, y.width);
    EXPECT_EQ(x.height, y.height);
    EXPECT_EQ(x.srgb, y.srgb);
    EXPECT_EQ(x.is_float, y.is_float);
    EXPECT_EQ(std::memcmp(&a.textures[k].to_uv, &b.textures[k].to_uv, sizeof(luz::UvTransform)), 0);
  }
  // Textured parameters hold their texture's mean: the materials show the statistics.
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t k = 0; k < a.materials.size(); ++k) {
    const std::vector<float> x = parameters(a.materials[k].bsdf), y = parameters(b.materials[k].bsdf);
    EXPECT_TRUE(same_bytes(x, y)) << "material " << k;
    EXPECT_EQ(a.materials[k].opacity, b.materials[k].opacity);
  }
  EXPECT_EQ(a.lights.size(), b.lights.size());
}

TEST(ReadAhead, TakesWhatWasReadAsOftenAsListed) {
  luz::ReadAhead<int> ahead;
  int reads = 0;
  ahead.run({"a", "bad", "a"}, [&](const std::string& k) {
    if (k == "bad") throw luz::InputError(k, 3, "broken");
    ++reads;  // one thread reads "a": the other read throws at once
    return 7;
  });
  EXPECT_EQ(reads, 1);
  EXPECT_EQ(ahead.take("a").value_or(0), 7);
  EXPECT_EQ(ahead.take("a").value_or(0), 7);
  EXPECT_FALSE(ahead.take("a").has_value());  // listed twice: read afresh now
  EXPECT_FALSE(ahead.take("other").has_value());
  EXPECT_EQ(error_of([&] { ahead.take("bad"); }), "bad:3: broken");
}

// ---- texture statistics, read ahead or not ----

class ReadAheadFiles : public TempDirTest {
 protected:
  // A w × h PNG of varied sRGB values.
  std::string png(const std::string& name, int w, int h) {
    luz::Image img;
    img.width = w, img.height = h;
    for (int k = 0; k < w * h * 3; ++k) img.rgb.push_back(float((k * 37) % 101) / 100.f);
    const std::string p = (dir / name).string();
    luz::write_image(p, img);
    return p;
  }
};

TEST_F(ReadAheadFiles, TextureStatisticsAreTheSequentialOnes) {
  const std::string p = png("t.png", 37, 23);
  for (bool srgb : {true, false}) {
    luz::SceneBuilder ahead("s"), plain("s");
    ahead.read_images_ahead({p, p});
    const int32_t a = ahead.add_image_texture({}, {p, srgb});
    const int32_t b = plain.add_image_texture({}, {p, srgb});
    // A view of the same texels: statistics computed from the scene's texels.
    const int32_t c = plain.add_texture({}, plain.scene().textures[size_t(b)]);
    for (const luz::TextureStats* s : {&plain.texture_stats(b), &plain.texture_stats(c)}) {
      EXPECT_EQ(std::memcmp(&ahead.texture_stats(a), s, sizeof(luz::TextureStats)), 0) << "srgb " << srgb;
    }
    EXPECT_TRUE(same_bytes(ahead.scene().texels8, plain.scene().texels8));
  }
}

TEST_F(ReadAheadFiles, AFileWithOtherSettingsSharesItsTexels) {
  const std::string p = png("t.png", 8, 4);
  luz::SceneBuilder b("s");
  b.read_images_ahead({p});
  const int32_t srgb = b.add_image_texture({}, {p, true});
  luz::ImageTextureDesc d{p, false};
  d.wrap = luz::WrapMode::Clamp;
  const int32_t raw = b.add_image_texture({}, d);
  EXPECT_NE(srgb, raw);
  EXPECT_EQ(b.scene().texels8.size(), 32u);
  const luz::BitmapTexture& t = b.scene().textures[size_t(raw)].bitmap;
  EXPECT_EQ(t.offset, b.scene().textures[size_t(srgb)].bitmap.offset);
  EXPECT_FALSE(t.srgb);
  EXPECT_EQ(t.wrap, luz::WrapMode::Clamp);
  // As the texture read on its own with those settings.
  luz::SceneBuilder alone("s");
  const int32_t k = alone.add_image_texture({}, d);
  EXPECT_EQ(std::memcmp(&alone.texture_stats(k), &b.texture_stats(raw), sizeof(luz::TextureStats)), 0);
}

// ---- of two bad files, the first in file order ----

// The first bad file is slow to fail (a large PNG cut short: most of it
// decodes before the error), the second fails at once: a reader that
// reported whichever failed first would name the second.
class FirstError : public ReadAheadFiles {
 protected:
  void SetUp() override {
    ReadAheadFiles::SetUp();
    const std::string big = png("slow.png", 1500, 1500);
    fs::resize_file(big, fs::file_size(big) * 9 / 10);
    write("fast.png", "not a PNG");
    write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  }

  // The error of loading `scene`, checked to be the sequential load's (on
  // one thread) and the same over several loads.
  std::string error_of_scene(const std::string& scene) {
    const std::string expected = sequential([&] { return error_of([&] { luz::load_scene(scene); }); });
    for (int k = 0; k < 5; ++k) EXPECT_EQ(error_of([&] { luz::load_scene(scene); }), expected);
    return expected;
  }
};

std::string mitsuba_bitmap(const std::string& file) {
  return "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"" +
         file + "\"/></texture></bsdf>";
}

TEST_F(FirstError, MitsubaNamesTheFirstBadTexture) {
  const std::string scene = write("s.xml", "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n"
                                           "<shape type=\"rectangle\">" +
                                               mitsuba_bitmap("slow.png") + "</shape>\n<shape type=\"rectangle\">" +
                                               mitsuba_bitmap("fast.png") + "</shape>\n</scene>\n");
  const std::string e = error_of_scene(scene);
  EXPECT_EQ(e.rfind(scene + ":3: ", 0), 0u) << e;
  EXPECT_NE(e.find("slow.png"), std::string::npos) << e;
}

TEST_F(FirstError, MitsubaNamesABadMeshBeforeABadTexture) {
  const std::string scene = write("s.xml", "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n"
                                           "<shape type=\"obj\"><string name=\"filename\" value=\"bad.obj\"/></shape>\n"
                                           "<shape type=\"rectangle\">" +
                                               mitsuba_bitmap("slow.png") + "</shape>\n</scene>\n");
  const std::string e = error_of_scene(scene);
  EXPECT_EQ(e.rfind((dir / "bad.obj").string() + ":4: ", 0), 0u) << e;
}

TEST_F(FirstError, PbrtNamesTheFirstBadTexture) {
  const std::string scene = write("s.pbrt",
                                  "Camera \"perspective\"\nWorldBegin\n"
                                  "Texture \"a\" \"spectrum\" \"imagemap\" \"string filename\" \"slow.png\"\n"
                                  "Texture \"b\" \"spectrum\" \"imagemap\" \"string filename\" [ \"fast.png\" ]\n");
  const std::string e = error_of_scene(scene);
  EXPECT_EQ(e.rfind(scene + ":3: ", 0), 0u) << e;
  EXPECT_NE(e.find("slow.png"), std::string::npos) << e;
}

// glTF: the first image that cannot be decoded is reported, as tinygltf
// would have stopped there, before reading what follows the images (here a
// texture that is not an object).
TEST_F(FirstError, GltfNamesTheFirstBadImage) {
  for (const std::string after : {"", ", \"textures\": [5]"}) {
    const std::string scene = write("s.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"images\": [{\"uri\": \"slow.png\"}, "
                                              "{\"uri\": \"fast.png\", \"name\": \"b\"}]" + after + "}");
    const std::string e = error_of_scene(scene);
    EXPECT_EQ(e.rfind(scene + ": images[0]: cannot read image", 0), 0u) << e;
  }
}

// ---- the staircase: the same scene on one thread and on all ----

TEST(ReadAheadStaircase, MitsubaOneThreadOrMany) {
  LUZ_SKIP_UNDER_SANITIZERS("the tests above and every staircase load run the read-ahead sanitized");
  const std::string f = kScenes + "staircase/mitsuba/scene.xml";
  const luz::Scene one = sequential([&] { return luz::load_scene(f); });
  expect_same_scene(one, luz::load_scene(f));
}

TEST(ReadAheadStaircase, PbrtOneThreadOrMany) {
  LUZ_SKIP_UNDER_SANITIZERS("the tests above and every staircase load run the read-ahead sanitized");
  const std::string f = kScenes + "staircase/pbrt-v4/scene-v4.pbrt";
  const luz::Scene one = sequential([&] { return luz::load_scene(f); });
  expect_same_scene(one, luz::load_scene(f));
}

}  // namespace
