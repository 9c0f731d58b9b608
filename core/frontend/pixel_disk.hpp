#pragma once
// The pixels a minimum-distance disk covers: integer pixel (x, y) with y in
// [ceil(c_y - r), floor(c_y + r)] and, in that row, x in [ceil(c_x - dx), floor(c_x + dx)],
// dx = sqrt(max(0, r^2 - (y - c_y)^2)), all in float. The detector's mask (block_disk) and the
// front end's crowding test (CrowdingGrid) both take it from here, so they cover the same pixels
// bit for bit: a track the mask would drop, the grid drops.

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

namespace ums {

inline int disk_first_row(const Eigen::Vector2f& c_px, float r_px) { return static_cast<int>(std::ceil(c_px.y() - r_px)); }
inline int disk_last_row(const Eigen::Vector2f& c_px, float r_px) { return static_cast<int>(std::floor(c_px.y() + r_px)); }

// Columns [*x_first, *x_last] the disk covers in row y (none when *x_last < *x_first), unclamped.
inline void disk_row_span(const Eigen::Vector2f& c_px, float r_px, int y, int* x_first, int* x_last) {
  const float dy = static_cast<float>(y) - c_px.y();
  const float dx = std::sqrt(std::max(0.0f, r_px * r_px - dy * dy));
  *x_first = static_cast<int>(std::ceil(c_px.x() - dx));
  *x_last = static_cast<int>(std::floor(c_px.x() + dx));
}

inline bool disk_covers(const Eigen::Vector2f& c_px, float r_px, int x, int y) {
  if (y < disk_first_row(c_px, r_px) || y > disk_last_row(c_px, r_px)) return false;
  int x_first = 0, x_last = 0;
  disk_row_span(c_px, r_px, y, &x_first, &x_last);
  return x >= x_first && x <= x_last;
}

}  // namespace ums
