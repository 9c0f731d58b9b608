#include "core/frontend/keyframe_selector.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ums {

void KeyframeOptions::validate() const {
  auto fail = [](const char* field, double v) {
    throw std::invalid_argument(std::string("KeyframeOptions.") + field + " out of range: " + std::to_string(v));
  };
  if (!(max_interval_s > 0.0)) fail("max_interval_s", max_interval_s);
  if (!(min_parallax_px > 0.0f)) fail("min_parallax_px", static_cast<double>(min_parallax_px));
  if (!(focal_px > 0.0f)) fail("focal_px", static_cast<double>(focal_px));
  if (min_depth_features < 0) fail("min_depth_features", min_depth_features);
  if (min_shared_features < 0) fail("min_shared_features", min_shared_features);
}

KeyframeSelector::KeyframeSelector(const KeyframeOptions& options) : options_(options) { options_.validate(); }

KeyframeDecision KeyframeSelector::update(const FrameFeatures& frame, int n_2d_with_depth) {
  KeyframeDecision d;
  if (!has_keyframe_) {
    d.reasons |= kKeyframeFirst;
  } else {
    d.since_last_s = static_cast<double>(frame.t_ns - last_t_ns_) * 1e-9;
    if (d.since_last_s > options_.max_interval_s) d.reasons |= kKeyframeInterval;
    double sum = 0.0;
    int shared = 0;
    for (const FeatureObservation& o : frame.features) {
      const Entry* lo = entries_;
      const Entry* hi = entries_ + n_entries_;
      const Entry* e = std::lower_bound(lo, hi, o.id, [](const Entry& a, std::uint32_t id) { return a.id < id; });
      if (e == hi || e->id != o.id) continue;
      // A feature that switched camera (cannot happen today) would compare different images.
      if (o.has_left() != (e->cls != FeatureClass::k2DRight)) continue;
      sum += static_cast<double>((reference_xy(o) - e->xy).norm());
      ++shared;
    }
    d.shared_features = shared;
    d.mean_parallax_px = shared > 0 ? static_cast<float>(sum / shared) * options_.focal_px : 0.0f;
    if (shared < options_.min_shared_features) d.reasons |= kKeyframeFewShared;
    if (shared > 0 && d.mean_parallax_px > options_.min_parallax_px) d.reasons |= kKeyframeParallax;
  }
  if (frame.n_3d + n_2d_with_depth < options_.min_depth_features) d.reasons |= kKeyframeFewDepthFeatures;
  d.is_keyframe = d.reasons != kKeyframeNone;
  if (d.is_keyframe) {
    has_keyframe_ = true;
    last_t_ns_ = frame.t_ns;
    n_entries_ = 0;
    for (const FeatureObservation& o : frame.features) {
      if (n_entries_ == capacity::kMaxFeaturesPerCamera) break;
      entries_[n_entries_++] = Entry{o.id, o.cls, reference_xy(o)};
    }
    std::sort(entries_, entries_ + n_entries_, [](const Entry& a, const Entry& b) { return a.id < b.id; });
  }
  return d;
}

}  // namespace ums
