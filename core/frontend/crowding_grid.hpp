#pragma once
// The front end's crowding test without the detector's image mask: which tracks fall inside the
// minimum-distance disk (pixel_disk.hpp) of a track kept before them. The disks' centres sit in
// a coarse grid of cells at least the radius wide, so a test reads the few centres of the 3 x 3
// cells around it instead of the mask a disk per track would have to fill (about 50 rows each),
// and the mask is then only built in the frames that detect. The answers are the mask's, bit
// for bit: the same pixel rounding, the same disk pixels.
// Fixed storage, nothing allocated.

#include <cstdint>

#include <Eigen/Core>

#include "core/common/capacity.hpp"

namespace ums {

class CrowdingGrid {
 public:
  static constexpr int kCapacity = static_cast<int>(capacity::kMaxFeaturesPerCamera);  // disks
  // Empties the grid for a width x height image and disks of radius_px (the detector's
  // min_distance_px, 1..200 px). Image sizes up to the capacity's.
  void reset(int width, int height, float radius_px);

  // What CornerDetector::is_free would say after block_disk of every added centre: p rounded to
  // the nearest pixel is inside the image and no added disk covers it.
  bool is_free(const Eigen::Vector2f& p_px) const;

  // Adds a disk at center_px (a finite point; non-finite ones are ignored, as block_disk does).
  // At most kCapacity disks; false (not added) beyond.
  bool add(const Eigen::Vector2f& center_px);

  int size() const { return count_; }

 private:
  static constexpr int kMinCellPx = 16;
  static constexpr int kMaxCols = capacity::kMaxImageWidth / kMinCellPx + 1;
  static constexpr int kMaxRows = capacity::kMaxImageHeight / kMinCellPx + 1;
  static constexpr int kMaxDisks = kCapacity;
  static_assert(kMaxDisks <= 32767, "disk indices are int16");

  int cell_col(float x_px) const;
  int cell_row(float y_px) const;

  int width_ = 0, height_ = 0;
  float radius_px_ = 0.0f;
  float cell_px_ = float(kMinCellPx);
  int cols_ = 0, rows_ = 0;
  int count_ = 0;
  std::int16_t head_[kMaxCols * kMaxRows] = {};  // first centre of each cell, -1: none
  std::int16_t next_[kMaxDisks] = {};            // the next centre in the same cell, -1: none
  Eigen::Vector2f center_[kMaxDisks];
};

}  // namespace ums
