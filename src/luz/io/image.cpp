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
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

// stb's functions are exempt from UBSan's nonnull-attribute check in the
// sanitizer build (clang): stbi__getn memcpy's zero bytes to a null buffer
// for an empty PNG chunk, harmless and not Luz's code to change.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((no_sanitize("nonnull-attribute"))), apply_to = function)
#endif
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#include <stb/stb_image.h>
#if defined(__clang__)
#pragma clang attribute pop
#endif

#include "luz/io/atomic_file.h"
#include "luz/core/memory.h"
#include "luz/io/error.h"
#include "luz/io/mesh_serialized.h"
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

// Guards against bugs of Debian 12's stb_image (2.27), fixed in 2.28.
// A JPEG DHT table whose 16 code counts add up to more than 256 makes stb
// write past its Huffman tables: such a file is refused before stb reads it.
// Walks the markers, skipping each segment's payload (bytes inside one are
// never taken for a marker); bytes past the end read as 0, as stb reads them.
// Where a JPEG's start-of-image marker's second byte is, after any 0xFF
// fill bytes (stb skips them too); 0: not a JPEG.
size_t jpeg_start(const uint8_t* d, size_t size) {
  size_t start = 1;
  while (size > 0 && d[0] == 0xFF && start < size && d[start] == 0xFF) ++start;
  return size > start && d[0] == 0xFF && d[start] == 0xD8 ? start : 0;
}

bool jpeg_huffman_tables_fit(const uint8_t* d, size_t size) {
  auto at = [&](size_t i) { return i < size ? d[i] : uint8_t(0); };
  const size_t start = jpeg_start(d, size);
  if (!start) return true;
  for (size_t pos = start + 1; pos + 1 < size;) {
    const uint8_t m = d[pos + 1];
    // Entropy-coded data, byte stuffing, fill bytes, RSTn, TEM, SOI.
    if (d[pos] != 0xFF || m == 0x00 || m == 0xFF || m == 0x01 || (m >= 0xD0 && m <= 0xD8)) {
      ++pos;
      continue;
    }
    const size_t end = pos + 2 + (size_t(at(pos + 2)) << 8 | at(pos + 3));
    if (m == 0xC4)
      for (size_t t = pos + 4; t < end;) {  // tables: class and id, 16 counts, the symbols
        size_t symbols = 0;
        for (size_t k = 1; k <= 16; ++k) symbols += at(t + k);
        if (symbols > 256) return false;
        t += 17 + symbols;
      }
    pos = end;
  }
  return true;
}

// stb loops forever on Radiance HDR run-length data cut short, reading
// zeros past the end (CVE-2021-42715): it reads through callbacks that give
// line feeds past the end instead (one ends a header line; in run-length
// data, each is a literal run of 10: stb moves on), and an image that
// needed them is refused as truncated. Other formats' decoders could loop
// on them: only Radiance HDR files are read so.
struct StbSource {
  const std::vector<uint8_t>& data;
  size_t pos = 0;
  bool past_end = false;
  explicit StbSource(const std::vector<uint8_t>& d) : data(d) {}
  static int read(void* user, char* out, int size) {
    auto* s = static_cast<StbSource*>(user);
    if (s->pos >= s->data.size()) {
      s->past_end = true;
      std::memset(out, '\n', size_t(size));
      return size;
    }
    const size_t n = std::min(size_t(size), s->data.size() - s->pos);
    std::memcpy(out, s->data.data() + s->pos, n);
    s->pos += n;
    return int(n);
  }
  static void skip(void* user, int n) {
    auto* s = static_cast<StbSource*>(user);
    s->pos = n < 0 ? s->pos - std::min(s->pos, size_t(-int64_t(n))) : s->pos + size_t(n);
  }
  static int eof(void* user) {
    auto* s = static_cast<StbSource*>(user);
    return s->pos >= s->data.size();
  }
};

// An image of w×h pixels at `bytes` a pixel must fit in memory (core/memory.h).
void require_pixels(const std::string& path, int64_t w, int64_t h, uint64_t bytes) {
  require_memory(uint64_t(w) * uint64_t(h) * bytes, path, "its " + std::to_string(w) + "×" + std::to_string(h) + " pixels");
}

// stb's reason for a failed decode; some of its PNG paths fail without one.
std::string stb_failure() {
  const char* why = stbi_failure_reason();
  return why && *why ? why : "corrupt data";
}

Image read_hdr(const std::string& path) {
  const std::vector<uint8_t> data = read_binary_file(path);
  int w = 0, h = 0, channels = 0;
  // A run-length scanline holds at most 127 pixels per 2 bytes per channel
  // (4): a header promising more pixels than that is refused before stb
  // allocates and fills them.
  const int size = int(std::min(data.size(), size_t(INT32_MAX)));
  if (!stbi_is_hdr_from_memory(data.data(), size))
    throw InputError(path, 0, "cannot read Radiance HDR image: it starts with neither #?RADIANCE nor #?RGBE");
  if (stbi_info_from_memory(data.data(), size, &w, &h, &channels) && double(w) * double(h) > 16.0 * double(data.size()))
    throw InputError(path, 0, "cannot read Radiance HDR image: " + std::to_string(w) + "x" + std::to_string(h) +
                                  " pixels cannot fit in " + std::to_string(data.size()) + " bytes (truncated?)");
  require_pixels(path, w, h, 24);  // stb's floats and the image's
  StbSource src(data);
  const stbi_io_callbacks io{StbSource::read, StbSource::skip, StbSource::eof};
  float* px = stbi_loadf_from_callbacks(&io, &src, &w, &h, &channels, 3);
  if (src.past_end) {
    stbi_image_free(px);
    throw InputError(path, 0, "cannot read Radiance HDR image: truncated");
  }
  if (!px) throw InputError(path, 0, "cannot read Radiance HDR image: " + stb_failure());
  Image img;
  img.width = w;
  img.height = h;
  img.rgb.assign(px, px + size_t(w) * size_t(h) * 3);
  stbi_image_free(px);
  return img;
}

// OpenEXR 3.1 trusts a file's header: it allocates an attribute at its
// stated size before reading it, and buffers for the data window, so a file
// of a few bytes could cost gigabytes. Checked first: every attribute of
// every part lies inside the file, and a data window holds at most 4096
// pixels per byte of the file (no OpenEXR compression comes near: zlib's
// best packs 1032 bytes in one).
void check_exr_header(const std::string& path, const std::vector<uint8_t>& d) {
  auto fail = [&](size_t at, const std::string& problem) {
    throw InputError(path, 0, "byte " + std::to_string(at) + ": " + problem);
  };
  auto i32 = [&](size_t at) {
    if (at + 4 > d.size()) fail(at, "OpenEXR header cut short");
    return int32_t(uint32_t(d[at]) | uint32_t(d[at + 1]) << 8 | uint32_t(d[at + 2]) << 16 | uint32_t(d[at + 3]) << 24);
  };
  // A name as OpenEXR reads one: through its zero, or 256 bytes without one.
  // Returns the bytes it takes.
  auto name_at = [&](size_t at, std::string* name = nullptr) {
    size_t n = 0;
    while (n < 256) {
      if (at + n >= d.size()) fail(at, "OpenEXR header cut short");
      if (d[at + n++] == 0) break;
    }
    if (name) name->assign(reinterpret_cast<const char*>(&d[at]), d[at + n - 1] == 0 ? n - 1 : n);
    return n;
  };
  if (i32(0) != 20000630) fail(0, "not an OpenEXR file");
  const bool multipart = i32(4) & 0x1000;
  size_t pos = 8;
  do {
    if (pos >= d.size()) fail(pos, "OpenEXR header cut short");
    if (multipart && d[pos] == 0) break;  // the empty header after the last part's
    while (true) {
      if (pos >= d.size()) fail(pos, "OpenEXR header cut short");
      if (d[pos] == 0) break;
      std::string name, type;
      pos += name_at(pos, &name);
      pos += name_at(pos, &type);
      const int32_t size = i32(pos);
      pos += 4;
      if (size < 0 || size_t(size) > d.size() - pos)
        fail(pos - 4, "attribute '" + name + "' of " + std::to_string(size) + " bytes runs past the end of the file");
      if (type == "chlist") {
        // OpenEXR reads a channel list by its entries (a name, 16 bytes),
        // up to an empty name, whatever its stated size: where it goes on
        // reading, so does this check.
        while (true) {
          if (pos >= d.size()) fail(pos, "OpenEXR header cut short");
          if (d[pos] == 0) break;
          pos += name_at(pos) + 16;
        }
        ++pos;
        continue;
      }
      if (name == "dataWindow" && size >= 16) {
        const double w = double(i32(pos + 8)) - i32(pos) + 1, h = double(i32(pos + 12)) - i32(pos + 4) + 1;
        if (w < 1 || h < 1) fail(pos, "empty data window");
        if (w * h > 4096.0 * double(d.size()))
          fail(pos, "a data window of " + std::to_string(int64_t(w)) + "x" + std::to_string(int64_t(h)) +
                        " pixels cannot fit in " + std::to_string(d.size()) + " bytes");
      }
      pos += size_t(size);
    }
    ++pos;
  } while (multipart);
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
  check_exr_header(path, read_binary_file(path));
  try {
    Imf::InputFile file(path.c_str());
    Imath::Box2i dw = file.header().dataWindow();
    Image img;
    img.width = dw.max.x - dw.min.x + 1;
    img.height = dw.max.y - dw.min.y + 1;
    require_pixels(path, img.width, img.height, 12);
    img.rgb.assign(size_t(img.width) * img.height * 3, 0.f);
    Imf::FrameBuffer fb;
    const size_t xs = 3 * sizeof(float), ys = xs * img.width;
    // Slice::Make places the data window's origin at the pointer (moving a
    // pointer back by the origin's offset overflows for a far origin).
    fb.insert("R", Imf::Slice::Make(Imf::FLOAT, img.rgb.data(), dw, xs, ys));
    fb.insert("G", Imf::Slice::Make(Imf::FLOAT, img.rgb.data() + 1, dw, xs, ys));
    fb.insert("B", Imf::Slice::Make(Imf::FLOAT, img.rgb.data() + 2, dw, xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const std::exception& ex) {
    throw InputError(path, 0, std::string("cannot read OpenEXR: ") + ex.what());
  }
}

// PFM: "PF" (RGB) or "Pf" (grey, read into all three channels), then the
// width, the height and a scale whose sign gives the byte order (negative:
// little-endian) and whose magnitude multiplies the values (as pbrt-v4 and
// Mitsuba 3 read it); rows bottom to top.
Image read_pfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open");
  std::string magic;
  long long w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (!in || (magic != "PF" && magic != "Pf"))
    throw InputError(path, 1, "not a PFM (its header must start with PF or Pf, the width, the height and a scale)");
  if (w <= 0 || h <= 0 || w > 65536 || h > 65536)
    throw InputError(path, 1, "a PFM of " + std::to_string(w) + "×" + std::to_string(h) + " pixels (1 to 65536 a side)");
  if (!(std::isfinite(scale) && scale != 0))
    throw InputError(path, 1, "a PFM's scale must be finite and non-zero (its sign gives the byte order)");
  const int channels = magic == "PF" ? 3 : 1;
  // The header must promise no more pixels than the file holds.
  std::streamoff start = in.tellg();
  in.seekg(0, std::ios::end);
  std::streamoff size = in.tellg();
  if (start < 0 || size - start < std::streamoff(w * h * channels * sizeof(float)))
    throw InputError(path, 0, "truncated PFM");
  in.seekg(start);
  require_pixels(path, w, h, 12);
  std::vector<float> row(size_t(w) * channels);
  Image img;
  img.width = int(w);
  img.height = int(h);
  img.rgb.resize(size_t(w) * h * 3);
  const bool swap = (scale > 0) != (std::endian::native == std::endian::big);
  const float factor = float(std::fabs(scale));
  for (long long y = h - 1; y >= 0; --y) {
    in.read(reinterpret_cast<char*>(row.data()), std::streamsize(row.size() * sizeof(float)));
    float* out = img.rgb.data() + size_t(y) * w * 3;
    for (size_t k = 0; k < row.size(); ++k) {
      float v = row[k];
      if (swap) {
        uint32_t bits;
        std::memcpy(&bits, &v, 4);
        bits = __builtin_bswap32(bits);
        std::memcpy(&v, &bits, 4);
      }
      if (factor != 1.f) v *= factor;
      if (channels == 3) out[k] = v;
      else out[3 * k] = out[3 * k + 1] = out[3 * k + 2] = v;
    }
  }
  if (!in) throw InputError(path, 0, "truncated PFM");
  return img;
}

// The extensions of the 8-bit formats read through stb.
static bool is_image8_extension(const std::string& e) {
  return e == ".jpg" || e == ".jpeg" || e == ".png" || e == ".tga" || e == ".bmp";
}

Image8 read_image8(const std::string& path) {
  std::string e = lower_extension(path);
  if (!is_image8_extension(e))
    throw InputError(path, 0, "unsupported bitmap format '" + e + "' (supported: .jpg, .png, .tga, .bmp)");
  const std::vector<uint8_t> data = read_binary_file(path);
  return decode_image8(path, data.data(), data.size());
}

Image8 decode_image8(const std::string& name, const uint8_t* data, size_t size) {
  if (!jpeg_huffman_tables_fit(data, size))
    throw InputError(name, 0, "cannot read image: corrupt JPEG (a Huffman table of more than 256 codes)");
  int w = 0, h = 0, channels = 0;
  const int len = int(std::min(size, size_t(INT32_MAX)));
  // A header's size against the file's, as stb would allocate and fill what
  // a tiny file's header claims (reading zeros past a file's end): no real
  // PNG, JPEG or GIF packs 2048 pixels into a byte (zlib's limit is
  // ~1032:1), nor any other format stb reads 64 (RLE: 128 pixels in a
  // packet of 2 bytes or more; 1-bit BMP: 8).
  const bool png = size >= 4 && data[0] == 0x89 && data[1] == 'P' && data[2] == 'N' && data[3] == 'G';
  const bool gif = size >= 3 && data[0] == 'G' && data[1] == 'I' && data[2] == 'F';
  const double px_per_byte = png || gif || jpeg_start(data, size) ? 2048.0 : 64.0;
  if (stbi_info_from_memory(data, len, &w, &h, &channels) && double(w) * double(h) > px_per_byte * double(size) + 65536.0)
    throw InputError(name, 0, "cannot read image: its header claims " + std::to_string(w) + "×" + std::to_string(h) +
                                  " pixels, more than a file of " + std::to_string(size) + " bytes can hold");
  require_pixels(name, w, h, 8);  // stb's RGBA bytes and the image's
  stbi_uc* px = stbi_load_from_memory(data, len, &w, &h, &channels, 4);
  if (!px) throw InputError(name, 0, "cannot read image: " + stb_failure());
  Image8 img;
  img.width = w;
  img.height = h;
  img.rgba.resize(size_t(w) * size_t(h));
  for (size_t k = 0; k < img.rgba.size(); ++k)
    img.rgba[k] = pack_rgba8(px[4 * k], px[4 * k + 1], px[4 * k + 2], px[4 * k + 3]);
  stbi_image_free(px);
  if (img.rgba.empty()) throw InputError(name, 0, "image is empty");
  return img;
}

Image read_image_linear(const std::string& path) {
  const std::string e = lower_extension(path);
  if (e == ".exr") return read_exr(path);
  if (e == ".pfm") return read_pfm(path);
  Image img;
  if (e == ".hdr") {
    img = read_hdr(path);
  } else {
    if (!is_image8_extension(e))
      throw InputError(path, 0,
                       "unsupported image format '" + e + "' (supported: .exr, .hdr, .pfm, .png, .jpg, .tga, .bmp)");
    const Image8 ldr = read_image8(path);
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
