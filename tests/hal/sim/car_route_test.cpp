#include "hal/sim/car_route.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace ums::sim;

namespace {

constexpr double kDt_s = 0.05;
constexpr double kKmh = 3.6;  // km/h per m/s
constexpr double kRadToDeg = 180.0 / M_PI;

double horizontal_speed_m_s(const CarPose& a, const CarPose& b) {
  return (b.p_w_c - a.p_w_c).head<2>().norm() / (b.t_s - a.t_s);
}

// Camera pitch (optical axis above the horizon) and roll (image x axis off the horizontal), deg.
double pitch_deg(const CarPose& p) { return std::asin(p.R_w_c.col(2).z()) * kRadToDeg; }
double roll_deg(const CarPose& p) { return std::asin(p.R_w_c.col(0).z()) * kRadToDeg; }

double yaw_rad(const CarPose& p) { return std::atan2(p.R_w_c.col(2).y(), p.R_w_c.col(2).x()); }

double distance_m(const std::vector<CarPose>& poses) {
  double d = 0.0;
  for (std::size_t k = 2; k + 1 < poses.size(); ++k) d += (poses[k].p_w_c - poses[k - 1].p_w_c).head<2>().norm();
  return d;
}

}  // namespace

TEST_CASE("car routes: speed 15-25 km/h, planar, camera 1.4 m high looking along the travel", "[sim][car]") {
  for (CarRoute route : {CarRoute::kTurn, CarRoute::kLoop}) {
    const std::vector<CarPose> poses = car_camera_poses(route, kDt_s);
    REQUIRE(poses.size() > 100);
    double v_min = 1e9, v_max = 0.0, z_min = 1e9, z_max = -1e9, tilt_max = 0.0, heading_err_max = 0.0;
    for (std::size_t k = 1; k < poses.size(); ++k) {
      const double v = horizontal_speed_m_s(poses[k - 1], poses[k]);
      v_min = std::min(v_min, v);
      v_max = std::max(v_max, v);
      z_min = std::min(z_min, poses[k].p_w_c.z());
      z_max = std::max(z_max, poses[k].p_w_c.z());
      tilt_max = std::max({tilt_max, std::abs(pitch_deg(poses[k])), std::abs(roll_deg(poses[k]))});
      // The optical axis along the travel direction (chord of one knot), horizontally.
      const Eigen::Vector2d travel = (poses[k].p_w_c - poses[k - 1].p_w_c).head<2>().normalized();
      const Eigen::Vector2d axis_mid =
          (poses[k].R_w_c.col(2) + poses[k - 1].R_w_c.col(2)).head<2>().normalized();
      heading_err_max = std::max(heading_err_max, std::acos(std::min(1.0, travel.dot(axis_mid))) * kRadToDeg);
    }
    INFO("route " << static_cast<int>(route) << ": " << v_min * kKmh << ".." << v_max * kKmh << " km/h, z " << z_min
                  << ".." << z_max << " m, tilt " << tilt_max << " deg, heading " << heading_err_max << " deg");
    CHECK(v_min * kKmh >= 15.0);
    CHECK(v_max * kKmh <= 25.0);
    CHECK(z_min >= kCarCameraHeight_m - 0.015);
    CHECK(z_max <= kCarCameraHeight_m + 0.015);
    CHECK(z_max - z_min > 0.005);  // the bumps are there
    CHECK(tilt_max < 0.5);
    CHECK(heading_err_max < 0.5);
  }
}

TEST_CASE("car-turn: 25 m of uniform motion, a 90 deg turn of radius 9 m, ~60 m", "[sim][car]") {
  const std::vector<CarPose> poses = car_camera_poses(CarRoute::kTurn, kDt_s);
  CHECK(distance_m(poses) == Approx(60.0).margin(1.0));
  CHECK(car_route_length_m(CarRoute::kTurn) == Approx(60.0).margin(1.0));
  // Uniform start: every pose before 25 m has the first pose's attitude and height, the steps are
  // equal (constant velocity; the knot before the start too).
  int uniform = 0;
  const Eigen::Vector3d step0 = poses[1].p_w_c - poses[0].p_w_c;
  for (std::size_t k = 1; k < poses.size() && poses[k].s_m < car_uniform_length_m(CarRoute::kTurn); ++k) {
    CHECK((poses[k].R_w_c - poses[0].R_w_c).norm() < 1e-12);
    CHECK((poses[k].p_w_c - poses[k - 1].p_w_c - step0).norm() < 1e-9);
    ++uniform;
  }
  CHECK(uniform * step0.norm() == Approx(25.0).margin(0.3));
  // Curvature: heading change over distance between knots; the tightest radius and the total turn.
  double r_min = 1e9;
  for (std::size_t k = 2; k < poses.size(); ++k) {
    const double dyaw = std::remainder(yaw_rad(poses[k]) - yaw_rad(poses[k - 2]), 2.0 * M_PI);
    const double ds = poses[k].s_m - poses[k - 2].s_m;
    if (std::abs(dyaw) > 1e-6) r_min = std::min(r_min, ds / std::abs(dyaw));
  }
  CHECK(r_min == Approx(kCarCornerRadius_m).epsilon(0.03));
  const double turn_deg = std::remainder(yaw_rad(poses.back()) - yaw_rad(poses.front()), 2.0 * M_PI) * kRadToDeg;
  CHECK(turn_deg == Approx(90.0).margin(0.3));
}

TEST_CASE("car-loop: a closed 80 m x 50 m rounded rectangle, speed varying", "[sim][car]") {
  const std::vector<CarPose> poses = car_camera_poses(CarRoute::kLoop, kDt_s);
  const double lap_m = car_route_length_m(CarRoute::kLoop) - 15.0;
  CHECK(distance_m(poses) == Approx(lap_m + 15.0).margin(2.0));
  CHECK(lap_m > 200.0);
  CHECK(lap_m < 300.0);
  Eigen::Vector2d lo = poses[1].p_w_c.head<2>(), hi = lo;
  double v_min = 1e9, v_max = 0.0;
  const CarPose* after_lap = nullptr;
  for (std::size_t k = 1; k < poses.size(); ++k) {
    lo = lo.cwiseMin(poses[k].p_w_c.head<2>());
    hi = hi.cwiseMax(poses[k].p_w_c.head<2>());
    const double v = horizontal_speed_m_s(poses[k - 1], poses[k]);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
    if (!after_lap && poses[k].s_m >= lap_m) after_lap = &poses[k];
  }
  CHECK(hi.x() - lo.x() == Approx(80.0).margin(1.0));
  CHECK(hi.y() - lo.y() == Approx(50.0).margin(1.0));
  CHECK((v_max - v_min) * kKmh > 6.0);  // "speed varying": several km/h apart
  // Closed: one lap on, the car is back at its start (within one knot's travel) with its heading.
  REQUIRE(after_lap != nullptr);
  const CarPose& start = poses[1];
  CHECK((after_lap->p_w_c - start.p_w_c).head<2>().norm() < 0.4);
  CHECK(std::abs(std::remainder(yaw_rad(*after_lap) - yaw_rad(start), 2.0 * M_PI)) * kRadToDeg < 0.5);
}
