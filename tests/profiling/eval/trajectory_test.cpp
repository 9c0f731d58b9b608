#include "profiling/eval/trajectory.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>

#include "tests/common/test_paths.hpp"

using namespace ums::eval;

TEST_CASE("TUM round trip keeps nanosecond stamps and poses", "[eval][trajectory]") {
  const std::string dir = ums::test::make_temp_dir("eval_tum_roundtrip");
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.t_ns = 1403715274312143104LL + i * 50'000'001LL;
    p.p_w_x = {0.1 * i, -2.0 + i, 3.5};
    p.q_w_x = Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d(1, 2, 3).normalized()));
    t.poses.push_back(p);
  }
  write_tum(dir + "/a.tum", t);
  const Trajectory r = read_trajectory(dir + "/a.tum");
  REQUIRE(r.frame == PoseFrame::kBody);
  REQUIRE(r.poses.size() == 5);
  for (int i = 0; i < 5; ++i) {
    CHECK(r.poses[i].t_ns == t.poses[i].t_ns);
    CHECK((r.poses[i].p_w_x - t.poses[i].p_w_x).norm() < 1e-8);
    CHECK(r.poses[i].q_w_x.angularDistance(t.poses[i].q_w_x) < 1e-8);
  }
}

TEST_CASE("shared *_GT.txt reads as cam0 with q = R_CW inverted", "[eval][trajectory]") {
  const Trajectory gt = read_trajectory(ums::test::groundtruth_dir() + "/V101_GT.txt");
  REQUIRE(gt.frame == PoseFrame::kCam0);
  REQUIRE(gt.poses.size() == 2871);
  // First row: 1403715274312143104, 0.8687393558, 2.2070275302, 0.9257726725, qw .4259596512 ...
  CHECK(gt.poses[0].t_ns == 1403715274312143104LL);
  CHECK(gt.poses[0].p_w_x.x() == Approx(0.8687393558));
  const Eigen::Quaterniond q_cw(0.4259596512, 0.6262011737, -0.5441421096, 0.361026079545);
  CHECK(gt.poses[0].q_w_x.angularDistance(q_cw.normalized().conjugate()) < 1e-9);
  // The vehicle rests at the start: the accelerometer measures "up" in the body frame. The first
  // real sample of V1_01 (imu0/data.csv) reads (9.0875, 0.1308, -3.6938) m/s^2; the ground truth
  // moved to the body with T_BS must point world z along it within a few degrees.
  const Trajectory body = change_frame(gt, euroc_T_b_c0().inverse(), PoseFrame::kBody);
  const Eigen::Vector3d up_in_body = body.poses[0].q_w_x.conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d accel(9.0874956666666655, 0.13075533333333333, -3.6938381666666662);
  const double angle_deg = std::acos(up_in_body.dot(accel.normalized())) * 180.0 / M_PI;
  CHECK(angle_deg < 3.0);
}

TEST_CASE("EuRoC csv (17 columns) reads as body and T_BS parses from sensor.yaml", "[eval][trajectory]") {
  const std::string dir = ums::test::make_temp_dir("eval_euroc_csv");
  {
    std::ofstream f(dir + "/data.csv");
    f << "#timestamp,p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z [],v_x,v_y,v_z,"
         "bw_x,bw_y,bw_z,ba_x,ba_y,ba_z\n";
    f << "1000000000,1,2,3,0.70710678,0,0,0.70710678,0,0,0,0,0,0,0,0,0\n";
    f << "1005000000,1.1,2,3,1,0,0,0,0,0,0,0,0,0,0,0,0\n";
  }
  const Trajectory t = read_trajectory(dir + "/data.csv");
  REQUIRE(t.frame == PoseFrame::kBody);
  REQUIRE(t.poses.size() == 2);
  CHECK(t.poses[0].t_ns == 1000000000LL);
  // q (w,x,y,z) = 90 deg about z: body x maps to world y.
  CHECK(((t.poses[0].q_w_x * Eigen::Vector3d::UnitX()) - Eigen::Vector3d::UnitY()).norm() < 1e-6);

  const Eigen::Isometry3d T = read_T_BS(ums::test::euroc_micro_dir() + "/mav0/cam0/sensor.yaml");
  CHECK((T.matrix() - euroc_T_b_c0().matrix()).norm() < 1e-9);
  CHECK_THROWS_WITH(read_trajectory(dir + "/missing.csv"), Catch::Contains("missing.csv"));
}

TEST_CASE("to_frame moves body <-> cam0 only when the frames differ", "[eval][trajectory]") {
  Trajectory body;
  StampedPose p;
  p.t_ns = 5;
  p.p_w_x = {1.0, 2.0, 3.0};
  p.q_w_x = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0, 1, 1).normalized()));
  body.poses.push_back(p);
  const Eigen::Isometry3d T_b_c0 = euroc_T_b_c0();
  const Trajectory same = to_frame(body, PoseFrame::kBody, T_b_c0);
  CHECK(same.poses[0].p_w_x == body.poses[0].p_w_x);
  const Trajectory cam = to_frame(body, PoseFrame::kCam0, T_b_c0);
  REQUIRE(cam.frame == PoseFrame::kCam0);
  // T_w_c0 = T_w_b T_b_c0: the camera sits at p + R t_b_c0.
  CHECK((cam.poses[0].p_w_x - (p.p_w_x + p.q_w_x * T_b_c0.translation())).norm() < 1e-12);
  const Trajectory back = to_frame(cam, PoseFrame::kBody, T_b_c0);
  CHECK(back.frame == PoseFrame::kBody);
  CHECK((back.poses[0].p_w_x - p.p_w_x).norm() < 1e-12);
  CHECK(back.poses[0].q_w_x.angularDistance(p.q_w_x) < 1e-12);
}

// Found by tests/fuzz/trajectory_fuzz: a stamp of 1e20 s overflowed int64 nanoseconds (UB).
TEST_CASE("a TUM stamp beyond int64 nanoseconds is refused naming file and line", "[eval][trajectory][fuzz]") {
  const std::string dir = ums::test::make_temp_dir("eval_tum_huge_stamp");
  for (const std::string stamp : {"222222222222222222221.1", "9223372036854775807", "-99999999999.5"}) {
    const std::string path = dir + "/huge.txt";
    std::ofstream(path) << "1.0 0 0 0 0 0 0 1\n" << stamp << " 0.1 0 0 0 0 0 1\n";
    CHECK_THROWS_WITH(read_tum(path), Catch::Contains("huge.txt:2: time out of range"));
  }
}
