#include "hal/sim/photo_world.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "hal/sim/ray_cast.hpp"
#include "hal/sim/simulate.hpp"
#include "tests/common/test_paths.hpp"
#include "tests/common/emulation.hpp"

using namespace ums::sim;

namespace {

const PhotoSource& euroc_micro_source() {
  static const PhotoSource source = load_photo_source(ums::test::euroc_micro_dir());
  return source;
}

struct Flight {
  SimTrajectory tr;
  std::vector<Eigen::Vector3d> path;  // every 0.1 s, as simulate() samples it
};

Flight flight(SimStyle style, const char* name) {
  SimOptions o;
  o.style = style;
  o.texture_dataset = "unused";
  o.trajectory_path = ums::test::groundtruth_dir() + "/" + name + "_GT.txt";
  o.duration_s = 60.0;
  o.out_dir = "unused";
  Flight f{make_trajectory(o, rig_preset(CameraPreset::kEuroc)), {}};
  for (std::int64_t t = f.tr.t_begin_ns; t <= f.tr.t_end_ns; t += 100'000'000LL) f.path.push_back(f.tr.T_w_b(t).translation());
  return f;
}

// Depths (z in cam0) of every 8th pixel's ray from every 2nd second of the flight, sorted.
std::vector<double> cam0_depths_m(const World& w, const SimTrajectory& tr) {
  const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
  const auto cam = ums::CameraT<double>::from_calibration(rig.cam[0]);
  std::vector<double> depth;
  for (std::int64_t t = tr.t_begin_ns; t <= tr.t_end_ns; t += 2'000'000'000LL) {
    const Eigen::Isometry3d T_w_c = tr.T_w_b(t) * rig.cam[0].T_b_c;
    const Eigen::Vector3f o = T_w_c.translation().cast<float>();
    for (int v = 4; v < 480; v += 8)
      for (int u = 4; u < 752; u += 8) {
        Eigen::Vector3d b;
        if (!cam.unproject(Eigen::Vector2d(u, v), &b)) continue;
        const Eigen::Vector3f d = (T_w_c.linear() * b.normalized()).cast<float>();
        const Eigen::Vector3f inv_d(1.0f / d.x(), 1.0f / d.y(), 1.0f / d.z());
        SurfaceHit hit = hit_room(w, o, d, inv_d);
        for (const Box& box : w.boxes) hit_box(w, box, o, inv_d, &hit);
        depth.push_back(static_cast<double>(hit.t) * b.normalized().z());
      }
  }
  std::sort(depth.begin(), depth.end());
  return depth;
}

double quantile(const std::vector<double>& sorted, double q) { return sorted[static_cast<std::size_t>(q * static_cast<double>(sorted.size() - 1))]; }

double share_beyond(const std::vector<double>& sorted, double m) {
  return static_cast<double>(sorted.end() - std::upper_bound(sorted.begin(), sorted.end(), m)) / static_cast<double>(sorted.size());
}

}  // namespace

TEST_CASE("photo world: walls 3-12 m from the path, high ceiling, boxes clear of the path", "[sim][photo_world]") {
  if (ums::test::skip_heavy_under_emulation()) return;
  const Flight f = flight(SimStyle::kPhoto, "MH01");
  Eigen::Vector3d lo = f.path[0], hi = f.path[0];
  for (const auto& p : f.path) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  PhotoWorldOptions o;
  o.texture_size = 256;
  std::vector<double> wall_gaps;
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    o.seed = seed;
    const World w = make_photo_world(f.path, o, euroc_micro_source());
    const Eigen::Vector3d gap_lo = lo - w.room_lo.cast<double>(), gap_hi = w.room_hi.cast<double>() - hi;
    for (int a = 0; a < 2; ++a) {
      for (double g : {gap_lo[a], gap_hi[a]}) {
        CHECK(g >= 3.0 - 1e-4);
        CHECK(g <= 12.0 + 1e-4);
        wall_gaps.push_back(g);
      }
    }
    CHECK(gap_lo.z() >= 0.8 - 1e-4);
    CHECK(gap_lo.z() <= 1.6 + 1e-4);
    CHECK(gap_hi.z() >= 4.0 - 1e-4);
    CHECK(gap_hi.z() <= 8.0 + 1e-4);
    CHECK(w.boxes.size() == static_cast<std::size_t>(o.boxes + o.pillars));
    for (const Box& b : w.boxes) {
      for (const auto& p : f.path) {
        const Eigen::Vector3d q = p.cwiseMax(b.lo.cast<double>()).cwiseMin(b.hi.cast<double>());
        CHECK((q - p).norm() > o.box_clearance_m - 1e-3);
      }
      CHECK((b.lo.array() >= w.room_lo.array() - 1e-3f).all());
      CHECK((b.hi.array() <= w.room_hi.array() + 1e-3f).all());
    }
    CHECK(w.lighting.lights.size() == 5u);
    CHECK(w.materials.size() == 13u);  // 6 faces, textureless, 6 for the boxes
  }
  // Seeded per wall: the 16 gaps spread over the range.
  CHECK(*std::max_element(wall_gaps.begin(), wall_gaps.end()) - *std::min_element(wall_gaps.begin(), wall_gaps.end()) > 4.0);
}

// Acceptance: much of the photo scene is far away (machine-hall like: at 6 m a 0.11 m baseline
// gives 8 px of disparity, at 11 m 4.6 px). Along V102 the procedural room shows almost nothing
// beyond 6 m; the photo world a third of the image. Along MH01 (a large path already) the far
// tail is what grows.
TEST_CASE("photo world: the scene is deeper than the procedural room", "[sim][photo_world]") {
  if (ums::test::skip_heavy_under_emulation()) return;
  for (const char* name : {"V102", "MH01"}) {
    const Flight photo = flight(SimStyle::kPhoto, name);
    const Flight proc = flight(SimStyle::kProcedural, name);
    PhotoWorldOptions po;
    po.texture_size = 256;
    po.seed = static_cast<std::uint32_t>(1 * 2654435761ULL);  // as simulate() scrambles seed 1
    WorldOptions wo;
    wo.texture_size = 256;
    wo.seed = po.seed;
    const std::vector<double> d_photo = cam0_depths_m(make_photo_world(photo.path, po, euroc_micro_source()), photo.tr);
    const std::vector<double> d_proc = cam0_depths_m(make_world(proc.path, wo), proc.tr);
    WARN(name << " depth p50 / p90 / share beyond 6 m: photo " << quantile(d_photo, 0.5) << " / " << quantile(d_photo, 0.9)
              << " m / " << share_beyond(d_photo, 6.0) << ", procedural " << quantile(d_proc, 0.5) << " / "
              << quantile(d_proc, 0.9) << " m / " << share_beyond(d_proc, 6.0));
    CHECK(quantile(d_photo, 0.9) > 9.0);
    CHECK(quantile(d_photo, 0.9) > 1.4 * quantile(d_proc, 0.9));
    CHECK(share_beyond(d_photo, 6.0) > 0.2);
    if (std::string(name) == "V102") CHECK(share_beyond(d_photo, 6.0) > 5.0 * share_beyond(d_proc, 6.0));
  }
}

TEST_CASE("photo world: textureless walls on request, options validated", "[sim][photo_world]") {
  const Flight f = flight(SimStyle::kPhoto, "V101");
  PhotoWorldOptions o;
  o.texture_size = 256;
  o.textureless_walls = true;
  const World w = make_photo_world(f.path, o, euroc_micro_source());
  for (int face = 0; face < 6; ++face) CHECK(w.face_material[static_cast<std::size_t>(face)] == (face == 4 ? 4 : 6));
  o.wall_distance_min_m = 0.5;
  std::string err;
  CHECK_FALSE(o.validate(&err));
  CHECK_THROWS(make_photo_world(f.path, o, euroc_micro_source()));
}
