// The host scene: what the loaders fill in. compile() derives the light
// selection table and hands out a SceneView over these arrays.
#pragma once

#include <string>
#include <vector>

#include "luz/film/filter.h"
#include "luz/integrator/path.h"
#include "luz/io/image.h"
#include "luz/sampling/sampler.h"
#include "luz/scene/scene_view.h"

namespace luz {

struct RenderSettings {
  // Luz's best sampler where a scene names none (OBJ, PLY, glTF, pbrt-v4
  // without a Sampler, a Mitsuba sensor without <sampler>).
  SamplerType sampler = SamplerType::Sobol;
  uint32_t spp = 16;
  uint64_t seed = 0;
  IntegratorParams integrator;
  FilterKind filter = FilterKind::Box;
  // Splatting by default: 2-3x less variance per pixel than filter sampling
  // for the tent and gaussian (bench/RESULTS.md).
  Reconstruction reconstruction = Reconstruction::Splat;
  // The light BVH by default, as pbrt-v4 and Cycles: 20-80x power's
  // efficiency where lights are spread wide, 0.6-2.3x in a room of lights
  // all about as far, 0.8-22x with a few lights (bench/RESULTS.md).
  LightSamplerType light_sampler = LightSamplerType::Bvh;
  // A constant environment sampled where it is seen from (light/env_guide.h):
  // 2.6x less noise for 1.2x the time indoors under a sky (bench/RESULTS.md),
  // nothing changed where there is no constant environment.
  bool env_guide = true;
  ExrFormat exr_format;  // how .exr outputs are written (Mitsuba's hdrfilm formats)
};

// Which extent of the film a field of view is given along (Mitsuba's
// fov_axis; pbrt's fov is along the shorter side): what stays fixed when the
// resolution changes.
enum class FovAxis : uint8_t { X, Y, Diagonal, Smaller, Larger };

// The film's half extents (Camera::tan_half_x, tan_half_y) for a half field
// of view of tangent t along `axis` on a width × height film.
void fit_fov(FovAxis axis, double t, int width, int height, float& tan_half_x, float& tan_half_y);

struct Scene {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  // empty, or one per position
  std::vector<Vec2> uvs;      // empty, or one per position (texture coordinates, texture.h)
  std::vector<Color> colors;  // empty, or one per position (vertex colours, linear; white where a mesh has none)
  std::vector<uint32_t> indices;
  std::vector<uint32_t> tri_material;
  std::vector<int32_t> tri_emitter;
  std::vector<Sphere> spheres;
  std::vector<Material> materials;
  std::vector<TextureBinding> texture_bindings;  // Material::first_binding indexes it
  std::vector<Light> lights;  // area lights (named by tri_emitter, Sphere::emitter), then the others
  // Textures (texture.h): the list, all 8-bit texels back to back, all float
  // texels (3 per texel) back to back, and the sRGB decoding table (filled by
  // the first 8-bit bitmap).
  std::vector<Texture> textures;
  std::vector<uint32_t> texels8;
  std::vector<float> texelsf;
  std::vector<float> srgb_table;
  Camera camera;
  FovAxis fov_axis = FovAxis::X;  // what set_resolution keeps
  RenderSettings settings;
  // Instancing (geometry/instance.h): the objects' triangles follow the
  // world's in the arrays above, in object space, and are placed by
  // `instances`; num_triangles() counts the world's. flattened_instances:
  // placements the loader flattened into the world's triangles instead.
  std::vector<SceneObject> objects;
  std::vector<Instance> instances;
  size_t flattened_instances = 0;
  // One-line warnings of the loader ("file:line: warning: ..."), for the CLI to print.
  std::vector<std::string> warnings;

  // Filled by compile().
  // Light selection: the power alias table (light_pmf[k] = P(light k)) and
  // the light BVH; lights_emit false when no light has power.
  std::vector<AliasEntry> light_alias;
  std::vector<float> light_pmf;
  LightBvhData light_bvh;
  bool lights_emit = false;
  std::vector<float> light_data;  // what LightsView::data points to (filled by the loaders)
  std::vector<Vec3> tri_normals;  // unit geometric normal per triangle (the CPU's SceneView)
  int32_t environment = -1;
  Vec3 bounds_min{}, bounds_max{};

  // The world's triangles (the objects' stored after them are not counted).
  uint32_t num_triangles() const {
    return objects.empty() ? uint32_t(tri_material.size()) : objects.front().first_triangle;
  }
  // Triangles the instances place (each object's count once per instance).
  uint64_t num_instanced_triangles() const;

  // Appends a triangle mesh (positions already in world space). normals may be
  // empty, and so may uv (texture coordinates). With `emission`, every
  // triangle is an area light of that radiance, or, with emission_texture
  // >= 0 (and uv), of that texture's (emission holding its mean), on both
  // sides with `two_sided`. col: its vertex colours, or empty. Once an
  // object is begun, meshes (without emission) go into the last object.
  void add_mesh(const std::vector<Vec3>& pos, const std::vector<Vec3>& nrm, const std::vector<uint32_t>& idx,
                uint32_t material, const Color* emission, const std::vector<Vec2>& uv = {},
                int32_t emission_texture = -1, bool two_sided = false, const std::vector<Color>& col = {});
  // A sphere; with `emission`, an area light of that radiance, or with
  // emission_texture >= 0 of that texture's at its uv (emission holding its
  // mean). frame: its object frame (Sphere::frame).
  void add_sphere(Vec3 center, float radius, uint32_t material, const Color* emission, bool flip,
                  int32_t emission_texture = -1, const Frame& frame = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  // A new object, empty; the meshes added next (add_mesh, in object space)
  // are its. Returns its index.
  uint32_t add_object();
  // Places an object; to_object must be to_world's inverse.
  uint32_t add_instance(uint32_t object, const Affine3& to_world, const Affine3& to_object);
  // Every instance becomes world triangles (vertices by Affine3::point,
  // normals by Instance::normal: what an instanced hit computes), and the
  // objects are dropped. Call compile() after.
  void flatten_instances();
  // A material: the BSDF with its constant parameters, and the textures
  // driving the others, and its opacity (Material::opacity). Returns its index.
  uint32_t add_material(const Bsdf& b, const std::vector<TextureBinding>& bindings = {}, float opacity = 1.f,
                        int32_t opacity_texture = -1);
  // Appends a bitmap's width · height texels (rows top to bottom: packed RGBA8
  // or 3 floats each); bitmap.offset and is_float are set here. Returns the
  // texture's index. Throws std::length_error past the texel arrays' limits.
  uint32_t add_bitmap(BitmapTexture bitmap, const UvTransform& to_uv, const std::vector<uint32_t>& rgba8);
  uint32_t add_bitmap(BitmapTexture bitmap, const UvTransform& to_uv, const std::vector<float>& rgb);
  uint32_t add_texture(const Texture& t);

  // Renders at width × height instead: the field of view along fov_axis
  // stays, the other extent follows the new aspect ratio.
  void set_resolution(int width, int height);

  // Bounds, emitter selection table, triangle normals; call after loading,
  // before rendering, and again after any change to the geometry (view()
  // trusts what compile() derived).
  void compile();
  SceneView view() const;

 private:
  void merge_parallelogram_emitters();
};

}  // namespace luz
