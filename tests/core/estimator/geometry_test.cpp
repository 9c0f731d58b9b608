#include "core/estimator/geometry.hpp"

#include <random>

#include <catch2/catch.hpp>

namespace {

constexpr double kFocalPx = 460.0;

// A bearing seen with `noise_px` of image noise (random direction in the tangent plane).
Eigen::Vector3d noisy_bearing(const Eigen::Vector3d& P_c, double noise_px, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, noise_px / kFocalPx);
  const Eigen::Vector3d b = P_c.normalized();
  const Eigen::Vector3d t1 = b.cross(Eigen::Vector3d::UnitX()).normalized();
  const Eigen::Vector3d t2 = b.cross(t1);
  return (b + n(rng) * t1 + n(rng) * t2).normalized();
}

}  // namespace

TEST_CASE("triangulation: stereo and multi-view rays, refused without parallax", "[estimator]") {
  std::mt19937 rng(3);
  const Eigen::Vector3d P_w(0.3, -0.2, 4.0);
  // Stereo pair with an 11 cm baseline, 0.5 px noise: depth error at 4 m is a few cm.
  ums::Ray rays[4];
  rays[0].origin = Eigen::Vector3d::Zero();
  rays[1].origin = Eigen::Vector3d(0.11, 0.0, 0.0);
  for (int k = 0; k < 2; ++k) rays[k].direction = noisy_bearing(P_w - rays[k].origin, 0.5, rng);
  ums::TriangulationResult r = ums::triangulate(rays, 2, 0.1 * M_PI / 180.0);
  REQUIRE(r.ok);
  CHECK((r.p_w - P_w).norm() < 0.2);
  // Two more views 1 m apart: the error drops to millimetres.
  rays[2].origin = Eigen::Vector3d(1.0, 0.0, 0.0);
  rays[3].origin = Eigen::Vector3d(0.5, 0.5, 0.0);
  for (int k = 2; k < 4; ++k) rays[k].direction = noisy_bearing(P_w - rays[k].origin, 0.5, rng);
  r = ums::triangulate(rays, 4, 0.1 * M_PI / 180.0);
  REQUIRE(r.ok);
  CHECK((r.p_w - P_w).norm() < 0.02);
  // Parallax below the threshold (identical origins) is refused rather than guessed.
  rays[1].origin = rays[0].origin;
  rays[1].direction = rays[0].direction;
  CHECK_FALSE(ums::triangulate(rays, 2, 0.1 * M_PI / 180.0).ok);
}

TEST_CASE("PnP on bearings: 1 px noise and 20 % gross outliers, two cameras", "[estimator]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Isometry3d T_b_c[2];
  T_b_c[0] = Eigen::Isometry3d::Identity();
  T_b_c[0].linear() = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();  // camera looks along body y
  T_b_c[1] = T_b_c[0];
  T_b_c[1].translation() = Eigen::Vector3d(0.11, 0.0, 0.0);
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 0.3, 1.0).normalized()).toRotationMatrix();
  T_w_b.translation() = Eigen::Vector3d(1.0, 2.0, 0.5);

  std::vector<ums::PnpMatch> m;
  int outliers = 0;
  for (int k = 0; k < 120; ++k) {
    const Eigen::Vector3d P_c(2.0 * u(rng), 1.5 * u(rng), 3.0 + 2.0 * (u(rng) + 1.0));
    const std::uint8_t cam = static_cast<std::uint8_t>(k % 2);
    ums::PnpMatch match;
    match.cam = cam;
    match.p_w = T_w_b * (T_b_c[cam] * P_c);
    match.bearing = noisy_bearing(P_c, 1.0, rng);
    if (k % 5 == 0) {  // gross outlier: a random direction in the field of view
      match.bearing = Eigen::Vector3d(u(rng), u(rng), 1.5).normalized();
      ++outliers;
    }
    m.push_back(match);
  }
  // The prior is 10 cm and 3 degrees off (a rough constant-velocity prediction).
  Eigen::Isometry3d T = T_w_b;
  T.translation() += Eigen::Vector3d(0.06, -0.05, 0.06);
  T.linear() = T.linear() * Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d(1, 0, 1).normalized()).toRotationMatrix();
  std::vector<std::uint8_t> mask(m.size());
  ums::PnpOptions o;
  const ums::PnpResult r = ums::solve_pnp(m.data(), static_cast<int>(m.size()), T_b_c, o, &T, mask.data());
  REQUIRE(r.ok);
  const double err_m = (T.translation() - T_w_b.translation()).norm();
  const double err_deg = Eigen::AngleAxisd(T.linear().transpose() * T_w_b.linear()).angle() * 180.0 / M_PI;
  // The same solver started at the truth gives the optimum of this noisy data set: RANSAC from a
  // poor prior must find the same optimum, which itself is within the noise of the truth.
  Eigen::Isometry3d T_ref = T_w_b;
  REQUIRE(ums::solve_pnp(m.data(), static_cast<int>(m.size()), T_b_c, o, &T_ref, nullptr).ok);
  const double ref_m = (T_ref.translation() - T_w_b.translation()).norm();
  const double diff_m = (T.translation() - T_ref.translation()).norm();
  const double diff_deg = Eigen::AngleAxisd(T.linear().transpose() * T_ref.linear()).angle() * 180.0 / M_PI;
  INFO("position error " << err_m << " m (optimum " << ref_m << " m), rotation error " << err_deg << " deg, inliers "
                         << r.inliers << ", from the optimum " << diff_m << " m " << diff_deg << " deg");
  CHECK(diff_m < 1e-3);
  CHECK(diff_deg < 0.01);
  CHECK(err_m < 0.03);
  CHECK(err_deg < 0.3);
  CHECK(r.inliers >= 120 - outliers - 4);
  CHECK(r.rms_rad * kFocalPx < 1.6);  // about the 1 px noise (2-D: sqrt(2) px)
  int outliers_flagged = 0;
  for (std::size_t k = 0; k < m.size(); k += 5) outliers_flagged += mask[k] == 0 ? 1 : 0;
  CHECK(outliers_flagged >= outliers - 2);
}

TEST_CASE("PnP refuses too few matches", "[estimator]") {
  ums::PnpMatch m[5];
  Eigen::Isometry3d T_b_c[2] = {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  CHECK_FALSE(ums::solve_pnp(m, 5, T_b_c, ums::PnpOptions(), &T, nullptr).ok);
}
