// The frames a flight controller reads: a vehicle with a forward-looking D455 (body = left-IR
// optical axes: x right, y down, z forward), level and facing the estimator's +y. Moving forward,
// right and up, turning right, rolling right and pitching up must read as the FRD/NED
// conventions say: +x, +y, -z; positive yaw, roll and pitch.
#include "core/mavlink/frd_odometry.hpp"

#include <catch2/catch.hpp>
#include <cmath>

using namespace ums::mavlink;

namespace {

// Vehicle axes (forward, right, down) in the D455 body: x_v = z_b, y_v = x_b, z_v = y_b.
Eigen::Matrix3d forward_d455() {
  Eigen::Matrix3d R_b_v;
  R_b_v << 0, 1, 0,
           0, 0, 1,
           1, 0, 0;
  return R_b_v;
}

// Level, facing the world's +y (z up): forward +y, right +x, down -z.
Eigen::Matrix3d facing_plus_y() {
  Eigen::Matrix3d R_w_v;
  R_w_v << 0, 1, 0,
           1, 0, 0,
           0, 0, -1;
  return R_w_v;
}

BodyState state_of(const Eigen::Matrix3d& R_w_v, const Eigen::Vector3d& p_w, const Eigen::Vector3d& v_w) {
  BodyState s;
  s.t_ns = 2'000'000'000;
  s.q_w_b = Eigen::Quaterniond(R_w_v * forward_d455().transpose());
  s.p_w_b = p_w;
  s.v_w_b = v_w;
  return s;
}

struct Euler {
  double roll_deg, pitch_deg, yaw_deg;
};

Euler euler_of(const Odometry& m) {
  const double w = static_cast<double>(m.q[0]), x = static_cast<double>(m.q[1]), y = static_cast<double>(m.q[2]),
               z = static_cast<double>(m.q[3]);
  const double rad = 180.0 / M_PI;
  return {std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)) * rad, std::asin(2 * (w * y - z * x)) * rad,
          std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)) * rad};
}

Eigen::Matrix3d about(const Eigen::Vector3d& axis, double deg) {
  return Eigen::AngleAxisd(deg * M_PI / 180.0, axis).toRotationMatrix();
}

}  // namespace

TEST_CASE("FRD: moving forward, right and up reads +x, +y and -z, velocities in the vehicle's axes", "[mavlink]") {
  FrdConverter frd(forward_d455());
  Odometry m;
  frd.convert(state_of(facing_plus_y(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), &m);
  CHECK(m.q[0] == Approx(1.0).margin(1e-6));  // level, heading of the start: identity
  CHECK(m.time_usec == 2'000'000u);
  CHECK(m.frame_id == kFrameLocalFrd);
  CHECK(m.child_frame_id == kFrameBodyFrd);

  frd.convert(state_of(facing_plus_y(), {0.5, 2.0, 1.0}, {0.0, 1.0, 0.0}), &m);
  CHECK(m.x == Approx(2.0));   // forward
  CHECK(m.y == Approx(0.5));   // right
  CHECK(m.z == Approx(-1.0));  // up is -down
  CHECK(m.vx == Approx(1.0));  // forward speed
  CHECK(m.vy == Approx(0.0).margin(1e-6));
  CHECK(m.vz == Approx(0.0).margin(1e-6));

  frd.convert(state_of(facing_plus_y(), Eigen::Vector3d::Zero(), {0.0, 0.0, 2.0}), &m);
  CHECK(m.vz == Approx(-2.0));  // climbing
}

TEST_CASE("FRD: turning right, rolling right and pitching up read as positive yaw, roll and pitch", "[mavlink]") {
  FrdConverter frd(forward_d455());
  Odometry m;
  frd.convert(state_of(facing_plus_y(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), &m);
  const Eigen::Vector3d x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);  // vehicle axes: forward, right, down

  const Eigen::Matrix3d turned = facing_plus_y() * about(z, 30.0);
  const Eigen::Vector3d forward_w = turned.col(0);
  frd.convert(state_of(turned, forward_w, forward_w), &m);
  Euler e = euler_of(m);
  CHECK(e.yaw_deg == Approx(30.0).margin(1e-4));
  CHECK(e.roll_deg == Approx(0.0).margin(1e-4));
  CHECK(m.x == Approx(std::cos(M_PI / 6)));
  CHECK(m.y == Approx(std::sin(M_PI / 6)));  // a step along the new forward goes right of the start's
  CHECK(m.vx == Approx(1.0));                 // and is forward in the vehicle's own axes

  frd.convert(state_of(facing_plus_y() * about(x, 10.0), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), &m);
  e = euler_of(m);
  CHECK(e.roll_deg == Approx(10.0).margin(1e-4));
  CHECK(e.pitch_deg == Approx(0.0).margin(1e-4));

  frd.convert(state_of(facing_plus_y() * about(y, 15.0), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), &m);
  e = euler_of(m);
  CHECK(e.pitch_deg == Approx(15.0).margin(1e-4));  // nose up
  CHECK(e.yaw_deg == Approx(0.0).margin(1e-4));
}

TEST_CASE("FRD: body rates are turned into the vehicle's axes, unknown rates stay NaN", "[mavlink]") {
  FrdConverter frd(forward_d455());
  Odometry m;
  BodyState s = state_of(facing_plus_y(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  frd.convert(s, &m);
  CHECK(std::isnan(m.rollspeed));
  s.omega_b = forward_d455() * Eigen::Vector3d(0.0, 0.0, 0.5);  // turning right at 0.5 rad/s
  frd.convert(s, &m);
  CHECK(m.yawspeed == Approx(0.5));
  CHECK(m.rollspeed == Approx(0.0).margin(1e-6));
}

TEST_CASE("FRD: the local frame's heading is fixed by the first pose, not re-taken later", "[mavlink]") {
  FrdConverter frd(Eigen::Matrix3d::Identity());
  Odometry m;
  Eigen::Matrix3d R_w_v = Eigen::Vector3d(1, -1, -1).asDiagonal();  // FRD vehicle facing world +x
  frd.convert(state_of(R_w_v * forward_d455(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), &m);
  REQUIRE(frd.anchored());
  // With R_b_v = I and q_w_b = R_w_v R_b_v^T of the D455 helper, the body's x is the vehicle's y.
  const Eigen::Matrix3d first = frd.R_L_w();
  frd.convert(state_of(R_w_v * about(Eigen::Vector3d::UnitZ(), 90.0), Eigen::Vector3d(1, 0, 0),
                       Eigen::Vector3d::Zero()), &m);
  CHECK((frd.R_L_w() - first).norm() == Approx(0.0).margin(1e-12));
  CHECK(std::abs(first.determinant() - 1.0) < 1e-12);
}
