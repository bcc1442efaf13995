// Image files: OpenEXR (float RGB), PFM, and sRGB PNG (clamped, 8 bit). The
// format follows the extension.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace luz {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // interleaved, rows top to bottom
};

// An 8-bit image as packed RGBA texels (texture.h's pack_rgba8), rows top
// to bottom: what bitmap textures are made of.
struct Image8 {
  int width = 0, height = 0;
  std::vector<uint32_t> rgba;
};

// A path's extension in lower case, with its dot (".exr"; "" when none).
std::string lower_extension(const std::string& path);
bool is_supported_image_extension(const std::string& path);
// JPEG, PNG, TGA or BMP through stb_image; throws InputError naming the path.
Image8 read_image8(const std::string& path);
// The same from an image file's bytes (glTF's embedded images); `name` names it in errors.
Image8 decode_image8(const std::string& name, const uint8_t* data, size_t size);
// How an OpenEXR output is written (Mitsuba's hdrfilm pixel_format and
// component_format): its channels (R G B; Y, the luminance; or X Y Z, CIE
// 1931 from linear sRGB primaries) and their type (32- or 16-bit float).
// PFM and PNG outputs are RGB whatever it says.
enum class ExrChannels { Rgb, Luminance, Xyz };
struct ExrFormat {
  ExrChannels channels = ExrChannels::Rgb;
  bool half = false;
};

// Named text attributes an OpenEXR output carries (the other formats have
// no place for them).
using ImageMetadata = std::vector<std::pair<std::string, std::string>>;

// A further layer of an OpenEXR output, e.g. "albedo" with channels R G B:
// written as channels "albedo.R", ... (32-bit float), values interleaved per
// pixel, rows top to bottom.
struct ImageLayer {
  std::string name;
  std::vector<std::string> channels;
  std::vector<float> values;
};

// Written whole or not at all (io/atomic_file.h): through a symbolic link to
// its target. Throws InputError naming the path on failure.
void write_image(const std::string& path, const Image& img, const ExrFormat& exr = {},
                 const ImageMetadata& metadata = {}, const std::vector<ImageLayer>& layers = {});
Image read_exr(const std::string& path);
Image read_pfm(const std::string& path);
// A linear float RGB image from OpenEXR, PFM, Radiance HDR, or an 8-bit
// format (JPEG, PNG, TGA, BMP: decoded from sRGB); throws InputError naming
// the path.
Image read_image_linear(const std::string& path);

float linear_to_srgb(float v);

}  // namespace luz
