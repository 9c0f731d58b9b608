#include "core/estimator/landmark_map.hpp"

#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>
#include <memory>

#include "core/estimator/state_blocks.hpp"
#include "core/estimator/window.hpp"
#include "tests/core/estimator/stereo_scene.hpp"

namespace {

using Scene = ums::test::StereoScene;

Eigen::Vector3d point(int i) { return Eigen::Vector3d(-1.0 + 0.1 * i, 0.5 - 0.05 * i, 4.0 + 0.2 * i); }

// Two stereo frames 0.2 m apart seeing the 20 points p (filled in); their slots in *s0, *s1.
void two_frames(Scene* s, ums::LandmarkMap* map, Eigen::Vector3d* p, int* s0, int* s1) {
  for (int i = 0; i < 20; ++i) p[i] = point(i);
  *s0 = s->add_frame(0.0, p, 20, true, map);
  *s1 = s->add_frame(0.2, p, 20, true, map);
}

}  // namespace

TEST_CASE("LandmarkMap: triangulated points survive the host leaving (rehost), to float rounding", "[estimator][landmarks]") {
  Scene s;
  ums::LandmarkMap map{ums::LandmarkMapOptions()};
  Eigen::Vector3d p[20];
  int s0 = -1, s1 = -1;
  two_frames(&s, &map, p, &s0, &s1);
  REQUIRE(s0 >= 0);
  REQUIRE(s1 >= 0);
  REQUIRE(map.size() == 20);
  map.triangulate_all(s.window, -1);
  for (int k = 0; k < map.size(); ++k) {
    REQUIRE(map[k].has_depth);
    CHECK(map[k].host_slot == s0);
    CHECK((map.point_w(map[k], s.window) - p[map[k].id - 1]).norm() < 2e-3);  // float bearings, 4-5 m
  }
  Eigen::Vector3d before[20];
  for (int k = 0; k < map.size(); ++k) before[k] = map.point_w(map[k], s.window);
  map.remove_frame(s0, s.window, ums::Rehost::kMeasuredRay);
  s.window.erase(0);
  REQUIRE(map.size() == 20);
  for (int k = 0; k < map.size(); ++k) {
    CHECK(map[k].host_slot == s1);
    CHECK(map[k].n_obs == 1);
    // The same point, new host: the new host ray is the observation's float bearing (~1e-8 rad).
    CHECK((map.point_w(map[k], s.window) - before[k]).norm() < 1e-6);
  }
  // The last observation leaves: the landmarks leave the map and the pool is free again.
  map.remove_frame(s1, s.window, ums::Rehost::kMeasuredRay);
  CHECK(map.size() == 0);
}

// The new host's pose estimate is off by 0.5 deg of yaw: anchoring on its measured rays moves every
// point by that angle times its distance from the turn axis (4-8 m: 35-70 mm); keeping the point
// moves none.
TEST_CASE("LandmarkMap: rehosting on the measured ray inherits the new host's pose error, keeping the point does not",
          "[estimator][landmarks]") {
  for (const ums::Rehost how : {ums::Rehost::kMeasuredRay, ums::Rehost::kKeepPoint}) {
    Scene s;
    ums::LandmarkMap map{ums::LandmarkMapOptions()};
    Eigen::Vector3d p[20];
    int s0 = -1, s1 = -1;
    two_frames(&s, &map, p, &s0, &s1);
    REQUIRE((s0 >= 0 && s1 >= 0));
    map.triangulate_all(s.window, -1);
    Eigen::Vector3d before[20];
    for (int k = 0; k < map.size(); ++k) before[k] = map.point_w(map[k], s.window);
    const Eigen::Quaterniond dq(Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d::UnitY()));
    Eigen::Map<Eigen::Quaterniond> q1(s.window.slot(s1).pose + 3);
    q1 = (q1 * dq).normalized();
    map.remove_frame(s0, s.window, how);
    s.window.erase(0);
    REQUIRE(map.size() == 20);
    double min_moved_m = 1e9, max_moved_m = 0.0;
    for (int k = 0; k < map.size(); ++k) {
      const double moved_m = (map.point_w(map[k], s.window) - before[k]).norm();
      const Eigen::Vector3d P = before[k] - Eigen::Vector3d(0.2, 0, 0);  // from the new host
      const double expected_m = std::hypot(P.x(), P.z()) * 0.5 * M_PI / 180.0;  // turned about y
      if (how == ums::Rehost::kMeasuredRay) CHECK(moved_m == Approx(expected_m).epsilon(0.05));
      min_moved_m = std::min(min_moved_m, moved_m);
      max_moved_m = std::max(max_moved_m, moved_m);
    }
    if (how == ums::Rehost::kMeasuredRay) CHECK(min_moved_m > 0.03);
    if (how == ums::Rehost::kKeepPoint) CHECK(max_moved_m < 1e-9);
  }
}

TEST_CASE("LandmarkMap: a full pool refuses new features and counts them, freed slots are reused", "[estimator][landmarks]") {
  Scene s;
  ums::LandmarkMap map{ums::LandmarkMapOptions()};
  const int cap = ums::LandmarkMap::kCapacity;
  ums::WindowFrame& f = s.window.next();
  s.window.push_next();
  const int slot = s.window.slot_of(f);
  s.window.choose_next_slot();
  int dropped = 0;
  for (int batch = 0; batch < 2; ++batch) {
    s.ff->features.clear();
    for (int i = 0; i < 400; ++i) {
      ums::FeatureObservation o;
      o.id = static_cast<std::uint32_t>(batch * 400 + i + 1);
      o.bearing_left = Eigen::Vector3f::UnitZ();
      s.ff->features.push_back(o);
    }
    dropped += map.ingest(*s.ff, slot, Eigen::Matrix3d::Identity());
  }
  CHECK(map.size() == cap);
  CHECK(dropped == 800 - cap);
  CHECK(map.peak() == static_cast<std::size_t>(cap));
  // Ids stay sorted and findable.
  for (int k = 1; k < map.size(); ++k) CHECK(map[k].id > map[k - 1].id);
  CHECK(map.find(1) >= 0);
  CHECK(map.find(static_cast<std::uint32_t>(cap + 1)) < 0);
  // Outliers leave at compaction and make room.
  for (int k = 0; k < 10; ++k) map[k].outlier = true;
  map.compact();
  CHECK(map.size() == cap - 10);
  s.ff->features.clear();
  ums::FeatureObservation o;
  o.id = 5000;
  o.bearing_left = Eigen::Vector3f::UnitZ();
  s.ff->features.push_back(o);
  CHECK(map.ingest(*s.ff, slot, Eigen::Matrix3d::Identity()) == 0);
  CHECK(map.find(5000) >= 0);
}

TEST_CASE("LandmarkMap: a stereo match with too little disparity enters as a 2D-left feature", "[estimator][landmarks]") {
  // 0.11 m baseline at 460 px focal: 4 m gives 12.6 px of disparity, 40 m gives 1.3 px.
  ums::LandmarkMapOptions options;
  options.min_stereo_parallax_rad = 3.0 / 460.0;  // 3 px
  ums::LandmarkMap map{options};
  Scene s;
  const Eigen::Vector3d p[2] = {Eigen::Vector3d(0.3, 0.1, 4.0), Eigen::Vector3d(0.3, 0.1, 40.0)};
  REQUIRE(s.add_frame(0.0, p, 2, true, &map) >= 0);
  REQUIRE(map.size() == 2);
  const ums::Landmark& near = map.at_pool(map.find(1));
  const ums::Landmark& far = map.at_pool(map.find(2));
  CHECK(near.group() == ums::LandmarkGroup::k3D);
  CHECK(near.obs[0].has_right);
  CHECK(far.group() == ums::LandmarkGroup::k2DLeft);
  CHECK(far.obs[0].has_left);
  CHECK_FALSE(far.obs[0].has_right);
}

TEST_CASE("LandmarkMap: bearing velocities, central inside a track, one-sided at its ends, zero unseen before",
          "[estimator][landmarks][td]") {
  Scene s;
  ums::LandmarkMap map{ums::LandmarkMapOptions()};
  // A left feature whose bearing turns at 0.5 rad/s about y, with 0.2 rad/s^2 of angular
  // acceleration, seen in four frames 1/30 s apart; feature 2 from the third frame on.
  const double dt_s = 1.0 / 30.0;
  auto bearing = [](double t_s) {
    const double a = 0.5 * t_s + 0.1 * t_s * t_s;
    return Eigen::Vector3f(static_cast<float>(std::sin(a)), 0.0f, static_cast<float>(std::cos(a)));
  };
  int slots[4];
  for (int k = 0; k < 4; ++k) {
    ums::WindowFrame& f = s.window.next();
    s.window.push_next();
    slots[k] = s.window.slot_of(f);
    s.window.choose_next_slot();
    s.ff->features.clear();
    ums::FeatureObservation o;
    o.id = 1;
    o.bearing_left = bearing(k * dt_s);
    s.ff->features.push_back(o);
    if (k >= 2) {
      o.id = 2;
      s.ff->features.push_back(o);
    }
    map.ingest(*s.ff, slots[k], Eigen::Matrix3d::Identity(), k > 0 ? slots[k - 1] : -1, k > 0 ? dt_s : 0.0);
  }
  const ums::Landmark& l = map.at_pool(map.find(1));
  REQUIRE(l.n_obs == 4);
  // d/dt of the bearing: |rate| = 0.5 + 0.2 t rad/s along x at t = 0 (the chord's direction).
  auto rate = [](double t_s) { return 0.5 + 0.2 * t_s; };
  // First observation: the forward difference (rate at dt/2); inside: central (rate at its own
  // time, to the chord's curvature); last: backward (rate at t - dt/2). Within 1e-3 rad/s.
  CHECK(std::abs(l.obs[0].velocity_left.cast<double>().norm() - rate(0.5 * dt_s)) < 1e-3);
  CHECK(std::abs(l.obs[1].velocity_left.cast<double>().norm() - rate(1 * dt_s)) < 1e-3);
  CHECK(std::abs(l.obs[2].velocity_left.cast<double>().norm() - rate(2 * dt_s)) < 1e-3);
  CHECK(std::abs(l.obs[3].velocity_left.cast<double>().norm() - rate(2.5 * dt_s)) < 1e-3);
  CHECK(l.obs[0].velocity_right.norm() == 0.0f);  // never seen on the right
  // Seen once, then in the next frame: both get the one difference; before that, zero.
  const ums::Landmark& l2 = map.at_pool(map.find(2));
  REQUIRE(l2.n_obs == 2);
  CHECK(std::abs(l2.obs[0].velocity_left.cast<double>().norm() - rate(2.5 * dt_s)) < 1e-3);
  // A frame in between missing (not the previous window frame): no rate.
  s.ff->features.clear();
  ums::FeatureObservation o;
  o.id = 3;
  o.bearing_left = bearing(0.0);
  s.ff->features.push_back(o);
  map.ingest(*s.ff, slots[3], Eigen::Matrix3d::Identity(), slots[2], dt_s);
  CHECK(map.at_pool(map.find(3)).obs[0].velocity_left.norm() == 0.0f);
}

namespace {

// A left camera at x = v t (m, v = 1 m/s), turning about y by theta(t) = w0 t + 1/2 a t^2 (w0 = 1 rad/s,
// a = 5 rad/s^2: a sharp yaw), and a point 2 m ahead. The camera's rotation in the world: Ry(theta).
struct TurningCamera {
  static Eigen::Matrix3d R_w_c(double t_s) {
    return Eigen::AngleAxisd(1.0 * t_s + 2.5 * t_s * t_s, Eigen::Vector3d::UnitY()).toRotationMatrix();
  }
  static double w_rad_s(double t_s) { return 1.0 + 5.0 * t_s; }
  static Eigen::Vector3d bearing(double t_s) {
    const Eigen::Vector3d p_w(0.3, -0.2, 2.0), c_w(1.0 * t_s, 0.0, 0.0);
    return (R_w_c(t_s).transpose() * (p_w - c_w)).normalized();
  }
  static Eigen::Vector3d rate(double t_s) {  // numeric d/dt, to 1e-8
    const double h = 1e-6;
    return (bearing(t_s + h) - bearing(t_s - h)) / (2.0 * h);
  }
  // What the estimator gives the map: the gyro's rotation and rates between frames at t0 and t1.
  static ums::CameraMotion motion(double t0_s, double t1_s) {
    ums::CameraMotion m;
    m.valid = true;
    for (int c = 0; c < 2; ++c) {
      m.R_cur_prev[c] = (R_w_c(t1_s).transpose() * R_w_c(t0_s)).cast<float>();
      m.w_cur_rad_s[c] = (w_rad_s(t1_s) * Eigen::Vector3d::UnitY()).cast<float>();
      m.w_prev_rad_s[c] = (w_rad_s(t0_s) * Eigen::Vector3d::UnitY()).cast<float>();
    }
    return m;
  }
};

// Feeds frames k = 0..n-1 (1/30 s apart) of the turning camera; the landmark's observations.
const ums::Landmark& turning_track(Scene* s, ums::LandmarkMap* map, int n, bool gyro) {
  const double dt_s = 1.0 / 30.0;
  int prev = -1;
  for (int k = 0; k < n; ++k) {
    ums::WindowFrame& f = s->window.next();
    s->window.push_next();
    const int slot = s->window.slot_of(f);
    s->window.choose_next_slot();
    s->ff->features.clear();
    ums::FeatureObservation o;
    o.id = 7;
    o.bearing_left = TurningCamera::bearing(k * dt_s).cast<float>();
    s->ff->features.push_back(o);
    const ums::CameraMotion m = gyro && k > 0 ? TurningCamera::motion((k - 1) * dt_s, k * dt_s) : ums::CameraMotion();
    map->ingest(*s->ff, slot, Eigen::Matrix3d::Identity(), prev, k > 0 ? dt_s : 0.0, m);
    prev = slot;
  }
  return map->at_pool(map->find(7));
}

}  // namespace

TEST_CASE("LandmarkMap: with the gyro, bearing rates hold at the frame's own time, newest and first sightings too",
          "[estimator][landmarks][td]") {
  const double dt_s = 1.0 / 30.0;
  auto error = [](const ums::LandmarkObservation& o, double t_s) {
    return (o.velocity_left.cast<double>() - TurningCamera::rate(t_s)).norm();
  };
  Scene s_gyro, s_images;
  ums::LandmarkMap with_gyro{ums::LandmarkMapOptions()}, images_only{ums::LandmarkMapOptions()};
  const ums::Landmark& g = turning_track(&s_gyro, &with_gyro, 4, true);
  const ums::Landmark& d = turning_track(&s_images, &images_only, 4, false);
  REQUIRE(g.n_obs == 4);
  REQUIRE(d.n_obs == 4);
  // The true rate is about 1.1-1.7 rad/s. The newest frame: differencing alone lags half a frame
  // (the turn accelerates at 5 rad/s^2: about 0.08 rad/s off); the spin from the gyro does not.
  CHECK(error(d.obs[3], 3 * dt_s) > 0.05);
  CHECK(error(g.obs[3], 3 * dt_s) < 0.01);
  // Inside the track, central differences of the rest: within 0.01 rad/s.
  CHECK(error(g.obs[1], dt_s) < 0.01);
  CHECK(error(g.obs[2], 2 * dt_s) < 0.01);
  // The track's first sighting (the host): its spin and the forward difference of the rest.
  CHECK(error(g.obs[0], 0.0) < 0.01);
  CHECK(error(d.obs[0], 0.0) > 0.05);
  // A sighting with no frame before it has its spin only: most of the rate in a turn.
  Scene s1;
  ums::LandmarkMap one{ums::LandmarkMapOptions()};
  s1.ff->features.clear();
  ums::FeatureObservation o;
  o.id = 9;
  o.bearing_left = TurningCamera::bearing(0.1).cast<float>();
  s1.ff->features.push_back(o);
  ums::WindowFrame& f = s1.window.next();
  s1.window.push_next();
  one.ingest(*s1.ff, s1.window.slot_of(f), Eigen::Matrix3d::Identity(), -1, 0.0, TurningCamera::motion(0.0, 0.1));
  const ums::LandmarkObservation& single = one.at_pool(one.find(9)).obs[0];
  const Eigen::Vector3d spin = -(TurningCamera::w_rad_s(0.1) * Eigen::Vector3d::UnitY()).cross(TurningCamera::bearing(0.1));
  CHECK((single.velocity_left.cast<double>() - spin).norm() < 1e-5);
  CHECK(!single.has_rate_left);
}
