#include "hal/sim/car_route.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace ums::sim {
namespace {

constexpr double kRamp_m = 3.0;        // curvature ramp into and out of a corner, m
constexpr double kStep_m = 0.005;      // integration step along the road, m
constexpr double kDegToRad = M_PI / 180.0;

// A piece of road whose curvature goes linearly from the previous piece's end value to this one.
struct RoadPiece {
  double length_m;
  double curvature_end_1_m;
};

// Appends a 90 deg left corner: ramp in, constant radius, ramp out. The heading change is
// k (hold + ramp) = pi / 2 with k = 1 / radius.
void add_corner(std::vector<RoadPiece>* road) {
  const double k = 1.0 / kCarCornerRadius_m;
  const double hold_m = 0.5 * M_PI / k - kRamp_m;
  road->push_back({kRamp_m, k});
  road->push_back({hold_m, k});
  road->push_back({kRamp_m, 0.0});
}

// How far a corner reaches along its entry direction (= sideways along its exit, the corner being
// symmetric), m: the radius for a plain arc, a little more with the ramps.
double corner_reach_m() {
  std::vector<RoadPiece> corner;
  add_corner(&corner);
  double x = 0.0, yaw = 0.0, k_prev = 0.0;
  for (const RoadPiece& piece : corner) {
    const int n = static_cast<int>(std::lround(piece.length_m / kStep_m));
    const double ds = piece.length_m / n;
    for (int i = 0; i < n; ++i) {
      const double k_mid = k_prev + (piece.curvature_end_1_m - k_prev) * (i + 0.5) / n;
      x += ds * std::cos(yaw + 0.5 * k_mid * ds);
      yaw += k_mid * ds;
    }
    k_prev = piece.curvature_end_1_m;
  }
  return x;
}

std::vector<RoadPiece> road_of(CarRoute route) {
  std::vector<RoadPiece> road;
  if (route == CarRoute::kTurn) {
    road.push_back({car_uniform_length_m(route), 0.0});
    add_corner(&road);
    road.push_back({18.0, 0.0});
    return road;
  }
  // Rounded rectangle 80 m x 50 m: straights of the sides less two corners' reach; opposite sides
  // are equal and the corners alike, so the loop closes.
  const double reach_m = corner_reach_m();
  for (int side = 0; side < 4; ++side) {
    road.push_back({(side % 2 == 0 ? 80.0 : 50.0) - 2.0 * reach_m, 0.0});
    add_corner(&road);
  }
  road.push_back({15.0, 0.0});
  return road;
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

// Speed over distance, m/s. Turn: 20 km/h, a raised-cosine dip to ~16 km/h through the corner.
// Loop: 19.8 km/h +- 4.3 km/h, one period per 57 m.
double speed_m_s(CarRoute route, double s_m) {
  if (route == CarRoute::kTurn) {
    const double s0 = car_uniform_length_m(route), span_m = 27.0;
    if (s_m <= s0 || s_m >= s0 + span_m) return 5.6;
    return 5.6 - 1.2 * 0.5 * (1.0 - std::cos(2.0 * M_PI * (s_m - s0) / span_m));
  }
  return 5.5 + 1.2 * std::sin(2.0 * M_PI * s_m / 57.0);
}

// The road sampled every kStep_m: time, planar position and heading.
struct RoadTable {
  std::vector<double> t_s, x_m, y_m, yaw_rad, s_m;
};

RoadTable integrate_road(CarRoute route) {
  RoadTable r;
  double t = 0.0, x = 0.0, y = 0.0, yaw = 0.0, s = 0.0, k_prev = 0.0;
  auto push = [&] {
    r.t_s.push_back(t);
    r.x_m.push_back(x);
    r.y_m.push_back(y);
    r.yaw_rad.push_back(yaw);
    r.s_m.push_back(s);
  };
  push();
  for (const RoadPiece& piece : road_of(route)) {
    const int n = std::max(1, static_cast<int>(std::lround(piece.length_m / kStep_m)));
    const double ds = piece.length_m / n;
    for (int i = 0; i < n; ++i) {
      // Midpoint rule for heading, position and time.
      const double k_mid = k_prev + (piece.curvature_end_1_m - k_prev) * (i + 0.5) / n;
      const double yaw_mid = yaw + 0.5 * k_mid * ds;
      x += ds * std::cos(yaw_mid);
      y += ds * std::sin(yaw_mid);
      yaw += k_mid * ds;
      t += ds / speed_m_s(route, s + 0.5 * ds);
      s += ds;
      push();
    }
    k_prev = piece.curvature_end_1_m;
  }
  return r;
}

// Suspension bumps as functions of time, scaled by `on` in [0, 1]: heave m, pitch and roll rad.
Eigen::Vector3d bumps(double t_s, double on) {
  const double w = 2.0 * M_PI;
  const double heave_m = 0.007 * std::sin(w * 1.3 * t_s) + 0.004 * std::sin(w * 2.7 * t_s + 1.0);
  const double pitch_rad = (0.25 * std::sin(w * 1.1 * t_s + 0.3) + 0.1 * std::sin(w * 2.3 * t_s)) * kDegToRad;
  const double roll_rad = (0.2 * std::sin(w * 0.9 * t_s + 2.0) + 0.1 * std::sin(w * 1.9 * t_s + 0.7)) * kDegToRad;
  return on * Eigen::Vector3d(heave_m, pitch_rad, roll_rad);
}

// The camera pose of the car at road position (x, y, yaw) with bumps (heave, pitch, roll). Car
// axes x forward, y left, z up; cam z = car x, cam y = -car z, cam x = -car y.
void camera_pose(double x_m, double y_m, double yaw_rad, const Eigen::Vector3d& bump, CarPose* pose) {
  const Eigen::Matrix3d R_w_car = (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
                                   Eigen::AngleAxisd(bump.y(), Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(bump.z(), Eigen::Vector3d::UnitX()))
                                      .toRotationMatrix();
  Eigen::Matrix3d R_car_c;
  R_car_c.col(0) = -Eigen::Vector3d::UnitY();
  R_car_c.col(1) = -Eigen::Vector3d::UnitZ();
  R_car_c.col(2) = Eigen::Vector3d::UnitX();
  pose->R_w_c = R_w_car * R_car_c;
  pose->p_w_c = Eigen::Vector3d(x_m, y_m, kCarCameraHeight_m + bump.x());
}

// Road state at time t: interpolated inside the table, straight on at constant speed outside.
void road_at(const RoadTable& r, CarRoute route, double t_s, double* x, double* y, double* yaw, double* s) {
  const std::size_t last = r.t_s.size() - 1;
  if (t_s <= 0.0 || t_s >= r.t_s[last]) {
    const std::size_t i = t_s <= 0.0 ? 0 : last;
    const double ds = speed_m_s(route, r.s_m[i]) * (t_s - r.t_s[i]);
    *x = r.x_m[i] + ds * std::cos(r.yaw_rad[i]);
    *y = r.y_m[i] + ds * std::sin(r.yaw_rad[i]);
    *yaw = r.yaw_rad[i];
    *s = r.s_m[i] + ds;
    return;
  }
  const std::size_t j = static_cast<std::size_t>(std::upper_bound(r.t_s.begin(), r.t_s.end(), t_s) - r.t_s.begin());
  const std::size_t i = j - 1;
  const double f = (t_s - r.t_s[i]) / (r.t_s[j] - r.t_s[i]);
  *x = r.x_m[i] + f * (r.x_m[j] - r.x_m[i]);
  *y = r.y_m[i] + f * (r.y_m[j] - r.y_m[i]);
  *yaw = r.yaw_rad[i] + f * (r.yaw_rad[j] - r.yaw_rad[i]);
  *s = r.s_m[i] + f * (r.s_m[j] - r.s_m[i]);
}

}  // namespace

double car_route_length_m(CarRoute route) {
  double length_m = 0.0;
  for (const RoadPiece& piece : road_of(route)) length_m += piece.length_m;
  return length_m;
}

double car_uniform_length_m(CarRoute route) { return route == CarRoute::kTurn ? 25.0 : 0.0; }

std::vector<CarPose> car_camera_poses(CarRoute route, double dt_s, double t_end_s) {
  const RoadTable road = integrate_road(route);
  double end_s = road.t_s.back();
  if (t_end_s > 0.0) end_s = std::min(end_s, t_end_s);
  const double s_uniform_m = car_uniform_length_m(route);
  std::vector<CarPose> poses;
  const int n = static_cast<int>(std::ceil(end_s / dt_s - 1e-9));
  for (int k = -1; k <= n + 1; ++k) {
    CarPose pose;
    pose.t_s = k * dt_s;
    double x = 0.0, y = 0.0, yaw = 0.0;
    road_at(road, route, pose.t_s, &x, &y, &yaw, &pose.s_m);
    // Bumps fade in over 3 m after the unexcited start (none on the turn's first 25 m).
    const double on = route == CarRoute::kTurn ? smoothstep((pose.s_m - s_uniform_m) / 3.0) : 1.0;
    camera_pose(x, y, yaw, bumps(pose.t_s, on), &pose);
    poses.push_back(pose);
  }
  return poses;
}

}  // namespace ums::sim
