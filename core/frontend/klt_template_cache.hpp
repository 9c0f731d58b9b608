#pragma once
// Storage for klt_track's templates of points, kept between calls (klt_tracker.hpp). A track
// samples, per pyramid level, the window around its starting point and the window's gradients
// before it iterates. The front end starts three tracks from each left feature's position in the
// same left image: the backward check of the temporal track, the stereo match, and the next
// frame's temporal track. With a slot per feature they sample that template once.
//
// A slot holds one point of one pyramid build: the key (the pyramid's address and build count,
// the level-0 position, bit for bit) and, per level, a block of 16-bit units that klt_track fills the
// first time a call needs that level and reads afterwards. A call whose key differs from the
// slot's re-keys it and fills the levels again, so a wrong slot costs time, never a different
// result (but on sparse levels, whose texture test differs with and without a cache:
// klt_tracker.hpp), as long as the pyramids outlive the cache (a new pyramid at a dead one's address would
// start its build count again; the front end owns both for its lifetime). Storage is allocated at
// construction; nothing per frame.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/frontend/image_pyramid.hpp"

namespace ums {

class KltTemplateCache {
 public:
  // Start-up: `slots` points, levels 0 .. levels-1 of each (coarser levels are not kept), blocks
  // of units_per_level 16-bit units (klt_template_units(window_px)). Throws std::invalid_argument
  // on a count below 1.
  KltTemplateCache(int slots, int levels, int units_per_level);

  int slots() const { return slots_; }
  int levels() const { return levels_; }

  // The block of `level` for point p of pyramid in slot s; the slot is re-keyed to (pyramid, p)
  // first when it holds another point. *filled: the block already holds that level. nullptr
  // when s or level is outside the cache.
  std::int16_t* block(int s, const ImagePyramid& pyramid, const Eigen::Vector2f& p, int level, bool* filled);
  // The block returned for (s, level) now holds that level.
  void mark_filled(int s, int level) { keys_[static_cast<std::size_t>(s)].filled |= 1u << level; }

 private:
  struct Key {
    const ImagePyramid* pyramid = nullptr;
    std::uint64_t generation = 0;
    float x = 0.0f, y = 0.0f;
    std::uint32_t filled = 0;  // bit per level
  };
  int slots_ = 0, levels_ = 0, units_per_level_ = 0;
  std::vector<Key> keys_;
  std::vector<std::int16_t> data_;
};

}  // namespace ums
