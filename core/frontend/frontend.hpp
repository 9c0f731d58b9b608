#pragma once
// The visual front end (paper Sec. III-A.1): per stereo frame it
//  1. builds 4-level pyramids for both images into buffers allocated at construction;
//  2. tracks left features from the previous left image (3D features on levels 0-1, retried on
//     all 4 levels when that fails; 2D features on 4 levels) and 2D-right features in the right
//     image, starting from positions predicted by the IMU rotation when a hint is given, each
//     confirmed by a forward-backward check;
//  3. rejects temporal outliers per camera by RANSAC on the epipolar constraint;
//  4. thins crowded tracks (longest tracks win) and detects new sub-pixel Shi-Tomasi corners in
//     the left image up to the fixed total max_cnt;
//  5. matches every left feature into the right image (left->right KLT, right->left
//     confirmation, calibrated epipolar check: the pair need not be rectified) -> 3D or 2D-left;
//  6. detects 2D-right corners where no left feature covers the right image, with what is left
//     of max_cnt. In rich texture the left image fills the budget and most features are 3D; in
//     poor texture fewer left corners and stereo matches survive and the 2D share rises.
// Nothing is allocated after construction.

#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera/camera.hpp"
#include "core/common/calibration.hpp"
#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"
#include "core/common/status.hpp"
#include "core/common/stereo_frame.hpp"
#include "core/frontend/corner_detector.hpp"
#include "core/frontend/crowding_grid.hpp"
#include "core/frontend/epipolar_ransac.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/frontend/image_pyramid.hpp"
#include "core/frontend/klt_tracker.hpp"

namespace ums {

struct FrontendOptions {
  int max_cnt = 200;                   // features, fixed total of 3D + 2D-left + 2D-right
  int levels_2d = 4;                   // pyramid levels for 2D features (paper: four)
  int levels_3d = 2;                   // pyramid levels for 3D features (paper: two, retry on levels_2d)
  int levels_stereo = 4;               // pyramid levels for the left->right match
  // Pyramid levels of the backward (confirmation) tracks, temporal and stereo, at most the
  // forward track's. They start at the forward track's origin, so level 0 alone would confirm a
  // consistent match at 0.77x the front end's instructions; on the photo flights 1 and 2 levels
  // cost accuracy (docs/frontend.md, "Less work per frame"): the coarse levels see farther.
  int levels_back = 4;
  // klt.sparse_from_level for the confirmation tracks: they only test a match against fb_max_px
  // and the photometric check (their result is not kept), so they iterate on the sparse window on
  // every level by default: 6 % of the front end's instructions, and over 42 simulated flights
  // the mean ATE was lower, not higher (docs/frontend.md, "Sparse windows"). kMaxPyramidLevels:
  // whole windows.
  int confirm_sparse_from_level = 0;
  float fb_max_px = 0.5f;              // px, forward-backward disagreement allowed (temporal)
  float stereo_fb_max_px = 1.0f;       // px, right->left confirmation must land this close
  // A feature matched in the previous frame first tracks into the right image on levels_3d from
  // next to that match, and the match is then checked against its epipolar line; true: that match
  // is also confirmed right->left, as new matches and full-pyramid retries always are. Off by
  // default: over 28 simulated flights (7 x 2 seeds x 2 styles) the 1 s RPE did not move (+0.2 %
  // and +0.8 %, se 1.1 and 1.7 %) and the x86 front end fell 7.6 % (docs/performance.md, session 30).
  bool stereo_confirm_tracked = false;
  float stereo_epipolar_max_px = 1.5f; // px in cam1, distance of a 3D match to its epipolar line
  int stereo_retry_interval = 4;       // frames between stereo retries of a track whose match failed (1 = every frame)
  bool detect_right = true;            // add 2D-right features in uncovered right-image regions
  int detect_min_missing = 1;          // features: detect only when at least this many of max_cnt are
                                       // missing. A detection costs a corner response over the free area; 10
                                       // saved 11 % of the pipeline's CPU on the 7 simulated flights
                                       // and raised their mean ATE from 13.7 to 14.4 mm
                                       // (docs/frontend.md): a knob for slow boards, off by default
  // Frames: a top-up runs at most every this many frames (1: any). Every other frame halves the
  // detections; a track lost waits one frame at most for its replacement, which the drift did
  // not see over 28 simulated flights, unlike detect_min_missing's longer waits (aarch64 front end
  // on the clips -19 / -22 %; 1 s RPE -1.0 %, 10 s RPE +1.5 % (se 2.7), ATE +2.3 % (se 3.4):
  // docs/performance.md, session 31).
  int detect_interval = 2;
  bool use_ransac = true;              // temporal epipolar RANSAC per camera
  bool measure_stages = true;          // time the sub-stages into FrontendFrameStats::*_ms (two steady-clock reads per stage, ~11 per frame)
  KltOptions klt;
  DetectorOptions detector;
  RansacOptions ransac;

  void validate() const;  // throws std::invalid_argument naming the field and value
};

class Frontend {
 public:
  // Start-up: validates the options (std::invalid_argument) and the calibration (image sizes
  // within capacity, std::runtime_error), allocates pyramids, detector buffers and tracks.
  Frontend(const FrontendOptions& options, const RigCalibration& calibration);
  ~Frontend();
  Frontend(const Frontend&) = delete;
  Frontend& operator=(const Frontend&) = delete;

  // Processes one stereo frame. q_c0prev_c0curr (optional) is the rotation of cam0 at this
  // frame relative to cam0 at the previous frame (maps vectors from the current cam0 frame into
  // the previous one; Eigen stores x, y, z, w), e.g. from integrated gyro rates; it only moves
  // the KLT starting positions. A frame without a valid right image yields only 2D-left features
  // (2D-right tracks are dropped). Returns kInvalidInput when the left image is missing or a
  // size differs from the calibration (the tracker state is then unchanged). Allocates nothing.
  Status process(const StereoFrame& frame, const Eigen::Quaterniond* q_c0prev_c0curr, FrameFeatures* out);

  // Forgets every track (e.g. after a long gap); ids keep increasing.
  void reset();

  const FrontendOptions& options() const { return options_; }
  const Camera& camera(int i) const { return cam_[i]; }
  const Eigen::Matrix3f& R_c1_c0() const { return R_c1_c0_; }
  const Eigen::Vector3f& t_c1_c0() const { return t_c1_c0_; }  // m

  // Distance (px in cam1) of a stereo match to the epipolar line of its left bearing.
  float stereo_epipolar_distance_px(const Eigen::Vector3f& bearing_left, const Eigen::Vector3f& bearing_right) const;

 private:
  struct LeftTrack {
    std::uint32_t id = 0;
    std::uint32_t length = 0;
    bool stereo = false;                 // 3D (matched in the right image) at the last match_stereo
    bool stereo_prev = false;            // scratch: the class before this frame's match
    bool stereo_failed = false;          // the last stereo attempt failed (retry throttled)
    Eigen::Vector2f uv = Eigen::Vector2f::Zero();        // cam0 px
    Eigen::Vector3f bearing = Eigen::Vector3f::UnitZ();  // cam0
    Eigen::Vector2f xy = Eigen::Vector2f::Zero();        // cam0 normalized
    Eigen::Vector2f uv_right = Eigen::Vector2f::Zero();  // cam1 px (valid when stereo)
    Eigen::Vector3f bearing_right = Eigen::Vector3f::UnitZ();
    Eigen::Vector2f xy_right = Eigen::Vector2f::Zero();
    Eigen::Vector2f right_guess = Eigen::Vector2f::Zero();  // where the right match was sought
    int slot = -1;  // templates_' slot holding the KLT templates at uv (-1: none)
  };
  struct RightTrack {
    std::uint32_t id = 0;
    std::uint32_t length = 0;
    Eigen::Vector2f uv = Eigen::Vector2f::Zero();        // cam1 px
    Eigen::Vector3f bearing = Eigen::Vector3f::UnitZ();  // cam1
    Eigen::Vector2f xy = Eigen::Vector2f::Zero();
  };
  static constexpr std::size_t kCap = capacity::kMaxFeaturesPerCamera;

  class StageClock;  // laps of the steady clock into FrontendFrameStats (frontend.cpp)

  // KLT + forward-backward of the tracks, then their temporal RANSAC: laps track_ms, ransac_ms.
  void track_left(const Eigen::Matrix3f* R_curr_prev, FrontendFrameStats* st, StageClock* clock);
  void track_right(const Eigen::Matrix3f* R_curr_prev, FrontendFrameStats* st, StageClock* clock);
  void thin_crowded(FrontendFrameStats* st);
  // New corners one camera may add (0: none): what max_cnt lacks, bounded by the camera's free
  // track slots; 0 while fewer than detect_min_missing are missing, and in the frames
  // detect_interval leaves out after the last top-up.
  int detection_budget(std::size_t tracks_in_camera) const;
  // This frame may top up: the first frame, detect_interval frames after the last top-up, or
  // fewer than half of max_cnt tracks left.
  bool detection_due() const;
  void detect_left(FrontendFrameStats* st);
  void match_stereo(FrontendFrameStats* st);
  struct StereoMatch {
    bool matched = false, epipolar_failed = false;  // epipolar_failed: some hypothesis failed that check
    Eigen::Vector2f uv = Eigen::Vector2f::Zero();   // px in the right image
    Eigen::Vector3f bearing = Eigen::Vector3f::UnitZ();
    float epipolar_px = 0.0f;
    int confirmations = 0;  // right->left KLT confirmations run
  };
  // The right-image match of left track t from guess (and the depth hypotheses of a new track).
  StereoMatch match_track(const LeftTrack& t, const Eigen::Vector2f& guess, bool had_match);
  // The backward (confirmation) track of a forward track p_from -> p_to: from p_to in `to` back
  // into `from`, starting at p_from, on at most levels_back of `levels`; true when it lands
  // within max_px of p_from. slot: templates_' slot for p_to's templates in `to` (-1: none).
  bool confirmed(const ImagePyramid& from, const ImagePyramid& to, int levels, const Eigen::Vector2f& p_from,
                 const Eigen::Vector2f& p_to, float max_px, int slot = -1);
  // A slot of this frame's half of templates_ for each new left track (none in use by a track).
  void assign_template_slots(std::size_t first_new);
  void detect_right(FrontendFrameStats* st);
  void write_output(const StereoFrame& frame, FrameFeatures* out) const;
  Eigen::Vector2f predict(const Camera& cam, const Eigen::Matrix3f& R_curr_prev, const Eigen::Vector2f& uv) const;

  FrontendOptions options_;
  KltOptions confirm_klt_;  // options_.klt with confirm_sparse_from_level
  Camera cam_[2];
  Eigen::Matrix3f R_c1_c0_ = Eigen::Matrix3f::Identity();
  Eigen::Vector3f t_c1_c0_ = Eigen::Vector3f::Zero();
  Eigen::Matrix3f E_c1_c0_ = Eigen::Matrix3f::Zero();  // stereo essential: x1^T E x0 = 0

  // pyr_[k][cam]: k = cur_ is this frame, 1 - cur_ the previous one (swapped, never copied).
  std::unique_ptr<ImagePyramid> pyr_[2][2];
  int cur_ = 0;
  bool has_prev_ = false;
  int frames_since_detection_ = 0;  // frames since the last one that detected (0: this one)
  bool detection_due_ = true;       // this frame may top up (detect_interval)
  bool detected_ = false;           // this frame ran a detection
  bool prev_right_valid_ = false;
  std::unique_ptr<CornerDetector> detector_;
  CrowdingGrid crowd_;  // thin_crowded's disks of the kept tracks
  // Left tracks' KLT templates in the left pyramid they sit in: max_cnt slots per frame parity,
  // this frame's half cur_ * max_cnt .. + max_cnt - 1 (klt_template_cache.hpp).
  std::unique_ptr<KltTemplateCache> templates_;

  FixedVector<LeftTrack, kCap> left_;
  FixedVector<RightTrack, kCap> right_;
  std::uint32_t next_id_ = 0;
  Eigen::Vector2f stereo_offset_px_ = Eigen::Vector2f::Zero();  // mean right - infinity transfer of 3D matches
  Xorshift32 rng_;

  // Scratch, sized once (members so the per-frame path never allocates).
  Eigen::Vector3f b_prev_[kCap];
  Eigen::Vector3f b_curr_[kCap];
  std::uint8_t inlier_[kCap];
  std::uint16_t order_[kCap];
  std::uint8_t slot_used_[kCap];
  Eigen::Vector2f new_px_[kCap];
};

}  // namespace ums
