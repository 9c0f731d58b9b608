#include "profiling/eval/alignment.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace ums::eval;

namespace {
std::vector<Eigen::Vector3d> random_points(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n; ++i) p.emplace_back(u(rng), u(rng), 0.3 * u(rng));
  return p;
}
}  // namespace

TEST_CASE("Umeyama recovers a known SE(3), Sim(3) and yaw transform exactly", "[eval][alignment]") {
  const auto x = random_points(40, 7);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.5, 1.0).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(1.0, -2.0, 0.5);
  for (double s : {1.0, 0.37}) {
    std::vector<Eigen::Vector3d> y;
    for (const auto& p : x) y.push_back(s * (R * p) + t);
    const Alignment a = align(x, y, s == 1.0 ? AlignMode::kSe3 : AlignMode::kSim3);
    CHECK(a.scale == Approx(s).epsilon(1e-12));
    CHECK((a.R_gt_est - R).norm() < 1e-10);
    CHECK((a.t_gt_est - t).norm() < 1e-10);
  }
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(-2.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::vector<Eigen::Vector3d> y;
  for (const auto& p : x) y.push_back(Rz * p + t);
  const Alignment a = align(x, y, AlignMode::kPosYaw);
  CHECK((a.R_gt_est - Rz).norm() < 1e-10);
  CHECK((a.t_gt_est - t).norm() < 1e-10);
  // Position+yaw cannot absorb a tilt: a 5-degree roll leaves a residual.
  const Eigen::Matrix3d Rt = Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::vector<Eigen::Vector3d> yt;
  for (const auto& p : x) yt.push_back(Rt * p);
  const Alignment b = align(x, yt, AlignMode::kPosYaw);
  double res = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) res = std::max(res, (b.apply(x[i]) - yt[i]).norm());
  CHECK(res > 0.05);
}

TEST_CASE("align mode names parse both ways", "[eval][alignment]") {
  for (AlignMode m : {AlignMode::kNone, AlignMode::kSe3, AlignMode::kSim3, AlignMode::kPosYaw}) {
    AlignMode back = AlignMode::kNone;
    REQUIRE(parse_align_mode(align_mode_name(m), &back));
    CHECK(back == m);
  }
  AlignMode m;
  CHECK_FALSE(parse_align_mode("SE3x", &m));
}
