#pragma once
// Test-only synthetic images with exactly known geometry.
//  - BlobTexture: a field of isotropic Gaussian blobs rendered analytically (no resampling), so
//    an image of the field after a similarity transform (rotation, scale 1, sub-pixel shift) is
//    rendered exactly and every point's true position in the second image is known.
//  - render_checkerboard: an anti-aliased checkerboard whose X-corners sit at known sub-pixel
//    positions.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/common/image_view.hpp"

namespace ums::test {

struct GreyImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;
  GreyImage(int w, int h, std::uint8_t fill = 0) : width(w), height(h), pixels(static_cast<std::size_t>(w) * h, fill) {}
  ImageView view() const { return ImageView{pixels.data(), width, height, width}; }
  std::uint8_t& at(int x, int y) { return pixels[static_cast<std::size_t>(y) * width + x]; }
};

// Uniform random grey levels (xorshift32 from seed): every pixel value, no structure.
inline GreyImage random_image(int w, int h, std::uint32_t seed) {
  GreyImage img(w, h);
  std::uint32_t s = seed;
  for (auto& p : img.pixels) {
    s ^= s << 13;
    s ^= s >> 17;
    s ^= s << 5;
    p = static_cast<std::uint8_t>(s >> 24);
  }
  return img;
}

struct Blob {
  Eigen::Vector2d c;
  double sigma;
  double amp;
};

class BlobTexture {
 public:
  // Deterministic pseudo-random blobs over a region somewhat larger than the image.
  BlobTexture(int width, int height, int count, std::uint32_t seed) {
    std::uint32_t s = seed;
    auto rnd = [&s]() {
      s ^= s << 13;
      s ^= s >> 17;
      s ^= s << 5;
      return static_cast<double>(s % 1000003u) / 1000003.0;
    };
    for (int i = 0; i < count; ++i) {
      Blob b;
      b.c = Eigen::Vector2d(-60.0 + rnd() * (width + 120.0), -60.0 + rnd() * (height + 120.0));
      // Log-uniform scales 2..24 px: structure at every pyramid level, like real scenes.
      b.sigma = 2.0 * std::exp(rnd() * std::log(12.0));
      b.amp = (rnd() < 0.5 ? -1.0 : 1.0) * (40.0 + 60.0 * rnd());
      blobs_.push_back(b);
    }
  }

  // The same field made periodic along x with period_px: every blob repeated at multiples of the
  // period over the region (a fence, a tiled wall: a row where every patch has look-alikes).
  static BlobTexture periodic_x(int width, int height, int count_per_period, double period_px, std::uint32_t seed) {
    BlobTexture base(static_cast<int>(period_px) - 120, height, count_per_period, seed);
    BlobTexture out = base;
    out.blobs_.clear();
    for (const Blob& b : base.blobs_)
      for (double x = b.c.x() - period_px * std::ceil(200.0 / period_px); x < width + 200.0; x += period_px)
        out.blobs_.push_back(Blob{Eigen::Vector2d(x, b.c.y()), b.sigma, b.amp});
    return out;
  }

  // Renders the field after x' = R(angle) (x - pivot) + pivot + shift.
  GreyImage render(int width, int height, double angle_rad = 0.0, Eigen::Vector2d shift = Eigen::Vector2d::Zero(),
                   Eigen::Vector2d pivot = Eigen::Vector2d::Zero()) const {
    std::vector<double> acc(static_cast<std::size_t>(width) * height, 128.0);
    for (const Blob& b : blobs_) {
      const Eigen::Vector2d c = transform(b.c, angle_rad, shift, pivot);
      const double r = 3.0 * b.sigma;
      const int x0 = std::max(0, static_cast<int>(std::floor(c.x() - r)));
      const int x1 = std::min(width - 1, static_cast<int>(std::ceil(c.x() + r)));
      const int y0 = std::max(0, static_cast<int>(std::floor(c.y() - r)));
      const int y1 = std::min(height - 1, static_cast<int>(std::ceil(c.y() + r)));
      if (x1 < x0 || y1 < y0) continue;
      // The isotropic Gaussian is separable: exp(k(dx^2 + dy^2)) = exp(k dx^2) exp(k dy^2).
      const double k = -0.5 / (b.sigma * b.sigma);
      wx_.resize(static_cast<std::size_t>(x1 - x0 + 1));
      for (int x = x0; x <= x1; ++x) wx_[static_cast<std::size_t>(x - x0)] = std::exp(k * (x - c.x()) * (x - c.x()));
      for (int y = y0; y <= y1; ++y) {
        const double wy = b.amp * std::exp(k * (y - c.y()) * (y - c.y()));
        double* row = acc.data() + static_cast<std::size_t>(y) * width;
        for (int x = x0; x <= x1; ++x) row[x] += wy * wx_[static_cast<std::size_t>(x - x0)];
      }
    }
    GreyImage img(width, height);
    for (std::size_t i = 0; i < acc.size(); ++i) {
      img.pixels[i] = static_cast<std::uint8_t>(std::clamp(std::lround(acc[i]), 0L, 255L));
    }
    return img;
  }

  static Eigen::Vector2d transform(const Eigen::Vector2d& p, double angle_rad, const Eigen::Vector2d& shift,
                                   const Eigen::Vector2d& pivot) {
    const double c = std::cos(angle_rad), s = std::sin(angle_rad);
    const Eigen::Vector2d d = p - pivot;
    return Eigen::Vector2d(c * d.x() - s * d.y(), s * d.x() + c * d.y()) + pivot + shift;
  }

 private:
  std::vector<Blob> blobs_;
  mutable std::vector<double> wx_;  // scratch row of the separable kernel
};

// Checkerboard of square_px squares with a corner at origin (sub-pixel), 8x8 supersampled.
inline GreyImage render_checkerboard(int width, int height, double square_px, Eigen::Vector2d origin) {
  GreyImage img(width, height);
  constexpr int kSs = 8;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      int on = 0;
      for (int j = 0; j < kSs; ++j) {
        for (int i = 0; i < kSs; ++i) {
          // Pixel (x, y) covers [x - 0.5, x + 0.5]: its centre is the integer coordinate.
          const double px = x - 0.5 + (i + 0.5) / kSs - origin.x();
          const double py = y - 0.5 + (j + 0.5) / kSs - origin.y();
          const long cx = static_cast<long>(std::floor(px / square_px));
          const long cy = static_cast<long>(std::floor(py / square_px));
          on += ((cx + cy) & 1) == 0 ? 1 : 0;
        }
      }
      img.at(x, y) = static_cast<std::uint8_t>(std::lround(40.0 + 170.0 * on / (kSs * kSs)));
    }
  }
  return img;
}

}  // namespace ums::test
