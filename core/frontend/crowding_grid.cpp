#include "core/frontend/crowding_grid.hpp"

#include <algorithm>
#include <cmath>

#include "core/frontend/pixel_disk.hpp"

namespace ums {

void CrowdingGrid::reset(int width, int height, float radius_px) {
  width_ = std::clamp(width, 0, capacity::kMaxImageWidth);
  height_ = std::clamp(height, 0, capacity::kMaxImageHeight);
  radius_px_ = radius_px;
  // Wider than the radius: a test's centres lie within r of it, so it reads at most 3 x 3 cells.
  const int cell = std::max(kMinCellPx, static_cast<int>(std::ceil(radius_px)) + 2);
  cell_px_ = static_cast<float>(cell);
  cols_ = std::min(kMaxCols, width_ / cell + 1);
  rows_ = std::min(kMaxRows, height_ / cell + 1);
  std::fill(head_, head_ + cols_ * rows_, std::int16_t{-1});
  count_ = 0;
}

// floor(x / cell), clamped to the grid: monotonic in x, so a range of x maps to a range of cells
// holding every centre inside it (centres off the image fall into the edge cells).
int CrowdingGrid::cell_col(float x_px) const {
  const float c = std::floor(x_px / cell_px_);
  return c < 0.0f ? 0 : (c >= static_cast<float>(cols_) ? cols_ - 1 : static_cast<int>(c));
}

int CrowdingGrid::cell_row(float y_px) const {
  const float c = std::floor(y_px / cell_px_);
  return c < 0.0f ? 0 : (c >= static_cast<float>(rows_) ? rows_ - 1 : static_cast<int>(c));
}

bool CrowdingGrid::add(const Eigen::Vector2f& center_px) {
  if (!std::isfinite(center_px.x()) || !std::isfinite(center_px.y())) return true;
  if (count_ >= kMaxDisks) return false;
  const int cell = cell_row(center_px.y()) * cols_ + cell_col(center_px.x());
  center_[count_] = center_px;
  next_[count_] = head_[cell];
  head_[cell] = static_cast<std::int16_t>(count_);
  ++count_;
  return true;
}

bool CrowdingGrid::is_free(const Eigen::Vector2f& p_px) const {
  const int x = static_cast<int>(std::lround(p_px.x())), y = static_cast<int>(std::lround(p_px.y()));
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return false;
  // A disk covering (x, y) has its centre within r of it; one pixel more absorbs the rounding of
  // x - r and y + r in float.
  const float fx = static_cast<float>(x), fy = static_cast<float>(y), reach = radius_px_ + 1.0f;
  const int c0 = cell_col(fx - reach), c1 = cell_col(fx + reach);
  const int r0 = cell_row(fy - reach), r1 = cell_row(fy + reach);
  for (int row = r0; row <= r1; ++row) {
    for (int col = c0; col <= c1; ++col) {
      for (int k = head_[row * cols_ + col]; k >= 0; k = next_[k])
        if (disk_covers(center_[k], radius_px_, x, y)) return false;
    }
  }
  return true;
}

}  // namespace ums
