// glTF 2.0 loader (Khronos glTF 2.0 specification; tinygltf parses the JSON
// or GLB container, decodes data URIs and images). Mapping onto Luz:
//
//  - Nodes: the default scene's node forest (matrix, or T·R·S), each mesh
//    placed by its node's world transform; a mesh placed by several nodes is
//    a SceneBuilder object with one instance per node (unless it emits, or
//    the node mirrors: then copied). A negative determinant reverses the
//    winding, as the specification says.
//  - Primitives: TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN (converted to
//    triangles as §3.7.2.1 lists them); POINTS and LINES* skipped with a
//    warning. Indices of any type (or none). POSITION (float), NORMAL
//    (float; absent: flat shading), TEXCOORD_n (float, or normalised
//    unsigned byte or short), and KHR_mesh_quantization's integer types
//    where the file uses it: one uv set per primitive, the one its material's
//    textures name (KHR_texture_transform's texCoord included); COLOR_0
//    (float, or normalised unsigned byte or short) multiplies the base
//    colour (its alpha is ignored, with a warning where it matters); sparse
//    accessors are refused. Morph targets
//    at the node's (else the mesh's) weights; skins by their joints'
//    matrices (linear blend, the skinned node's own transform ignored, as
//    §3.7.3 says): the pose the file holds, without animation.
//  - Materials: the metallic-roughness model (bsdf/gltf_pbr.h). Factors
//    multiply their textures (Texture::scale); roughness is read from G and
//    metallic from B of metallicRoughnessTexture (Texture::channel). Normal
//    textures perturb the shading frame (Material::normal_map: the tangent
//    along dp/du, the bitangent along -dp/dv's side of n × t, the sign
//    MikkTSpace gives a mesh without TANGENT, mirrored uv layouts too;
//    x and y times normalTexture.scale, §3.9.3); TANGENT is ignored with a
//    warning (the tangent follows dp/du). occlusionTexture is ignored (the path
//    tracer computes occlusion). doubleSided -> Bsdf::two_sided; a
//    one-sided surface's back is black and opaque rather than culled (a
//    rasteriser's culling, followed by rays, would let light leak through
//    single-sided walls).
//    KHR_materials_ior sets the dielectric f0; KHR_materials_specular its
//    strength and F0 colour (factors and textures); KHR_materials_clearcoat
//    layers gltf_pbr.h's coat over it (factors and textures; the coat takes
//    the base's shading normal, its own normal texture ignored with a
//    warning; emission is not darkened by it; not on transmitting
//    materials); KHR_materials_transmission
//    (factor, texture's R) and KHR_materials_diffuse_transmission (factor,
//    texture's A; colour factor, sRGB texture) make it gltf_pbr.h's thin
//    transmitting sheet (two-sided whatever doubleSided says;
//    KHR_materials_volume ignored).
//  - Emission: emissiveFactor × emissiveTexture × KHR_materials_emissive_strength
//    is the radiance of the primitive's triangles as area lights (front side;
//    both with doubleSided, whose "double-sided lighting" covers emission):
//    1 is radiance 1, as Blender's importer takes it (the specification
//    leaves the scale to the renderer), while punctual lights are
//    photometric at 683 lm/W (below), as Blender's importer too.
//  - Alpha: OPAQUE ignores alpha; MASK makes the surface exist where
//    alpha = baseColorFactor.a × texture.a >= alphaCutoff (Material::alpha_cutoff,
//    the alpha test of material/opacity.h); BLEND uses alpha as a stochastic
//    opacity (the same alpha test with a fractional opacity: a transparent
//    surface, without the order-dependence of rasterised blending).
//  - KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv with
//    R = [cos sin; -sin cos] (three.js's and Babylon.js's reading, which
//    the extension's sample model TextureTransformTest checks).
//  - Samplers: magFilter NEAREST -> nearest, else bilinear (no mipmaps);
//    wrapS (wrapT when it differs: warning).
//  - KHR_lights_punctual, photometric to Luz's radiometric units at
//    683 lm/W (the luminous efficacy that defines the candela): point and
//    spot intensity I [cd] -> color · I / 683 W/sr; directional illuminance
//    E [lux] -> color · E / 683 W/m². Spot cones: inner -> Luz's beam width,
//    outer -> cutoff, the falloff between them the extension's square of a
//    linear ramp in cos θ; `range` is ignored with a warning (the inverse
//    square law to any distance, as a physical light).
//  - No light at all (no emission, no punctual light): a uniform white
//    environment of radiance 1 with a warning, as for OBJ and PLY files.
//  - Camera: the first node with a camera in traversal order, or the one
//    whose camera or node has the name asked (luz render --camera NAME) (perspective:
//    yfov, aspectRatio; orthographic: xmag, ymag; znear and zfar unused: rays
//    start at the camera, as for Mitsuba's near_clip); none: the bounds framed
//    as for an OBJ. The film is 512 pixels high (wide by the aspect ratio).
//  - Images: 8 or 16 bits per channel (16 reduced to 8), RGBA.
#include "luz/io/gltf.h"

#include <tbb/parallel_for.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <tuple>

#include "luz/core/memory.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/math/transform.h"
#include "luz/scene/scene_builder.h"

namespace luz {
namespace {

namespace fs = std::filesystem;

// Photometric to radiometric: lumens per watt at 555 nm (SI definition of the candela).
constexpr double kLumensPerWatt = 683.0;

std::string at(const char* what, size_t i) { return std::string(what) + "[" + std::to_string(i) + "]"; }

// A JSON value read as an index: a whole number in [0, 2^31), else -1.
int index_of(const tinygltf::Value& v) {
  if (!v.IsNumber()) return -1;
  const double d = v.GetNumberAsDouble();
  return d >= 0.0 && d < 2147483648.0 && d == std::floor(d) ? int(d) : -1;
}


// A check tinygltf 2.7 lacks: that an image's bufferView lies inside its
// buffer (else tinygltf hands over bytes from past the buffer's end).
bool view_inside_buffer(const tinygltf::Model& m, const tinygltf::Image& image) {
  if (image.bufferView < 0) return true;  // tinygltf checked the indices
  const tinygltf::BufferView& v = m.bufferViews[size_t(image.bufferView)];
  const size_t buffer = m.buffers[size_t(v.buffer)].data.size();
  return v.byteOffset <= buffer && v.byteLength <= buffer - v.byteOffset;
}

// tinygltf's image decoder, replaced: Luz's own (io/image.h: it refuses
// files that Debian's stb_image mishandles), after view_inside_buffer.
// `model` is the model being read.
bool decode_image(tinygltf::Image* image, int index, std::string* err, std::string*, int, int,
                  const unsigned char* bytes, int size, void* model) {
  const std::string where = "images[" + std::to_string(index) + "]";
  if (!view_inside_buffer(*static_cast<const tinygltf::Model*>(model), *image)) {
    *err += where + ": bufferView " + std::to_string(image->bufferView) + " reaches past the end of its buffer\n";
    return false;
  }
  try {
    const Image8 img = decode_image8(where, bytes, size_t(std::max(size, 0)));
    image->width = img.width;
    image->height = img.height;
    image->component = 4;
    image->bits = 8;
    image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
    image->image.resize(img.rgba.size() * 4);
    for (size_t k = 0; k < img.rgba.size(); ++k)
      for (int c = 0; c < 4; ++c) image->image[4 * k + size_t(c)] = uint8_t(img.rgba[k] >> (8 * c));
    return true;
  } catch (const InputError& e) {
    *err += e.what() + std::string("\n");
    return false;
  }
}

class GltfLoader {
 public:
  GltfLoader(const std::string& path, const std::string& camera) : path_(path), camera_(camera), builder_(path) {}

  Scene load() {
    read_model();
    check_extensions();
    const std::vector<int> roots = root_nodes();
    walk(roots);
    if (!camera_.empty() && !builder_.has_camera()) {
      std::string names;  // the cameras of the scene drawn
      for (size_t i = 0; i < model_.nodes.size(); ++i) {
        const tinygltf::Node& n = model_.nodes[i];
        if (in_scene_[i] && n.camera >= 0 && size_t(n.camera) < model_.cameras.size()) {
          const std::string& c = model_.cameras[size_t(n.camera)].name;
          names += (names.empty() ? "" : ", ") + ("'" + (c.empty() ? n.name : c) + "'");
        }
      }
      fail("cameras", "no camera named '" + camera_ + "' (" + (names.empty() ? "the file has none" : "the file has " + names) + ")");
    }
    // Area lights come first in Scene::lights (add_mesh numbers them), then the others.
    for (const Light& l : punctual_) builder_.add_light(at_, l);
    if (builder_.scene().lights.empty()) {  // as for mesh files (mesh_scene.cpp): the model shows
      ConstantLight sky;
      sky.radiance = {1.f, 1.f, 1.f};
      builder_.add_light(at_, sky);
      warn("no light in the file: lit by a uniform white environment (radiance 1)");
    }
    builder_.settings().spp = 64;
    builder_.settings().integrator.max_depth = -1;
    if (!builder_.has_camera()) builder_.frame_bounds(512, 512);
    return builder_.finish();
  }

 private:
  const std::string path_;
  const std::string camera_;  // the name asked, or "": the first camera
  const SourceLoc at_{path_, 0};  // glTF has no useful line numbers: messages name the object instead
  tinygltf::Model model_;
  SceneBuilder builder_;
  std::vector<Light> punctual_;  // KHR_lights_punctual, added after the meshes' area lights
  bool quantized_ = false;       // KHR_mesh_quantization used
  std::vector<Matrix4> world_;   // each node's world transform
  std::vector<bool> in_scene_;   // the nodes of the scene drawn
  std::set<std::string> warned_;
  // Per glTF material: the Luz material, its emission, and its texture-coordinate set.
  struct MaterialInfo {
    uint32_t index = 0;
    bool emissive = false, emission_two_sided = false;
    Color emission;
    int32_t emission_texture = -1;
    int uv_set = -1;  // -1: no texture
    bool blended = false;  // alphaMode MASK or BLEND
  };
  std::map<std::pair<int, bool>, MaterialInfo> materials_;  // by (glTF material, with COLOR_0)
  std::map<int, int32_t> image_texture_;  // image -> its texels' first Luz texture
  std::vector<int> uses_;                  // per mesh: how many nodes place it
  std::map<int, int32_t> objects_;         // mesh -> its SceneBuilder object (-1: flattened)

  [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
    builder_.error(at_, where.empty() ? problem : where + ": " + problem);
  }
  void warn(const std::string& msg) {
    if (warned_.insert(msg).second) builder_.warn(at_, msg);
  }

  // An image as tinygltf hands it over: decoded after the model is read, all
  // in parallel (tinygltf decodes them one after another).
  struct PendingImage {
    int index = 0, req_width = 0, req_height = 0;
    std::string name, err_before;  // err_before: tinygltf's error text so far
    std::vector<unsigned char> bytes;
  };
  std::vector<PendingImage> pending_;

  // An image's bytes are not copied when its bufferView reaches past its
  // buffer (they would be read from there; decode_image refuses it).
  static bool keep_image(tinygltf::Image* image, int index, std::string* err, std::string*, int req_width,
                         int req_height, const unsigned char* bytes, int size, void* loader) {
    GltfLoader& self = *static_cast<GltfLoader*>(loader);
    if (!view_inside_buffer(self.model_, *image)) size = 0;
    self.pending_.push_back({index, req_width, req_height, image->name, err ? *err : "", {bytes, bytes + size}});
    return true;
  }

  // Decodes the pending images (decode_image, in parallel) into the model;
  // returns the error text of the first that fails ("" when none does), as
  // tinygltf would have stopped there.
  std::string decode_images() {
    std::vector<std::string> errors(pending_.size());
    tbb::parallel_for(size_t(0), pending_.size(), [&](size_t k) {
      const PendingImage& p = pending_[k];
      if (size_t(p.index) >= model_.images.size()) return;  // the model stopped before keeping it
      tinygltf::Image& im = model_.images[size_t(p.index)];
      std::string warn;
      if (!decode_image(&im, p.index, &errors[k], &warn, p.req_width, p.req_height, p.bytes.data(),
                        int(p.bytes.size()), &model_))
        errors[k] = p.err_before + errors[k];
    });
    pending_.clear();
    for (const std::string& e : errors)
      if (!e.empty()) return e;
    return "";
  }

  void read_model() {
    tinygltf::TinyGLTF reader;
    reader.SetImageLoader(keep_image, this);
    std::string err, warn_text, thrown;
    const std::string ext = lower_extension(path_);
    bool ok = false;
    try {
      ok = ext == ".glb" ? reader.LoadBinaryFromFile(&model_, &err, &warn_text, path_)
                         : reader.LoadASCIIFromFile(&model_, &err, &warn_text, path_);
    } catch (const std::exception& e) {
      thrown = e.what();
    }
    // The images read before a later failure would have failed first.
    if (std::string image_err = decode_images(); !image_err.empty()) ok = false, err = image_err, thrown.clear();
    if (!thrown.empty()) fail("", "cannot parse: " + thrown);
    if (!ok) {
      std::string first = err.substr(0, err.find('\n'));
      if (first.empty()) first = "not a valid glTF file";
      // tinygltf's messages may quote a whole data URI: one readable line.
      const size_t data = first.find("data:");
      if (data != std::string::npos && first.size() - data > 100)
        first = first.substr(0, data) + "a data URI of " + std::to_string(first.size() - data) +
                " characters (not base64, or not of its buffer's byteLength)";
      if (first.size() > 300) first = first.substr(0, 240) + " ... (" + std::to_string(first.size()) + " characters)";
      fail("", first);
    }
  }

  void check_extensions() {
    static const std::set<std::string> supported = {
        "KHR_texture_transform", "KHR_materials_emissive_strength", "KHR_lights_punctual", "KHR_materials_ior",
        "KHR_mesh_quantization", "KHR_materials_transmission", "KHR_materials_specular",
        "KHR_materials_clearcoat", "KHR_materials_diffuse_transmission"};
    for (const std::string& e : model_.extensionsRequired)
      if (!supported.count(e)) fail("", "requires extension " + e + ", which Luz does not support");
    // Optional ones are left out with a word (KHR_materials_volume: where a
    // material uses it).
    for (const std::string& e : model_.extensionsUsed) {
      quantized_ |= e == "KHR_mesh_quantization";
      if (!supported.count(e) && e != "KHR_materials_volume")
        warn("extension " + e + " is not supported: rendered without it");
    }
  }

  std::vector<int> root_nodes() {
    if (!model_.scenes.empty()) {
      const size_t s = model_.defaultScene >= 0 ? size_t(model_.defaultScene) : 0;
      if (s >= model_.scenes.size()) fail("scene", "no scene " + std::to_string(s));
      return model_.scenes[s].nodes;
    }
    // No scenes: every node that is nobody's child.
    std::vector<bool> child(model_.nodes.size(), false);
    for (const tinygltf::Node& n : model_.nodes)
      for (int c : n.children)
        if (c >= 0 && size_t(c) < child.size()) child[size_t(c)] = true;
    std::vector<int> r;
    for (size_t i = 0; i < child.size(); ++i)
      if (!child[i]) r.push_back(int(i));
    return r;
  }

  Matrix4 local_transform(const tinygltf::Node& n, const std::string& where) {
    Matrix4 m;
    auto finite = [&](const std::vector<double>& v, size_t len, const char* what) {
      if (!v.empty() && v.size() != len) fail(where, std::string(what) + " needs " + std::to_string(len) + " numbers");
      for (double x : v)
        if (!std::isfinite(x) || std::fabs(x) > 1e18) fail(where, std::string(what) + " has a non-finite or huge number");
    };
    finite(n.matrix, 16, "matrix");
    finite(n.translation, 3, "translation");
    finite(n.rotation, 4, "rotation");
    finite(n.scale, 3, "scale");
    if (!n.matrix.empty()) {
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) m.m[r][c] = n.matrix[size_t(4 * c + r)];  // column-major
      return m;
    }
    Matrix4 t, r, s;
    if (!n.translation.empty()) t = Matrix4::translate({float(n.translation[0]), float(n.translation[1]), float(n.translation[2])});
    if (!n.scale.empty()) {
      for (int k = 0; k < 3; ++k) s.m[k][k] = n.scale[size_t(k)];
    }
    if (!n.rotation.empty()) {
      double x = n.rotation[0], y = n.rotation[1], z = n.rotation[2], w = n.rotation[3];
      const double len = std::sqrt(x * x + y * y + z * z + w * w);
      if (!(len > 0.0)) fail(where, "rotation is a zero quaternion");
      x /= len, y /= len, z /= len, w /= len;
      r.m[0][0] = 1 - 2 * (y * y + z * z), r.m[0][1] = 2 * (x * y - z * w), r.m[0][2] = 2 * (x * z + y * w);
      r.m[1][0] = 2 * (x * y + z * w), r.m[1][1] = 1 - 2 * (x * x + z * z), r.m[1][2] = 2 * (y * z - x * w);
      r.m[2][0] = 2 * (x * z - y * w), r.m[2][1] = 2 * (y * z + x * w), r.m[2][2] = 1 - 2 * (x * x + y * y);
    }
    return t * r * s;
  }

  // Depth-first over the node forest with an explicit stack; a node reached
  // twice (a cycle, or shared by two parents) is an error.
  void walk(const std::vector<int>& roots) {
    std::vector<bool> seen(model_.nodes.size(), false);
    uses_.assign(model_.meshes.size(), 0);
    for (const tinygltf::Node& n : model_.nodes)
      if (n.mesh >= 0 && size_t(n.mesh) < uses_.size()) ++uses_[size_t(n.mesh)];
    // Every node's world transform first: a skin's joints may come after its mesh.
    world_.assign(model_.nodes.size(), Matrix4{});
    std::vector<int> order;
    std::vector<std::pair<int, Matrix4>> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, Matrix4{}});
    while (!stack.empty()) {
      auto [i, parent] = stack.back();
      stack.pop_back();
      if (i < 0 || size_t(i) >= model_.nodes.size()) fail("nodes", "no node " + std::to_string(i));
      if (seen[size_t(i)]) fail(at("nodes", size_t(i)), "the node is reached twice (a cycle or two parents)");
      seen[size_t(i)] = true;
      order.push_back(i);
      const tinygltf::Node& n = model_.nodes[size_t(i)];
      world_[size_t(i)] = parent * local_transform(n, at("nodes", size_t(i)));
      for (auto c = n.children.rbegin(); c != n.children.rend(); ++c) stack.push_back({*c, world_[size_t(i)]});
    }
    in_scene_ = std::move(seen);
    for (int i : order) {
      const tinygltf::Node& n = model_.nodes[size_t(i)];
      const std::string where = at("nodes", size_t(i));
      const Matrix4& world = world_[size_t(i)];
      if (n.mesh >= 0) add_mesh(n.mesh, world, n, where);
      if (n.camera >= 0 && !builder_.has_camera() && wanted(n)) set_camera(n.camera, world, where);
      auto l = n.extensions.find("KHR_lights_punctual");
      if (l != n.extensions.end() && l->second.Has("light")) add_light(l->second.Get("light"), world, where);
    }
  }

  // ---- accessors ----
  struct Data {
    const unsigned char* base = nullptr;
    size_t count = 0, stride = 0;
    int components = 0, component_type = 0;
    bool normalized = false;
  };

  Data accessor(int index, const std::string& where) {
    if (index < 0 || size_t(index) >= model_.accessors.size()) fail(where, "no accessor " + std::to_string(index));
    const tinygltf::Accessor& a = model_.accessors[size_t(index)];
    const std::string aw = at("accessors", size_t(index));
    if (a.sparse.isSparse) fail(aw, "sparse accessors are not supported");
    if (a.bufferView < 0 || size_t(a.bufferView) >= model_.bufferViews.size())
      fail(aw, "no bufferView (accessors of zeros are not supported)");
    const tinygltf::BufferView& v = model_.bufferViews[size_t(a.bufferView)];
    if (v.buffer < 0 || size_t(v.buffer) >= model_.buffers.size()) fail(at("bufferViews", size_t(a.bufferView)), "no buffer");
    const std::vector<unsigned char>& buf = model_.buffers[size_t(v.buffer)].data;
    if (v.byteOffset > buf.size() || v.byteLength > buf.size() - v.byteOffset)
      fail(at("bufferViews", size_t(a.bufferView)), "lies beyond its buffer's " + std::to_string(buf.size()) + " bytes");
    Data d;
    d.components = tinygltf::GetNumComponentsInType(uint32_t(a.type));
    const int size = tinygltf::GetComponentSizeInBytes(uint32_t(a.componentType));
    if (d.components <= 0 || size <= 0) fail(aw, "unknown type or componentType");
    d.component_type = a.componentType;
    d.normalized = a.normalized;
    d.count = a.count;
    const size_t elem = size_t(d.components) * size_t(size);
    d.stride = v.byteStride ? v.byteStride : elem;
    if (d.stride < elem) fail(aw, "byteStride is smaller than an element");
    if (a.byteOffset > v.byteLength) fail(aw, "byteOffset lies beyond its bufferView");
    const size_t room = v.byteLength - a.byteOffset;
    if (d.count > 0 && (room < elem || (d.count - 1) > (room - elem) / d.stride))
      fail(aw, std::to_string(d.count) + " elements do not fit in the bufferView's " + std::to_string(v.byteLength) + " bytes");
    d.base = buf.data() + v.byteOffset + a.byteOffset;
    return d;
  }

  // Component c of element i as a number (normalised integers mapped to [0, 1]).
  static double component(const Data& d, size_t i, int c) {
    const unsigned char* p = d.base + i * d.stride;
    switch (d.component_type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p + 4 * c, 4);
        return f;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return p[c] * (d.normalized ? 1.0 / 255.0 : 1.0);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t u;
        std::memcpy(&u, p + 2 * c, 2);
        return u * (d.normalized ? 1.0 / 65535.0 : 1.0);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t u;
        std::memcpy(&u, p + 4 * c, 4);
        return u;
      }
      // Signed, normalised: max(c / (2^(b-1) - 1), -1) (§3.11).
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const double v = int8_t(p[c]);
        return d.normalized ? std::max(v / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t u;
        std::memcpy(&u, p + 2 * c, 2);
        return d.normalized ? std::max(u / 32767.0, -1.0) : double(u);
      }
      default: return 0.0;
    }
  }

  // A vertex attribute of the core specification's types, and of
  // KHR_mesh_quantization's where the file uses it: positions of any
  // integer type, normalised or not; normals of normalised signed bytes or
  // shorts; texture coordinates of any 8- or 16-bit type.
  enum class Attr { Position, Normal, Texcoord, Color };
  Data attribute(const tinygltf::Primitive& p, const std::string& name, Attr kind, const std::string& where) {
    Data d = accessor(p.attributes.at(name), where + ": " + name);
    const int t = d.component_type;
    const bool small = t == TINYGLTF_COMPONENT_TYPE_BYTE || t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                       t == TINYGLTF_COMPONENT_TYPE_SHORT || t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    const bool unsigned_norm = d.normalized && (t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE || t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
    const bool signed_norm = d.normalized && (t == TINYGLTF_COMPONENT_TYPE_BYTE || t == TINYGLTF_COMPONENT_TYPE_SHORT);
    const bool ok = t == TINYGLTF_COMPONENT_TYPE_FLOAT || ((kind == Attr::Texcoord || kind == Attr::Color) && unsigned_norm) ||
                    (quantized_ && kind != Attr::Color && (kind == Attr::Normal ? signed_norm : small));
    if (kind == Attr::Color) {
      if ((d.components != 3 && d.components != 4) || !ok)
        fail(where, name + " must be VEC3 or VEC4 of floats or normalised unsigned bytes or shorts");
      return d;
    }
    const int components = kind == Attr::Texcoord ? 2 : 3;
    if (d.components != components || !ok) {
      const char* core = kind == Attr::Texcoord ? "floats or normalised unsigned bytes or shorts" : "floats";
      const char* more = kind == Attr::Normal ? "normalised bytes or shorts" : "bytes or shorts";
      fail(where, name + " must be " + (components == 3 ? "VEC3" : "VEC2") + " of " + core +
                      (quantized_ ? std::string(" or ") + more + " (KHR_mesh_quantization)"
                                  : std::string(" (other types need KHR_mesh_quantization)")));
    }
    return d;
  }

  static Vec3 vec3(const Data& d, size_t i) {
    return {float(component(d, i, 0)), float(component(d, i, 1)), float(component(d, i, 2))};
  }

  // ---- morph targets and skins (§3.7.2.2, §3.7.3) ----
  // What bends a node's mesh: its morph weights (the node's, else the
  // mesh's; empty when all are 0) and its skin's joint matrices
  // (world(joint) · inverseBindMatrix), which replace the node's own
  // transform.
  struct Deform {
    std::vector<double> weights;
    bool skin = false;
    std::vector<Matrix4> joints;
  };
  Deform deformation(int mesh, const tinygltf::Node& node, const std::string& where) {
    Deform d;
    const tinygltf::Mesh& m = model_.meshes[size_t(mesh)];
    size_t targets = 0;
    for (const tinygltf::Primitive& p : m.primitives) targets = std::max(targets, p.targets.size());
    for (const tinygltf::Primitive& p : m.primitives)
      if (p.targets.size() != targets) fail(at("meshes", size_t(mesh)), "its primitives have different numbers of morph targets");
    const std::vector<double>& w = !node.weights.empty() ? node.weights : m.weights;
    if (!w.empty() && w.size() != targets)
      fail(node.weights.empty() ? at("meshes", size_t(mesh)) : where,
           "weights has " + std::to_string(w.size()) + " numbers for " + std::to_string(targets) + " morph targets");
    for (double x : w)
      if (!std::isfinite(x) || std::fabs(x) > 1e6) fail(where, "a morph weight is not finite or beyond 1e6");
    bool any = false;
    for (double x : w) any |= x != 0.0;
    if (any) d.weights = w;
    if (node.skin >= 0) {
      if (size_t(node.skin) >= model_.skins.size()) fail(where, "no skin " + std::to_string(node.skin));
      const tinygltf::Skin& sk = model_.skins[size_t(node.skin)];
      const std::string sw = at("skins", size_t(node.skin));
      if (sk.joints.empty()) fail(sw, "no joints");
      std::vector<Matrix4> inverse_bind(sk.joints.size());
      if (sk.inverseBindMatrices >= 0) {
        const Data ib = accessor(sk.inverseBindMatrices, sw + ": inverseBindMatrices");
        if (ib.components != 16 || ib.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT)
          fail(sw, "inverseBindMatrices must be MAT4 of floats");
        if (ib.count < sk.joints.size()) fail(sw, "fewer inverseBindMatrices than joints");
        for (size_t j = 0; j < sk.joints.size(); ++j)
          for (int c = 0; c < 16; ++c) {
            const double v = component(ib, j, c);
            if (!std::isfinite(v)) fail(sw, "an inverse bind matrix is not finite");
            inverse_bind[j].m[c % 4][c / 4] = v;  // column-major
          }
      }
      for (size_t j = 0; j < sk.joints.size(); ++j) {
        const int node_index = sk.joints[j];
        if (node_index < 0 || size_t(node_index) >= model_.nodes.size() || !in_scene_[size_t(node_index)])
          fail(sw, "joint " + std::to_string(node_index) + " is not a node of the scene");
        d.joints.push_back(world_[size_t(node_index)] * inverse_bind[j]);
      }
      d.skin = true;
    }
    return d;
  }

  // Positions and normals plus the weighted morph targets' displacements.
  void morph(const tinygltf::Primitive& p, const Deform& d, std::vector<Vec3>& pos, std::vector<Vec3>& nrm,
             const std::string& where) {
    for (size_t k = 0; k < d.weights.size(); ++k) {
      const float w = float(d.weights[k]);
      if (w == 0.f) continue;
      const std::string tw = where + ".targets[" + std::to_string(k) + "]";
      auto add = [&](const char* name, std::vector<Vec3>& to) {
        auto it = p.targets[k].find(name);
        if (it == p.targets[k].end() || to.empty()) return;
        // KHR_mesh_quantization: displacements of signed bytes or shorts,
        // normalised or not (normals: normalised).
        const Data t = accessor(it->second, tw + ": " + name);
        const bool small = t.component_type == TINYGLTF_COMPONENT_TYPE_BYTE || t.component_type == TINYGLTF_COMPONENT_TYPE_SHORT;
        const bool normal = std::string(name) == "NORMAL";
        const bool ok = t.component_type == TINYGLTF_COMPONENT_TYPE_FLOAT || (quantized_ && small && (t.normalized || !normal));
        if (t.components != 3 || !ok)
          fail(tw, std::string(name) + " must be VEC3 of floats" +
                       (quantized_ ? std::string(" or ") + (normal ? "normalised " : "") + "bytes or shorts (KHR_mesh_quantization)"
                                   : std::string(" (other types need KHR_mesh_quantization)")));
        if (t.count != to.size()) fail(tw, std::string(name) + " and the primitive's differ in count");
        for (size_t i = 0; i < to.size(); ++i) to[i] += vec3(t, i) * w;
      };
      add("POSITION", pos);
      add("NORMAL", nrm);
    }
  }

  // Each vertex's matrix: its joints' matrices weighted (JOINTS_n,
  // WEIGHTS_n), the weights scaled to sum to 1.
  std::vector<Matrix4> skin_matrices(const tinygltf::Primitive& p, const Deform& d, size_t n, const std::string& where) {
    std::vector<Matrix4> out(n, Matrix4{{}});  // zero matrices: sums of weighted joints
    std::vector<double> total(n, 0.0);
    bool any = false;
    for (int set = 0; p.attributes.count("JOINTS_" + std::to_string(set)); ++set) {
      const std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
      if (!p.attributes.count(wn)) fail(where, jn + " without " + wn);
      const Data j = accessor(p.attributes.at(jn), where + ": " + jn), w = accessor(p.attributes.at(wn), where + ": " + wn);
      if (j.components != 4 || (j.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                                j.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT))
        fail(where, jn + " must be VEC4 of unsigned bytes or shorts");
      if (w.components != 4 || !(w.component_type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
                                 (w.normalized && (w.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                                   w.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT))))
        fail(where, wn + " must be VEC4 of floats or normalised unsigned bytes or shorts");
      if (j.count != n || w.count != n) fail(where, jn + " or " + wn + " and POSITION differ in count");
      any = true;
      for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 4; ++c) {
          const double wt = component(w, i, c);
          if (!(wt >= 0.0) || !std::isfinite(wt)) fail(where, wn + " holds a negative or non-finite weight");
          if (wt == 0.0) continue;
          const double ji = component(j, i, c);
          if (!(ji < double(d.joints.size()))) fail(where, jn + " names joint " + std::to_string(uint64_t(ji)) + " of " +
                                                           std::to_string(d.joints.size()));
          const Matrix4& jm = d.joints[size_t(ji)];
          for (int r = 0; r < 4; ++r)
            for (int k = 0; k < 4; ++k) out[i].m[r][k] += wt * jm.m[r][k];
          total[i] += wt;
        }
    }
    if (!any) fail(where, "a skinned mesh needs JOINTS_0 and WEIGHTS_0");
    for (size_t i = 0; i < n; ++i) {
      if (!(total[i] > 0.0)) fail(where, "vertex " + std::to_string(i) + " has no joint weight");
      for (int r = 0; r < 4; ++r)
        for (int k = 0; k < 4; ++k) out[i].m[r][k] /= total[i];
    }
    return out;
  }

  // ---- meshes ----
  // One triangle-mode primitive of a mesh, read and placed: where it came
  // from, its material, its triangles.
  struct Part {
    SourceLoc at;
    const MaterialInfo* material;
    TriangleMesh mesh;
  };

  // A mesh placed by its node: a mesh that several nodes place is an object
  // built once and instanced (SceneBuilder), unless it emits (emitters are
  // not instanced) or the transform mirrors (glTF then reverses the winding;
  // an instance keeps it); any other mesh is added as it is placed.
  void add_mesh(int mesh, const Matrix4& world, const tinygltf::Node& node, const std::string& where) {
    if (size_t(mesh) >= model_.meshes.size()) fail("nodes", "no mesh " + std::to_string(mesh));
    const Deform deform = deformation(mesh, node, where);
    if (uses_[size_t(mesh)] > 1 && world.det3() > 0.0 && !deform.skin && deform.weights.empty()) {
      auto it = objects_.find(mesh);
      if (it == objects_.end()) {
        std::vector<Part> parts = primitives(mesh, Matrix4{});
        bool emits = false;
        for (const Part& p : parts) emits |= p.material->emissive;
        int32_t object = -1;
        if (!emits) {
          object = int32_t(builder_.begin_object(at_, at("meshes", size_t(mesh))));
          for (Part& p : parts) builder_.add_object_mesh(p.at, uint32_t(object), std::move(p.mesh), p.material->index);
        }
        it = objects_.emplace(mesh, object).first;
      }
      if (it->second >= 0) {
        builder_.add_instance(at_, uint32_t(it->second), world);
        return;
      }
    }
    for (Part& p : primitives(mesh, world, &deform)) {
      const MaterialInfo& mat = *p.material;
      if (mat.emission_texture >= 0) {
        add_textured_emitter(p.at, std::move(p.mesh), mat);
      } else {
        const AreaEmission e{mat.emission, -1, mat.emission_two_sided};
        builder_.add_mesh(p.at, std::move(p.mesh), mat.index, mat.emissive ? &e : nullptr);
      }
    }
  }

  std::vector<Part> primitives(int mesh, const Matrix4& world, const Deform* deform = nullptr) {
    std::vector<Part> parts;
    const tinygltf::Mesh& m = model_.meshes[size_t(mesh)];
    const bool flip = world.det3() < 0.0;
    for (size_t pi = 0; pi < m.primitives.size(); ++pi) {
      const tinygltf::Primitive& p = m.primitives[pi];
      const std::string where = at("meshes", size_t(mesh)) + "." + at("primitives", pi);
      const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
      if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
          mode == TINYGLTF_MODE_LINE_STRIP) {
        warn(where + ": points and lines are not rendered; skipped");
        continue;
      }
      if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
        fail(where, "unknown mode " + std::to_string(mode));
      if (!p.attributes.count("POSITION")) fail(where, "no POSITION");
      const Data pos = attribute(p, "POSITION", Attr::Position, where);
      const size_t n = pos.count;
      if (n > size_t(UINT32_MAX / 2)) fail(where, "too many vertices");
      // Once per placement where the mesh is not instanced (add_mesh): many nodes add up.
      // Skinned: a matrix, a weight sum and the local copies per vertex too.
      const uint64_t skinning = deform && deform->skin ? sizeof(Matrix4) + sizeof(double) + 2 * sizeof(Vec3) + 1 : 0;
      require_memory(uint64_t(n) * (4 * sizeof(Vec3) + sizeof(Vec2) + 3 * sizeof(uint32_t) + skinning), path_,
                     where + ": its " + std::to_string(n) + " vertices");
      TriangleMesh mesh;  // positions, normals in world space (SceneBuilder checks them)
      std::vector<Vec3> local(n), local_n;
      for (size_t i = 0; i < n; ++i) local[i] = vec3(pos, i);
      if (p.attributes.count("NORMAL")) {
        const Data nd = attribute(p, "NORMAL", Attr::Normal, where);
        if (nd.count != n) fail(where, "NORMAL and POSITION differ in count");
        local_n.resize(n);
        for (size_t i = 0; i < n; ++i) local_n[i] = vec3(nd, i);
      }
      if (deform) morph(p, *deform, local, local_n, where);
      std::vector<bool> mirrored;  // skinned: per vertex, whether its matrix mirrors (the winding then reverses)
      if (deform && deform->skin) {
        const std::vector<Matrix4> mv = skin_matrices(p, *deform, n, where);
        mirrored.resize(n);
        for (size_t i = 0; i < n; ++i) mirrored[i] = mv[i].det3() < 0.0;
        mesh.positions.resize(n);
        for (size_t i = 0; i < n; ++i) mesh.positions[i] = mv[i].point(local[i]);
        mesh.normals.resize(local_n.size());
        for (size_t i = 0; i < local_n.size(); ++i) mesh.normals[i] = mv[i].normal(local_n[i]);
      } else {
        mesh.positions.resize(n);
        for (size_t i = 0; i < n; ++i) mesh.positions[i] = world.point(local[i]);
        mesh.normals.resize(local_n.size());
        for (size_t i = 0; i < local_n.size(); ++i) mesh.normals[i] = world.normal(local_n[i]);
      }
      if (p.attributes.count("TANGENT")) warn(where + ": TANGENT is ignored (tangents follow dp/du)");
      const bool colored = p.attributes.count("COLOR_0") > 0;
      const MaterialInfo& mat = material(p.material, colored);
      if (colored) {
        const Data c = attribute(p, "COLOR_0", Attr::Color, where);
        if (c.count != n) fail(where, "COLOR_0 and POSITION differ in count");
        mesh.colors.resize(n);
        bool translucent = false;
        for (size_t i = 0; i < n; ++i) {
          mesh.colors[i] = vec3(c, i);
          translucent |= c.components == 4 && component(c, i, 3) < 1.0;
        }
        if (translucent && mat.blended)
          warn(where + ": COLOR_0's alpha is ignored (the opacity is the base colour's alone)");
      }
      std::vector<Vec2>& uvs = mesh.uvs;
      if (mat.uv_set >= 0) {
        const std::string name = "TEXCOORD_" + std::to_string(mat.uv_set);
        if (!p.attributes.count(name)) fail(where, "its material's textures need " + name);
        const Data t = attribute(p, name, Attr::Texcoord, where);
        if (t.count != n) fail(where, name + " and POSITION differ in count");
        uvs.resize(n);
        for (size_t i = 0; i < n; ++i) uvs[i] = {float(component(t, i, 0)), float(component(t, i, 1))};
      }
      std::vector<uint32_t> order;  // the vertex sequence the mode reads
      if (p.indices >= 0) {
        const Data id = accessor(p.indices, where + ": indices");
        if (id.components != 1 || (id.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                                   id.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
                                   id.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
          fail(where, "indices must be SCALAR unsigned bytes, shorts or ints");
        order.resize(id.count);
        for (size_t i = 0; i < id.count; ++i) {
          const double v = component(id, i, 0);
          if (!(v < double(n))) fail(where, "index " + std::to_string(uint64_t(v)) + " is not below the " +
                                                std::to_string(n) + " vertices");
          order[i] = uint32_t(v);
        }
      } else {
        order.resize(n);
        for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
      }
      std::vector<uint32_t>& tris = mesh.indices;
      auto tri = [&](uint32_t a, uint32_t b, uint32_t c) {
        if (mirrored.empty() ? flip : bool(mirrored[a])) std::swap(b, c);
        tris.insert(tris.end(), {a, b, c});
      };
      if (mode == TINYGLTF_MODE_TRIANGLES) {
        for (size_t i = 0; i + 2 < order.size(); i += 3) tri(order[i], order[i + 1], order[i + 2]);
      } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
        // §3.7.2.1: p_i = {v_i, v_{i+(1+i%2)}, v_{i+(2-i%2)}}.
        for (size_t i = 0; i + 2 < order.size(); ++i)
          tri(order[i], order[i + 1 + i % 2], order[i + 2 - i % 2]);
      } else {
        // p_i = {v_{i+1}, v_{i+2}, v_0}.
        for (size_t i = 0; i + 2 < order.size(); ++i) tri(order[i + 1], order[i + 2], order[0]);
      }
      if (tris.empty()) continue;
      parts.push_back({{path_ + ": " + where, 0}, &mat, std::move(mesh)});
    }
    return parts;
  }

  // A primitive with an emission texture: the triangles whose texels are all
  // black are not lights; each other one is a light whose radiance (what
  // light selection weighs it by; the texture gives the emission itself) is
  // the mean of its texels.
  // (Each lit triangle is a mesh of its own three vertices, for its own radiance.)
  void add_textured_emitter(const SourceLoc& at, TriangleMesh mesh, const MaterialInfo& mat) {
    const Texture tex = builder_.scene().textures[size_t(mat.emission_texture)];
    std::vector<uint32_t> dark;
    const std::vector<uint32_t>& tris = mesh.indices;
    // Each triangle's footprint on its own (in parallel), then added in order.
    std::vector<Color> radiance(tris.size() / 3, mat.emission);
    std::vector<float> maxima(tris.size() / 3, 1.f);
    tbb::parallel_for(size_t(0), tris.size() / 3, [&](size_t t) {
      footprint(tex, mesh.uvs[tris[3 * t]], mesh.uvs[tris[3 * t + 1]], mesh.uvs[tris[3 * t + 2]], radiance[t], maxima[t]);
    });
    for (size_t k = 0; k < tris.size(); k += 3) {
      const AreaEmission e{radiance[k / 3], mat.emission_texture, mat.emission_two_sided};
      const float max = maxima[k / 3];
      const uint32_t v[3] = {tris[k], tris[k + 1], tris[k + 2]};
      if (!(max > 0.f)) {
        dark.insert(dark.end(), v, v + 3);
        continue;
      }
      TriangleMesh one;
      one.indices = {0, 1, 2};
      for (uint32_t i : v) {
        one.positions.push_back(mesh.positions[i]);
        one.uvs.push_back(mesh.uvs[i]);
        if (!mesh.colors.empty()) one.colors.push_back(mesh.colors[i]);
        if (!mesh.normals.empty()) one.normals.push_back(mesh.normals[i]);
      }
      builder_.add_mesh(at, std::move(one), mat.index, &e);
    }
    if (dark.empty()) return;
    mesh.indices = std::move(dark);
    builder_.add_mesh(at, std::move(mesh), mat.index);
  }

  // The greatest luminance and the mean of the texels a lookup inside the uv
  // triangle (a, b, c) can read: the texel box around the triangle grown by
  // one texel (the bilinear filter's reach), wrapped as the texture wraps.
  // Leaves mean and max as they are when the box exceeds 2^20 texels.
  void footprint(const Texture& tex, Vec2 a, Vec2 b, Vec2 c, Color& mean, float& max) const {
    const BitmapTexture& bm = tex.bitmap;
    const Vec2 p[3] = {tex.to_uv.apply(a), tex.to_uv.apply(b), tex.to_uv.apply(c)};
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
    const double size[2] = {double(bm.width), double(bm.height)};
    for (const Vec2& q : p)
      for (int d = 0; d < 2; ++d) {
        const double x = double(d ? q.y : q.x) * size[d] - 0.5;
        lo[d] = std::min(lo[d], x), hi[d] = std::max(hi[d], x);
      }
    const double x0 = std::floor(lo[0]), x1 = std::floor(hi[0]) + 1, y0 = std::floor(lo[1]), y1 = std::floor(hi[1]) + 1;
    if (!((x1 - x0 + 1) * (y1 - y0 + 1) <= double(1 << 20))) return;
    auto wrap = [&](int64_t i, int64_t n) {
      if (bm.wrap == WrapMode::Clamp) return std::clamp<int64_t>(i, 0, n - 1);
      if (bm.wrap == WrapMode::Mirror) {
        const int64_t m = ((i % (2 * n)) + 2 * n) % (2 * n);
        return m < n ? m : 2 * n - 1 - m;
      }
      return ((i % n) + n) % n;
    };
    const Scene& scene = builder_.scene();
    TextureView v;
    v.texels8 = scene.texels8.data();
    v.texelsf = scene.texelsf.data();
    v.srgb_table = scene.srgb_table.data();
    double sum[3] = {0, 0, 0};
    float m = 0.f;
    for (int64_t y = int64_t(y0); y <= int64_t(y1); ++y)
      for (int64_t x = int64_t(x0); x <= int64_t(x1); ++x) {
        const Color t = tex.scale * v.texel(bm, uint32_t(wrap(y, bm.height) * bm.width + wrap(x, bm.width)));
        m = std::max(m, std::max(t.x, std::max(t.y, t.z)));
        for (int k = 0; k < 3; ++k) sum[k] += t[k];
      }
    const double n = (x1 - x0 + 1) * (y1 - y0 + 1);
    mean = {float(sum[0] / n), float(sum[1] / n), float(sum[2] / n)};
    max = m;
  }

  // ---- materials and textures ----
  static Color rgb(const std::vector<double>& v, size_t len, Color fallback) {
    if (v.size() != len) return fallback;
    return {float(v[0]), float(v[1]), float(v[2])};
  }

  // A texture reference's Luz texture: `channel` of the image, times `scale`,
  // sRGB-decoded or not, with its sampler and KHR_texture_transform; sets uv_set.
  // Also returns the mean of the texture's values.
  int32_t texture(const tinygltf::TextureInfo& info, TextureChannel channel, bool srgb, Color scale,
                  const std::string& where, int& uv_set, Color* mean) {
    return texture(info.index, info.texCoord, info.extensions, channel, srgb, scale, where, uv_set, mean);
  }
  int32_t texture(int index, int tex_coord, const tinygltf::ExtensionMap& ext, TextureChannel channel, bool srgb,
                  Color scale, const std::string& where, int& uv_set, Color* mean) {
    if (index < 0 || size_t(index) >= model_.textures.size()) fail(where, "no texture " + std::to_string(index));
    const tinygltf::Texture& t = model_.textures[size_t(index)];
    if (t.source < 0 || size_t(t.source) >= model_.images.size())
      fail(at("textures", size_t(index)), "no image source (KHR_texture_basisu and EXT_texture_webp are not supported)");
    UvTransform to_uv;
    int set = tex_coord;
    auto tt = ext.find("KHR_texture_transform");
    if (tt != ext.end()) {
      const tinygltf::Value& v = tt->second;
      auto num = [&](const tinygltf::Value& x) {
        if (!x.IsNumber() || !std::isfinite(x.GetNumberAsDouble())) fail(where, "KHR_texture_transform needs numbers");
        return x.GetNumberAsDouble();
      };
      double ox = 0, oy = 0, r = 0, sx = 1, sy = 1;
      if (v.Has("offset")) {
        const tinygltf::Value& o = v.Get("offset");
        if (o.ArrayLen() != 2) fail(where, "KHR_texture_transform offset needs 2 numbers");
        ox = num(o.Get(0)), oy = num(o.Get(1));
      }
      if (v.Has("scale")) {
        const tinygltf::Value& s = v.Get("scale");
        if (s.ArrayLen() != 2) fail(where, "KHR_texture_transform scale needs 2 numbers");
        sx = num(s.Get(0)), sy = num(s.Get(1));
      }
      if (v.Has("rotation")) r = num(v.Get("rotation"));
      if (v.Has("texCoord")) set = index_of(v.Get("texCoord"));
      const double c = std::cos(r), s = std::sin(r);
      to_uv = {float(c * sx), float(s * sy), float(ox), float(-s * sx), float(c * sy), float(oy)};
    }
    if (set < 0 || set > 1) fail(where, "texCoord must be 0 or 1 (Luz reads TEXCOORD_0 and TEXCOORD_1)");
    if (uv_set >= 0 && uv_set != set) warn(where + ": textures of one material use two texture-coordinate sets; all read TEXCOORD_" + std::to_string(uv_set));
    else uv_set = set;
    const int32_t base = image(t.source);
    Texture tex = builder_.scene().textures[size_t(base)];
    tex.bitmap.srgb = srgb;
    tex.bitmap.channel = channel;
    tex.to_uv = to_uv;
    tex.scale = scale;
    if (t.sampler >= 0) {
      if (size_t(t.sampler) >= model_.samplers.size()) fail(at("textures", size_t(index)), "no sampler " + std::to_string(t.sampler));
      const tinygltf::Sampler& s = model_.samplers[size_t(t.sampler)];
      tex.bitmap.filter = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST ? TextureFilter::Nearest : TextureFilter::Bilinear;
      auto wrap = [](int w) {
        return w == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE ? WrapMode::Clamp
               : w == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? WrapMode::Mirror : WrapMode::Repeat;
      };
      tex.bitmap.wrap = wrap(s.wrapS);
      if (s.wrapT != s.wrapS) warn(at("samplers", size_t(t.sampler)) + ": wrapT differs from wrapS; both follow wrapS");
    }
    const int32_t id = builder_.add_texture({path_ + ": " + where, 0}, tex);
    if (mean) *mean = builder_.texture_stats(id).mean;
    return id;
  }

  // The image's texels, added once; its first texture (RGB, sRGB) is the template.
  int32_t image(int index) {
    auto it = image_texture_.find(index);
    if (it != image_texture_.end()) return it->second;
    const tinygltf::Image& im = model_.images[size_t(index)];
    const std::string where = at("images", size_t(index));
    if (im.image.empty() && !im.uri.empty() && im.uri.rfind("data:", 0) != 0)
      fail(where, "cannot read image file '" + im.uri + "' (missing, unreadable or not an image)");
    if (im.width <= 0 || im.height <= 0 || im.component != 4 || (im.bits != 8 && im.bits != 16))
      fail(where, "not decoded to 8- or 16-bit RGBA (an unsupported image format?)");
    const size_t texels = size_t(im.width) * size_t(im.height), bytes = size_t(im.bits / 8);
    if (im.image.size() < texels * 4 * bytes) fail(where, "fewer texels than its size says");
    std::vector<uint32_t> rgba(texels);
    for (size_t k = 0; k < texels; ++k) {
      uint32_t c[4];
      for (int j = 0; j < 4; ++j) c[j] = im.image[(4 * k + size_t(j)) * bytes + (bytes - 1)];  // 16 bits: the high byte
      rgba[k] = pack_rgba8(c[0], c[1], c[2], c[3]);
    }
    BitmapTexture b;
    b.width = uint32_t(im.width);
    b.height = uint32_t(im.height);
    const int32_t id = builder_.add_image8({path_ + ": " + where, 0}, b, UvTransform{}, rgba);
    image_texture_[index] = id;
    return id;
  }

  double extension_number(const tinygltf::ExtensionMap& ext, const char* name, const char* key, double fallback,
                          const std::string& where) {
    auto it = ext.find(name);
    if (it == ext.end() || !it->second.Has(key)) return fallback;
    const tinygltf::Value& v = it->second.Get(key);
    if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble()))
      fail(where, std::string(name) + "." + key + " must be a finite number");
    return v.GetNumberAsDouble();
  }

  // glTF material `index` (-1: the default), on a primitive with COLOR_0
  // (`colored`: the base colour times the vertex colours) or without.
  // A textureInfo inside a material extension (`key` of extension `name`):
  // its index (-1: none), texCoord and own extensions (KHR_texture_transform).
  struct ExtensionTexture {
    int index = -1, set = 0;
    tinygltf::ExtensionMap ext;
  };
  ExtensionTexture extension_texture(const tinygltf::ExtensionMap& extensions, const char* name, const char* key,
                                     const std::string& where) {
    ExtensionTexture r;
    const auto x = extensions.find(name);
    if (x == extensions.end() || !x->second.Has(key)) return r;
    const tinygltf::Value& t = x->second.Get(key);
    r.index = t.Has("index") ? index_of(t.Get("index")) : -1;
    if (r.index < 0) fail(where, std::string(key) + " needs an index");
    if (t.Has("texCoord")) r.set = index_of(t.Get("texCoord"));
    if (t.Has("extensions") && t.Get("extensions").IsObject())
      for (const std::string& k : t.Get("extensions").Keys()) r.ext[k] = t.Get("extensions").Get(k);
    return r;
  }

  const MaterialInfo& material(int index, bool colored) {
    auto it = materials_.find({index, colored});
    if (it != materials_.end()) return it->second;
    MaterialInfo info;
    if (index < 0) {  // glTF's default material: white, metallic 1, roughness 1
      MaterialDesc d;
      d.bsdf = Bsdf::make_gltf_pbr({1.f, 1.f, 1.f}, 1.f, 1.f);
      if (colored) {
        const int32_t t = builder_.add_vertex_color_texture(at_);
        d.bindings.push_back({t, BsdfPart::Front, BsdfParam::BaseColor});
        d.bsdf.gltf_pbr.base_color = builder_.texture_stats(t).mean;
      }
      info.index = builder_.add_material(at_, d);
      return materials_[{index, colored}] = info;
    }
    if (size_t(index) >= model_.materials.size()) fail("meshes", "no material " + std::to_string(index));
    const tinygltf::Material& m = model_.materials[size_t(index)];
    const std::string where = at("materials", size_t(index));
    const tinygltf::PbrMetallicRoughness& pbr = m.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4) fail(where, "baseColorFactor needs 4 numbers");
    const Color base = rgb(pbr.baseColorFactor, 4, {1, 1, 1});
    const double alpha = pbr.baseColorFactor[3];
    auto unit = [&](double v, const char* what) {
      if (!(v >= 0.0 && v <= 1.0)) fail(where, std::string(what) + " must lie in [0, 1]");
      return float(v);
    };
    for (int k = 0; k < 3; ++k) unit(base[k], "baseColorFactor");
    unit(alpha, "baseColorFactor");
    const float metallic = unit(pbr.metallicFactor, "metallicFactor");
    const float roughness = unit(pbr.roughnessFactor, "roughnessFactor");
    const double ior = extension_number(m.extensions, "KHR_materials_ior", "ior", 1.5, where);
    // 0: the extension's full-weight Fresnel (f0 = 1), with which
    // KHR_materials_specular carries specular-glossiness materials.
    if (!(ior >= 1.0 || ior == 0.0)) fail(where, "KHR_materials_ior's ior must be 0 or >= 1");
    // KHR_materials_transmission: a thin sheet (KHR_materials_volume's
    // thickness is not modelled).
    const float transmission = unit(extension_number(m.extensions, "KHR_materials_transmission", "transmissionFactor", 0.0, where),
                                    "transmissionFactor");
    const ExtensionTexture transmission_tex =
        extension_texture(m.extensions, "KHR_materials_transmission", "transmissionTexture", where);
    // KHR_materials_specular: the dielectric's strength (A of its texture)
    // and F0 colour (sRGB texture; the factor may exceed 1).
    const float specular = unit(extension_number(m.extensions, "KHR_materials_specular", "specularFactor", 1.0, where),
                                "specularFactor");
    // An extension's colour factor: 3 numbers, finite and >= 0, at most 1
    // where `unit`; white where absent.
    auto color_factor = [&](const char* ext, const char* name, bool unit) {
      Color c{1.f, 1.f, 1.f};
      auto x = m.extensions.find(ext);
      if (x == m.extensions.end() || !x->second.Has(name)) return c;
      const tinygltf::Value& v = x->second.Get(name);
      if (!v.IsArray() || v.ArrayLen() != 3) fail(where, std::string(name) + " needs 3 numbers");
      for (int k = 0; k < 3; ++k) {
        const tinygltf::Value& e = v.Get(k);
        const double d = e.IsNumber() ? e.GetNumberAsDouble() : -1.0;
        if (!(d >= 0.0 && d <= (unit ? 1.0 : 1e30)))
          fail(where, std::string(name) + (unit ? " must lie in [0, 1]" : " must be finite and >= 0"));
        c[k] = float(d);
      }
      return c;
    };
    const Color specular_color = color_factor("KHR_materials_specular", "specularColorFactor", false);
    const ExtensionTexture specular_tex = extension_texture(m.extensions, "KHR_materials_specular", "specularTexture", where);
    const ExtensionTexture specular_color_tex =
        extension_texture(m.extensions, "KHR_materials_specular", "specularColorTexture", where);
    // KHR_materials_diffuse_transmission: the diffuse part's share that
    // passes through (A of its texture) and its colour (sRGB texture).
    const float diffuse_transmission =
        unit(extension_number(m.extensions, "KHR_materials_diffuse_transmission", "diffuseTransmissionFactor", 0.0, where),
             "diffuseTransmissionFactor");
    const Color diffuse_transmission_color =
        color_factor("KHR_materials_diffuse_transmission", "diffuseTransmissionColorFactor", true);
    const ExtensionTexture dt_tex =
        extension_texture(m.extensions, "KHR_materials_diffuse_transmission", "diffuseTransmissionTexture", where);
    const ExtensionTexture dt_color_tex =
        extension_texture(m.extensions, "KHR_materials_diffuse_transmission", "diffuseTransmissionColorTexture", where);
    // (A texture times a zero factor is none.)
    const bool transmissive = transmission > 0.f || diffuse_transmission > 0.f;
    if (transmissive && m.extensions.count("KHR_materials_volume"))
      warn(where + ": KHR_materials_volume is not supported; the transmission is a thin sheet");
    Bsdf b = transmissive ? Bsdf::make_gltf_pbr_transmission(base, metallic, roughness, transmission, float(ior))
                          : Bsdf::make_gltf_pbr(base, metallic, roughness, float(ior), m.doubleSided);
    GltfPbrBsdf& surface = transmissive ? b.gltf_pbr_transmission.surface : b.gltf_pbr;
    surface.specular_strength = specular;
    surface.specular_color = specular_color;
    std::vector<TextureBinding> bindings;
    if (pbr.baseColorTexture.index >= 0) {
      Color mean;
      const int32_t t = texture(pbr.baseColorTexture, TextureChannel::Rgb, true, base, where + ".baseColorTexture",
                                info.uv_set, &mean);
      bindings.push_back({t, BsdfPart::Front, BsdfParam::BaseColor});
      surface.base_color = mean;
    }
    if (colored) {  // COLOR_0 × baseColorFactor × baseColorTexture
      const SourceLoc mat_at{path_ + ": " + where, 0};
      int32_t t = builder_.add_vertex_color_texture(mat_at, pbr.baseColorTexture.index >= 0 ? Color{1.f, 1.f, 1.f} : base);
      if (pbr.baseColorTexture.index >= 0) {
        t = builder_.add_product_texture(mat_at, {bindings.back().texture, {}}, {t, {}});
        bindings.pop_back();
      }
      bindings.insert(bindings.begin(), {t, BsdfPart::Front, BsdfParam::BaseColor});
      surface.base_color = builder_.texture_stats(t).mean;
    }
    // An extension's texture (its channel, times the factor) bound to a parameter: its mean.
    auto bind = [&](const ExtensionTexture& x, TextureChannel channel, bool srgb, Color factor, const char* name,
                    BsdfParam param) {
      Color mean;
      const int32_t t = texture(x.index, x.set, x.ext, channel, srgb, factor, where + "." + name, info.uv_set, &mean);
      bindings.push_back({t, BsdfPart::Front, param});
      return mean;
    };
    const Color one{1.f, 1.f, 1.f};
    if (diffuse_transmission > 0.f) {
      GltfPbrTransmissionBsdf& sheet = b.gltf_pbr_transmission;
      sheet.diffuse_transmission = diffuse_transmission;
      sheet.diffuse_transmission_color = diffuse_transmission_color;
      if (dt_tex.index >= 0)
        sheet.diffuse_transmission = bind(dt_tex, TextureChannel::A, false, one * diffuse_transmission,
                                          "diffuseTransmissionTexture", BsdfParam::DiffuseTransmission).x;
      if (dt_color_tex.index >= 0)
        sheet.diffuse_transmission_color = bind(dt_color_tex, TextureChannel::Rgb, true, diffuse_transmission_color,
                                                "diffuseTransmissionColorTexture", BsdfParam::DiffuseTransmissionColor);
    }
    if (transmission > 0.f && transmission_tex.index >= 0)
      b.gltf_pbr_transmission.transmission =
          bind(transmission_tex, TextureChannel::R, false, one * transmission, "transmissionTexture", BsdfParam::Transmission).x;
    if (specular_tex.index >= 0)
      surface.specular_strength = bind(specular_tex, TextureChannel::A, false, one * specular, "specularTexture", BsdfParam::Specular).x;
    if (specular_color_tex.index >= 0)
      surface.specular_color =
          bind(specular_color_tex, TextureChannel::Rgb, true, specular_color, "specularColorTexture", BsdfParam::SpecularColor);
    // KHR_materials_clearcoat: the coat's weight (R of its texture) and
    // roughness (G of its texture); a zero clearcoatFactor disables it.
    const float clearcoat = unit(extension_number(m.extensions, "KHR_materials_clearcoat", "clearcoatFactor", 0.0, where),
                                 "clearcoatFactor");
    const float clearcoat_roughness =
        unit(extension_number(m.extensions, "KHR_materials_clearcoat", "clearcoatRoughnessFactor", 0.0, where),
             "clearcoatRoughnessFactor");
    const ExtensionTexture coat_tex = extension_texture(m.extensions, "KHR_materials_clearcoat", "clearcoatTexture", where);
    const ExtensionTexture coat_rough_tex =
        extension_texture(m.extensions, "KHR_materials_clearcoat", "clearcoatRoughnessTexture", where);
    const ExtensionTexture coat_normal_tex =
        extension_texture(m.extensions, "KHR_materials_clearcoat", "clearcoatNormalTexture", where);
    const bool coated = clearcoat > 0.f && !transmissive;
    if (clearcoat > 0.f && transmissive)
      warn(where + ": KHR_materials_clearcoat on a transmitting material is not supported: rendered without the coat");
    if (coated) {
      surface.clearcoat = clearcoat;
      surface.clearcoat_roughness = clearcoat_roughness;
      if (coat_tex.index >= 0)
        surface.clearcoat = bind(coat_tex, TextureChannel::R, false, one * clearcoat, "clearcoatTexture", BsdfParam::Clearcoat).x;
      if (coat_rough_tex.index >= 0)
        surface.clearcoat_roughness = bind(coat_rough_tex, TextureChannel::G, false, one * clearcoat_roughness,
                                           "clearcoatRoughnessTexture", BsdfParam::ClearcoatRoughness).x;
      // Luz shades the whole material in one frame: the coat takes the base's.
      if (coat_normal_tex.index >= 0)
        warn(where + ": clearcoatNormalTexture is ignored (the coat follows the base's shading normal)");
      else if (m.normalTexture.index >= 0)
        warn(where + ": the clear coat follows the base's normal texture (the extension leaves it unmapped)");
    }
    if (pbr.metallicRoughnessTexture.index >= 0) {
      Color mean;
      const std::string w = where + ".metallicRoughnessTexture";
      const int32_t tr = texture(pbr.metallicRoughnessTexture, TextureChannel::G, false,
                                 Color{1.f, 1.f, 1.f} * roughness, w, info.uv_set, &mean);
      surface.roughness = mean.x;
      const int32_t tm = texture(pbr.metallicRoughnessTexture, TextureChannel::B, false,
                                 Color{1.f, 1.f, 1.f} * metallic, w, info.uv_set, &mean);
      surface.metallic = mean.x;
      bindings.push_back({tr, BsdfPart::Front, BsdfParam::Roughness});
      bindings.push_back({tm, BsdfPart::Front, BsdfParam::Metallic});
    }
    // Alpha (material/opacity.h): MASK thresholds, BLEND is a fractional opacity.
    float opacity = 1.f, cutoff = -1.f;
    int32_t opacity_texture = -1;
    if (m.alphaMode == "MASK" || m.alphaMode == "BLEND") {
      const bool mask = m.alphaMode == "MASK";
      info.blended = true;
      if (mask && !(m.alphaCutoff >= 0.0 && std::isfinite(m.alphaCutoff))) fail(where, "alphaCutoff must be >= 0");
      if (mask) cutoff = float(m.alphaCutoff);
      if (pbr.baseColorTexture.index >= 0) {
        opacity_texture = texture(pbr.baseColorTexture, TextureChannel::A, false, Color{1.f, 1.f, 1.f} * float(alpha),
                                  where + ".baseColorTexture", info.uv_set, nullptr);
      } else {
        opacity = mask ? (alpha >= m.alphaCutoff ? 1.f : 0.f) : float(alpha);
      }
    } else if (m.alphaMode != "OPAQUE") {
      fail(where, "alphaMode must be OPAQUE, MASK or BLEND");
    }
    if (!std::isfinite(m.normalTexture.scale) || std::fabs(m.normalTexture.scale) > 1e6)
      fail(where, "normalTexture.scale must be a finite number");
    int32_t normal_map = -1;
    if (m.normalTexture.index >= 0)
      normal_map = texture(m.normalTexture.index, m.normalTexture.texCoord, m.normalTexture.extensions,
                           TextureChannel::Rgb, false, {1.f, 1.f, 1.f}, where + ".normalTexture", info.uv_set, nullptr);
    // Emission.
    const Color ef = rgb(m.emissiveFactor, 3, {0, 0, 0});
    const double strength = extension_number(m.extensions, "KHR_materials_emissive_strength", "emissiveStrength", 1.0, where);
    for (int k = 0; k < 3; ++k)
      if (!(ef[k] >= 0.f && ef[k] <= 1.f)) fail(where, "emissiveFactor must lie in [0, 1]");
    if (!(strength >= 0.0 && strength < 1e30)) fail(where, "emissiveStrength must be finite and >= 0");
    const Color emission = ef * float(strength);
    if (!is_black(emission)) {
      info.emissive = true;
      info.emission = emission;
      info.emission_two_sided = m.doubleSided;
      if (m.emissiveTexture.index >= 0) {
        info.emission_texture = texture(m.emissiveTexture, TextureChannel::Rgb, true, emission,
                                        where + ".emissiveTexture", info.uv_set, &info.emission);
        if (is_black(info.emission)) info.emissive = false, info.emission_texture = -1;  // all texels black
      }
    }
    MaterialDesc d;
    d.bsdf = b;
    d.bindings = bindings;
    d.opacity = opacity;
    d.opacity_texture = opacity_texture;
    d.alpha_cutoff = cutoff;
    d.normal_map = normal_map;
    d.normal_scale = float(m.normalTexture.scale);
    d.normal_y_by_uv = true;
    if (info.emissive && coated)
      warn(where + ": the emission is not darkened by the clear coat's Fresnel (KHR_materials_clearcoat's coated_emission)");
    if (info.emissive && d.masked()) {
      warn(where + ": an emissive material with alphaMode MASK or BLEND is rendered without its emission");
      info.emissive = false, info.emission_texture = -1;
    }
    info.index = builder_.add_material({path_ + ": " + where, 0}, d);
    return materials_[{index, colored}] = info;
  }

  // ---- camera and lights ----
  // The camera asked for: by the camera's name or its node's.
  bool wanted(const tinygltf::Node& n) const {
    if (camera_.empty()) return true;
    return n.name == camera_ ||
           (size_t(n.camera) < model_.cameras.size() && model_.cameras[size_t(n.camera)].name == camera_);
  }

  void set_camera(int index, const Matrix4& world, const std::string& where) {
    if (size_t(index) >= model_.cameras.size()) fail(where, "no camera " + std::to_string(index));
    const tinygltf::Camera& c = model_.cameras[size_t(index)];
    const std::string cw = at("cameras", size_t(index));
    Camera cam;
    cam.height = 512;
    cam.origin = world.point({0, 0, 0});
    // glTF's camera looks along -z with +y up and +x right, its node's
    // scale ignored (§3.10.2: a mirroring or uneven scale neither mirrors
    // nor shears the view): the frame of the node's -z and +y, made
    // orthonormal; Luz's x_axis points to the image's left (camera/frame.h).
    cam.z_axis = normalize(world.vector({0, 0, -1}));
    const Vec3 up = world.vector({0, 1, 0});
    cam.y_axis = normalize(up - cam.z_axis * dot(up, cam.z_axis));
    cam.x_axis = cross(cam.y_axis, cam.z_axis);
    if (!is_finite(cam.x_axis) || !is_finite(cam.y_axis) || !is_finite(cam.z_axis) || !is_finite(cam.origin) ||
        max_abs(cam.origin) > kMaxCoordinate)
      fail(where, "the camera's transform is degenerate or lies beyond 1e18");
    if (c.type == "perspective") {
      const double yfov = c.perspective.yfov, aspect = c.perspective.aspectRatio > 0 ? c.perspective.aspectRatio : 1.0;
      if (!(yfov > 0.0 && yfov < M_PI)) fail(cw, "yfov must lie in (0, π)");
      if (!(aspect > 1e-3 && aspect < 1e3)) fail(cw, "aspectRatio must lie in (0.001, 1000)");
      cam.type = CameraType::Perspective;
      cam.width = std::max(1, int(std::lround(cam.height * aspect)));
      cam.tan_half_y = float(std::tan(yfov / 2));
      cam.tan_half_x = cam.tan_half_y * float(cam.width) / float(cam.height);
    } else if (c.type == "orthographic") {
      const double xm = std::fabs(c.orthographic.xmag), ym = std::fabs(c.orthographic.ymag);
      if (!(xm > 0 && ym > 0 && xm < 1e18 && ym < 1e18)) fail(cw, "xmag and ymag must be finite and not zero");
      if (!(xm / ym > 1e-3 && xm / ym < 1e3)) fail(cw, "xmag / ymag must lie in (0.001, 1000)");
      cam.type = CameraType::Orthographic;
      cam.width = std::max(1, int(std::lround(cam.height * xm / ym)));
      cam.tan_half_x = float(xm);
      cam.tan_half_y = float(ym);
    } else {
      fail(cw, "camera type must be perspective or orthographic");
    }
    builder_.set_camera({path_ + ": " + where, 0}, cam, FovAxis::Y);  // yfov (ymag) kept at another resolution
  }

  void add_light(const tinygltf::Value& ref, const Matrix4& world, const std::string& where) {
    const int index = index_of(ref);
    if (index < 0 || size_t(index) >= model_.lights.size()) fail(where, "KHR_lights_punctual.light names no light");
    const tinygltf::Light& l = model_.lights[size_t(index)];
    const std::string lw = "KHR_lights_punctual." + at("lights", size_t(index));
    const Color color = l.color.empty() ? Color{1, 1, 1} : rgb(l.color, 3, {-1, -1, -1});
    for (int k = 0; k < 3; ++k)
      if (!(color[k] >= 0.f && std::isfinite(color[k]))) fail(lw, "color needs 3 finite numbers >= 0");
    if (!(l.intensity >= 0.0 && l.intensity < 1e30)) fail(lw, "intensity must be finite and >= 0");
    const Color power = color * float(l.intensity / kLumensPerWatt);
    if (l.range > 0.0 && l.type != "directional")
      warn(lw + ": range is ignored (the light falls off by the inverse square law to any distance)");
    const Vec3 pos = world.point({0, 0, 0});
    const Vec3 axis = normalize(world.vector({0, 0, -1}));  // lights shine along -z
    if (!is_finite(pos) || max_abs(pos) > kMaxCoordinate || !is_finite(axis))
      fail(where, "the light's transform is degenerate or lies beyond 1e18");
    if (l.type == "point") {
      PointLight p;
      p.intensity = power;
      p.position = pos;
      punctual_.push_back(p);
    } else if (l.type == "directional") {
      DirectionalLight d;
      d.irradiance = power;
      d.direction = axis;
      punctual_.push_back(d);
    } else if (l.type == "spot") {
      const double outer = l.spot.outerConeAngle, inner = l.spot.innerConeAngle;
      if (!(outer > 0.0 && outer <= M_PI / 2)) fail(lw, "outerConeAngle must lie in (0, π/2]");
      if (!(inner >= 0.0 && inner < outer)) fail(lw, "innerConeAngle must lie in [0, outerConeAngle)");
      SpotLight s;
      s.intensity = power;
      s.position = pos;
      // Light space: z along the axis; an orthonormal x, y around it (the
      // rows of the inverse of an orthonormal frame are its columns).
      const Vec3 x = normalize(world.vector({1, 0, 0}));
      s.inv_z = axis;
      s.inv_x = normalize(x - axis * dot(x, axis));
      s.inv_y = cross(s.inv_z, s.inv_x);
      if (!is_finite(s.inv_x) || !is_finite(s.inv_y)) fail(where, "the spot light's transform is degenerate");
      s.set_cone(outer, inner, SpotFalloff::SquaredRampCos);
      punctual_.push_back(s);
    } else {
      fail(lw, "light type must be point, spot or directional");
    }
  }
};

}  // namespace

Scene load_gltf(const std::string& path, const std::string& camera) {
  try {
    return GltfLoader(path, camera).load();
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {  // tinygltf's JSON errors, texel-array limits
    throw InputError(path, 0, e.what());
  }
}

}  // namespace luz
