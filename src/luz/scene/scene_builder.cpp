#include "luz/scene/scene_builder.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>

#include "luz/core/memory.h"
#include "luz/io/error.h"
#include "luz/io/image.h"

namespace luz {

SceneBuilder::SceneBuilder(std::string file) : file_(std::move(file)) {}

void SceneBuilder::error(const SourceLoc& at, const std::string& problem) const {
  throw InputError(at.file.empty() ? file_ : at.file, at.line, problem);
}

void SceneBuilder::warn(const SourceLoc& at, const std::string& problem) {
  const std::string& f = at.file.empty() ? file_ : at.file;
  std::string w = InputError::one_line(f);
  if (at.line > 0) (w += ':') += std::to_string(at.line);
  (w += ": warning: ") += InputError::one_line(problem);
  scene_.warnings.push_back(std::move(w));
}

// ---- textures ----

int32_t SceneBuilder::push_texture_stats(int32_t index, const std::optional<TextureStats>& stats) {
  texture_stats_.resize(scene_.textures.size());
  texture_stats_[size_t(index)] = stats;
  return index;
}

const TextureStats& SceneBuilder::texture_stats(int32_t texture) const {
  std::optional<TextureStats>& s = texture_stats_.at(size_t(texture));
  if (!s) s = bitmap_stats(scene_.textures[size_t(texture)]);
  return *s;
}

namespace {

bool is_float_image(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".exr" || ext == ".hdr" || ext == ".pfm";
}

// Per-channel mean (summed in double), minimum and maximum, in this order:
// texture statistics the same bit for bit however the image was read.
struct StatsSum {
  double sum[3] = {0, 0, 0};
  TextureStats stats{{}, {INFINITY, INFINITY, INFINITY}, {0.f, 0.f, 0.f}};
  void add(Color c) {
    for (int k = 0; k < 3; ++k) sum[k] += c[k];
    stats.min = vmin(stats.min, c);
    stats.max = vmax(stats.max, c);
  }
  TextureStats done(size_t texels) {
    for (int k = 0; k < 3; ++k) stats.mean[k] = float(sum[k] / double(texels));
    return stats;
  }
};

// An 8-bit image's statistics, its texels read as sRGB or as linear values.
TextureStats stats8(const Image8& img, bool srgb) {
  static const std::vector<float> table = [] {  // Scene::srgb_table's values
    std::vector<float> t;
    for (int k = 0; k < 256; ++k) t.push_back(float(srgb_to_linear(k / 255.0)));
    return t;
  }();
  StatsSum sum;
  for (uint32_t texel : img.rgba) sum.add(texel_color(texel, srgb, table.data()));
  return sum.done(img.rgba.size());
}

}  // namespace

SceneBuilder::ImageFile SceneBuilder::read_image_file(const std::string& path) {
  ImageFile f;
  if (is_float_image(path)) {
    f.img = read_image_linear(path);  // float texels are linear: srgb changes nothing
    return f;
  }
  f.img8 = read_image8(path);
  f.srgb_stats = stats8(f.img8, true);  // what 8-bit textures mostly are
  return f;
}

void SceneBuilder::read_images_ahead(const std::vector<std::string>& paths) {
  std::vector<std::string> unique;  // each taken once (a second use shares the texels)
  for (const std::string& p : paths)
    if (std::find(unique.begin(), unique.end(), p) == unique.end()) unique.push_back(p);
  const std::vector<std::string> keys = largest_first(unique);
  // Room for all texels at once: appending them one image at a time would
  // copy the earlier ones again at each growth.
  std::atomic<size_t> texels8 = 0, floats = 0;
  images_ahead_.run(keys, [&](const std::string& path) {
    ImageFile f = read_image_file(path);
    texels8 += f.img8.rgba.size();
    floats += f.img.rgb.size();
    return f;
  });
  scene_.texels8.reserve(scene_.texels8.size() + texels8);
  scene_.texelsf.reserve(scene_.texelsf.size() + floats);
}

int32_t SceneBuilder::add_image_texture(const SourceLoc& at, const ImageTextureDesc& d) {
  char key_tail[160];
  const UvTransform& m = d.to_uv;
  std::snprintf(key_tail, sizeof key_tail, "|%d|%d|%d|%a|%a|%a|%a|%a|%a", int(d.srgb), int(d.filter), int(d.wrap), m.a,
                m.b, m.c, m.d, m.e, m.f);
  const std::string key = d.path + key_tail;
  if (auto it = image_cache_.find(key); it != image_cache_.end()) return it->second;

  BitmapTexture bm;
  bm.filter = d.filter;
  bm.wrap = d.wrap;
  bm.srgb = d.srgb;
  int32_t index = -1;
  std::optional<TextureStats> stats;  // none: computed when asked for
  if (auto it = image_files_.find(d.path); it != image_files_.end()) {
    // Read already with other settings: a view of the same texels.
    Texture t = scene_.textures[size_t(it->second)];
    bm.width = t.bitmap.width, bm.height = t.bitmap.height, bm.offset = t.bitmap.offset;
    bm.is_float = t.bitmap.is_float;
    t.bitmap = bm;
    t.to_uv = d.to_uv;
    try {
      index = int32_t(scene_.add_texture(t));
    } catch (const std::length_error& e) {
      error(at, e.what());
    }
  } else {
    // Read first (a reader's error gains this place), then check and add.
    std::optional<ImageFile> f;
    try {
      f = images_ahead_.take(d.path);
      if (!f) f = read_image_file(d.path);
    } catch (const InputError& e) {
      error(at, e.what());
    }
    try {
      if (is_float_image(d.path)) {
        const Image& img = f->img;
        const size_t texels = size_t(img.width) * size_t(img.height);
        StatsSum sum;
        for (size_t k = 0; k < texels; ++k) {
          const Color c{img.rgb[3 * k], img.rgb[3 * k + 1], img.rgb[3 * k + 2]};
          if (!is_finite(c) || c.x < 0.f || c.y < 0.f || c.z < 0.f)
            error(at, "bitmap '" + d.path + "': texel (" + std::to_string(k % size_t(img.width)) + ", " +
                          std::to_string(k / size_t(img.width)) + ") is negative or not finite");
          sum.add(c);
        }
        stats = sum.done(texels);
        bm.width = uint32_t(img.width), bm.height = uint32_t(img.height);
        index = int32_t(scene_.add_bitmap(bm, d.to_uv, img.rgb));
      } else {
        bm.width = uint32_t(f->img8.width), bm.height = uint32_t(f->img8.height);
        index = int32_t(scene_.add_bitmap(bm, d.to_uv, f->img8.rgba));
        if (d.srgb) stats = f->srgb_stats;
      }
    } catch (const std::length_error& e) {
      error(at, e.what());
    }
    image_files_[d.path] = index;
  }
  image_cache_[key] = index;
  return push_texture_stats(index, stats);
}

int32_t SceneBuilder::add_vertex_color_texture(const SourceLoc& at, Color scale) {
  if (!is_finite(scale) || !(scale.x >= 0.f && scale.y >= 0.f && scale.z >= 0.f))
    error(at, "a vertex colour's scale must be finite and not negative");
  Texture tex{VertexColorTexture{}};
  tex.scale = scale;
  int32_t index = -1;
  try {
    index = int32_t(scene_.add_texture(tex));
  } catch (const std::length_error& e) {
    error(at, e.what());
  }
  // Colours in [0, 1] (check_mesh), their mean unknown until every mesh is
  // read: mid-grey.
  return push_texture_stats(index, TextureStats{scale * 0.5f, Color{}, scale});
}

int32_t SceneBuilder::add_checkerboard(const SourceLoc& at, Color color0, Color color1, const UvTransform& to_uv) {
  for (Color v : {color0, color1})
    if (!is_finite(v) || !(v.x >= 0.f && v.y >= 0.f && v.z >= 0.f))
      error(at, "checkerboard colours must be finite and not negative");
  CheckerboardTexture c;
  c.color0 = color0;
  c.color1 = color1;
  Texture tex(c);
  tex.to_uv = to_uv;
  int32_t index;
  try {
    index = int32_t(scene_.add_texture(tex));
  } catch (const std::length_error& e) {
    error(at, e.what());
  }
  return push_texture_stats(index, TextureStats{(color0 + color1) * 0.5f, vmin(color0, color1), vmax(color0, color1)});
}

TextureView SceneBuilder::texture_view() const {
  TextureView v;
  v.list = scene_.textures.data();
  v.texels8 = scene_.texels8.data();
  v.texelsf = scene_.texelsf.data();
  v.srgb_table = scene_.srgb_table.data();
  v.count = uint32_t(scene_.textures.size());
  return v;
}

TextureStats SceneBuilder::bitmap_stats(const Texture& t) const {
  const TextureView v = texture_view();
  StatsSum sum;
  const uint32_t n = t.bitmap.width * t.bitmap.height;
  for (uint32_t k = 0; k < n; ++k) sum.add(t.scale * v.texel(t.bitmap, k) + t.offset);
  return sum.done(n);
}

int32_t SceneBuilder::add_image8(const SourceLoc& at, BitmapTexture bm, const UvTransform& to_uv,
                                 const std::vector<uint32_t>& rgba) {
  if (bm.width == 0 || bm.height == 0 || size_t(bm.width) * bm.height != rgba.size())
    error(at, "an image's size does not match its texels");
  int32_t index = -1;
  try {
    index = int32_t(scene_.add_bitmap(bm, to_uv, rgba));
  } catch (const std::length_error& e) {
    error(at, e.what());
  }
  return push_texture_stats(index, std::nullopt);
}

int32_t SceneBuilder::add_texture(const SourceLoc& at, const Texture& t) {
  const bool plain = t.scale.x >= 0.f && t.scale.y >= 0.f && t.scale.z >= 0.f && t.offset.x == 0.f &&
                     t.offset.y == 0.f && t.offset.z == 0.f;
  if (!is_finite(t.scale) || !is_finite(t.offset)) error(at, "a texture's scale and offset must be finite");
  if (t.type != TextureType::Bitmap) error(at, "add_texture takes bitmaps");
  const BitmapTexture& b = t.bitmap;
  const size_t texels = size_t(b.width) * b.height;
  const size_t stored = b.is_float ? scene_.texelsf.size() / 3 : scene_.texels8.size();
  if (texels == 0 || b.offset > stored || texels > stored - b.offset) error(at, "a texture's texels lie outside the scene's");
  // A negative scale or an offset (an inverted texture) must keep every value ≥ 0.
  std::optional<TextureStats> stats;
  if (!plain) {
    stats = bitmap_stats(t);
    if (!(stats->min.x >= 0.f && stats->min.y >= 0.f && stats->min.z >= 0.f))
      error(at, "a texture's scale and offset make values negative");
  }
  int32_t index = -1;
  try {
    index = int32_t(scene_.add_texture(t));
  } catch (const std::length_error& e) {
    error(at, e.what());
  }
  return push_texture_stats(index, stats);
}

// ---- materials ----

uint32_t SceneBuilder::add_material(const SourceLoc& at, const MaterialDesc& d) {
  const int32_t n = int32_t(scene_.textures.size());
  auto check = [&](int32_t t, const char* what) {
    if (t < -1 || t >= n) error(at, std::string(what) + " names no texture");
  };
  for (const TextureBinding& b : d.bindings) check(b.texture, "a texture binding");
  check(d.opacity_texture, "the opacity");
  check(d.normal_map, "the normal map");
  check(d.bump_map, "the bump map");
  for (int32_t t : {d.normal_map, d.bump_map})
    if (t >= 0 && texture_reads_vertex_color(scene_.textures.data(), uint32_t(t)))
      error(at, "a normal or bump map from vertex colours is not supported");
  if (!(d.opacity >= 0.f && d.opacity <= 1.f)) error(at, "opacity must lie in [0, 1]");
  if (!std::isfinite(d.bump_scale)) error(at, "the bump scale is not finite");
  if (!std::isfinite(d.normal_scale)) error(at, "the normal map's scale is not finite");
  if (!(d.alpha_cutoff <= 1.f)) error(at, "the alpha cutoff must be at most 1 (negative: none)");
  if (scene_.materials.size() >= size_t(UINT32_MAX)) error(at, "more than 2^32 - 1 materials");
  const uint32_t m = scene_.add_material(d.bsdf, d.bindings, d.opacity, d.opacity_texture);
  Material& mat = scene_.materials[m];
  mat.normal_map = d.normal_map;
  mat.bump_map = d.bump_map;
  mat.bump_scale = d.bump_scale;
  mat.normal_scale = d.normal_scale;
  mat.normal_y_by_uv = d.normal_y_by_uv;
  mat.alpha_cutoff = d.alpha_cutoff;
  return m;
}

bool SceneBuilder::material_reads_uv(uint32_t m) const {
  const Material& mat = scene_.materials.at(m);
  bool any = mat.normal_map >= 0 || mat.bump_map >= 0;
  for (uint32_t k = 0; k < mat.num_bindings; ++k)
    any |= texture_reads_uv(scene_.textures.data(), uint32_t(scene_.texture_bindings[mat.first_binding + k].texture));
  return any || (mat.opacity_texture >= 0 && texture_reads_uv(scene_.textures.data(), uint32_t(mat.opacity_texture)));
}

bool SceneBuilder::material_reads_colors(uint32_t m) const {
  const Material& mat = scene_.materials.at(m);
  bool any = false;
  for (uint32_t k = 0; k < mat.num_bindings; ++k)
    any |= texture_reads_vertex_color(scene_.textures.data(),
                                      uint32_t(scene_.texture_bindings[mat.first_binding + k].texture));
  return any ||
         (mat.opacity_texture >= 0 && texture_reads_vertex_color(scene_.textures.data(), uint32_t(mat.opacity_texture)));
}

MaterialDesc SceneBuilder::material(uint32_t index) const {
  const Material& m = scene_.materials.at(index);
  const auto first = scene_.texture_bindings.begin() + std::ptrdiff_t(m.first_binding);
  MaterialDesc d;
  d.bsdf = m.bsdf;
  d.bindings.assign(first, first + std::ptrdiff_t(m.num_bindings));
  d.opacity = m.opacity;
  d.opacity_texture = m.opacity_texture;
  d.normal_map = m.normal_map;
  d.bump_map = m.bump_map;
  d.bump_scale = m.bump_scale;
  d.normal_scale = m.normal_scale;
  d.normal_y_by_uv = m.normal_y_by_uv;
  d.alpha_cutoff = m.alpha_cutoff;
  return d;
}

uint32_t SceneBuilder::default_material() {
  if (default_material_ < 0) default_material_ = int32_t(scene_.add_material(MaterialDesc().bsdf));
  return uint32_t(default_material_);
}

// ---- shapes ----

void SceneBuilder::check_emission(const SourceLoc& at, const AreaEmission& e) const {
  for (int k = 0; k < 3; ++k)
    if (!(e.radiance[k] >= 0.f) || !std::isfinite(e.radiance[k])) error(at, "radiance must be finite and not negative");
  if (e.texture < -1 || e.texture >= int32_t(scene_.textures.size())) error(at, "the emitter names no texture");
  // Light sampling evaluates the radiance at points it picks by their uv alone.
  if (e.texture >= 0 && texture_reads_vertex_color(scene_.textures.data(), uint32_t(e.texture)))
    error(at, "an emitter's radiance from vertex colours is not supported");
}

void SceneBuilder::check_shape_material(const SourceLoc& at, uint32_t material, const AreaEmission* emission,
                                        bool has_uvs, bool has_colors, const char* what) const {
  if (material >= scene_.materials.size()) error(at, "the shape names no material");
  const Material& m = scene_.materials[material];
  const bool textured_bsdf = material_reads_uv(material), colored = material_reads_colors(material);
  if (emission) check_emission(at, *emission);
  const bool textured_emitter = emission && emission->texture >= 0;
  if ((textured_bsdf || textured_emitter) && !has_uvs)
    error(at, std::string(textured_bsdf ? "a textured material" : "a textured emitter") + " on " + what +
                  " without texture coordinates");
  if (colored && !has_colors) error(at, std::string("a material reading vertex colours on ") + what + " without them");
  // Light sampling would pick points on the cut-away parts too.
  if (emission && m.masked()) error(at, "a masked material on an emitting shape is not supported");
}

void SceneBuilder::check_mesh(const SourceLoc& at, TriangleMesh& mesh, uint32_t material,
                              const AreaEmission* emission) {
  const size_t nv = mesh.positions.size();
  if (mesh.indices.size() % 3 != 0) error(at, "the mesh's index count is not a multiple of 3");
  if (!mesh.normals.empty() && mesh.normals.size() != nv) error(at, "the mesh has normals for some vertices only");
  if (!mesh.uvs.empty() && mesh.uvs.size() != nv)
    error(at, "the mesh has texture coordinates for some vertices only");
  if (!mesh.colors.empty() && mesh.colors.size() != nv) error(at, "the mesh has colours for some vertices only");
  check_shape_material(at, material, emission, !mesh.uvs.empty(), !mesh.colors.empty(), "a mesh");
  for (size_t k = 0; k < mesh.colors.size(); ++k)
    if (!is_unit_color(mesh.colors[k])) error(at, "the colour of vertex " + std::to_string(k) + " is not within [0, 1]");
  for (size_t k = 0; k < nv; ++k)
    if (!is_finite(mesh.positions[k]) || max_abs(mesh.positions[k]) > kMaxCoordinate)
      error(at, "vertex " + std::to_string(k) + " is not finite or lies beyond 1e18");
  // A vertex normal that is not finite (exporters write NaN for degenerate
  // faces) becomes zero: such a vertex shades flat, as one with no normal.
  size_t bad_normals = 0;
  for (Vec3& n : mesh.normals)
    if (!is_finite(n)) n = Vec3{}, ++bad_normals;
  if (bad_normals > 0)
    warn(at, std::to_string(bad_normals) + " vertex normal" + (bad_normals > 1 ? "s are" : " is") +
                 " not finite: shaded flat");
  for (size_t k = 0; k < mesh.uvs.size(); ++k)
    if (!std::isfinite(mesh.uvs[k].x) || !std::isfinite(mesh.uvs[k].y))
      error(at, "the texture coordinates of vertex " + std::to_string(k) + " are not finite");
  for (size_t k = 0; k < mesh.indices.size(); ++k)
    if (mesh.indices[k] >= nv)
      error(at, "index " + std::to_string(mesh.indices[k]) + " (triangle " + std::to_string(k / 3) + ") is out of range (" +
                    std::to_string(nv) + " vertices)");
}

void SceneBuilder::check_room(const SourceLoc& at, const TriangleMesh& mesh) const {
  // The scene's arrays are indexed by 32 bits (and Embree's primitive IDs).
  if (scene_.positions.size() + mesh.positions.size() >= size_t(UINT32_MAX) ||
      scene_.tri_material.size() + mesh.indices.size() / 3 >= size_t(UINT32_MAX))
    error(at, "the scene would have more than 2^32 - 1 vertices or triangles");
  // What the scene's arrays would allocate to take the mesh (a vector that
  // is full doubles): many placements of one mesh add up to more than any
  // reader's own request.
  const size_t nv = mesh.positions.size(), nt = mesh.indices.size() / 3;
  uint64_t grow = 0;
  auto add = [&](const auto& v, size_t more) {
    if (v.size() + more > v.capacity()) grow += std::max(2 * v.capacity(), v.size() + more) * sizeof(v[0]);
  };
  add(scene_.positions, nv);
  if (!mesh.normals.empty() || !scene_.normals.empty()) add(scene_.normals, nv);
  if (!mesh.uvs.empty() || !scene_.uvs.empty()) add(scene_.uvs, nv);
  if (!mesh.colors.empty() || !scene_.colors.empty()) add(scene_.colors, nv);
  add(scene_.indices, 3 * nt);
  add(scene_.tri_material, nt);
  add(scene_.tri_emitter, nt);
  require_memory(grow, at.file, "the scene's arrays, grown to " + std::to_string(scene_.positions.size() + nv) +
                                    " vertices,", at.line);
}

void SceneBuilder::add_mesh(const SourceLoc& at, TriangleMesh mesh, uint32_t material, const AreaEmission* emission,
                            bool flip_normals) {
  if (!scene_.objects.empty()) throw std::logic_error("SceneBuilder: a mesh added after the instances were resolved");
  check_mesh(at, mesh, material, emission);
  check_room(at, mesh);
  if (emission && scene_.lights.size() + mesh.indices.size() / 3 >= size_t(INT32_MAX))
    error(at, "the scene would have more than 2^31 - 1 lights");
  if (flip_normals) {
    for (size_t k = 0; k + 2 < mesh.indices.size(); k += 3) std::swap(mesh.indices[k + 1], mesh.indices[k + 2]);
    for (Vec3& n : mesh.normals) n = -n;
  }
  scene_.add_mesh(mesh.positions, mesh.normals, mesh.indices, material, emission ? &emission->radiance : nullptr,
                  mesh.uvs, emission ? emission->texture : -1, emission && emission->two_sided, mesh.colors);
}

void SceneBuilder::add_sphere(const SourceLoc& at, Vec3 center, float radius, uint32_t material,
                              const AreaEmission* emission, bool flip_normals, const Matrix4& orientation) {
  check_shape_material(at, material, emission, true, false, "a sphere");
  if (emission && emission->two_sided) error(at, "a two-sided emitting sphere is not supported");
  if (!(radius > 0.f) || !std::isfinite(radius)) error(at, "the sphere's radius must be finite and positive");
  if (!is_finite(center) || max_abs(center) + radius > kMaxCoordinate)
    error(at, "the sphere is not finite or reaches beyond 1e18");
  // The object axes: orientation's columns, orthonormalised (Gram-Schmidt,
  // in double), z keeping the columns' handedness.
  double c[3][3], a[3][3];
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) c[j][i] = orientation.m[i][j];
  auto dot3 = [](const double* x, const double* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  auto unit = [&](double* x) {
    const double l = std::sqrt(dot3(x, x));
    if (!(l > 0) || !std::isfinite(l)) error(at, "the sphere's transform is singular or not finite");
    for (int i = 0; i < 3; ++i) x[i] /= l;
  };
  for (int i = 0; i < 3; ++i) a[0][i] = c[0][i];
  unit(a[0]);
  const double d01 = dot3(a[0], c[1]);
  for (int i = 0; i < 3; ++i) a[1][i] = c[1][i] - d01 * a[0][i];
  unit(a[1]);
  for (int i = 0; i < 3; ++i) a[2][i] = a[0][(i + 1) % 3] * a[1][(i + 2) % 3] - a[0][(i + 2) % 3] * a[1][(i + 1) % 3];
  if (dot3(a[2], c[2]) < 0)
    for (double& x : a[2]) x = -x;
  auto vec = [](const double* x) { return Vec3{float(x[0]), float(x[1]), float(x[2])}; };
  scene_.add_sphere(center, radius, material, emission ? &emission->radiance : nullptr, flip_normals,
                    emission ? emission->texture : -1, Frame{vec(a[0]), vec(a[1]), vec(a[2])});
}

// ---- instancing ----

uint32_t SceneBuilder::begin_object(const SourceLoc& at, const std::string& name) {
  if (objects_.size() >= size_t(INT32_MAX)) error(at, "more than 2^31 - 1 objects");
  objects_.push_back({name, {}, {}, {}, 0});
  return uint32_t(objects_.size() - 1);
}

void SceneBuilder::add_object_mesh(const SourceLoc& at, uint32_t object, TriangleMesh mesh, uint32_t material) {
  if (object >= objects_.size()) error(at, "no such object");
  check_mesh(at, mesh, material, nullptr);
  Object& o = objects_[object];
  o.meshes.push_back(std::move(mesh));
  o.materials.push_back(material);
  o.at.push_back(at);
}

void SceneBuilder::add_instance(const SourceLoc& at, uint32_t object, const Matrix4& to_world) {
  if (object >= objects_.size()) error(at, "no such object");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(to_world.m[r][c])) error(at, "the instance's transform is not finite");
  placements_.push_back({at, object, to_world});
  ++objects_[object].placements;
  ++num_instances_;
}

namespace {

Affine3 to_affine(const Matrix4& m) {
  Affine3 a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) a.m[r][c] = float(m.m[r][c]);
  return a;
}

// The inverse of an affine map (by cofactors, in double), false when it is
// singular or its inverse does not fit in floats.
bool invert_affine(const Matrix4& m, Affine3& inv) {
  const double det = m.det3();
  if (!(det != 0.0)) return false;
  double l[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      l[i][j] = (m.m[i1][j1] * m.m[i2][j2] - m.m[i1][j2] * m.m[i2][j1]) / det;  // adjugate / det
    }
  for (int i = 0; i < 3; ++i) {
    double t = 0;
    for (int j = 0; j < 3; ++j) {
      inv.m[i][j] = float(l[i][j]);
      t -= l[i][j] * m.m[j][3];
    }
    inv.m[i][3] = float(t);
    for (int j = 0; j < 4; ++j)
      if (!std::isfinite(inv.m[i][j])) return false;
  }
  return true;
}

}  // namespace

// An object placed at least twice is stored once (in object space) and
// instanced; one placed once is flattened (an instance would save nothing),
// and so is a placement by a singular map (no inverse to trace through).
// Objects never emit (begin_object's contract), so lights stay world
// triangles. Flattened meshes keep the winding, normals by the inverse
// transpose: a mirroring map turns the geometric normal, as an instance's.
void SceneBuilder::resolve_instances() {
  std::vector<Affine3> inverse(placements_.size());
  std::vector<uint8_t> flatten(placements_.size());
  std::vector<uint32_t> instanced(objects_.size());  // placements kept as instances, per object
  for (size_t k = 0; k < placements_.size(); ++k) {
    const Placement& p = placements_[k];
    flatten[k] = objects_[p.object].placements < 2 || !invert_affine(p.to_world, inverse[k]);
    instanced[p.object] += !flatten[k];
  }
  for (size_t k = 0; k < placements_.size(); ++k) {
    if (!flatten[k]) continue;
    const Placement& p = placements_[k];
    const Object& o = objects_[p.object];
    for (size_t j = 0; j < o.meshes.size(); ++j) {
      TriangleMesh m = o.meshes[j];
      for (Vec3& v : m.positions) v = p.to_world.point(v);
      for (Vec3& n : m.normals)
        if (!is_black(n)) n = p.to_world.normal(n);  // zero: a vertex shaded flat (check_mesh)
      add_mesh(p.at, std::move(m), o.materials[j]);
    }
    ++scene_.flattened_instances;
  }
  std::vector<uint32_t> scene_object(objects_.size(), UINT32_MAX);
  const Vec3 inf{kInfinity, kInfinity, kInfinity};
  std::vector<Vec3> lo(objects_.size(), inf), hi(objects_.size(), -inf);  // each instanced object's bounds
  for (size_t k = 0; k < objects_.size(); ++k) {
    if (instanced[k] == 0) continue;
    const Object& o = objects_[k];
    scene_object[k] = scene_.add_object();
    for (size_t j = 0; j < o.meshes.size(); ++j) {
      const TriangleMesh& m = o.meshes[j];
      check_room(o.at[j], m);
      scene_.add_mesh(m.positions, m.normals, m.indices, o.materials[j], nullptr, m.uvs, -1, false, m.colors);
      for (const Vec3& v : m.positions) lo[k] = vmin(lo[k], v), hi[k] = vmax(hi[k], v);
    }
  }
  for (size_t k = 0; k < placements_.size(); ++k) {
    if (flatten[k]) continue;
    const Placement& p = placements_[k];
    const SceneObject& o = scene_.objects[scene_object[p.object]];
    const Affine3 to_world = to_affine(p.to_world);
    // Every placed vertex within the range the flattened ones are held to:
    // the object's box, mapped corner by corner, encloses them.
    const Vec3 l = lo[p.object], h = hi[p.object];
    for (int c = 0; c < 8 && o.num_vertices > 0; ++c) {
      const Vec3 q = to_world.point({c & 1 ? h.x : l.x, c & 2 ? h.y : l.y, c & 4 ? h.z : l.z});
      if (!is_finite(q) || max_abs(q) > kMaxCoordinate) error(p.at, "the instance places vertices beyond 1e18");
    }
    try {
      scene_.add_instance(scene_object[p.object], to_world, inverse[k]);
    } catch (const std::length_error& e) {
      error(p.at, e.what());
    }
  }
  placements_.clear();
}

// ---- lights ----

void SceneBuilder::add_light(const SourceLoc& at, const Light& light) {
  if (is_environment(light))
    for (const Light& l : scene_.lights)
      if (is_environment(l)) error(at, "only one environment emitter is supported");
  if (scene_.lights.size() >= size_t(INT32_MAX)) error(at, "more than 2^31 - 1 lights");
  if (light.type == LightType::Spot && light.spot.texture >= 0 &&
      (light.spot.texture >= int32_t(scene_.textures.size()) ||
       texture_reads_vertex_color(scene_.textures.data(), uint32_t(light.spot.texture))))
    error(at, "a spot light's texture must be an image or checkerboard (no vertex colours: it lights no surface's vertices)");
  scene_.lights.push_back(light);
}

void SceneBuilder::add_envmap(const SourceLoc& at, EnvmapLight l, const Image& img, const std::string& name) {
  if (img.width < 2 || img.height < 3) error(at, "envmap '" + name + "' must be at least 2x3 pixels");
  if (size_t(img.width) * size_t(img.height) > (size_t(1) << 28))
    error(at, "envmap '" + name + "' has more than 2^28 pixels");
  for (size_t k = 0; k < img.rgb.size(); ++k)
    if (!(img.rgb[k] >= 0.f) || !std::isfinite(img.rgb[k])) {
      const size_t px = k / 3;
      error(at, "envmap '" + name + "': pixel (" + std::to_string(px % size_t(img.width)) + ", " +
                    std::to_string(px / size_t(img.width)) + ") is " +
                    (std::isfinite(img.rgb[k]) ? "negative" : "not finite"));
    }
  if (!(l.scale >= 0.f) || !std::isfinite(l.scale)) error(at, "the envmap's scale must be finite and not negative");
  for (const Light& e : scene_.lights)
    if (is_environment(e)) error(at, "only one environment emitter is supported");
  build_envmap(l, img.rgb, uint32_t(img.width), uint32_t(img.height), scene_.light_data);
  scene_.lights.push_back(l);
}

// ---- camera ----

void SceneBuilder::set_camera(const SourceLoc& at, const Camera& cam, FovAxis axis) {
  if (has_camera_) error(at, "only one camera is supported");
  if (cam.width < 1 || cam.height < 1 || cam.width > 65536 || cam.height > 65536)
    error(at, "film size must be between 1 and 65536");
  if (!(cam.tan_half_x > 0.f) || !(cam.tan_half_y > 0.f) || !std::isfinite(cam.tan_half_x) ||
      !std::isfinite(cam.tan_half_y))
    error(at, "the camera's field of view is degenerate");
  // Embree refuses (asserts on) rays whose origin or direction is not finite
  // or exceeds 1.8e18 in magnitude.
  if (!is_finite(cam.x_axis) || !is_finite(cam.y_axis) || !is_finite(cam.z_axis) || length(cam.z_axis) == 0.f)
    error(at, "the camera's transform gives it a degenerate orientation");
  if (!is_finite(cam.origin) || max_abs(cam.origin) > kMaxCoordinate)
    error(at, "the camera lies too far from the origin (a coordinate beyond 1e18)");
  if (cam.type == CameraType::Orthographic &&
      max_abs(cam.x_axis) + max_abs(cam.y_axis) * cam.tan_half_y + max_abs(cam.origin) > kMaxCoordinate)
    error(at, "the orthographic view reaches beyond 1e18");
  scene_.camera = cam;
  scene_.fov_axis = axis;
  has_camera_ = true;
}

int32_t SceneBuilder::add_scaled_texture(const SourceLoc& at, int32_t index, Color k) {
  if (k.x == 1.f && k.y == 1.f && k.z == 1.f) return index;
  if (!is_finite(k) || !(k.x >= 0.f && k.y >= 0.f && k.z >= 0.f)) error(at, "a texture's scale must be finite and not negative");
  Texture t = scene_.textures[size_t(index)];
  t.scale = t.scale * k;
  t.offset = t.offset * k;
  if (t.type == TextureType::Bitmap) return add_texture(at, t);
  if (!is_finite(t.scale) || !is_finite(t.offset)) error(at, "a texture's scale must be finite");
  const TextureStats s = texture_stats(index);
  int32_t scaled = -1;
  try {
    scaled = int32_t(scene_.add_texture(t));
  } catch (const std::length_error& e) {
    error(at, e.what());
  }
  return push_texture_stats(scaled, TextureStats{s.mean * k, s.min * k, s.max * k});
}

int32_t SceneBuilder::add_mix_texture(const SourceLoc& at, TextureOperand a, TextureOperand b, TextureOperand amount) {
  return add_mix(at, MixOp::Lerp, a, b, amount);
}

int32_t SceneBuilder::add_product_texture(const SourceLoc& at, TextureOperand a, TextureOperand b) {
  return add_mix(at, MixOp::Product, a, b, {});
}

int32_t SceneBuilder::add_mix(const SourceLoc& at, MixOp op, TextureOperand a, TextureOperand b, TextureOperand amount) {
  const bool lerp = op == MixOp::Lerp;
  MixTexture m;
  m.op = op;
  m.a = a.texture, m.ca = a.value, m.b = b.texture, m.cb = b.value;
  m.amount = lerp ? amount.texture : -1;
  m.w = lerp && amount.texture < 0 ? amount.value.x : 0.f;
  // Each operand's range: a texture's statistics, or the constant.
  auto range = [&](int32_t t, Color c, const char* what) {
    if (t < 0) {
      if (!is_finite(c)) error(at, std::string("a texture ") + what + " is not finite");
      return TextureStats{c, c, c};
    }
    if (size_t(t) >= scene_.textures.size()) error(at, std::string("a texture ") + what + " names no texture");
    if (scene_.textures[size_t(t)].type == TextureType::Mix)
      error(at, std::string("a mix or scale texture whose ") + what + " is itself a mix or scale of textures is not supported");
    return texture_stats(t);
  };
  const TextureStats ra = range(m.a, m.ca, "operand"), rb = range(m.b, m.cb, "operand");
  TextureStats out;
  if (lerp) {
    const TextureStats rw = range(m.amount, Color{m.w, m.w, m.w}, "amount");
    if (!(luminance(rw.min) >= 0.f && luminance(rw.max) <= 1.f)) error(at, "a mix texture's amount must lie in [0, 1]");
    out.min = vmin(ra.min, rb.min), out.max = vmax(ra.max, rb.max);
  } else {
    // Interval products, per channel.
    for (int k = 0; k < 3; ++k) {
      const float p[4] = {ra.min[k] * rb.min[k], ra.min[k] * rb.max[k], ra.max[k] * rb.min[k], ra.max[k] * rb.max[k]};
      out.min[k] = std::min({p[0], p[1], p[2], p[3]});
      out.max[k] = std::max({p[0], p[1], p[2], p[3]});
    }
  }
  int32_t index = -1;
  try {
    index = int32_t(scene_.add_texture(Texture(m)));
  } catch (const std::length_error& e) {
    error(at, e.what());
  }
  // The mean over the unit square of texture coordinates (a mix has no
  // texels of its own), at the centres of a 256² grid, vertex colours at
  // their assumed mean (add_vertex_color_texture).
  const TextureView v = texture_view();
  constexpr int kGrid = 256;
  double sum[3] = {0, 0, 0};
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const Color c = v.eval(uint32_t(index), {(i + 0.5f) / kGrid, (j + 0.5f) / kGrid}, {0.5f, 0.5f, 0.5f});
      for (int k = 0; k < 3; ++k) sum[k] += c[k];
    }
  for (int k = 0; k < 3; ++k) out.mean[k] = float(sum[k] / (kGrid * kGrid));
  return push_texture_stats(index, out);
}

void SceneBuilder::crop_camera(const SourceLoc& at, long x0, long x1, long y0, long y1) {
  Camera& c = scene_.camera;
  if (!(0 <= x0 && x0 < x1 && x1 <= c.width && 0 <= y0 && y0 < y1 && y1 <= c.height))
    error(at, "the crop window [" + std::to_string(x0) + ", " + std::to_string(x1) + ") × [" + std::to_string(y0) +
                  ", " + std::to_string(y1) + ") is empty or leaves the " + std::to_string(c.width) + "×" +
                  std::to_string(c.height) + " film");
  c.crop(int(x0), int(y0), int(x1 - x0), int(y1 - y0));
}

void SceneBuilder::frame_bounds(int width, int height) {
  resolve_instances();  // (only finish() may follow)
  scene_.compile();
  const Vec3 c = (scene_.bounds_min + scene_.bounds_max) * 0.5f;
  const Vec3 ext = scene_.bounds_max - scene_.bounds_min;
  const float half = 0.5f * std::max(ext.x, ext.y);
  const float t = std::tan(20.f * kPi / 180.f);
  Camera cam;
  cam.width = width;
  cam.height = height;
  fit_fov(FovAxis::Smaller, t, width, height, cam.tan_half_x, cam.tan_half_y);
  cam.origin = {c.x, c.y, scene_.bounds_max.z + half / t * 1.05f};
  if (!is_finite(cam.origin) || max_abs(cam.origin) > kMaxCoordinate)
    error({}, "the model is too large to frame (the camera would lie beyond 1e18)");
  cam.x_axis = {-1, 0, 0};
  cam.y_axis = {0, 1, 0};
  cam.z_axis = {0, 0, -1};
  set_camera({}, cam, FovAxis::Smaller);
}

Scene SceneBuilder::finish() {
  resolve_instances();
  if (scene_.num_triangles() == 0 && scene_.spheres.empty() && scene_.num_instanced_triangles() == 0)
    error({}, "the scene has no shapes");
  if (!has_camera_) error({}, "the scene has no camera");
  images_ahead_.clear();
  scene_.compile();
  return std::move(scene_);
}

}  // namespace luz
