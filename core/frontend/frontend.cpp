#include "core/frontend/frontend.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ums {

namespace {

Eigen::Matrix3f skew(const Eigen::Vector3f& v) {
  Eigen::Matrix3f S;
  S << 0.0f, -v.z(), v.y(), v.z(), 0.0f, -v.x(), -v.y(), v.x(), 0.0f;
  return S;
}

const Eigen::Vector2f kNan2(std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::quiet_NaN());
const Eigen::Vector3f kNan3(std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::quiet_NaN());

// Depths (m) of the extra stereo starting points tried for new features.
constexpr int kStereoDepthHypotheses = 3;
constexpr float kStereoDepthsM[kStereoDepthHypotheses] = {2.0f, 1.0f, 0.5f};

}  // namespace

// Charges the time since the previous lap (or construction) to one stage field. When off it
// never reads the clock, so measure_stages = false costs nothing but a branch per stage.
class Frontend::StageClock {
 public:
  explicit StageClock(bool on) : on_(on) {
    if (on_) last_ = std::chrono::steady_clock::now();
  }
  void lap(float* stage_ms) {
    if (!on_) return;
    const std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now();
    *stage_ms += std::chrono::duration<float, std::milli>(now - last_).count();
    last_ = now;
  }

 private:
  bool on_;
  std::chrono::steady_clock::time_point last_{};
};

void FrontendOptions::validate() const {
  auto fail = [](const char* field, double v) {
    throw std::invalid_argument(std::string("FrontendOptions.") + field + " out of range: " + std::to_string(v));
  };
  if (max_cnt < 1 || max_cnt > static_cast<int>(capacity::kMaxFeaturesPerCamera)) fail("max_cnt", max_cnt);
  if (levels_2d < 1 || levels_2d > capacity::kMaxPyramidLevels) fail("levels_2d", levels_2d);
  if (levels_3d < 1 || levels_3d > levels_2d) fail("levels_3d", levels_3d);
  if (levels_stereo < 1 || levels_stereo > capacity::kMaxPyramidLevels) fail("levels_stereo", levels_stereo);
  if (levels_back < 1 || levels_back > capacity::kMaxPyramidLevels) fail("levels_back", levels_back);
  if (confirm_sparse_from_level < 0 || confirm_sparse_from_level > capacity::kMaxPyramidLevels) {
    fail("confirm_sparse_from_level", confirm_sparse_from_level);
  }
  if (stereo_retry_interval < 1 || stereo_retry_interval > 1000) fail("stereo_retry_interval", stereo_retry_interval);
  if (detect_min_missing < 1 || detect_min_missing > max_cnt) fail("detect_min_missing", detect_min_missing);
  if (detect_interval < 1 || detect_interval > 1000) fail("detect_interval", detect_interval);
  if (!(fb_max_px > 0.0f)) fail("fb_max_px", static_cast<double>(fb_max_px));
  if (!(stereo_fb_max_px > 0.0f)) fail("stereo_fb_max_px", static_cast<double>(stereo_fb_max_px));
  if (!(stereo_epipolar_max_px > 0.0f)) fail("stereo_epipolar_max_px", static_cast<double>(stereo_epipolar_max_px));
  klt.validate();
  detector.validate();
  ransac.validate();
}

Frontend::Frontend(const FrontendOptions& options, const RigCalibration& calib) : options_(options) {
  options_.validate();
  confirm_klt_ = options_.klt;
  confirm_klt_.sparse_from_level = options_.confirm_sparse_from_level;
  for (int c = 0; c < 2; ++c) {
    const CameraCalibration& cc = calib.cam[c];
    if (cc.width <= 0 || cc.height <= 0 || cc.width > capacity::kMaxImageWidth || cc.height > capacity::kMaxImageHeight ||
        !(cc.fx > 0.0) || !(cc.fy > 0.0)) {
      throw std::runtime_error("Frontend: calibration cam" + std::to_string(c) + " invalid (size " + std::to_string(cc.width) +
                               "x" + std::to_string(cc.height) + ", fx " + std::to_string(cc.fx) + ")");
    }
    cam_[c] = Camera::from_calibration(cc);
  }
  const Eigen::Isometry3d T_c1_c0 = calib.cam[1].T_b_c.inverse() * calib.cam[0].T_b_c;
  R_c1_c0_ = T_c1_c0.linear().cast<float>();
  t_c1_c0_ = T_c1_c0.translation().cast<float>();
  E_c1_c0_ = skew(t_c1_c0_.normalized()) * R_c1_c0_;
  const int levels = std::max({options_.levels_2d, options_.levels_3d, options_.levels_stereo});
  for (int k = 0; k < 2; ++k) {
    for (int c = 0; c < 2; ++c) pyr_[k][c] = std::make_unique<ImagePyramid>(cam_[c].width(), cam_[c].height(), levels);
  }
  // Levels 0 and 1 are kept: 3D features track on levels_3d = 2, and 95 % of the templates a
  // replay samples are at those levels (coarser ones come with the rarer 4-level tracks).
  constexpr int kCachedTemplateLevels = 2;
  templates_ = std::make_unique<KltTemplateCache>(2 * options_.max_cnt, std::min(levels, kCachedTemplateLevels),
                                                  klt_template_units(options_.klt.window_px));
  detector_ = std::make_unique<CornerDetector>(std::max(cam_[0].width(), cam_[1].width()),
                                               std::max(cam_[0].height(), cam_[1].height()));
  if (cam_[0].width() != cam_[1].width() || cam_[0].height() != cam_[1].height()) {
    throw std::runtime_error("Frontend: cam0 and cam1 must have the same image size");
  }
  rng_.state = options_.ransac.seed != 0 ? options_.ransac.seed : 0x2545F491u;
}

Frontend::~Frontend() = default;

void Frontend::reset() {
  left_.clear();
  right_.clear();
  has_prev_ = false;
  prev_right_valid_ = false;
  stereo_offset_px_.setZero();
}

float Frontend::stereo_epipolar_distance_px(const Eigen::Vector3f& bl, const Eigen::Vector3f& br) const {
  // Line l = E b_l in the cam1 z = 1 plane; distance of x_r = b_r / z_r to it.
  const Eigen::Vector3f l = E_c1_c0_ * bl;
  const float den = std::sqrt(l.x() * l.x() + l.y() * l.y());
  if (!(den > 1e-12f) || !(br.z() > 1e-6f)) return std::numeric_limits<float>::infinity();
  const Eigen::Vector3f xr = br / br.z();
  return std::abs(l.dot(xr)) / den * cam_[1].fx();
}

Eigen::Vector2f Frontend::predict(const Camera& cam, const Eigen::Matrix3f& R_curr_prev, const Eigen::Vector2f& uv) const {
  Eigen::Vector3f b;
  Eigen::Vector2f out;
  if (!cam.unproject(uv, &b) || !cam.project(R_curr_prev * b, &out) || !cam.in_image(out)) return uv;
  return out;
}

void Frontend::track_left(const Eigen::Matrix3f* R_curr_prev, FrontendFrameStats* st, StageClock* clock) {
  const ImagePyramid& prev = *pyr_[1 - cur_][0];
  const ImagePyramid& curr = *pyr_[cur_][0];
  std::size_t w = 0;
  for (std::size_t i = 0; i < left_.size(); ++i) {
    LeftTrack t = left_[i];
    const Eigen::Vector2f guess = R_curr_prev != nullptr ? predict(cam_[0], *R_curr_prev, t.uv) : t.uv;
    int levels = t.stereo ? options_.levels_3d : options_.levels_2d;
    Eigen::Vector2f p = guess;
    Status s = klt_track(prev, curr, levels, options_.klt, t.uv, &p, templates_.get(), t.slot);
    if (s != Status::kOk && t.stereo && options_.levels_2d > levels) {
      // The paper's split: 3D features try the cheap 2-level pyramid first, then all 4 levels.
      ++st->retried_3d;
      levels = options_.levels_2d;
      p = guess;
      s = klt_track(prev, curr, levels, options_.klt, t.uv, &p, templates_.get(), t.slot);
      if (s == Status::kOk) ++st->retried_3d_ok;
    }
    if (s != Status::kOk) {
      ++st->lost_klt;
      continue;
    }
    // The templates at p in this image go to this frame's slot w: the stereo match and the next
    // frame's forward track start from p too.
    const int slot = cur_ * options_.max_cnt + static_cast<int>(w);
    if (!confirmed(prev, curr, levels, t.uv, p, options_.fb_max_px, slot)) {
      ++st->lost_fb;
      continue;
    }
    Eigen::Vector3f b;
    if (!cam_[0].unproject(p, &b)) {
      ++st->lost_klt;
      continue;
    }
    b_prev_[w] = t.bearing;
    b_curr_[w] = b;
    t.slot = slot;
    t.right_guess = t.stereo ? Eigen::Vector2f(t.uv_right + (p - t.uv)) : kNan2;
    t.uv = p;
    t.bearing = b;
    left_[w++] = t;
  }
  left_.resize(w);
  st->tracked_left = static_cast<int>(w);
  clock->lap(&st->track_ms);
  if (options_.use_ransac && w >= 8) {
    int n_in = 0;
    if (ransac_essential(b_prev_, b_curr_, static_cast<int>(w), cam_[0].fx(), options_.ransac, &rng_, inlier_, &n_in) ==
        Status::kOk) {
      std::size_t k = 0;
      for (std::size_t i = 0; i < w; ++i) {
        if (inlier_[i] != 0) left_[k++] = left_[i];
      }
      st->lost_ransac += static_cast<int>(w - k);
      left_.resize(k);
    }
  }
  clock->lap(&st->ransac_ms);
}

void Frontend::track_right(const Eigen::Matrix3f* R_curr_prev, FrontendFrameStats* st, StageClock* clock) {
  const ImagePyramid& prev = *pyr_[1 - cur_][1];
  const ImagePyramid& curr = *pyr_[cur_][1];
  Eigen::Matrix3f R1;
  if (R_curr_prev != nullptr) R1 = R_c1_c0_ * (*R_curr_prev) * R_c1_c0_.transpose();
  const int levels = options_.levels_2d;
  std::size_t w = 0;
  for (std::size_t i = 0; i < right_.size(); ++i) {
    RightTrack t = right_[i];
    Eigen::Vector2f p = R_curr_prev != nullptr ? predict(cam_[1], R1, t.uv) : t.uv;
    if (klt_track(prev, curr, levels, options_.klt, t.uv, &p) != Status::kOk) {
      ++st->lost_klt;
      continue;
    }
    if (!confirmed(prev, curr, levels, t.uv, p, options_.fb_max_px)) {
      ++st->lost_fb;
      continue;
    }
    Eigen::Vector3f b;
    if (!cam_[1].unproject(p, &b)) {
      ++st->lost_klt;
      continue;
    }
    b_prev_[w] = t.bearing;
    b_curr_[w] = b;
    t.uv = p;
    t.bearing = b;
    right_[w++] = t;
  }
  right_.resize(w);
  st->tracked_right = static_cast<int>(w);
  clock->lap(&st->track_ms);
  if (options_.use_ransac && w >= 8) {
    int n_in = 0;
    if (ransac_essential(b_prev_, b_curr_, static_cast<int>(w), cam_[1].fx(), options_.ransac, &rng_, inlier_, &n_in) ==
        Status::kOk) {
      std::size_t k = 0;
      for (std::size_t i = 0; i < w; ++i) {
        if (inlier_[i] != 0) right_[k++] = right_[i];
      }
      st->lost_ransac += static_cast<int>(w - k);
      right_.resize(k);
    }
  }
  clock->lap(&st->ransac_ms);
}

void Frontend::thin_crowded(FrontendFrameStats* st) {
  // Longest tracks first (ties: older id first), each blocks a min_distance disk; a track that
  // falls inside an earlier disk is dropped, as VINS-Fusion's setMask does.
  const std::size_t n = left_.size();
  for (std::size_t i = 0; i < n; ++i) order_[i] = static_cast<std::uint16_t>(i);
  std::sort(order_, order_ + n, [this](std::uint16_t a, std::uint16_t b) {
    if (left_[a].length != left_[b].length) return left_[a].length > left_[b].length;
    return left_[a].id < left_[b].id;
  });
  // The grid answers as the detector's mask would; the mask itself is built in detect_left, only
  // in the frames that detect. Every track fits in it, so no disk is refused.
  static_assert(kCap <= static_cast<std::size_t>(CrowdingGrid::kCapacity), "a disk per left track");
  crowd_.reset(cam_[0].width(), cam_[0].height(), options_.detector.min_distance_px);
  for (std::size_t k = 0; k < n; ++k) {
    LeftTrack& t = left_[order_[k]];
    if (!crowd_.is_free(t.uv)) {
      t.length = 0;  // marks removal
      continue;
    }
    crowd_.add(t.uv);
  }
  std::size_t w = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (left_[i].length != 0) left_[w++] = left_[i];
  }
  st->lost_crowding += static_cast<int>(n - w);
  left_.resize(w);
}

bool Frontend::detection_due() const {
  if (!has_prev_ || frames_since_detection_ + 1 >= options_.detect_interval) return true;
  // A frame that lost most of its tracks (blur, occlusion) does not wait for the interval: it
  // would go to the estimator nearly empty.
  return 2 * static_cast<int>(left_.size() + right_.size()) < options_.max_cnt;
}

int Frontend::detection_budget(std::size_t tracks_in_camera) const {
  const int missing = options_.max_cnt - static_cast<int>(left_.size() + right_.size());
  if (missing < options_.detect_min_missing || !detection_due_) return 0;
  return std::max(0, std::min(missing, static_cast<int>(kCap - tracks_in_camera)));
}

void Frontend::detect_left(FrontendFrameStats* st) {
  const int budget = detection_budget(left_.size());
  if (budget == 0) return;
  detected_ = true;
  const std::size_t first_new = left_.size();
  // New corners keep min_distance from every track thin_crowded kept (all of left_ now).
  detector_->clear_mask();
  for (const LeftTrack& t : left_) detector_->block_disk(t.uv, options_.detector.min_distance_px);
  const int found = detector_->detect(pyr_[cur_][0]->level(0), budget, options_.detector, new_px_);
  for (int i = 0; i < found; ++i) {
    LeftTrack t;
    if (!cam_[0].unproject(new_px_[i], &t.bearing)) continue;
    t.id = next_id_++;
    t.length = 0;  // incremented with every observation in process()
    t.stereo = false;
    t.uv = new_px_[i];
    t.right_guess = kNan2;
    left_.push_back(t);
    ++st->new_left;
  }
  assign_template_slots(first_new);
}

void Frontend::assign_template_slots(std::size_t first_new) {
  const int base = cur_ * options_.max_cnt;
  std::fill(slot_used_, slot_used_ + options_.max_cnt, std::uint8_t{0});
  for (std::size_t i = 0; i < first_new; ++i) {
    const int k = left_[i].slot - base;
    if (k >= 0 && k < options_.max_cnt) slot_used_[k] = 1;
  }
  // left_ never holds more than max_cnt tracks (detection_budget): a free slot is always left.
  int k = 0;
  for (std::size_t i = first_new; i < left_.size(); ++i) {
    while (k < options_.max_cnt && slot_used_[k] != 0) ++k;
    left_[i].slot = k < options_.max_cnt ? base + k++ : -1;
  }
}

bool Frontend::confirmed(const ImagePyramid& from, const ImagePyramid& to, int levels, const Eigen::Vector2f& p_from,
                         const Eigen::Vector2f& p_to, float max_px, int slot) {
  Eigen::Vector2f back = p_from;
  return klt_track(to, from, std::min(levels, options_.levels_back), confirm_klt_, p_to, &back, templates_.get(),
                   slot) == Status::kOk &&
         !((back - p_from).squaredNorm() > max_px * max_px);
}

// New features (no match history) also try starting points along the epipolar line at finite
// depths: near points (the floor below the camera) have disparities far beyond what the pyramid
// recovers from the infinity guess. Older features keep their single guess. A feature matched in
// the previous frame starts next to its match: like temporal 3D tracking it uses levels_3d first
// and falls back to the full levels_stereo pyramid.
Frontend::StereoMatch Frontend::match_track(const LeftTrack& t, const Eigen::Vector2f& guess, bool had_match) {
  const ImagePyramid& L = *pyr_[cur_][0];
  const ImagePyramid& R = *pyr_[cur_][1];
  const int n_hyp = (t.length == 0) ? 1 + kStereoDepthHypotheses : (had_match ? 2 : 1);
  StereoMatch m;
  for (int h = 0; h < n_hyp; ++h) {
    Eigen::Vector2f start = guess;
    int levels = options_.levels_stereo;
    if (had_match) {
      levels = h == 0 ? std::min(options_.levels_3d, options_.levels_stereo) : options_.levels_stereo;
    } else if (h > 0 && !cam_[1].project(R_c1_c0_ * (t.bearing * kStereoDepthsM[h - 1]) + t_c1_c0_, &start)) {
      continue;
    }
    Eigen::Vector2f pr = start;
    if (klt_track(L, R, levels, options_.klt, t.uv, &pr, templates_.get(), t.slot) != Status::kOk) continue;
    // Only the first try of a continued match, on levels_3d from next to the previous match, may
    // skip the right->left check: the full-pyramid retry can travel far along the row.
    if (!(had_match && h == 0) || options_.stereo_confirm_tracked) {
      ++m.confirmations;
      if (!confirmed(L, R, levels, t.uv, pr, options_.stereo_fb_max_px)) continue;
    }
    Eigen::Vector3f br;
    if (!cam_[1].unproject(pr, &br)) continue;
    const float d = stereo_epipolar_distance_px(t.bearing, br);
    if (!(d <= options_.stereo_epipolar_max_px)) {
      m.epipolar_failed = true;
      continue;
    }
    m.matched = true;
    m.uv = pr;
    m.bearing = br;
    m.epipolar_px = d;
    return m;
  }
  return m;
}

void Frontend::match_stereo(FrontendFrameStats* st) {
  Eigen::Vector2f offset_sum = Eigen::Vector2f::Zero();
  int offset_n = 0;
  double sq_sum = 0.0;
  for (LeftTrack& t : left_) {
    // Starting point: the previous match moved with the left flow, else the point at infinity
    // (rotation only) shifted by the mean disparity of the last frame's matches.
    Eigen::Vector2f inf_px = t.uv;
    const bool inf_ok = cam_[1].project(R_c1_c0_ * t.bearing, &inf_px);
    // A 2D-left track whose match failed is retried only every stereo_retry_interval frames:
    // its failure (occlusion, no texture in the right view) rarely changes from one frame to
    // the next, and the retries were a quarter of the front end's time.
    if (t.stereo_failed && options_.stereo_retry_interval > 1 &&
        t.length % static_cast<std::uint32_t>(options_.stereo_retry_interval) != 0) {
      t.stereo_prev = false;
      t.right_guess = inf_ok ? Eigen::Vector2f(inf_px + stereo_offset_px_) : t.uv;
      continue;
    }
    ++st->stereo_attempts;
    Eigen::Vector2f guess = t.right_guess;
    t.stereo_prev = t.stereo;
    if (!std::isfinite(guess.x())) guess = inf_ok ? Eigen::Vector2f(inf_px + stereo_offset_px_) : t.uv;
    t.right_guess = guess;
    t.stereo = false;
    const bool had_match = t.stereo_prev;
    const StereoMatch m = match_track(t, guess, had_match);
    st->stereo_confirmations += m.confirmations;
    const bool matched = m.matched;
    t.stereo_failed = !matched;
    if (!matched) {
      ++(m.epipolar_failed ? st->stereo_rejected_epipolar : st->stereo_rejected_klt);
      continue;
    }
    t.stereo = true;
    t.uv_right = m.uv;
    t.bearing_right = m.bearing;
    sq_sum += static_cast<double>(m.epipolar_px) * static_cast<double>(m.epipolar_px);
    if (inf_ok) {
      offset_sum += m.uv - inf_px;
      ++offset_n;
    }
  }
  const int n3 = offset_n;
  if (n3 > 0) stereo_offset_px_ = offset_sum / static_cast<float>(n3);
  int n_stereo = 0;
  for (const LeftTrack& t : left_) n_stereo += t.stereo ? 1 : 0;
  st->stereo_epipolar_rms_px = n_stereo > 0 ? static_cast<float>(std::sqrt(sq_sum / n_stereo)) : 0.0f;
}

void Frontend::detect_right(FrontendFrameStats* st) {
  const int budget = detection_budget(right_.size());
  if (budget == 0) return;
  detected_ = true;
  // Cover the right image where left features are (3D: their match; 2D-left: where the match
  // was sought) and where 2D-right tracks already are.
  detector_->clear_mask();
  const float r = options_.detector.min_distance_px;
  for (const LeftTrack& t : left_) {
    if (t.stereo) {
      detector_->block_disk(t.uv_right, r);
    } else if (std::isfinite(t.right_guess.x())) {
      detector_->block_disk(t.right_guess, r);
    }
  }
  for (const RightTrack& t : right_) detector_->block_disk(t.uv, r);
  const int found = detector_->detect(pyr_[cur_][1]->level(0), budget, options_.detector, new_px_);
  for (int i = 0; i < found; ++i) {
    RightTrack t;
    if (!cam_[1].unproject(new_px_[i], &t.bearing)) continue;
    t.id = next_id_++;
    t.length = 0;
    t.uv = new_px_[i];
    right_.push_back(t);
    ++st->new_right;
  }
}

void Frontend::write_output(const StereoFrame& frame, FrameFeatures* out) const {
  out->t_ns = frame.t_ns;
  out->td_ns = frame.td_ns;
  out->seq = frame.seq;
  for (const LeftTrack& t : left_) {
    FeatureObservation o;
    o.id = t.id;
    o.track_length = t.length;
    o.cls = t.stereo ? FeatureClass::k3D : FeatureClass::k2DLeft;
    o.uv_left_px = t.uv;
    o.bearing_left = t.bearing;
    o.xy_left = t.bearing.head<2>() / t.bearing.z();
    if (t.stereo) {
      o.uv_right_px = t.uv_right;
      o.bearing_right = t.bearing_right;
      o.xy_right = t.bearing_right.head<2>() / t.bearing_right.z();
      ++out->n_3d;
    } else {
      o.uv_right_px = kNan2;
      o.bearing_right = kNan3;
      o.xy_right = kNan2;
      ++out->n_2d_left;
    }
    out->features.push_back(o);
  }
  for (const RightTrack& t : right_) {
    FeatureObservation o;
    o.id = t.id;
    o.track_length = t.length;
    o.cls = FeatureClass::k2DRight;
    o.uv_left_px = kNan2;
    o.bearing_left = kNan3;
    o.xy_left = kNan2;
    o.uv_right_px = t.uv;
    o.bearing_right = t.bearing;
    o.xy_right = t.bearing.head<2>() / t.bearing.z();
    ++out->n_2d_right;
    out->features.push_back(o);
  }
}

Status Frontend::process(const StereoFrame& frame, const Eigen::Quaterniond* q_c0prev_c0curr, FrameFeatures* out) {
  out->clear();
  if (!frame.left.valid() || frame.left.width != cam_[0].width() || frame.left.height != cam_[0].height()) {
    return Status::kInvalidInput;
  }
  const bool right_valid = frame.right.valid();
  if (right_valid && (frame.right.width != cam_[1].width() || frame.right.height != cam_[1].height())) {
    return Status::kInvalidInput;
  }
  FrontendFrameStats& st = out->stats;
  StageClock clock(options_.measure_stages);
  // Reseeding per frame from the frame index keeps results independent of earlier frames' draws.
  rng_.state = (options_.ransac.seed ^ static_cast<std::uint32_t>(frame.seq * 2654435761u)) | 1u;

  pyr_[cur_][0]->build(frame.left);
  if (right_valid) pyr_[cur_][1]->build(frame.right);
  clock.lap(&st.pyramid_ms);

  if (has_prev_) {
    Eigen::Matrix3f R_curr_prev;
    const Eigen::Matrix3f* R = nullptr;
    if (q_c0prev_c0curr != nullptr) {
      R_curr_prev = q_c0prev_c0curr->toRotationMatrix().cast<float>().transpose();
      R = &R_curr_prev;
    }
    track_left(R, &st, &clock);
    if (right_valid && prev_right_valid_) {
      track_right(R, &st, &clock);
    } else {
      right_.clear();
    }
  } else {
    left_.clear();
    right_.clear();
  }
  clock.lap(&st.track_ms);  // the clearing of the else branches; track_left/right lapped themselves
  detection_due_ = detection_due();
  detected_ = false;
  thin_crowded(&st);
  detect_left(&st);
  clock.lap(&st.detect_ms);
  if (right_valid) {
    match_stereo(&st);
    clock.lap(&st.stereo_ms);
    if (options_.detect_right) detect_right(&st);
    clock.lap(&st.detect_ms);
  } else {
    for (LeftTrack& t : left_) t.stereo = false;
  }
  for (LeftTrack& t : left_) ++t.length;
  for (RightTrack& t : right_) ++t.length;
  frames_since_detection_ = detected_ ? 0 : std::min(frames_since_detection_ + 1, options_.detect_interval);
  write_output(frame, out);

  prev_right_valid_ = right_valid;
  has_prev_ = true;
  cur_ = 1 - cur_;
  return Status::kOk;
}

}  // namespace ums
