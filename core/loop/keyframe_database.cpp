#include "core/loop/keyframe_database.hpp"

#include <cmath>
#include <limits>

#include "core/math/quaternion.hpp"

namespace ums::loop {

namespace {

// Distance of two keyframes for decimation: metres plus yaw at 1 m per 10 degrees (a keyframe
// that turned the view is worth keeping even when the vehicle hovers).
double spacing(const KeyframeRecord& a, const KeyframeRecord& b) {
  const double dp_m = (a.T_odom_b.translation() - b.T_odom_b.translation()).norm();
  double dyaw = std::abs(quat::yaw(a.T_odom_b.linear()) - quat::yaw(b.T_odom_b.linear()));
  if (dyaw > M_PI) dyaw = 2.0 * M_PI - dyaw;
  return dp_m + dyaw * (180.0 / M_PI) / 10.0;
}

}  // namespace

KeyframeDatabase::KeyframeDatabase(int protected_recent)
    : protected_recent_(protected_recent),
      records_(new KeyframeRecord[capacity::kMaxKeyframes]),
      free_(new std::uint32_t[capacity::kMaxKeyframes]) {
  for (std::size_t i = 0; i < capacity::kMaxKeyframes; ++i) {
    free_[i] = static_cast<std::uint32_t>(capacity::kMaxKeyframes - 1 - i);
  }
  n_free_ = capacity::kMaxKeyframes;
}

Status KeyframeDatabase::reserve(std::uint32_t* slot) {
  if (n_free_ == 0) return Status::kFull;
  *slot = free_[n_free_ - 1];
  KeyframeRecord& r = records_[*slot];
  r.id = kNoFrame;
  r.odometry_epoch = kMapEpoch;
  r.loops = 0;
  r.indexed = false;
  r.features.clear();
  r.bow.clear();
  r.prev = r.next = -1;
  return Status::kOk;
}

void KeyframeDatabase::commit(std::uint32_t slot) {
  UMS_ASSERT(n_free_ > 0 && free_[n_free_ - 1] == slot);
  --n_free_;
  ++size_;
  KeyframeRecord& r = records_[slot];
  r.prev = tail_;
  r.next = -1;
  if (tail_ >= 0) records_[tail_].next = static_cast<std::int32_t>(slot);
  tail_ = static_cast<std::int32_t>(slot);
  if (head_ < 0) head_ = tail_;
}

std::int32_t KeyframeDatabase::pick_for_decimation() const {
  // Walk back past the protected newest ones, then pick the smallest spacing to the predecessor.
  std::int32_t s = tail_;
  for (int i = 0; i < protected_recent_ && s >= 0; ++i) s = records_[s].prev;
  std::int32_t best = -1;
  double best_spacing = std::numeric_limits<double>::infinity();
  for (; s >= 0; s = records_[s].prev) {
    const KeyframeRecord& r = records_[s];
    if (r.loops > 0 || r.prev < 0) continue;  // loop ends and the anchor stay
    if (records_[r.prev].session != r.session) continue;  // a session's first keyframe stays
    const double d = spacing(r, records_[r.prev]);
    if (d < best_spacing) {
      best_spacing = d;
      best = s;
    }
  }
  return best;
}

void KeyframeDatabase::remove(std::uint32_t slot) {
  KeyframeRecord& r = records_[slot];
  if (r.prev >= 0) records_[r.prev].next = r.next; else head_ = r.next;
  if (r.next >= 0) records_[r.next].prev = r.prev; else tail_ = r.prev;
  r.prev = r.next = -1;
  r.id = kNoFrame;
  free_[n_free_++] = slot;
  --size_;
}

std::size_t KeyframeDatabase::footprint_bytes() const {
  return capacity::kMaxKeyframes * (sizeof(KeyframeRecord) + sizeof(std::uint32_t));
}

}  // namespace ums::loop
