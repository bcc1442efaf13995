#include "luz/io/image.h"

#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStdIO.h>
#include <ImfStringAttribute.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#include <stb/stb_image.h>

#include "luz/io/atomic_file.h"
#include "luz/io/error.h"
#include "luz/texture/texture.h"

namespace luz {

namespace {


std::string encode_exr(const Image& img, const ExrFormat& fmt, const ImageMetadata& metadata,
                       const std::vector<ImageLayer>& layers) {
  // Rows of the 3×3 map from linear sRGB (Rec. 709 primaries, D65) to CIE XYZ.
  static constexpr float kXyz[3][3] = {
      {0.412453f, 0.357580f, 0.180423f}, {0.212671f, 0.715160f, 0.072169f}, {0.019334f, 0.119193f, 0.950227f}};
  static const char* kNames[3][3] = {{"R", "G", "B"}, {"Y", "", ""}, {"X", "Y", "Z"}};
  const int format = int(fmt.channels), channels = fmt.channels == ExrChannels::Luminance ? 1 : 3;
  const size_t pixels = size_t(img.width) * size_t(img.height);
  std::vector<float> values(pixels * size_t(channels));
  for (size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < channels; ++c) {
      const float* rgb = &img.rgb[3 * i];
      const int row = fmt.channels == ExrChannels::Luminance ? 1 : c;
      values[i * size_t(channels) + size_t(c)] =
          fmt.channels == ExrChannels::Rgb ? rgb[c] : kXyz[row][0] * rgb[0] + kXyz[row][1] * rgb[1] + kXyz[row][2] * rgb[2];
    }
  std::vector<Imath::half> halves(fmt.half ? values.size() : 0);
  for (size_t i = 0; i < halves.size(); ++i) halves[i] = Imath::half(values[i]);
  const Imf::PixelType type = fmt.half ? Imf::HALF : Imf::FLOAT;
  const size_t size = fmt.half ? sizeof(Imath::half) : sizeof(float);
  char* base = fmt.half ? reinterpret_cast<char*>(halves.data()) : reinterpret_cast<char*>(values.data());
  Imf::Header header(img.width, img.height);
  Imf::FrameBuffer fb;
  const size_t xs = size_t(channels) * size, ys = xs * size_t(img.width);
  for (int c = 0; c < channels; ++c) {
    header.channels().insert(kNames[format][c], Imf::Channel(type));
    fb.insert(kNames[format][c], Imf::Slice(type, base + size_t(c) * size, xs, ys));
  }
  for (const ImageLayer& layer : layers) {
    const size_t n = layer.channels.size();
    if (n == 0 || layer.values.size() != n * pixels) throw std::invalid_argument("layer '" + layer.name + "' has the wrong size");
    for (size_t c = 0; c < n; ++c) {
      const std::string name = layer.name + "." + layer.channels[c];
      header.channels().insert(name, Imf::Channel(Imf::FLOAT));
      char* at = reinterpret_cast<char*>(const_cast<float*>(layer.values.data() + c));
      fb.insert(name, Imf::Slice(Imf::FLOAT, at, n * sizeof(float), n * sizeof(float) * size_t(img.width)));
    }
  }
  for (const auto& [name, value] : metadata) header.insert(name, Imf::StringAttribute(value));
  Imf::StdOSStream stream;
  {
    Imf::OutputFile file(stream, header);
    file.setFrameBuffer(fb);
    file.writePixels(img.height);
  }
  return stream.str();
}

std::string encode_pfm(const Image& img) {
  std::string out = "PF\n" + std::to_string(img.width) + " " + std::to_string(img.height) +
                    "\n-1.0\n";  // negative scale: little endian
  const size_t row = size_t(img.width) * 3 * sizeof(float);
  for (int y = img.height - 1; y >= 0; --y)  // PFM rows run bottom to top
    out.append(reinterpret_cast<const char*>(img.rgb.data() + size_t(y) * img.width * 3), row);
  return out;
}

std::string encode_png(const Image& img) {
  std::vector<unsigned char> px(img.rgb.size());
  for (size_t i = 0; i < px.size(); ++i)
    px[i] = (unsigned char)std::lround(255.f * linear_to_srgb(std::clamp(img.rgb[i], 0.f, 1.f)));
  std::string png;
  auto append = [](void* ctx, void* data, int size) { static_cast<std::string*>(ctx)->append(static_cast<char*>(data), size_t(size)); };
  if (!stbi_write_png_to_func(append, &png, img.width, img.height, 3, px.data(), img.width * 3))
    throw std::runtime_error("PNG encoding failed");
  return png;
}

}  // namespace

float linear_to_srgb(float v) {
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

std::string lower_extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

bool is_supported_image_extension(const std::string& path) {
  std::string e = lower_extension(path);
  return e == ".exr" || e == ".pfm" || e == ".png";
}

void write_image(const std::string& path, const Image& img, const ExrFormat& exr, const ImageMetadata& metadata,
                 const std::vector<ImageLayer>& layers) {
  std::string e = lower_extension(path);
  if (!is_supported_image_extension(path))
    throw InputError(path, 0, "unknown image format '" + e + "' (use .exr, .pfm or .png)");
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != size_t(img.width) * size_t(img.height) * 3)
    throw InputError(path, 0, "image has no pixels or the wrong number of them");
  // Encoded in memory (stb and OpenEXR would not report a full disk through
  // their file writers), then written whole or not at all.
  std::string bytes;
  try {
    if (!layers.empty() && e != ".exr") throw std::invalid_argument("only OpenEXR outputs hold further layers");
    bytes = e == ".exr" ? encode_exr(img, exr, metadata, layers) : e == ".pfm" ? encode_pfm(img) : encode_png(img);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& ex) {  // OpenEXR (Iex) and std:: exceptions alike
    throw InputError(path, 0, std::string("cannot write: ") + ex.what());
  }
  write_file_atomically(path, bytes.data(), bytes.size());
}

Image read_exr(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str());
    Imath::Box2i dw = file.header().dataWindow();
    Image img;
    img.width = dw.max.x - dw.min.x + 1;
    img.height = dw.max.y - dw.min.y + 1;
    img.rgb.assign(size_t(img.width) * img.height * 3, 0.f);
    Imf::FrameBuffer fb;
    const size_t xs = 3 * sizeof(float), ys = xs * img.width;
    char* base = reinterpret_cast<char*>(img.rgb.data()) - (dw.min.x * xs + dw.min.y * ys);
    fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const std::exception& ex) {
    throw InputError(path, 0, std::string("cannot read OpenEXR: ") + ex.what());
  }
}

Image read_pfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open");
  std::string magic;
  long long w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (!in || magic != "PF" || w <= 0 || h <= 0 || w > 65536 || h > 65536 || !(scale < 0))
    throw InputError(path, 1, "not a little-endian RGB PFM");
  // The header must promise no more pixels than the file holds.
  std::streamoff start = in.tellg();
  in.seekg(0, std::ios::end);
  std::streamoff size = in.tellg();
  if (start < 0 || size - start < std::streamoff(w * h * 3 * sizeof(float))) throw InputError(path, 0, "truncated PFM");
  in.seekg(start);
  Image img;
  img.width = int(w);
  img.height = int(h);
  img.rgb.resize(size_t(w) * h * 3);
  for (long long y = h - 1; y >= 0; --y)
    in.read(reinterpret_cast<char*>(img.rgb.data() + size_t(y) * w * 3), std::streamsize(w) * 3 * sizeof(float));
  if (!in) throw InputError(path, 0, "truncated PFM");
  return img;
}

Image8 read_image8(const std::string& path) {
  std::string e = lower_extension(path);
  if (e != ".jpg" && e != ".jpeg" && e != ".png" && e != ".tga" && e != ".bmp")
    throw InputError(path, 0, "unsupported bitmap format '" + e + "' (supported: .jpg, .png, .tga, .bmp)");
  int w = 0, h = 0, channels = 0;
  stbi_uc* px = stbi_load(path.c_str(), &w, &h, &channels, 4);
  if (!px) throw InputError(path, 0, std::string("cannot read image: ") + stbi_failure_reason());
  Image8 img;
  img.width = w;
  img.height = h;
  img.rgba.resize(size_t(w) * size_t(h));
  for (size_t k = 0; k < img.rgba.size(); ++k)
    img.rgba[k] = pack_rgba8(px[4 * k], px[4 * k + 1], px[4 * k + 2], px[4 * k + 3]);
  stbi_image_free(px);
  if (img.rgba.empty()) throw InputError(path, 0, "image is empty");
  return img;
}

Image read_image_linear(const std::string& path) {
  const std::string e = lower_extension(path);
  if (e == ".exr") return read_exr(path);
  if (e == ".pfm") return read_pfm(path);
  Image img;
  if (e == ".hdr") {
    int w = 0, h = 0, channels = 0;
    float* px = stbi_loadf(path.c_str(), &w, &h, &channels, 3);
    if (!px) throw InputError(path, 0, std::string("cannot read Radiance HDR image: ") + stbi_failure_reason());
    img.width = w;
    img.height = h;
    img.rgb.assign(px, px + size_t(w) * size_t(h) * 3);
    stbi_image_free(px);
  } else {
    const Image8 ldr = read_image8(path);  // names the supported formats when e is none of them
    img.width = ldr.width;
    img.height = ldr.height;
    img.rgb.resize(ldr.rgba.size() * 3);
    for (size_t k = 0; k < ldr.rgba.size(); ++k)
      for (int c = 0; c < 3; ++c) img.rgb[3 * k + c] = float(srgb_to_linear(((ldr.rgba[k] >> (8 * c)) & 0xff) / 255.0));
  }
  if (img.rgb.empty()) throw InputError(path, 0, "image is empty");
  return img;
}

}  // namespace luz
