#include "profiling/eval/eval_command.hpp"

#include <catch2/catch.hpp>

#include <fstream>
#include <sstream>

#include "tests/common/test_paths.hpp"

using namespace ums::eval;

// The shared ground truth is cam0; the estimator writes the body. A perfect body estimate made
// from the ground truth with the inverse EuRoC T_BS must evaluate to zero error, which proves the
// body -> cam0 move; the same estimate displaced by 3 cm in the body frame gives ATE = 3 cm after
// no alignment (the lever arm turns with the body, so its world norm stays 3 cm).
TEST_CASE("eval moves a body estimate to cam0 with T_BS and prints ATE/RPE", "[eval][command]") {
  const std::string dir = ums::test::make_temp_dir("eval_command");
  const std::string gt_path = ums::test::groundtruth_dir() + "/V102_GT.txt";
  const Trajectory gt = read_trajectory(gt_path);
  const Trajectory body = change_frame(gt, euroc_T_b_c0().inverse(), PoseFrame::kBody);
  write_tum(dir + "/est.tum", body);

  EvalOptions o;
  o.estimate_path = dir + "/est.tum";
  o.groundtruth_path = gt_path;
  o.align = AlignMode::kSe3;
  std::ostringstream out;
  std::string err;
  EvalResult r;
  REQUIRE(run_eval(o, out, &err, &r) == 0);
  INFO(out.str());
  CHECK(r.matched == gt.poses.size());
  CHECK(r.ate.translation_m.rmse < 1e-6);
  CHECK(r.ate.rotation_deg.max < 1e-4);
  CHECK(out.str().find("ATE trans [m]: rmse 0.0000") != std::string::npos);
  CHECK(out.str().find("RPE  10.0 m") != std::string::npos);

  Eigen::Isometry3d lever = Eigen::Isometry3d::Identity();
  lever.translation() = Eigen::Vector3d(0.0, 0.03, 0.0);
  write_tum(dir + "/est_off.tum", change_frame(body, lever, PoseFrame::kBody));
  o.estimate_path = dir + "/est_off.tum";
  o.align = AlignMode::kNone;
  std::ostringstream out2;
  REQUIRE(run_eval(o, out2, &err, &r) == 0);
  CHECK(r.ate.translation_m.mean == Approx(0.03).epsilon(1e-6));
  CHECK(r.ate.translation_m.max == Approx(0.03).epsilon(1e-6));

  o.estimate_path = dir + "/nope.tum";
  std::ostringstream out3;
  CHECK(run_eval(o, out3, &err, nullptr) == 1);
  CHECK(err.find("nope.tum") != std::string::npos);
}

// The error budget rides along: printed after RPE (existing lines unchanged), and with json_path
// the same figures as JSON. A perfect estimate has 0 m in every phase; with the timeline the VO
// and VIO phases split the matched poses at the change.
TEST_CASE("eval prints the error budget and writes eval.json", "[eval][command][budget]") {
  const std::string dir = ums::test::make_temp_dir("eval_command_budget");
  const std::string gt_path = ums::test::groundtruth_dir() + "/V102_GT.txt";
  const Trajectory gt = read_trajectory(gt_path);
  write_tum(dir + "/est.tum", change_frame(gt, euroc_T_b_c0().inverse(), PoseFrame::kBody));

  EvalOptions o;
  o.estimate_path = dir + "/est.tum";
  o.groundtruth_path = gt_path;
  o.json_path = dir + "/eval.json";
  ModeTimeline tl;
  tl.origin_known = true;
  tl.origin_t_ns = gt.poses.front().t_ns;
  tl.changes = {{0, "VO"}, {10'000'000'000LL, "VIO"}};
  o.modes = tl;
  std::ostringstream out;
  std::string err;
  EvalResult r;
  ErrorBudget b;
  REQUIRE(run_eval(o, out, &err, &r, &b) == 0);
  const std::string text = out.str();
  INFO(text);
  CHECK(text.find("ATE trans [m]: rmse 0.0000") != std::string::npos);
  CHECK(text.find("error budget (global SE(3) over " + std::to_string(r.matched) + " matched poses") !=
        std::string::npos);
  CHECK(text.find("  VO      : ATE rmse 0.0000 m over") != std::string::npos);
  CHECK(text.find("  VIO     : ATE rmse 0.0000 m over") != std::string::npos);
  CHECK(text.find("  IMU_ONLY: no matched pose") != std::string::npos);
  CHECK(text.find("scale error (sim3): +0.000 %") != std::string::npos);
  CHECK(b.phases.at(1).poses + b.phases.at(2).poses == r.matched);
  CHECK(b.final_drift_m < 1e-6);

  std::ifstream f(o.json_path);
  std::stringstream json;
  json << f.rdbuf();
  for (const char* key : {"\"align\": \"se3\"", "\"matched_poses\": ", "\"trans_m\": {", "\"rpe\": [", "\"budget\": {",
                          "\"has_phases\": true", "\"VO\": {", "\"VIO\": {", "\"share_of_ate2\": ",
                          "\"scale_error_pct\": ", "\"yaw_drift_deg_per_min\": ", "\"final_drift_pct\": ",
                          "\"worst_window\": {", "\"start_s\": "}) {
    INFO(key);
    CHECK(json.str().find(key) != std::string::npos);
  }

  // No timeline: still a budget, without the split, and it says so.
  o.modes.reset();
  std::ostringstream out2;
  REQUIRE(run_eval(o, out2, &err, &r, &b) == 0);
  CHECK(out2.str().find("per mode: no split") != std::string::npos);
  CHECK_FALSE(b.has_phases);
}
