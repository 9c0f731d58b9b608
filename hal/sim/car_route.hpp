#pragma once
// The paper's car experiment (Sec. IV-B: a D455 on a car in a city) as two built-in routes for
// the simulator. A route is a planar road given by its curvature profile (straights, and corners
// whose curvature ramps linearly in and out, i.e. clothoid transitions, so the yaw rate has no
// step), driven at a speed profile v(s) over the distance s travelled, with small suspension
// bumps (heave ~1 cm, pitch and roll < 0.4 deg). The camera sits 1.4 m above the road, looking
// along the travel direction with its y axis along world -z (horizontal, image "down" = down).
//  - kTurn (paper case 2): starts already moving, 25 m straight at a constant 20 km/h with no
//    bumps (constant velocity and attitude: the IMU sees only gravity), then a 90 deg left turn
//    of radius 9 m slowing to ~16 km/h, then straight; ~60 m.
//  - kLoop (paper case 1): a closed rounded rectangle 80 m x 50 m with 9 m corners driven once
//    (244 m) plus 15 m (the start seen again), speed varying between ~15.5 and ~24 km/h; ~259 m.
// Start-up code: std::vector storage.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace ums::sim {

enum class CarRoute : std::uint8_t { kTurn, kLoop };

inline constexpr double kCarCameraHeight_m = 1.4;  // camera centre above the road, m
inline constexpr double kCarCornerRadius_m = 9.0;  // radius of every corner's constant part, m

struct CarPose {
  double t_s = 0.0;                                  // s since the route's start (< 0: before)
  double s_m = 0.0;                                  // distance along the road, m
  Eigen::Vector3d p_w_c = Eigen::Vector3d::Zero();   // camera centre, m (road plane z = 0)
  Eigen::Matrix3d R_w_c = Eigen::Matrix3d::Identity();
};

// Length of the route's road, m, and of its unexcited start (bumps off, constant speed), m.
double car_route_length_m(CarRoute route);
double car_uniform_length_m(CarRoute route);

// Camera poses every dt_s from t = -dt_s to the end of the route (or t_end_s, when > 0) plus
// one dt_s; before 0 and after the end the car goes straight on at its speed there.
std::vector<CarPose> car_camera_poses(CarRoute route, double dt_s, double t_end_s = 0.0);

}  // namespace ums::sim
