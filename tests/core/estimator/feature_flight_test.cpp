#include "tests/core/estimator/feature_flight.hpp"

#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>

#include <catch2/catch.hpp>

#include "tests/common/test_paths.hpp"

namespace {

ums::test::FeatureFlightOptions flight(const char* name, double duration_s) {
  ums::test::FeatureFlightOptions o;
  o.trajectory = ums::test::groundtruth_dir() + "/" + name + "_GT.txt";
  o.duration_s = duration_s;
  o.estimator.round2_time_s = std::numeric_limits<double>::infinity();  // machine-independent
  return o;
}

// 0.3 px of bearing noise and the calibrated IMU noise.
ums::test::FeatureFlightOptions noisy_flight(const char* name, double duration_s) {
  ums::test::FeatureFlightOptions o = flight(name, duration_s);
  o.noise_px = 0.3;
  o.imu_noise = true;
  return o;
}

// Every frame has a finite pose, and every frame after t0_s is VIO.
void check_vio_after(const ums::test::FeatureFlightResult& r, double t0_s) {
  for (std::size_t i = 0; i < r.frame_t_s.size(); ++i) {
    REQUIRE(r.frame_finite[i]);
    if (r.frame_t_s[i] > t0_s) CHECK(r.frame_mode[i] == ums::EstimatorMode::kVio);
  }
}

void print(const char* what, const ums::test::FeatureFlightResult& r) {
  std::printf("%s: %d frames, %d with a pose, %d VIO, ATE %.5f m, yaw drift %.3f deg/min\n", what, r.frames,
              r.valid_frames, r.vio_frames, r.ate_m, r.yaw_drift_deg_min);
}

}  // namespace

// Exact bearings: whatever the estimator does to them must give the flight back. A modelling
// error (a Jacobian, a frame convention, the rehosting) shows here before any noise hides it.
TEST_CASE("feature flight: exact bearings, vision only, reproduce the flight to a millimetre", "[estimator][features]") {
  for (const char* name : {"V101", "MH03"}) {
    ums::test::FeatureFlightOptions o = flight(name, 30.0);
    o.vo_only = true;
    const ums::test::FeatureFlightResult r = ums::test::fly_features(o);
    print(name, r);
    CHECK(r.valid_frames >= r.frames - 2);
    CHECK(r.vio_frames == 0);
    CHECK(r.ate_m < 0.001);
    CHECK(std::abs(r.yaw_drift_deg_min) < 0.01);
  }
}

TEST_CASE("feature flight: exact bearings and IMU, VIO within 2 mm", "[estimator][features]") {
  const ums::test::FeatureFlightResult r = ums::test::fly_features(flight("V101", 30.0));
  print("V101", r);
  CHECK(r.vio_frames > r.frames - 40);  // VIO within 2 s
  CHECK(r.ate_m < 0.002);
  CHECK(std::abs(r.yaw_drift_deg_min) < 0.05);
}

// Both cameras dark for 3 s in VIO (nothing tracked): the estimator must say so (VISION_LOST, the
// pose is the IMU's) within vision_lost_after_s plus a frame, keep a finite pose for every frame
// without a restart, and be back in VIO within 1 s of the images returning, with nothing to
// initialize again. Exact IMU: the drift across the blackout is the model's, a few centimetres.
TEST_CASE("feature flight: a 3 s blackout is VISION_LOST, not VIO, and VIO returns without a restart", "[estimator][features]") {
  ums::test::FeatureFlightOptions o = flight("V101", 20.0);
  o.blackout_start_s = 10.0;
  o.blackout_s = 3.0;
  const ums::test::FeatureFlightResult r = ums::test::fly_features(o);
  print("V101 blackout", r);
  const double lost_after_s = o.estimator.vision_lost_after_s, back_after_s = o.estimator.vision_back_after_s;
  double first_lost_s = -1.0, last_lost_s = -1.0, first_vio_after_s = -1.0;
  std::uint32_t reset_before = 0;
  for (std::size_t i = 0; i < r.frame_t_s.size(); ++i) {
    const double t = r.frame_t_s[i];
    REQUIRE(r.frame_finite[i]);
    if (t < 9.9) reset_before = r.frame_reset_counter[i];
    if (t > 9.9) CHECK(r.frame_reset_counter[i] == reset_before);  // no restart, no re-levelling
    const bool lost = r.frame_mode[i] == ums::EstimatorMode::kVisionLost;
    if (lost && first_lost_s < 0.0) first_lost_s = t;
    if (lost) last_lost_s = t;
    if (t >= 13.0 && first_vio_after_s < 0.0 && r.frame_mode[i] == ums::EstimatorMode::kVio) first_vio_after_s = t;
    if (t > 5.0 && t < 10.0) CHECK(r.frame_mode[i] == ums::EstimatorMode::kVio);  // tracking: never lost
  }
  INFO("lost " << first_lost_s << " .. " << last_lost_s << " s, VIO again at " << first_vio_after_s << " s");
  CHECK(first_lost_s >= 10.0 + lost_after_s - 1e-6);
  CHECK(first_lost_s <= 10.0 + lost_after_s + 0.06);  // within a frame (20 Hz)
  CHECK(last_lost_s < 13.0 + back_after_s + 0.5);
  CHECK(first_vio_after_s > 0.0);
  CHECK(first_vio_after_s <= 14.0);
  CHECK(r.vio_frames >= r.frames - 40 - static_cast<int>((3.0 + lost_after_s + 1.0) * 20));
  CHECK(r.ate_m < 0.05);  // m, over the whole cut, blackout included
}

// IMU samples lost for 0.5 s and 2 s in VIO (noisy bearings, noisy IMU): the factors across the
// hole carry the variance of the motion nobody measured, so vision carries the window through;
// the bound is 2x.
// Before, the frames inside the hole got no IMU factor at all (one step of a held sample has a
// singular covariance) and the first factor after it was trusted in full: V102 rendered, 0.5 s
// lost at 20 s, went from 0.0074 to 0.235 m.
TEST_CASE("feature flight: IMU holes of 0.5 s and 2 s keep VIO within 2x of the flight without them", "[estimator][features]") {
  ums::test::FeatureFlightOptions o = noisy_flight("V102", 20.0);
  const ums::test::FeatureFlightResult nominal = ums::test::fly_features(o);
  print("V102 no hole", nominal);
  for (const double hole_s : {0.5, 2.0}) {
    o.imu_gap_start_s = 10.0;
    o.imu_gap_s = hole_s;
    const ums::test::FeatureFlightResult r = ums::test::fly_features(o);
    print(hole_s < 1.0 ? "V102 0.5 s hole" : "V102 2 s hole", r);
    CAPTURE(hole_s);
    check_vio_after(r, 5.0);
    // Measured 1.08x (0.5 s) and 1.83x (2 s: the 10-frame window is vision alone for 1.5 s).
    CHECK(r.ate_m <= (hole_s < 1.0 ? 1.3 : 2.0) * nominal.ate_m);
  }
}

// max_steps_stage 1 (config max_steps_per_solve): each first-round solve ends after its first
// accepted step, without the linearization that most often only finds the next step too small;
// the next frame's solve continues from there. The default exempts keyframes. 0.3 px and the
// IMU's noise, 20 s of V102.
TEST_CASE("feature flight: one accepted step per solve stays within 15 % of solves run to convergence", "[estimator][features]") {
  ums::test::FeatureFlightOptions o = noisy_flight("V102", 20.0);
  o.estimator.max_steps_stage = 0;
  o.estimator.reuse_gauss_newton_matrix = false;
  const ums::test::FeatureFlightResult full = ums::test::fly_features(o);
  print("V102 until converged", full);
  o.estimator.max_steps_stage = 1;
  o.estimator.max_steps_at_keyframes = true;
  const ums::test::FeatureFlightResult one = ums::test::fly_features(o);
  print("V102 one step per solve", one);
  check_vio_after(one, 5.0);
  CHECK(one.ate_m <= 1.15 * full.ate_m);
  CHECK(one.ate_m != full.ate_m);  // the budget took effect
  // Keyframes exempt: their solves end in the linearization the marginalization reuses, so the
  // prior holds converged states and the solve's own terms (none marginalized afresh).
  // (Without the budget 234 of 242 reuse them; the others are VO's and the fallback's.)
  const auto reused_share = [](const ums::test::FeatureFlightResult& r) {
    return static_cast<double>(r.stats.marginalizations_reused) / static_cast<double>(r.stats.marginalized_old);
  };
  CHECK(reused_share(full) > 0.95);
  CHECK(reused_share(one) < 0.5);
  o.estimator.max_steps_at_keyframes = false;
  const ums::test::FeatureFlightResult exempt = ums::test::fly_features(o);
  print("V102 one step, keyframes converged", exempt);
  check_vio_after(exempt, 5.0);
  CHECK(reused_share(exempt) > 0.95);
  CHECK(exempt.ate_m <= 1.05 * full.ate_m);
}

// The second linearization of a solve forms only the gradient (reuse_gauss_newton_matrix): the
// solves still stop where the true gradient vanishes, and the marginalization takes the kept terms
// (the first linearization's information, the gradient of the second).
TEST_CASE("feature flight: the solves' second linearization as a gradient pass, and the defaults, stay within 5 % of whole ones", "[estimator][features]") {
  ums::test::FeatureFlightOptions o = noisy_flight("V102", 20.0);
  o.estimator.max_steps_stage = 0;
  o.estimator.reuse_gauss_newton_matrix = false;
  const ums::test::FeatureFlightResult full = ums::test::fly_features(o);
  o.estimator.reuse_gauss_newton_matrix = true;
  const ums::test::FeatureFlightResult reuse = ums::test::fly_features(o);
  print("V102 gradient pass", reuse);
  check_vio_after(reuse, 5.0);
  CHECK(reuse.ate_m <= 1.05 * full.ate_m);
  CHECK(reuse.ate_m != full.ate_m);  // it took effect
  CHECK(reuse.stats.marginalizations_reused >= reuse.stats.marginalized_old * 95 / 100);
  // The shipped defaults: one step at frames that are not keyframes, the gradient pass in the rest.
  const ums::test::FeatureFlightResult shipped = ums::test::fly_features(noisy_flight("V102", 20.0));
  print("V102 defaults", shipped);
  check_vio_after(shipped, 5.0);
  CHECK(shipped.ate_m <= 1.05 * full.ate_m);
  CHECK(shipped.stats.marginalizations_reused >= shipped.stats.marginalized_old * 95 / 100);
}

// 0.3 px of bearing noise, vision only, 60 s. Rehosting a landmark on its new host's measured ray
// (what VIO does) made these drift 1.03 and 1.77 deg/min of yaw (ATE 0.034 and 0.031 m): every
// keyframe moved the map by the new oldest frame's error. Keeping the points: -0.01 to 0.29
// deg/min, ATE 0.004-0.008 m over seeds 1-4 (docs/results.md "Rehosting").
TEST_CASE("feature flight: noisy bearings, vision only: yaw drifts less than 0.4 deg/min", "[estimator][features]") {
  for (const char* name : {"V101", "V201"}) {
    ums::test::FeatureFlightOptions o = flight(name, 60.0);
    o.vo_only = true;
    o.noise_px = 0.3;
    const ums::test::FeatureFlightResult r = ums::test::fly_features(o);
    print(name, r);
    CHECK(std::abs(r.yaw_drift_deg_min) < 0.4);
    CHECK(r.ate_m < 0.015);
  }
}

// 0.3 px of bearing noise and the calibrated IMU noise, VIO, 60 s. Nothing in VIO sees a turn
// about gravity or a shift of the whole window; before the window was held at its oldest frame
// (Estimator::hold_gauge) these drifted 1.54 and -1.48 deg/min of yaw (ATE 0.0038 and 0.0137 m).
TEST_CASE("feature flight: noisy bearings and IMU, VIO: yaw drifts less than 0.5 deg/min", "[estimator][features]") {
  for (const char* name : {"MH01", "V201"}) {
    ums::test::FeatureFlightOptions o = noisy_flight(name, 60.0);
    const ums::test::FeatureFlightResult r = ums::test::fly_features(o);
    print(name, r);
    CHECK(std::abs(r.yaw_drift_deg_min) < 0.5);
    CHECK(r.ate_m < 0.006);
  }
}

namespace {

double env_num(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v == nullptr ? fallback : std::atof(v);
}

}  // namespace

// A measuring tool, not a test (hidden): one feature flight configured from the environment, e.g.
//   FF_FLIGHT=V102 FF_NOISE=0.3 FF_IMUNOISE=1 FF_SEED=2 test_estimator_sim "[.feature_flight]"
// FF_VO=1 vision only, FF_NOISER right camera's noise, FF_STEREO=0 left only, FF_TRACKS tracked
// features, FF_MARGIN wall margin (m), FF_START / FF_DUR (s), FF_TRACE=1 the error every second.
TEST_CASE("feature flight from the environment", "[.feature_flight]") {
  const char* f = std::getenv("FF_FLIGHT");
  ums::test::FeatureFlightOptions o = flight(f != nullptr ? f : "V101", env_num("FF_DUR", 60.0));
  o.start_s = env_num("FF_START", 0.0);
  o.noise_px = env_num("FF_NOISE", 0.0);
  o.noise_right_px = env_num("FF_NOISER", -1.0);
  o.stereo = env_num("FF_STEREO", 1.0) > 0;
  o.imu_noise = env_num("FF_IMUNOISE", 0.0) > 0;
  o.vo_only = env_num("FF_VO", 0.0) > 0;
  o.max_tracks = static_cast<int>(env_num("FF_TRACKS", 150));
  o.wall_margin_m = env_num("FF_MARGIN", 2.5);
  o.seed = static_cast<std::uint64_t>(env_num("FF_SEED", 1));
  const ums::test::FeatureFlightResult r = ums::test::fly_features(o);
  std::printf("frames %d valid %d vio %d ate %.4f m yaw_drift %.3f deg/min final_rot %.3f deg yaw/heading %.5f\n",
              r.frames, r.valid_frames, r.vio_frames, r.ate_m, r.yaw_drift_deg_min, r.final_rot_err_deg,
              r.yaw_per_heading);
  if (std::getenv("FF_TRACE") != nullptr)
    for (std::size_t i = 0; i < r.t_s.size(); i += 20)
      std::printf("  t %.1f s yaw error %.4f deg heading %.1f deg position error %.4f %.4f %.4f m\n", r.t_s[i],
                  r.yaw_err_deg[i], r.heading_deg[i], r.p_err_m[i].x(), r.p_err_m[i].y(), r.p_err_m[i].z());
  CHECK(r.frames > 0);
}
