#pragma once
// BRIEF-256 binary descriptors (Calonder et al., ECCV 2010) of keyframe features, for place
// recognition. 256 intensity comparisons between point pairs of a 31x31 patch, each point the
// 5x5 box mean around it (from an integral image, so noise does not flip bits). The pairs are
// drawn once from an isotropic Gaussian (sigma = 31/5 px, Calonder's G II) with a fixed seed,
// by integer arithmetic only: every build and architecture has the same pattern, so descriptors,
// vocabularies and map files agree across the fleet. Not rotated: a multirotor's roll stays small,
// and keyframes that see the same place from a very different roll are not expected to match
// (VINS-Mono makes the same choice).
//
// The describer owns its integral image (sized to the largest image at start-up); describing a
// keyframe allocates nothing.

#include <array>
#include <cstdint>
#include <memory>

#include "core/common/image_view.hpp"

namespace ums::loop {

using Descriptor = std::array<std::uint64_t, 4>;  // 256 bits

int hamming(const Descriptor& a, const Descriptor& b);

class BriefDescriber {
 public:
  static constexpr int kPatchRadius = 15;  // px, pairs within +-15
  static constexpr int kBoxRadius = 2;     // px, 5x5 box around each point
  static constexpr int kBorder = kPatchRadius + kBoxRadius + 1;

  // max_width x max_height: the largest image set_image() will be given.
  BriefDescriber(int max_width, int max_height);
  ~BriefDescriber();
  BriefDescriber(const BriefDescriber&) = delete;
  BriefDescriber& operator=(const BriefDescriber&) = delete;

  // Builds the integral image; false when the image is larger than the capacity or invalid.
  bool set_image(const ImageView& image);
  // The descriptor at (x_px, y_px) (rounded) of the last image; false within kBorder of an edge.
  bool describe(float x_px, float y_px, Descriptor* out) const;

  // The test pattern: pair i compares (x0, y0) with (x1, y1), offsets in px.
  struct Pair {
    std::int8_t x0, y0, x1, y1;
  };
  const Pair& pair(int i) const { return pattern_[i]; }

 private:
  int box_sum(int x, int y) const;

  int max_width_, max_height_;
  int width_ = 0, height_ = 0;
  std::unique_ptr<std::uint32_t[]> integral_;  // (width + 1) x (height + 1)
  Pair pattern_[256];
};

}  // namespace ums::loop
