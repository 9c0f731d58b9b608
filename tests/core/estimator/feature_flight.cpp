#include "tests/core/estimator/feature_flight.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>

#include "core/math/so3.hpp"
#include "hal/sim/simulate.hpp"
#include "profiling/eval/alignment.hpp"

namespace ums::test {
namespace {

// Points scattered uniformly over the six faces of the procedural renderer's room around the path
// (its walls wall_margin_m beyond the path's bounding box, its floor and ceiling margins).
std::vector<Eigen::Vector3d> room_points(const sim::SimTrajectory& tr, double margin_m, int n, std::mt19937_64& rng) {
  std::vector<Eigen::Vector3d> path_w;
  for (std::int64_t t = tr.t_begin_ns; t <= tr.t_end_ns; t += 50'000'000) path_w.push_back(tr.T_w_b(t).translation());
  sim::WorldOptions wo;
  wo.margin_xy_m = margin_m;
  wo.texture_size = 64;  // only the room's size is used
  const sim::World world = sim::make_world(path_w, wo);
  const Eigen::Vector3d lo = world.room_lo.cast<double>(), hi = world.room_hi.cast<double>();
  const Eigen::Vector3d size = hi - lo;
  const double area[3] = {size.y() * size.z(), size.x() * size.z(), size.x() * size.y()};
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(static_cast<std::size_t>(n));
  while (static_cast<int>(pts.size()) < n) {
    const double a = u(rng) * (area[0] + area[1] + area[2]);
    const int axis = a < area[0] ? 0 : (a < area[0] + area[1] ? 1 : 2);
    Eigen::Vector3d p(lo.x() + u(rng) * size.x(), lo.y() + u(rng) * size.y(), lo.z() + u(rng) * size.z());
    p[axis] = u(rng) < 0.5 ? lo[axis] : hi[axis];
    pts.push_back(p);
  }
  return pts;
}

struct View {
  bool ok = false;
  Eigen::Vector3d b = Eigen::Vector3d::UnitZ();   // unit bearing
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();   // pinhole pixel
};

View view_of(const Eigen::Isometry3d& T_w_c, const CameraCalibration& cam, const Eigen::Vector3d& p_w) {
  View v;
  const Eigen::Vector3d P = T_w_c.inverse() * p_w;
  if (P.z() < 0.2 || P.norm() > 60.0) return v;
  v.uv = Eigen::Vector2d(cam.fx * P.x() / P.z() + cam.cx, cam.fy * P.y() / P.z() + cam.cy);
  const double border_px = 10.0;
  v.ok = v.uv.x() >= border_px && v.uv.y() >= border_px && v.uv.x() <= cam.width - border_px &&
         v.uv.y() <= cam.height - border_px;
  v.b = P.normalized();
  return v;
}

// The bearing turned by an isotropic Gaussian angle of sigma_rad per tangent axis.
Eigen::Vector3d noisy(const Eigen::Vector3d& b, double sigma_rad, std::mt19937_64& rng) {
  if (sigma_rad <= 0.0) return b;
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::Vector3d a = std::abs(b.x()) < 0.6 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d t1 = (a - b * b.dot(a)).normalized();
  const Eigen::Vector3d t2 = b.cross(t1);
  return (b + sigma_rad * (n01(rng) * t1 + n01(rng) * t2)).normalized();
}

// What a front end would report: tracks live while the point stays in the left image, a new
// track (new id) starts on a visible point away from the others until max_tracks are live; a
// track is 3D while the right camera sees the point too.
class FeatureTracker {
 public:
  FeatureTracker(const FeatureFlightOptions& o, const RigCalibration& rig, std::vector<Eigen::Vector3d> pts)
      : o_(o), rig_(rig), pts_(std::move(pts)), rng_(o.seed * 7919 + 17) {
    sigma_rad_[0] = o.noise_px / rig.cam[0].fx;
    sigma_rad_[1] = (o.noise_right_px < 0.0 ? o.noise_px : o.noise_right_px) / rig.cam[1].fx;
    order_.resize(pts_.size());
    for (std::size_t i = 0; i < order_.size(); ++i) order_[i] = static_cast<int>(i);
  }

  void lose_all() { tracks_.clear(); }

  void frame(const Eigen::Isometry3d& T_w_c0, const Eigen::Isometry3d& T_w_c1, FrameFeatures* ff) {
    std::vector<Track> kept;
    for (Track tk : tracks_)
      if (emit(T_w_c0, T_w_c1, &tk, ff)) kept.push_back(tk);
    tracks_ = kept;
    std::vector<Eigen::Vector2d> taken;
    for (const FeatureObservation& ob : ff->features) taken.push_back(ob.uv_left_px.cast<double>());
    std::shuffle(order_.begin(), order_.end(), rng_);
    for (int i : order_) {
      if (static_cast<int>(tracks_.size()) >= o_.max_tracks) break;
      const View l = view_of(T_w_c0, rig_.cam[0], pts_[static_cast<std::size_t>(i)]);
      if (!l.ok) continue;
      bool crowded = false;
      for (const Eigen::Vector2d& q : taken) crowded = crowded || (q - l.uv).norm() < o_.min_spacing_px;
      if (crowded) continue;
      Track tk{i, next_id_++, 0};
      if (!emit(T_w_c0, T_w_c1, &tk, ff)) continue;
      tracks_.push_back(tk);
      taken.push_back(l.uv);
    }
  }

 private:
  struct Track {
    int point;
    std::uint32_t id;
    std::uint32_t length;
  };

  bool emit(const Eigen::Isometry3d& T_w_c0, const Eigen::Isometry3d& T_w_c1, Track* tk, FrameFeatures* ff) {
    const Eigen::Vector3d& p_w = pts_[static_cast<std::size_t>(tk->point)];
    const View l = view_of(T_w_c0, rig_.cam[0], p_w);
    if (!l.ok) return false;
    View r = view_of(T_w_c1, rig_.cam[1], p_w);
    r.ok = r.ok && o_.stereo;
    FeatureObservation ob;
    ob.id = tk->id;
    ob.track_length = ++tk->length;
    ob.cls = r.ok ? FeatureClass::k3D : FeatureClass::k2DLeft;
    const Eigen::Vector3d bl = noisy(l.b, sigma_rad_[0], rng_);
    ob.bearing_left = bl.cast<float>();
    ob.xy_left = (bl.head<2>() / bl.z()).cast<float>();
    ob.uv_left_px = l.uv.cast<float>();
    ob.bearing_right = Eigen::Vector3f::Constant(NAN);
    ob.xy_right = ob.uv_right_px = Eigen::Vector2f::Constant(NAN);
    if (r.ok) {
      const Eigen::Vector3d br = noisy(r.b, sigma_rad_[1], rng_);
      ob.bearing_right = br.cast<float>();
      ob.xy_right = (br.head<2>() / br.z()).cast<float>();
      ob.uv_right_px = r.uv.cast<float>();
    }
    ++(r.ok ? ff->n_3d : ff->n_2d_left);
    ff->features.push_back(ob);
    return true;
  }

  const FeatureFlightOptions& o_;
  const RigCalibration& rig_;
  std::vector<Eigen::Vector3d> pts_;
  std::mt19937_64 rng_;
  double sigma_rad_[2] = {0.0, 0.0};
  std::vector<Track> tracks_;
  std::vector<int> order_;
  std::uint32_t next_id_ = 1;
};

// Every valid output against the truth at its frame.
struct Recorded {
  std::vector<double> t_s;
  std::vector<Eigen::Vector3d> p_est, p_gt;
  std::vector<Eigen::Matrix3d> R_est, R_gt;
  std::vector<bool> vio;
};

double slope(const std::vector<double>& x, const std::vector<double>& y) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  const double n = static_cast<double>(x.size());
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

// ATE after an SE(3) alignment; the yaw error against the rotation error 1 s into VIO (or into
// the run: the start-up attitude settles first), so the drift does not depend on the alignment.
void score(const Recorded& tr, FeatureFlightResult* res) {
  if (tr.p_est.size() < 3) return;
  const eval::Alignment a = eval::align(tr.p_est, tr.p_gt, eval::AlignMode::kSe3);
  double se = 0.0;
  for (std::size_t i = 0; i < tr.p_est.size(); ++i) {
    res->p_err_m.push_back(a.apply(tr.p_est[i]) - tr.p_gt[i]);
    se += res->p_err_m.back().squaredNorm();
  }
  res->ate_m = std::sqrt(se / static_cast<double>(tr.p_est.size()));
  const std::size_t first_vio = static_cast<std::size_t>(std::find(tr.vio.begin(), tr.vio.end(), true) - tr.vio.begin());
  const std::size_t i0 = std::min((first_vio < tr.vio.size() ? first_vio : 0) + 20, tr.R_est.size() - 1);
  const Eigen::Matrix3d R0 = tr.R_gt[i0] * tr.R_est[i0].transpose();
  double heading_prev = 0.0, heading = 0.0;
  for (std::size_t i = 0; i < tr.R_est.size(); ++i) {
    const Eigen::Vector3d e = so3::log(Eigen::Matrix3d(R0 * tr.R_est[i] * tr.R_gt[i].transpose()));
    res->yaw_err_deg.push_back(e.z() * 180.0 / M_PI);
    res->final_rot_err_deg = e.norm() * 180.0 / M_PI;
    const double h = std::atan2(tr.R_gt[i](1, 0), tr.R_gt[i](0, 0)) * 180.0 / M_PI;
    if (i > 0) heading += std::remainder(h - heading_prev, 360.0);
    heading_prev = h;
    res->heading_deg.push_back(heading);
  }
  res->t_s = tr.t_s;
  res->yaw_drift_deg_min = 60.0 * slope(res->t_s, res->yaw_err_deg);
  res->yaw_per_heading = slope(res->heading_deg, res->yaw_err_deg);
}

EstimatorOptions estimator_options(const FeatureFlightOptions& o, const RigCalibration& rig) {
  EstimatorOptions eo = o.estimator;
  eo.focal_px = rig.cam[0].fx;
  if (o.vo_only) {  // every alignment refused as unobservable, no standstill start
    eo.align_max_tilt_sigma_deg = 1e-12;
    eo.align_min_excitation_m_s2 = 1e12;
    eo.standstill.gyro_multiplier = eo.standstill.accel_multiplier = 1e-12;
  }
  return eo;
}

}  // namespace

FeatureFlightResult fly_features(const FeatureFlightOptions& o) {
  sim::SimOptions so;
  so.trajectory_path = o.trajectory;
  so.start_s = o.start_s;
  so.duration_s = o.duration_s;
  so.seed = o.seed;
  so.out_dir = "unused";
  const RigCalibration rig = sim::rig_preset(sim::CameraPreset::kEuroc);
  ImuCalibration imu_cal = rig.imu;
  if (!o.imu_noise)
    imu_cal.gyro_noise_density = imu_cal.accel_noise_density = imu_cal.gyro_random_walk = imu_cal.accel_random_walk = 0.0;
  const sim::SimTrajectory tr = sim::make_trajectory(so, rig);
  const sim::ImuTrack imu = sim::generate_imu(tr, imu_cal, so);
  std::mt19937_64 rng(o.seed);
  FeatureTracker tracker(o, rig, room_points(tr, o.wall_margin_m, o.points, rng));
  auto est = std::make_unique<Estimator>(estimator_options(o, rig), rig);
  est->set_keyframe_sink(o.keyframe_sink);
  est->set_relocation_link(o.relocation);
  auto ff = std::make_unique<FrameFeatures>();
  const Eigen::Isometry3d T_b_c0 = rig.imu.T_b_i.inverse() * rig.cam[0].T_b_c;
  const Eigen::Isometry3d T_b_c1 = rig.imu.T_b_i.inverse() * rig.cam[1].T_b_c;
  FeatureFlightResult res;
  Recorded track;
  std::size_t k_imu = 0;
  const std::int64_t dt_ns = static_cast<std::int64_t>(std::llround(1e9 / rig.cam[0].rate_hz));
  for (std::int64_t t = tr.t_begin_ns + dt_ns; t <= tr.t_end_ns; t += dt_ns) {
    for (; k_imu < imu.samples.size() && imu.samples[k_imu].t_ns <= t; ++k_imu) {
      const double imu_t_s = static_cast<double>(imu.samples[k_imu].t_ns - tr.t_begin_ns) * 1e-9;
      if (o.imu_gap_start_s >= 0.0 && imu_t_s >= o.imu_gap_start_s && imu_t_s < o.imu_gap_start_s + o.imu_gap_s) continue;
      est->add_imu(imu.samples[k_imu]);
    }
    const Eigen::Isometry3d T_w_b = tr.T_w_b(t);
    ff->clear();
    ff->t_ns = t;
    ff->seq = static_cast<std::uint64_t>(res.frames);
    const double t_s = static_cast<double>(t - tr.t_begin_ns) * 1e-9;
    if (o.blackout_start_s >= 0.0 && t_s >= o.blackout_start_s && t_s < o.blackout_start_s + o.blackout_s) {
      tracker.lose_all();
    } else {
      tracker.frame(T_w_b * T_b_c0, T_w_b * T_b_c1, ff.get());
    }
    EstimatorOutput out;
    est->add_frame(*ff, &out, nullptr);
    ++res.frames;
    res.frame_t_s.push_back(t_s);
    res.frame_mode.push_back(out.mode);
    res.frame_finite.push_back(out.p_w_b.allFinite() && out.q_w_b.coeffs().allFinite());
    res.frame_reset_counter.push_back(out.reset_counter);
    if (out.mode == EstimatorMode::kVio) ++res.vio_frames;
    if (!out.valid) continue;
    ++res.valid_frames;
    track.t_s.push_back(static_cast<double>(t - tr.t_begin_ns) * 1e-9);
    track.p_est.push_back(out.p_w_b);
    track.R_est.push_back(out.q_w_b.normalized().toRotationMatrix());
    track.p_gt.push_back(T_w_b.translation());
    track.R_gt.push_back(T_w_b.linear());
    track.vio.push_back(out.mode == EstimatorMode::kVio);
  }
  score(track, &res);
  res.stats = est->stats();
  return res;
}

}  // namespace ums::test
