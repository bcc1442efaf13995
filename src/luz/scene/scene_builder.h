// What every scene reader calls: meshes, objects and their instances,
// materials, textures, lights, the camera and the settings, each with the
// place in the file it came from. The builder holds the checks that all
// formats share (finite numbers and coordinates within Embree's range, indices
// in range, texture coordinates for textured materials, one environment, the
// limits of the scene's arrays) and reports them as InputError
// "file:line: problem". Format-specific checks stay in the readers.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "luz/io/image.h"
#include "luz/io/read_ahead.h"
#include "luz/math/transform.h"
#include "luz/scene/scene.h"

namespace luz {

// Where something was written: a file and a line (0: unknown or not a text
// file; readers of binary files name the byte offset in the message).
struct SourceLoc {
  std::string file;
  int line = 0;
};

// Whether every channel of c lies in [0, 1] (false for NaN): what a vertex colour must.
inline bool is_unit_color(Color c) {
  return c.x >= 0.f && c.x <= 1.f && c.y >= 0.f && c.y <= 1.f && c.z >= 0.f && c.z <= 1.f;
}

struct TriangleMesh {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  // empty, or one per position
  std::vector<Vec2> uvs;      // empty, or one per position (texture.h's convention: v = 0 at the image's top)
  std::vector<uint32_t> indices;
  std::vector<Color> colors;  // empty, or one per position: vertex colours, linear, in [0, 1]
};

// An area emitter on a shape: a constant radiance, or a texture whose mean
// the radiance then holds (what power and light selection use).
struct AreaEmission {
  Color radiance{1.f, 1.f, 1.f};
  int32_t texture = -1;
  bool two_sided = false;  // on both sides of a mesh (pbrt's twosided; spheres refuse it)
};

// A material as the readers describe it (see material/material.h).
struct MaterialDesc {
  Bsdf bsdf = Bsdf::make_diffuse({0.5f, 0.5f, 0.5f});
  std::vector<TextureBinding> bindings;
  float opacity = 1.f;
  int32_t opacity_texture = -1;
  int32_t normal_map = -1, bump_map = -1;
  float bump_scale = 1.f;
  float normal_scale = 1.f;     // Material::normal_scale, normal_y_by_uv (glTF's normal textures)
  bool normal_y_by_uv = false;
  float alpha_cutoff = -1.f;  // Material::alpha_cutoff (glTF's alphaMode MASK)
  bool masked() const { return opacity_texture >= 0 || opacity < 1.f; }
  bool has_map() const { return normal_map >= 0 || bump_map >= 0; }
  // Whether the material needs texture coordinates.
  bool textured() const { return !bindings.empty() || opacity_texture >= 0 || normal_map >= 0 || bump_map >= 0; }
};

// A texture's texel statistics per channel: what readers check parameter
// ranges against and what a textured parameter's constant part holds.
struct TextureStats {
  Color mean, min, max;
};

// An image texture: the file (a path as given or resolved by the reader),
// how its texels are read and looked up.
struct ImageTextureDesc {
  std::string path;
  bool srgb = true;  // 8-bit files only: float files are linear
  TextureFilter filter = TextureFilter::Bilinear;
  WrapMode wrap = WrapMode::Repeat;
  UvTransform to_uv;
};

class SceneBuilder {
 public:
  // `file`: the scene file, named by messages that have no better place.
  explicit SceneBuilder(std::string file);

  [[noreturn]] void error(const SourceLoc& at, const std::string& problem) const;
  // A one-line warning "file:line: warning: ..." kept in Scene::warnings.
  void warn(const SourceLoc& at, const std::string& problem);
  const std::string& file() const { return file_; }

  // ---- textures ----
  // An image file read once per (path, srgb, filter, wrap, to_uv): a second
  // request returns the same index, one with other settings shares the
  // texels. Texels must be finite and not negative.
  int32_t add_image_texture(const SourceLoc& at, const ImageTextureDesc& desc);
  // Reads these image files in parallel ahead of the add_image_texture calls
  // that name them (a reader lists what its scene names; a file it misses is
  // read when named). The scene is the same as without, and so is any
  // error: a file that fails to read fails the call that names it.
  void read_images_ahead(const std::vector<std::string>& paths);
  int32_t add_checkerboard(const SourceLoc& at, Color color0, Color color1, const UvTransform& to_uv);
  // The shapes' vertex colours times `scale` (Mitsuba's mesh_attribute
  // vertex_color, glTF's COLOR_0). A material reading them goes only on
  // meshes that have them; no emitter reads them.
  int32_t add_vertex_color_texture(const SourceLoc& at, Color scale = {1.f, 1.f, 1.f});
  // An 8-bit image already in memory (glTF's embedded and binary-chunk
  // images): packed RGBA texels, rows top to bottom.
  int32_t add_image8(const SourceLoc& at, BitmapTexture bitmap, const UvTransform& to_uv,
                     const std::vector<uint32_t>& rgba);
  // Another view of texels already added (a channel, a scale, other lookup
  // settings: texture.h), e.g. a copy of an earlier texture changed.
  int32_t add_texture(const SourceLoc& at, const Texture& texture);
  // Texture `index` with every value times k (per channel, ≥ 0): a view of
  // the same texels (the texture itself when k is 1).
  int32_t add_scaled_texture(const SourceLoc& at, int32_t index, Color k);
  // pbrt-v4's mix, (1 - w) a + w b with w amount's luminance in [0, 1], and
  // scale, a b, of operands that are each a bitmap or checkerboard texture
  // or a constant (texture -1: `value`); a mix of mixes is refused.
  struct TextureOperand {
    int32_t texture = -1;
    Color value;
  };
  int32_t add_mix_texture(const SourceLoc& at, TextureOperand a, TextureOperand b, TextureOperand amount);
  int32_t add_product_texture(const SourceLoc& at, TextureOperand a, TextureOperand b);
  // (Of textures added as texels or views of them: computed when first asked for.)
  const TextureStats& texture_stats(int32_t texture) const;

  // ---- materials ----
  uint32_t add_material(const SourceLoc& at, const MaterialDesc& desc);
  MaterialDesc material(uint32_t index) const;
  // Whether material m reads texture coordinates (a bitmap, a checkerboard,
  // a normal or bump map), and whether it reads vertex colours.
  bool material_reads_uv(uint32_t m) const;
  bool material_reads_colors(uint32_t m) const;
  // Mitsuba's default material: diffuse, reflectance 0.5 (one shared index).
  uint32_t default_material();

  // ---- shapes (world space) ----
  // Checks: whole triangles, indices in range, finite positions within 1e18,
  // normals, uvs and colours one per position, texture coordinates where the
  // material or the emitter is textured, vertex colours where the material
  // reads them, no masked emitter.
  void add_mesh(const SourceLoc& at, TriangleMesh mesh, uint32_t material, const AreaEmission* emission = nullptr,
                bool flip_normals = false);
  // A sphere: `orientation`'s linear part (a rotation, perhaps a mirror,
  // times a uniform scale: the loader's to_world) gives its object frame,
  // in which its texture coordinates are spherical angles (sphere_uv).
  void add_sphere(const SourceLoc& at, Vec3 center, float radius, uint32_t material,
                  const AreaEmission* emission = nullptr, bool flip_normals = false, const Matrix4& orientation = {});

  // ---- instancing ----
  // An object: meshes stored once (in object space), placed by instances.
  // Emitters inside objects are refused (as in pbrt-v4 and Mitsuba 3).
  // Placements are resolved by frame_bounds() or finish(): an object placed
  // twice or more is instanced, others are flattened (resolve_instances).
  uint32_t begin_object(const SourceLoc& at, const std::string& name);
  void add_object_mesh(const SourceLoc& at, uint32_t object, TriangleMesh mesh, uint32_t material);
  void add_instance(const SourceLoc& at, uint32_t object, const Matrix4& to_world);
  size_t num_instances() const { return num_instances_; }

  // ---- lights other than area emitters ----
  void add_light(const SourceLoc& at, const Light& light);
  // An equirectangular environment map from an image (pixels checked here).
  void add_envmap(const SourceLoc& at, EnvmapLight light, const Image& image, const std::string& name);

  // ---- camera and settings ----
  // `axis`: what the field of view was given along (kept by a later
  // Scene::set_resolution).
  void set_camera(const SourceLoc& at, const Camera& camera, FovAxis axis = FovAxis::X);
  // Renders only the camera's pixels [x0, x1) × [y0, y1) (a film's crop
  // window), on a film of that size; after set_camera.
  void crop_camera(const SourceLoc& at, long x0, long x1, long y0, long y1);
  bool has_camera() const { return has_camera_; }
  // A camera that frames the scene's bounds from +z (40° field of view) at
  // width × height: for formats without a camera (OBJ, PLY, glTF).
  void frame_bounds(int width, int height);
  RenderSettings& settings() { return scene_.settings; }
  const Scene& scene() const { return scene_; }

  // The finished scene: it must have a shape and a camera; compiled.
  Scene finish();

 private:
  void check_emission(const SourceLoc& at, const AreaEmission& e) const;
  // add_mesh's checks of a mesh (a normal that is not finite becomes zero,
  // with a warning), and of the room left in the scene's arrays.
  void check_mesh(const SourceLoc& at, TriangleMesh& mesh, uint32_t material, const AreaEmission* emission);
  void check_room(const SourceLoc& at, const TriangleMesh& mesh) const;
  void resolve_instances();
  void check_shape_material(const SourceLoc& at, uint32_t material, const AreaEmission* emission,
                            bool has_uvs, bool has_colors, const char* what) const;
  int32_t push_texture_stats(int32_t index, const std::optional<TextureStats>& stats);
  TextureStats bitmap_stats(const Texture& texture) const;
  TextureView texture_view() const;  // of the textures added so far
  int32_t add_mix(const SourceLoc& at, MixOp op, TextureOperand a, TextureOperand b, TextureOperand amount);

  // An image file as add_image_texture reads it: linear float texels, or
  // 8-bit ones with their statistics read as sRGB.
  struct ImageFile {
    Image img;
    Image8 img8;
    TextureStats srgb_stats;
  };
  static ImageFile read_image_file(const std::string& path);

  struct Object {
    std::string name;
    std::vector<TriangleMesh> meshes;
    std::vector<uint32_t> materials;
    std::vector<SourceLoc> at;  // per mesh
    size_t placements = 0;
  };
  struct Placement {
    SourceLoc at;
    uint32_t object;
    Matrix4 to_world;
  };

  std::string file_;
  Scene scene_;
  mutable std::vector<std::optional<TextureStats>> texture_stats_;  // one per scene_.textures entry
  std::map<std::string, int32_t> image_cache_;
  std::map<std::string, int32_t> image_files_;  // path -> its first texture
  ReadAhead<ImageFile> images_ahead_;
  std::vector<Object> objects_;
  std::vector<Placement> placements_;  // until resolve_instances()
  size_t num_instances_ = 0;
  int32_t default_material_ = -1;
  bool has_camera_ = false;
};

// Coordinates beyond this are refused: Embree asserts on rays whose origin
// or direction exceed about 1.8e18.
constexpr float kMaxCoordinate = 1e18f;

}  // namespace luz
