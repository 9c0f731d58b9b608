#include "core/estimator/estimator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/estimator/imu_buffer.hpp"
#include "core/estimator/initializer.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/marginalizer.hpp"
#include "core/estimator/pnp_locator.hpp"
#include "core/estimator/problem_builder.hpp"
#include "core/estimator/relative_pose_cache.hpp"
#include "core/estimator/state_blocks.hpp"
#include "core/estimator/window.hpp"
#include "core/estimator/window_backup.hpp"
#include "solver/marginal_prior.hpp"
#include "solver/problem.hpp"

namespace ums {
namespace {

// Validated options with the IMU noise from the calibration, inflated (unmodelled effects).
EstimatorOptions prepared(const EstimatorOptions& in, const RigCalibration& rig) {
  in.validate();
  EstimatorOptions o = in;
  o.preintegration.noise = ImuNoise::from_calibration(rig.imu);
  o.preintegration.noise.gyro_noise_density *= o.imu_noise_inflation;
  o.preintegration.noise.accel_noise_density *= o.imu_noise_inflation;
  o.preintegration.noise.gyro_random_walk *= o.imu_walk_inflation;
  o.preintegration.noise.accel_random_walk *= o.imu_walk_inflation;
  o.preintegration.validate();
  return o;
}

ProblemBuilderOptions builder_options(const EstimatorOptions& o) {
  ProblemBuilderOptions b;
  b.weight_3d = o.focal_px / o.sigma_px * o.beta_3d;
  b.weight_2d = o.focal_px / o.sigma_px * o.beta_2d;
  b.huber_rad = o.huber_px / o.sigma_px;
  b.outlier_rad = o.outlier_px / o.focal_px;
  b.min_depth_m = o.min_depth_m;
  b.max_depth_m = o.max_depth_m;
  b.estimate_extrinsic = o.estimate_extrinsic;
  b.extrinsic_sigma_m = o.extrinsic_sigma_m;
  b.extrinsic_sigma_rad = o.extrinsic_sigma_deg * M_PI / 180.0;
  b.baseline_sigma_m = o.baseline_sigma_m;
  b.baseline_sigma_rad = o.baseline_sigma_deg * M_PI / 180.0;
  b.estimate_td = o.estimate_td;
  b.td_sigma_s = o.td_sigma_ms * 1e-3;
  b.estimate_gyro_scale = o.estimate_gyro_scale;
  b.gyro_scale_sigma = o.gyro_scale_sigma_pct * 1e-2;
  b.function_tolerance = o.function_tolerance;
  b.predicted_stop_share = o.predicted_stop_share;
  b.reuse_gauss_newton_matrix = o.reuse_gauss_newton_matrix;
  b.reuse_factorization = o.reuse_factorization;
  b.selection.budget = o.max_landmarks_in_solve;
  b.selection.share_2d = o.share_2d;
  b.selection.spread_cell_tan = o.landmark_spread_px / o.focal_px;
  b.still_sigma_m = o.still_sigma_m;
  b.still_sigma_rad = o.still_sigma_rad;
  b.still_sigma_v = o.still_sigma_v;
  return b;
}

LandmarkMapOptions landmark_options(const EstimatorOptions& o) {
  return LandmarkMapOptions{o.min_depth_m, o.max_depth_m, o.min_triangulation_angle_deg,
                            o.min_stereo_disparity_px / o.focal_px};
}


}  // namespace

Estimator::Estimator(const EstimatorOptions& options, const RigCalibration& rig)
    : options_(prepared(options, rig)),
      rig_(rig),
      g_w_(0.0, 0.0, -options.gravity_m_s2),
      keyframes_(options.keyframe),
      window_(std::make_unique<Window>(options_.preintegration)),
      imu_(std::make_unique<ImuBuffer>(static_cast<std::int64_t>(options_.imu_max_gap_ms * 1e6))),
      landmarks_(std::make_unique<LandmarkMap>(landmark_options(options_))),
      marginalizer_(std::make_unique<Marginalizer>()),
      stage_backup_(std::make_unique<WindowBackup>()),
      relocation_(std::make_unique<RelocationRequest>()),
      nav_(Eigen::Vector3d(0.0, 0.0, -options.gravity_m_s2)) {
  window_->extrinsics().set(rig.imu.T_b_i.inverse() * rig.cam[0].T_b_c, rig.imu.T_b_i.inverse() * rig.cam[1].T_b_c);
  window_->extrinsics().set_floating(options_.estimate_extrinsic);
  window_->time_offset().set(rig.td_s);
  builder_ = std::make_unique<ProblemBuilder>(builder_options(options_), window_.get(), landmarks_.get(),
                                              marginalizer_.get(), &stats_);
  initializer_ = std::make_unique<Initializer>(options_, rig_, window_.get(), landmarks_.get(), builder_.get(),
                                               marginalizer_.get(), &stats_);
  pnp_ = std::make_unique<PnpLocator>(options_.min_init_3d, options_.outlier_px / options_.focal_px);
}

Estimator::~Estimator() = default;

double Estimator::ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::size_t Estimator::footprint_bytes() const {
  return sizeof(*this) + Window::kSlots * sizeof(WindowFrame) + sizeof(ImuBuffer) +
         2 * ImuBuffer::kRecent * sizeof(ImuSample) + sizeof(LandmarkMap) +
         Pool<Landmark, capacity::kMaxLandmarks>::kStaticBytes + capacity::kMaxLandmarks * (4 + 2) +
         sizeof(ProblemBuilder) + sizeof(solver::Problem) + sizeof(RelativePoseCache) +
         capacity::kMaxVisualResiduals * sizeof(BearingResidual) + capacity::kMaxLandmarks * 2 * sizeof(int) +
         solver::capacity::kMaxParameterBlocks * sizeof(BlockName) + sizeof(Marginalizer) +
         2 * sizeof(solver::MarginalPrior) + sizeof(MarginalizedKeyframe) + 3 * sizeof(WindowBackup) +
         sizeof(Initializer) + sizeof(PnpLocator) + sizeof(RelocationRequest) +
         capacity::kMaxLoopFeaturesPerKeyframe * (sizeof(BearingResidual) + sizeof(int) + 3 * sizeof(LoopPointResidual)) + capacity::kMaxLandmarks * (sizeof(PnpMatch) + 1 + 2);
}

std::size_t Estimator::landmarks_in_use() const { return static_cast<std::size_t>(landmarks_->size()); }

void Estimator::set_keyframe_sink(KeyframeSink* sink) { marginalizer_->set_keyframe_sink(sink); }

// ---------------------------------------------------------------------------------------------
// IMU

void Estimator::note_lost_imu_time(std::int64_t lost_ns) { imu_->note_lost_time(lost_ns); }

void Estimator::add_imu(const ImuSample& in, bool saturated) {
  const ImuBuffer::Added a = imu_->add(in, saturated);
  if (!a.accepted) {
    ++stats_.imu_out_of_order;
    return;
  }
  if (a.held) ++stats_.imu_held;
  if (a.interval_full) ++stats_.drops_imu;
  const ImuSample& sample = imu_->last();
  if (a.first) {
    // Attitude from the first specific force: right at rest, a few degrees off in motion, and
    // corrected by the first standstill or the visual-IMU alignment.
    NavState s;
    s.q_w_b = attitude_from_gravity(sample.accel_m_s2);
    nav_.reset(s, sample);
    attitude_known_ = true;
  } else {
    nav_.propagate(sample);
  }
}

bool Estimator::imu_rate_state(NavState* state) const {
  if (!nav_.initialized() || (mode_ == EstimatorMode::kImuOnly && !velocity_known_)) return false;
  *state = nav_.state();
  state->p_w_b = odom_.p_w(state->p_w_b);
  state->q_w_b = odom_.q_w(state->q_w_b);
  state->v_w_b = odom_.v_w(state->v_w_b);
  return true;
}

// ---------------------------------------------------------------------------------------------
// One frame

void Estimator::add_frame(const FrameFeatures& ff, EstimatorOutput* out, EstimatorTiming* timing) {
  const auto t0 = std::chrono::steady_clock::now();
  EstimatorTiming local_timing;
  if (timing == nullptr) timing = &local_timing;
  *timing = EstimatorTiming{};
  if (out_of_order(ff, out)) return;
  WindowFrame& f = window_->next();
  const StandstillResult rest = begin_frame(ff, f);
  timing->preintegrate_ms = static_cast<float>(ms_since(t0));
  initial_state(f, rest);
  observe(ff, f, rest);
  run_mode(f, timing);
  guard_divergence(f);
  if (mode_ != EstimatorMode::kImuOnly || !window_->empty()) set_nav_from(window_->newest());
  write_output(ff, f, out);
  settled_ = kNoFrame;
  end_frame(f, timing);
  last_output_.settled_frame = settled_;
  if (out != nullptr) out->settled_frame = settled_;
  timing->backend_ms = static_cast<float>(ms_since(t0));
}

bool Estimator::out_of_order(const FrameFeatures& ff, EstimatorOutput* out) {
  if (stats_.frames == 0 || ff.t_ns > last_output_.t_ns) return false;
  // A source bug (sources order and de-duplicate): counted, never processed.
  ++stats_.frames_out_of_order;
  if (out != nullptr) {
    *out = last_output_;
    out->valid = false;
  }
  return true;
}

StandstillResult Estimator::begin_frame(const FrameFeatures& ff, WindowFrame& f) {
  ++stats_.frames;
  if (stats_.first_frame_t_ns < 0) stats_.first_frame_t_ns = ff.t_ns;
  f.t_ns = ff.t_ns;
  f.td_applied_s = 1e-9 * static_cast<double>(ff.td_ns);
  f.keyframe = false;
  if (!imu_->close_interval(f.t_ns)) ++stats_.drops_imu;
  if (imu_->interval_has_gap()) widen_imu_factor_over_hole(f);
  f.imu_ok = imu_->interval_open() && f.pre.num_samples() >= 2 && f.imu.residual().init(&f.pre, g_w_) == Status::kOk;
  StandstillResult rest;
  f.still = initializer_->imu_at_rest(f.t_ns, imu_.get(), &rest);
  last_still_ = rest;
  last_still_valid_ = f.still;
  last_output_.t_ns = ff.t_ns;
  return rest;
}

// Samples were lost inside this frame's interval: the factor holds the last sample across the
// hole, which claims the IMU's precision for motion it never measured. Its covariance gets the
// variance of that motion, modelled as a random walk changing at the rate the samples changed in
// the second before the hole: vision then carries the window through, and a short hole during
// slow motion keeps most of the IMU's weight. And the hole may be no time at all: a clock that
// jumped forward (both streams' stamps at once) leaves the same hole, and holding the sample
// across it claims the hole's whole length of travel and turn at the current rates. Which it
// was only the images can tell, so that motion is the factor's sigma too.
void Estimator::widen_imu_factor_over_hole(WindowFrame& f) {
  ++stats_.imu_gap_frames;
  const double hole_s = imu_->interval_hole_s();
  f.pre.add_unmodelled_motion(motion_claimed_over_hole(f, hole_s));
  double q_gyro = 0.0, q_accel = 0.0;
  if (!imu_->motion_density_before_hole(&q_gyro, &q_accel)) return;
  // A held sample drifts from the motion as a random walk, W(s) with variance q s; its integral
  // over the hole has variance q L^3 / 3, whose share in this interval is q s^2 ds. The factors
  // are independent, so each takes its share of the whole (its own marginal, q s ds^2, would
  // leave the window too sure of the motion across a long hole).
  const double age_s = imu_->hole_age_s();
  const double k = age_s * age_s * hole_s;
  f.pre.add_unmodelled_motion({q_gyro * k, q_accel * k, 0.5 * hole_s});
}

// The travel and turn the held sample claims over hole_s of this interval: the speed of the
// newest window frame, the interval's mean rotation rate. Nothing before the window has a speed.
Preintegration::UnmodelledMotion Estimator::motion_claimed_over_hole(const WindowFrame& f, double hole_s) const {
  Preintegration::UnmodelledMotion u;
  const double dt_s = f.pre.dt_s();
  if (!inertial_window() || window_->empty() || dt_s <= 0.0) return u;
  const double travel_m = state::v(window_->newest().sb).norm() * hole_s;
  const double turn_rad = Eigen::AngleAxisd(f.pre.gamma()).angle() * hole_s / dt_s;
  u.var_p_m2 = travel_m * travel_m;
  u.var_theta_rad2 = turn_rad * turn_rad;
  return u;
}

void Estimator::initial_state(WindowFrame& f, const StandstillResult& rest) {
  if (mode_ == EstimatorMode::kImuOnly || window_->empty()) {
    if (f.still && mode_ == EstimatorMode::kImuOnly) {
      velocity_known_ = true;
      // Hold still when still: zero velocity, gyro bias from the rest, attitude re-levelled.
      NavState s = nav_.state();
      const Eigen::Vector3d up_w = s.q_w_b * rest.mean_accel_m_s2;
      s.q_w_b = Eigen::Quaterniond(rotation_between(up_w, Eigen::Vector3d::UnitZ())) * s.q_w_b;
      s.v_w_b.setZero();
      s.bg = rest.mean_gyro_rad_s;
      nav_.reset(s, imu_->last());
    }
    blocks_from_nav(nav_.state(), f.pose, f.sb);
    return;
  }
  const WindowFrame& prev = window_->newest();
  std::copy(prev.sb, prev.sb + state::kSbSize, f.sb);
  if (inertial_window() && f.imu_ok) {
    const NavState sj = predict(nav_from_blocks(prev.pose, prev.sb), f.pre, g_w_);
    state::p(f.pose) = sj.p_w_b;
    set_quat(f.pose, sj.q_w_b);
    state::v(f.sb) = sj.v_w_b;
  } else {
    std::copy(prev.pose, prev.pose + state::kPoseSize, f.pose);
  }
}

Eigen::Matrix3d Estimator::c0_from_c1() const {
  const Extrinsics& e = window_->extrinsics();
  return e.T_b_c(0).linear().transpose() * e.T_b_c(1).linear();
}

CameraMotion Estimator::camera_motion(const WindowFrame& prev, const WindowFrame& f) const {
  CameraMotion m;
  const std::size_t n_prev = prev.pre.num_samples(), n_cur = f.pre.num_samples();
  if (n_prev < 1 || n_cur < 2) return m;
  // Each interval's last sample is held to its frame's stamp: the rate at that frame.
  const Eigen::Vector3d bg = state::bg(f.sb);
  const Eigen::Vector3d w_prev_b = prev.pre.sample(n_prev - 1).gyro_rad_s - bg;
  const Eigen::Vector3d w_cur_b = f.pre.sample(n_cur - 1).gyro_rad_s - bg;
  const Eigen::Matrix3d R_cur_prev_b = f.pre.gamma().toRotationMatrix().transpose();
  for (int c = 0; c < 2; ++c) {
    const Eigen::Matrix3d R_b_c = window_->extrinsics().T_b_c(c).linear();
    m.R_cur_prev[c] = (R_b_c.transpose() * R_cur_prev_b * R_b_c).cast<float>();
    m.w_cur_rad_s[c] = (R_b_c.transpose() * w_cur_b).cast<float>();
    m.w_prev_rad_s[c] = (R_b_c.transpose() * w_prev_b).cast<float>();
  }
  m.valid = m.R_cur_prev[0].allFinite() && m.w_cur_rad_s[0].allFinite() && m.w_prev_rad_s[0].allFinite();
  return m;
}

void Estimator::observe(const FrameFeatures& ff, WindowFrame& f, const StandstillResult& rest) {
  window_->push_next();
  const int slot = window_->slot_of(f);
  const int n = window_->size();
  const int prev_slot = n >= 2 ? window_->slot_at(n - 2) : -1;
  const double dt_s = n >= 2 ? 1e-9 * static_cast<double>(f.t_ns - window_->at(n - 2).t_ns) : 0.0;
  const CameraMotion motion =
      options_.estimate_td && f.imu_ok && n >= 2 ? camera_motion(window_->at(n - 2), f) : CameraMotion();
  stats_.drops_landmarks +=
      static_cast<std::uint64_t>(landmarks_->ingest(ff, slot, c0_from_c1(), prev_slot, dt_s, motion));
  // The IMU alone cannot tell rest from uniform motion (both read gravity and no rotation): when
  // the images can tell, they must agree that nothing moves.
  if (f.still && n >= 2) {
    const float flow_px = initializer_->visual_flow_px(window_->slot_at(n - 2), slot, rest.mean_gyro_rad_s);
    if (flow_px > static_cast<float>(options_.still_max_flow_px)) {
      f.still = false;
      last_still_valid_ = false;
      ++stats_.still_rejected_by_vision;
    }
  }
  if (f.still) ++stats_.still_frames;
  int n2d = 0;
  landmarks_->count_depth_observations(slot, &n2d);
  f.keyframe = keyframes_.update(ff, n2d).is_keyframe;
}

void Estimator::run_mode(WindowFrame& f, EstimatorTiming* timing) {
  switch (mode_) {
    case EstimatorMode::kImuOnly: apply(frame_imu_only(f)); break;
    case EstimatorMode::kVo: apply(frame_vo(f)); break;
    case EstimatorMode::kVio:
    case EstimatorMode::kVisionLost:
      frame_vio(f, timing);
      apply(watch_tracking(f));
      break;
  }
}

// VIO with nothing tracked (the images went dark) is the IMU alone: said so after
// vision_lost_after_s, and VIO again once tracking has held for vision_back_after_s. The window
// runs on either way; only what the pose is worth changes.
ModeEvent Estimator::watch_tracking(const WindowFrame& f) {
  const int tracked = landmarks_->count_depth_observations(window_->slot_of(f), nullptr);
  const bool enough = tracked >= options_.min_tracked_landmarks;
  if (enough != tracking_ok_) {
    tracking_ok_ = enough;
    tracking_since_ns_ = f.t_ns;
  }
  const double held_s = 1e-9 * static_cast<double>(f.t_ns - tracking_since_ns_);
  if (mode_ == EstimatorMode::kVio && !enough && held_s >= options_.vision_lost_after_s) return ModeEvent::kTracksLost;
  if (mode_ == EstimatorMode::kVisionLost && enough && held_s >= options_.vision_back_after_s)
    return ModeEvent::kTracksBack;
  return ModeEvent::kNone;
}

void Estimator::guard_divergence(WindowFrame& f) {
  if (!inertial_window()) return;
  const Eigen::Vector3d v = state::v(f.sb);
  bool finite = v.allFinite();
  for (double x : f.pose) finite = finite && std::isfinite(x);
  if (finite && v.norm() <= options_.max_speed_m_s) return;
  // Divergence: back to the last good pose, IMU only, and start again.
  ++stats_.resets;
  state::p(f.pose) = last_odom_.p_w_b;
  set_quat(f.pose, last_odom_.q_w_b);
  Eigen::Map<Eigen::Matrix<double, state::kSbSize, 1>>(f.sb).setZero();
  state::ba(f.sb) = last_odom_.ba;
  state::bg(f.sb) = last_odom_.bg;
  apply(ModeEvent::kDivergence);
  reset_window(true);
  if (options_.estimate_extrinsic) {
    // Extrinsics that floated into a divergence start again from the calibration, held until the
    // window is excited again.
    Extrinsics& x = window_->extrinsics();
    x.set(Eigen::Isometry3d(x.calibration(0)), Eigen::Isometry3d(x.calibration(1)));
    builder_->hold_extrinsics();
  }
  // An offset or a scale that floated into a divergence is not trusted.
  if (options_.estimate_td) window_->time_offset().reset();
  if (options_.estimate_gyro_scale) window_->gyro_scale().reset();
}

void Estimator::write_output(const FrameFeatures& ff, const WindowFrame& f, EstimatorOutput* out) {
  EstimatorOutput& o = last_output_;
  o.t_ns = ff.t_ns;
  o.frame_id = f.id;
  o.mode = mode_;
  // IMU_ONLY gives a pose only from a known state: at rest (zero velocity) or the last VO/VIO
  // estimate. Started in motion without vision, the velocity is unknown and the propagated
  // position would drift by metres within seconds: no pose rather than a false one.
  if (mode_ != EstimatorMode::kImuOnly) velocity_known_ = true;
  o.valid = mode_ != EstimatorMode::kImuOnly || (attitude_known_ && velocity_known_);
  if (!o.valid) ++stats_.frames_without_pose;
  o.keyframe = f.keyframe;
  o.td_s = window_->time_offset().value_s();
  last_odom_ = nav_from_blocks(f.pose, f.sb);
  o.p_w_b = odom_.p_w(last_odom_.p_w_b);
  o.q_w_b = odom_.q_w(last_odom_.q_w_b);
  o.v_w_b = odom_.v_w(last_odom_.v_w_b);
  o.ba = last_odom_.ba;
  o.bg = last_odom_.bg;
  o.still = f.still;
  o.odometry_epoch = static_cast<std::uint32_t>(stats_.resets + stats_.relevels);
  o.reset_counter = o.odometry_epoch + odom_.resets();
  const bool solved = mode_ != EstimatorMode::kImuOnly;
  o.landmarks_in_solve = solved ? builder_->num_selected() : 0;
  o.n_3d_used = o.n_2d_left_used = o.n_2d_right_used = 0;
  if (solved) {
    o.n_3d_used = builder_->num_selected(LandmarkGroup::k3D);
    o.n_2d_left_used = builder_->num_selected(LandmarkGroup::k2DLeft);
    o.n_2d_right_used = builder_->num_selected(LandmarkGroup::k2DRight);
    stats_.sum_landmarks_in_solve += o.landmarks_in_solve;
    stats_.sum_2d_in_solve += o.n_2d_left_used + o.n_2d_right_used;
    ++stats_.frames_solved;
  }
  if (out != nullptr) *out = o;
}

void Estimator::end_frame(const WindowFrame& f, EstimatorTiming* timing) {
  slide_window(timing);
  landmarks_->compact();
  builder_->forget_kept_outliers();  // released now
  stats_.peak_landmarks = landmarks_->peak();
  stats_.keyframes_emitted = marginalizer_->keyframes_emitted();
  // The next interval starts at this frame.
  window_->choose_next_slot();
  imu_->open_interval(&window_->next().pre, f.t_ns, last_odom_.ba, last_odom_.bg);
  ++stats_.frames_in_mode[static_cast<int>(mode_)];
}

void Estimator::set_nav_from(const WindowFrame& f) {
  NavState s = nav_from_blocks(f.pose, f.sb);
  s.t_ns = f.t_ns;
  ImuSample boundary = imu_->last();
  if (boundary.t_ns < f.t_ns) boundary.t_ns = f.t_ns;
  if (imu_->has_samples()) nav_.reset(s, boundary);
}

void Estimator::apply(ModeEvent event) {
  const ModeTransition t = transition(mode_, event);
  if (!t.changed || t.to == mode_) return;
  ModeChange c;
  c.t_ns = last_output_.t_ns;
  c.from = mode_;
  c.to = t.to;
  c.reason = t.reason;
  if (stats_.mode_changes.push_back(c) != Status::kOk) ++stats_.mode_changes_dropped;
  mode_ = t.to;
  if (c.from == EstimatorMode::kVisionLost || t.to == EstimatorMode::kVisionLost) return;  // same window
  if (t.to == EstimatorMode::kVio) {
    ++stats_.relevels;
    tracking_ok_ = true;
    tracking_since_ns_ = c.t_ns;
  }
  if (t.to == EstimatorMode::kVio && !stats_.initialized) {
    stats_.initialized = true;
    stats_.init_t_ns = c.t_ns;
    stats_.init_case = t.reason;
  }
}

}  // namespace ums
