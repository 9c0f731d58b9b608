#include "hal/sim/street_world.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "hal/sim/car_route.hpp"
#include "hal/sim/ray_cast.hpp"
#include "hal/sim/simulate.hpp"

using namespace ums::sim;

namespace {

std::vector<Eigen::Vector3d> camera_path(const std::vector<CarPose>& poses) {
  std::vector<Eigen::Vector3d> path;
  for (const CarPose& p : poses) path.push_back(p.p_w_c);
  return path;
}

// Horizontal distance from p to the box's footprint, m.
double distance_to_box_m(const Eigen::Vector3d& p, const Box& b) {
  const Eigen::Vector2d q = p.head<2>().cwiseMax(b.lo.head<2>().cast<double>()).cwiseMin(b.hi.head<2>().cast<double>());
  return (q - p.head<2>()).norm();
}

SurfaceHit cast(const World& w, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
  const Eigen::Vector3f o = origin.cast<float>(), d = dir.normalized().cast<float>();
  const Eigen::Vector3f inv_d(1.0f / d.x(), 1.0f / d.y(), 1.0f / d.z());
  SurfaceHit hit = hit_room(w, o, d, inv_d);
  for (const Box& b : w.boxes) hit_box(w, b, o, inv_d, &hit);
  return hit;
}

// Fraction of the image's 8 x 6 cells holding a Shi-Tomasi corner: a pixel whose 5x5 structure
// tensor of central-difference gradients has a smaller eigenvalue above 400 DN^2 (sensor noise of
// 2 DN alone gives ~25).
double corner_cell_fraction(const std::vector<std::uint8_t>& img, int width, int height) {
  auto at = [&](int x, int y) { return static_cast<double>(img[static_cast<std::size_t>(y) * width + x]); };
  const int cols = 8, rows = 6;
  std::vector<char> has(cols * rows, 0);
  for (int y = 3; y < height - 3; y += 2) {
    for (int x = 3; x < width - 3; x += 2) {
      const int cell = (y * rows / height) * cols + x * cols / width;
      if (has[static_cast<std::size_t>(cell)]) continue;
      double gxx = 0.0, gyy = 0.0, gxy = 0.0;
      for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
          const double gx = 0.5 * (at(x + dx + 1, y + dy) - at(x + dx - 1, y + dy));
          const double gy = 0.5 * (at(x + dx, y + dy + 1) - at(x + dx, y + dy - 1));
          gxx += gx * gx;
          gyy += gy * gy;
          gxy += gx * gy;
        }
      }
      const double min_eig = 0.5 * (gxx + gyy - std::sqrt((gxx - gyy) * (gxx - gyy) + 4.0 * gxy * gxy));
      if (min_eig > 400.0) has[static_cast<std::size_t>(cell)] = 1;
    }
  }
  return static_cast<double>(std::count(has.begin(), has.end(), 1)) / (cols * rows);
}

}  // namespace

TEST_CASE("street world: city blocks clear of the path, facades 5.5-8.5 m either side, sky overhead", "[sim][car]") {
  for (CarRoute route : {CarRoute::kTurn, CarRoute::kLoop}) {
    const std::vector<CarPose> poses = car_camera_poses(route, 0.05);
    StreetOptions o;
    o.texture_size = 64;  // geometry only
    const World w = make_street_world(camera_path(poses), o);
    INFO("route " << static_cast<int>(route) << ", " << w.boxes.size() << " blocks");
    // The inside of the corner / loop is filled, with few boxes (the renderer tests each per pixel).
    CHECK(w.boxes.size() >= 1);
    CHECK(w.boxes.size() <= 40);
    int both_sides = 0;
    double nearest_m = 1e9;
    for (const CarPose& p : poses) {
      CHECK((p.p_w_c.cast<float>().array() > w.room_lo.array()).all());
      CHECK((p.p_w_c.cast<float>().array() < w.room_hi.array()).all());
      for (const Box& b : w.boxes) nearest_m = std::min(nearest_m, distance_to_box_m(p.p_w_c, b));
      // Camera x is the car's right: horizontal rays to the left and right facades.
      const Eigen::Vector3d right = p.R_w_c.col(0);
      const double r_m = static_cast<double>(cast(w, p.p_w_c, Eigen::Vector3d(right.x(), right.y(), 0.0)).t);
      const double l_m = static_cast<double>(cast(w, p.p_w_c, Eigen::Vector3d(-right.x(), -right.y(), 0.0)).t);
      if (r_m >= 5.5 && r_m <= 8.5 && l_m >= 5.5 && l_m <= 8.5) ++both_sides;
      // Straight up: the textureless sky, 40 m above the road.
      const SurfaceHit up = cast(w, p.p_w_c, Eigen::Vector3d::UnitZ());
      CHECK(up.material == 1);
      CHECK(static_cast<double>(up.t) + p.p_w_c.z() == Approx(o.sky_height_m).margin(0.01));
    }
    CHECK(nearest_m > 5.5);
    // Corners' outsides are wider (the room's corner): most of the way, facades on both sides.
    CHECK(static_cast<double>(both_sides) / static_cast<double>(poses.size()) > 0.6);
  }
}

TEST_CASE("street world: the D455 camera sees texture all along car-turn, none in the sky", "[sim][car][slow]") {
  const std::vector<CarPose> poses = car_camera_poses(CarRoute::kTurn, 0.05);
  StreetOptions o;
  o.texture_size = 256;  // test-sized textures
  const World w = make_street_world(camera_path(poses), o);
  ums::RigCalibration rig = rig_preset(CameraPreset::kD455);
  const StereoRenderer renderer(w, rig);
  const int width = renderer.width(0), height = renderer.height(0);
  std::vector<std::uint8_t> img(static_cast<std::size_t>(width) * height);
  const Eigen::Isometry3d T_c0_b = rig.cam[0].T_b_c.inverse();
  // Start, end of the straight, mid-turn, end.
  for (double f : {0.0, 0.4, 0.55, 1.0}) {
    const CarPose& p = poses[std::min(poses.size() - 1, static_cast<std::size_t>(f * static_cast<double>(poses.size())))];
    Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
    T_w_c.linear() = p.R_w_c;
    T_w_c.translation() = p.p_w_c;
    renderer.render(0, T_w_c * T_c0_b, RenderOptions{}, 7, img.data());
    const double fraction = corner_cell_fraction(img, width, height);
    INFO("at " << p.s_m << " m: corners in " << fraction * 100.0 << " % of the cells");
    CHECK(fraction > 0.8);
  }
  // Looking straight up from 35 m, 5 m under the sky, no corners (the measure is not fooled by noise).
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();  // camera z = world z: looking up
  T_w_c.translation() = Eigen::Vector3d(poses[0].p_w_c.x(), poses[0].p_w_c.y(), 35.0);
  renderer.render(0, T_w_c * T_c0_b, RenderOptions{}, 7, img.data());
  CHECK(corner_cell_fraction(img, width, height) < 0.05);
}
