// The film on the host: per-pixel sums in double (value and square, so each
// pixel's sample variance is known), and the count of samples that were
// discarded for being non-finite.
#pragma once

#include <cstdint>
#include <vector>

#include "luz/math/vec.h"

namespace luz {

// One pixel's running sums, kept in registers while its samples are taken.
struct PixelSums {
  double sum[3] = {0, 0, 0}, sum_sq[3] = {0, 0, 0};
  uint32_t count = 0;
  void add(Color c) {
    for (int k = 0; k < 3; ++k) {
      sum[k] += c[k];
      sum_sq[k] += double(c[k]) * c[k];
    }
    ++count;
  }
};

// Pixels [x0, x1) × [y0, y1) of an image.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
  uint64_t pixels() const { return uint64_t(width()) * uint64_t(height()); }
};

struct Film {
  int width = 0, height = 0;
  std::vector<double> sum, sum_sq;  // 3 per pixel
  std::vector<uint32_t> count;      // samples per pixel (finite ones)
  // Pixel i holds samples [0, next[i]) when the film was rendered by blocks
  // that stopped at different samples (render/units.h); empty: every pixel
  // holds the same range, which the render that made the film knows.
  std::vector<uint32_t> next;

  Film() = default;
  Film(int w, int h) : width(w), height(h), sum(size_t(w) * h * 3), sum_sq(size_t(w) * h * 3), count(size_t(w) * h) {}

  void add(int x, int y, Color c) {
    size_t i = size_t(y) * width + x;
    for (int k = 0; k < 3; ++k) {
      sum[3 * i + k] += c[k];
      sum_sq[3 * i + k] += double(c[k]) * c[k];
    }
    ++count[i];
  }

  void add(int x, int y, const PixelSums& p) {
    size_t i = size_t(y) * width + x;
    for (int k = 0; k < 3; ++k) {
      sum[3 * i + k] += p.sum[k];
      sum_sq[3 * i + k] += p.sum_sq[k];
    }
    count[i] += p.count;
  }

  // Pixel i's sums, to continue adding samples onto them, and back.
  PixelSums pixel(size_t i) const {
    PixelSums p;
    for (int k = 0; k < 3; ++k) {
      p.sum[k] = sum[3 * i + k];
      p.sum_sq[k] = sum_sq[3 * i + k];
    }
    p.count = count[i];
    return p;
  }
  void set(size_t i, const PixelSums& p) {
    for (int k = 0; k < 3; ++k) {
      sum[3 * i + k] = p.sum[k];
      sum_sq[3 * i + k] = p.sum_sq[k];
    }
    count[i] = p.count;
  }

  // The pixels of `r` as a film of its size, and back.
  Film crop(const PixelRect& r) const {
    Film f(r.width(), r.height());
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x) f.set(size_t(y - r.y0) * f.width + (x - r.x0), pixel(size_t(y) * width + x));
    return f;
  }
  void paste(const PixelRect& r, const Film& f) {
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x) set(size_t(y) * width + x, f.pixel(size_t(y - r.y0) * f.width + (x - r.x0)));
  }

  // Mean per pixel, RGB interleaved, rows top to bottom.
  std::vector<float> mean() const {
    std::vector<float> out(sum.size());
    for (size_t i = 0; i < count.size(); ++i)
      for (int k = 0; k < 3; ++k) out[3 * i + k] = count[i] ? float(sum[3 * i + k] / count[i]) : 0.f;
    return out;
  }

  // Variance of the pixel mean (sample variance / n), RGB interleaved.
  std::vector<double> variance_of_mean() const {
    std::vector<double> out(sum.size());
    for (size_t i = 0; i < count.size(); ++i) {
      double n = count[i];
      for (int k = 0; k < 3; ++k) {
        if (n < 2) {
          out[3 * i + k] = 0;
          continue;
        }
        double m = sum[3 * i + k] / n;
        double var = (sum_sq[3 * i + k] - n * m * m) / (n - 1);
        out[3 * i + k] = (var > 0 ? var : 0) / n;
      }
    }
    return out;
  }
};

}  // namespace luz
