#include "profiling/eval/error_budget.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>

using namespace ums::eval;

namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr std::int64_t kT0 = 1'000'000'000'000LL;  // ns, first pose (any absolute stamp)
constexpr std::int64_t kDt = 50'000'000LL;         // ns, 20 Hz

double t_of(int k) { return static_cast<double>(k) * 0.05; }

// Ground truth: a 3D loop flown every 10 s (200 poses per loop), so every loop visits exactly the
// same positions; heading follows the loop, with a small roll.
Trajectory loop_groundtruth(int poses) {
  Trajectory gt;
  for (int k = 0; k < poses; ++k) {
    const double th = 2.0 * M_PI * static_cast<double>(k % 200) / 200.0;
    StampedPose p;
    p.t_ns = kT0 + k * kDt;
    p.p_w_x = {2.0 * std::cos(th), 1.5 * std::sin(th), 1.0 + 0.5 * std::sin(2.0 * th)};
    p.q_w_x = Eigen::AngleAxisd(th + M_PI / 2, Eigen::Vector3d::UnitZ()) *
              Eigen::AngleAxisd(0.1 * std::sin(th), Eigen::Vector3d::UnitX());
    gt.poses.push_back(p);
  }
  return gt;
}

// The VIO gauge: an estimate lives in its own world, yawed and shifted against the truth's.
struct Gauge {
  Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Vector3d t{5.0, -3.0, 1.0};
};

StampedPose in_gauge(const Gauge& g, const StampedPose& p) {
  StampedPose o = p;
  o.p_w_x = g.R * p.p_w_x + g.t;
  o.q_w_x = Eigen::Quaterniond(g.R) * p.q_w_x;
  return o;
}

// origin = first pose - 1 frame (the replay's first frame has no pose); changes at absolute stamps.
ModeTimeline timeline(std::initializer_list<std::pair<std::int64_t, const char*>> changes) {
  ModeTimeline tl;
  tl.origin_known = true;
  tl.origin_t_ns = kT0 - kDt;
  for (const auto& c : changes) tl.changes.push_back({c.first - tl.origin_t_ns, c.second});
  return tl;
}

}  // namespace

// 10 loops (100 s); VO during the first loop (10 % of the poses, f = 0.1), VIO after; the estimate
// carries a constant offset o, |o| = 2 cm, during VO only. Because the VO loop visits the same
// positions as every VIO loop, no rotation reduces the error and the best SE(3) removes the gauge
// and shifts by the mean offset f o. By hand: VO rmse = (1 - f)|o| = 0.018 m, VIO rmse = f|o| =
// 0.002 m, whole flight sqrt(f (1 - f)) |o| = 0.006 m, shares of ATE^2 (1 - f) = 0.9 and f = 0.1.
TEST_CASE("a 2 cm offset during VO only lands in the VO phase", "[eval][budget]") {
  const Trajectory gt = loop_groundtruth(2000);
  const Eigen::Vector3d offset = 0.02 * Eigen::Vector3d(1, 2, 2) / 3.0;
  Trajectory est;
  for (int k = 0; k < 2000; ++k) {
    StampedPose p = gt.poses[k];
    if (k < 200) p.p_w_x += offset;
    est.poses.push_back(in_gauge(Gauge{}, p));
  }
  const ModeTimeline tl = timeline({{kT0, "VO"}, {kT0 + 200 * kDt, "VIO"}});
  const ErrorBudget b = compute_error_budget(est, gt, &tl, BudgetOptions{});
  REQUIRE(b.has_phases);
  REQUIRE(b.phases.size() == 3);
  CHECK(b.origin_is_first_frame);
  CHECK(b.ate_rmse_m == Approx(0.006).margin(1e-9));
  const PhaseError& imu = b.phases[0];
  const PhaseError& vo = b.phases[1];
  const PhaseError& vio = b.phases[2];
  CHECK(imu.mode == "IMU_ONLY");
  CHECK(imu.poses == 0);
  CHECK(imu.duration_s == 0.0);
  CHECK(vo.mode == "VO");
  CHECK(vo.poses == 200);
  CHECK(vo.duration_s == Approx(10.0).margin(1e-9));
  CHECK(vo.ate_rmse_m == Approx(0.018).margin(1e-9));
  CHECK(vo.share_of_ate2 == Approx(0.9).margin(1e-9));
  CHECK(vio.mode == "VIO");
  CHECK(vio.poses == 1800);
  CHECK(vio.duration_s == Approx(89.95).margin(1e-9));  // last pose at 99.95 s after the first
  CHECK(vio.ate_rmse_m == Approx(0.002).margin(1e-9));
  CHECK(vio.share_of_ate2 == Approx(0.1).margin(1e-9));
  // The figures add up in the RMS sense.
  CHECK(vo.share_of_ate2 + vio.share_of_ate2 == Approx(1.0).margin(1e-12));
  // The two 5 s windows inside VO (from 0.05 s and 5.05 s after the origin, one frame before the
  // first pose) have 1.8 cm each, to rounding; every window reaching into VIO has less.
  REQUIRE(b.worst.found);
  CHECK((b.worst.start_s == Approx(0.05).margin(1e-12) || b.worst.start_s == Approx(5.05).margin(1e-12)));
  CHECK(b.worst.rmse_m == Approx(0.018).margin(1e-9));
  CHECK(b.worst.poses == 100);
  CHECK(b.worst.mode == "VO");
  CHECK(b.worst.mode_share == 1.0);
}

// Sim(3) of an estimate 1 % too large: s = 1 / 1.01 exactly, scale error 100 (1/s - 1) = +1 %;
// 1 % too small: -1 %.
TEST_CASE("a 1 % scaled estimate gives a 1 % scale error", "[eval][budget]") {
  const Trajectory gt = loop_groundtruth(400);
  for (const double factor : {1.01, 0.99}) {
    Trajectory est;
    for (const StampedPose& g : gt.poses) {
      StampedPose p = g;
      p.p_w_x *= factor;
      est.poses.push_back(in_gauge(Gauge{}, p));
    }
    const ErrorBudget b = compute_error_budget(est, gt, nullptr, BudgetOptions{});
    CHECK(b.sim3_scale == Approx(1.0 / factor).epsilon(1e-10));
    CHECK(b.scale_error_pct == Approx(100.0 * (factor - 1.0)).margin(1e-8));
  }
}

// The estimate's attitude turns away from the truth at 1 deg/min about world z, from a gauge yaw
// of 179.9 deg (the yaw error crosses +-180 deg: unwrapping is exercised). The anchor takes the
// mean yaw over the first 10 s, i.e. the yaw at t = 5 s, so by hand: yaw error at the end =
// 1 deg/min * (299.95 - 5) s = 4.915833 deg; drift (least-squares slope) = 1 deg/min.
TEST_CASE("a yaw turning at 1 deg/min gives a yaw drift of 1 deg/min", "[eval][budget]") {
  const Trajectory gt = loop_groundtruth(6000);  // 5 min
  const double gauge_rad = 179.9 * kDegToRad, rate_rad_s = 1.0 / 60.0 * kDegToRad;
  Trajectory est;
  for (int k = 0; k < 6000; ++k) {
    StampedPose p = gt.poses[k];
    p.p_w_x = Eigen::AngleAxisd(gauge_rad, Eigen::Vector3d::UnitZ()) * p.p_w_x;
    p.q_w_x = Eigen::AngleAxisd(gauge_rad + rate_rad_s * t_of(k), Eigen::Vector3d::UnitZ()) * p.q_w_x;
    est.poses.push_back(p);
  }
  const ErrorBudget b = compute_error_budget(est, gt, nullptr, BudgetOptions{});
  CHECK(b.anchor_s == Approx(10.0).margin(1e-12));
  CHECK(b.yaw_drift_deg_per_min == Approx(1.0).margin(1e-6));
  CHECK(b.yaw_error_end_deg == Approx((299.95 - 5.0) / 60.0).margin(1e-6));
}

// Positions drifting at 1 mm/s (attitudes exact, in a yawed gauge): the anchor translation is the
// mean over the first 10 s, i.e. the drift at 5 s, so the last pose is off by 1 mm/s * (99.95 - 5) s
// = 0.09495 m; in percent of the ground-truth path length (10 loops of the polyline).
TEST_CASE("a position drifting at 1 mm/s gives the final drift in % of the distance", "[eval][budget]") {
  const Trajectory gt = loop_groundtruth(2000);
  const Eigen::Vector3d v_m_s(0.0006, -0.0008, 0.0);  // |v| = 1 mm/s
  Trajectory est;
  for (int k = 0; k < 2000; ++k) {
    StampedPose p = gt.poses[k];
    p.p_w_x += v_m_s * t_of(k);
    est.poses.push_back(in_gauge(Gauge{}, p));
  }
  double distance_m = 0.0;
  for (int k = 1; k < 2000; ++k) distance_m += (gt.poses[k].p_w_x - gt.poses[k - 1].p_w_x).norm();
  const ErrorBudget b = compute_error_budget(est, gt, nullptr, BudgetOptions{});
  CHECK(b.yaw_error_end_deg == Approx(0.0).margin(1e-9));
  CHECK(b.yaw_drift_deg_per_min == Approx(0.0).margin(1e-9));
  CHECK(b.final_drift_m == Approx(0.09495).margin(1e-9));
  CHECK(b.distance_m == Approx(distance_m).epsilon(1e-12));
  CHECK(b.final_drift_pct == Approx(100.0 * 0.09495 / distance_m).epsilon(1e-9));
}

// 30 s flight, VO for the first 5 s then VIO; +-3 cm alternating in z (zero mean, so the global
// alignment cannot absorb it) on the poses from 12 s to 17 s after the first. The worst 5 s window
// is exactly that burst: start 12.05 s after the first frame (origin one frame before the first
// pose), rmse 3 cm to the alignment's leak, in VIO.
TEST_CASE("a 5 s burst of error is found as the worst 5 s, at its time and mode", "[eval][budget]") {
  const Trajectory gt = loop_groundtruth(600);
  Trajectory est;
  for (int k = 0; k < 600; ++k) {
    StampedPose p = gt.poses[k];
    if (k >= 240 && k < 340) p.p_w_x.z() += k % 2 == 0 ? 0.03 : -0.03;
    est.poses.push_back(in_gauge(Gauge{}, p));
  }
  const ModeTimeline tl = timeline({{kT0, "VO"}, {kT0 + 100 * kDt, "VIO"}});
  const ErrorBudget b = compute_error_budget(est, gt, &tl, BudgetOptions{});
  REQUIRE(b.worst.found);
  CHECK(b.worst.start_s == Approx(12.05).margin(1e-9));
  CHECK(b.worst.end_s == Approx(17.05).margin(1e-9));
  CHECK(b.worst.start_t_ns == kT0 + 240 * kDt);
  CHECK(b.worst.poses == 100);
  CHECK(b.worst.rmse_m == Approx(0.03).margin(3e-4));
  CHECK(b.worst.mode == "VIO");
  CHECK(b.worst.mode_share == 1.0);

  // Without a timeline: the same window, times from the first pose, and no mode.
  const ErrorBudget n = compute_error_budget(est, gt, nullptr, BudgetOptions{});
  CHECK_FALSE(n.has_phases);
  CHECK(n.phases.empty());
  CHECK(n.worst.start_s == Approx(12.0).margin(1e-9));
  CHECK(n.worst.mode.empty());
  std::ostringstream text;
  print_error_budget(n, text);
  CHECK(text.str().find("no split (no mode timeline: pass --stats") != std::string::npos);
  CHECK(text.str().find("worst 5.0 s: 12.00-17.00 s, rmse 0.030") != std::string::npos);
}

TEST_CASE("budget edge cases: short flights and too few poses", "[eval][budget]") {
  const Trajectory gt = loop_groundtruth(80);  // 3.95 s: shorter than the 5 s window
  const ErrorBudget b = compute_error_budget(gt, gt, nullptr, BudgetOptions{});
  CHECK_FALSE(b.worst.found);
  CHECK(b.anchor_s == Approx(3.95).margin(1e-12));  // the whole flight anchors
  CHECK(b.ate_rmse_m < 1e-12);
  std::ostringstream text;
  print_error_budget(b, text);
  CHECK(text.str().find("flight shorter than the window") != std::string::npos);

  Trajectory two = gt;
  two.poses.resize(2);
  CHECK_THROWS_WITH(compute_error_budget(two, two, nullptr, BudgetOptions{}), Catch::Contains("only 2 poses"));
  BudgetOptions bad;
  bad.window_s = 0.0;
  CHECK_THROWS(compute_error_budget(gt, gt, nullptr, bad));
}
