#pragma once
// An image pyramid over buffers allocated once at construction. build() copies level 0 (the
// source owns its pixels only until the next frame) and fills each coarser level by a separable
// [1 4 6 4 1]/16 blur and 2x decimation, so the previous frame's pyramid stays valid while the
// next one is built into a second instance (the front end swaps two pyramids per camera).

#include <cstdint>
#include <vector>

#include "core/common/capacity.hpp"
#include "core/common/image_view.hpp"
#include "core/common/status.hpp"

namespace ums {

class ImagePyramid {
 public:
  // Allocates every level for a width x height image (start-up only), each with margin_px
  // repeated edge pixels around it (ImageView::margin; 0 .. capacity::kPyramidMarginPx). Throws
  // std::runtime_error when the size, level count or margin exceeds the capacities in
  // core/common/capacity.hpp.
  ImagePyramid(int width, int height, int levels, int margin_px = capacity::kPyramidMarginPx);

  // Copies image into level 0 and rebuilds the coarser levels, then every level's margin.
  // kInvalidInput when the image size differs from the constructed one. Allocates nothing.
  Status build(const ImageView& image);

  int levels() const { return levels_; }
  const ImageView& level(int i) const { return views_[static_cast<std::size_t>(i)]; }
  // Counts the successful builds: with the object's address it names the images the pyramid
  // holds (KltTemplateCache keys its templates by both).
  std::uint64_t generation() const { return generation_; }

 private:
  int levels_ = 0;
  std::uint64_t generation_ = 0;
  std::vector<std::uint8_t> storage_;          // all levels, each with its margin
  std::vector<std::uint16_t> row_tmp_;         // horizontal pass of one output row (x5 rows)
  ImageView views_[capacity::kMaxPyramidLevels];
};

}  // namespace ums
