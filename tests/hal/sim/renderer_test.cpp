#include "hal/sim/renderer.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "hal/sim/simulate.hpp"

using namespace ums::sim;

namespace {

// A world whose +x wall is black except a 4x4-texel white square centred on the world point X
// (texel i's centre is at (i + 0.5) / texels_per_m, so a square of texels i0..i0+3 is centred
// at (i0 + 2) / texels_per_m). No boxes, no noise.
World marker_world(const Eigen::Vector3d& X) {
  World w;
  w.room_lo = Eigen::Vector3f(-5, -5, -2);
  w.room_hi = Eigen::Vector3f(static_cast<float>(X.x()), 5, 4);
  Texture black;
  black.size = 1024;
  black.texels_per_m = 256.0f;
  black.mips.assign(1, std::vector<std::uint8_t>(1024 * 1024, 0));
  black.build_mips();
  Texture marker = black;
  // +x face: u = y, v = z (axes (a+1)%3, (a+2)%3).
  const int iu = static_cast<int>(std::lround(X.y() * 256.0)) - 2;
  const int iv = static_cast<int>(std::lround(X.z() * 256.0)) - 2;
  for (int dv = 0; dv < 4; ++dv)
    for (int du = 0; du < 4; ++du) marker.mips[0][static_cast<std::size_t>(((iv + dv) & 1023) * 1024 + ((iu + du) & 1023))] = 255;
  marker.build_mips();
  w.materials = {black, marker};
  w.face_material = {0, 1, 0, 0, 0, 0};
  w.face_shade = {1, 1, 1, 1, 1, 1};
  return w;
}

}  // namespace

// Acceptance: a 3D point projected with the ground-truth pose and the camera model lands where
// the renderer drew it, sub-pixel, in both cameras (EuRoC radtan and an equidistant variant).
TEST_CASE("rendering consistency: a world marker lands at its projection in both cameras", "[sim][renderer]") {
  for (ums::CameraModel model : {ums::CameraModel::kPinholeRadTan, ums::CameraModel::kPinholeEquidistant}) {
    ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
    if (model == ums::CameraModel::kPinholeEquidistant) {
      for (auto& c : rig.cam) {
        c.model = model;
        c.distortion = {0.01, -0.005, 0.002, 0.0};
      }
    }
    const Eigen::Vector3d X(2.0, 80.0 / 256.0, 300.0 / 256.0);  // on texel corners
    // Body placed so cam0 looks along +x from 1.3 m, rotated a little (markers off-centre).
    Eigen::Matrix3d R_w_c;
    R_w_c.col(2) = Eigen::Vector3d(1, 0.12, -0.08).normalized();
    R_w_c.col(0) = Eigen::Vector3d(0, 0, 1).cross(R_w_c.col(2)).normalized() * -1.0;
    R_w_c.col(1) = R_w_c.col(2).cross(R_w_c.col(0));
    Eigen::Isometry3d T_w_c0 = Eigen::Isometry3d::Identity();
    T_w_c0.linear() = R_w_c;
    T_w_c0.translation() = Eigen::Vector3d(0.7, 0.1, 1.3);
    const Eigen::Isometry3d T_w_b = T_w_c0 * rig.cam[0].T_b_c.inverse();
    const World world = marker_world(X);
    const StereoRenderer r(world, rig);
    RenderOptions ro;
    ro.noise_sigma_dn = 0.0;
    for (int cam = 0; cam < 2; ++cam) {
      const int W = rig.cam[cam].width, H = rig.cam[cam].height;
      std::vector<std::uint8_t> img(static_cast<std::size_t>(W) * H);
      r.render(cam, T_w_b, ro, 1, img.data());
      const auto model_cam = ums::CameraT<double>::from_calibration(rig.cam[cam]);
      const Eigen::Vector3d p_c = (T_w_b * rig.cam[cam].T_b_c).inverse() * X;
      Eigen::Vector2d uv;
      REQUIRE(model_cam.project(p_c, &uv));
      double sw = 0, su = 0, sv = 0;
      for (int v = 0; v < H; ++v)
        for (int u = 0; u < W; ++u) {
          const double val = img[static_cast<std::size_t>(v) * W + u];
          sw += val;
          su += val * u;
          sv += val * v;
        }
      REQUIRE(sw > 1000.0);
      const Eigen::Vector2d centroid(su / sw, sv / sw);
      INFO("model " << static_cast<int>(model) << " cam " << cam << " projected " << uv.transpose() << " drawn "
                    << centroid.transpose());
      CHECK((centroid - uv).norm() < 0.1);
      WARN("rendering consistency, model " << static_cast<int>(model) << " cam " << cam << ": "
                                            << (centroid - uv).norm() << " px");
    }
  }
}

TEST_CASE("textured material has corners at every pyramid scale and textureless is flat", "[sim][renderer]") {
  const Texture t = make_textured_material(5);
  // Gradient energy at mip levels 0..4 (pyramid levels see these scales): all well above noise.
  for (int level = 0; level <= 4; ++level) {
    const int n = t.size >> level;
    const auto& m = t.mips[static_cast<std::size_t>(level)];
    double g = 0;
    for (int y = 0; y + 1 < n; ++y)
      for (int x = 0; x + 1 < n; ++x) g += std::abs(m[y * n + x + 1] - m[y * n + x]) + std::abs(m[(y + 1) * n + x] - m[y * n + x]);
    g /= static_cast<double>(n) * n;
    INFO("level " << level << " mean |gradient| " << g);
    CHECK(g > 3.0);
  }
  const Texture f = make_textureless_material(5);
  int lo = 255, hi = 0;
  for (auto v : f.mips[0]) {
    lo = std::min<int>(lo, v);
    hi = std::max<int>(hi, v);
  }
  CHECK(hi - lo <= 12);
}

// >= 20 stereo pairs/s at 752x480 on the 2-core host (render only; PNG encoding is the writer's).
// Throughput is a benchmark, not a test: profiling/sim_bench (umsvins_bench_sim).
