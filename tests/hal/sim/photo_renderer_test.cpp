#include "hal/sim/photo_renderer.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "core/math/so3.hpp"
#include "hal/sim/simulate.hpp"

using namespace ums::sim;

namespace {

Texture flat_texture(std::uint8_t value) {
  Texture t;
  t.size = 256;
  t.texels_per_m = 64.0f;
  t.mips.assign(1, std::vector<std::uint8_t>(256 * 256, value));
  t.build_mips();
  return t;
}

// A room whose walls are black except a 4x4-texel white marker on the +x wall centred on X
// (as renderer_test's marker world); uniform light.
World marker_world(const Eigen::Vector3d& X) {
  World w;
  w.room_lo = Eigen::Vector3f(-5, -5, -2);
  w.room_hi = Eigen::Vector3f(static_cast<float>(X.x()), 5, 4);
  Texture black;
  black.size = 1024;
  black.texels_per_m = 256.0f;
  black.mips.assign(1, std::vector<std::uint8_t>(1024 * 1024, 0));
  Texture marker = black;
  const int iu = static_cast<int>(std::lround(X.y() * 256.0)) - 2, iv = static_cast<int>(std::lround(X.z() * 256.0)) - 2;
  for (int dv = 0; dv < 4; ++dv)
    for (int du = 0; du < 4; ++du) marker.mips[0][static_cast<std::size_t>(((iv + dv) & 1023) * 1024 + ((iu + du) & 1023))] = 255;
  black.build_mips();
  marker.build_mips();
  w.materials = {black, marker};
  w.face_material = {0, 1, 0, 0, 0, 0};
  w.face_shade = {1, 1, 1, 1, 1, 1};
  return w;
}

// cam0 looking along +x from (0.7, 0.1, 1.3), yawed by yaw_rad about the world z axis.
Eigen::Isometry3d body_looking_at_x(const ums::RigCalibration& rig, double yaw_rad) {
  Eigen::Matrix3d R_w_c;
  R_w_c.col(2) = Eigen::Vector3d(1, 0.12, -0.08).normalized();
  R_w_c.col(0) = Eigen::Vector3d(0, 0, 1).cross(R_w_c.col(2)).normalized() * -1.0;
  R_w_c.col(1) = R_w_c.col(2).cross(R_w_c.col(0));
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
  T_w_c.linear() = ums::so3::exp(Eigen::Vector3d(0, 0, yaw_rad)) * R_w_c;
  T_w_c.translation() = Eigen::Vector3d(0.7, 0.1, 1.3);
  return T_w_c * rig.cam[0].T_b_c.inverse();
}

PhotoLensOptions no_vignetting() {
  PhotoLensOptions lens;
  for (auto& v : lens.vignetting) {
    v.corner_gain = 1.0;
    v.axis_tilt_rad.setZero();
  }
  return lens;
}

struct Moments {
  double sum = 0, u = 0, v = 0, var_u = 0;
};

Moments moments(const std::vector<std::uint8_t>& img, int W, int H) {
  Moments m;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const double x = img[static_cast<std::size_t>(v) * W + u];
      m.sum += x;
      m.u += x * u;
      m.v += x * v;
      m.var_u += x * u * u;
    }
  m.u /= m.sum;
  m.v /= m.sum;
  m.var_u = m.var_u / m.sum - m.u * m.u;
  return m;
}

}  // namespace

// The photo renderer casts the same rays through the same world as the procedural one: with its
// effects neutral (uniform light 1, no vignetting, no noise, one sub-exposure) both give the
// same pixels, boxes included, so the per-tile box culling hides nothing.
TEST_CASE("photo renderer: same image as the procedural renderer with the effects neutral", "[sim][photo_renderer][slow]") {
  const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
  std::vector<Eigen::Vector3d> path;
  for (int k = 0; k < 40; ++k) path.emplace_back(1.5 * std::cos(0.15 * k), 1.5 * std::sin(0.15 * k), 1.2);
  WorldOptions wo;
  wo.texture_size = 256;
  wo.boxes = 12;
  wo.seed = 5;
  const World w = make_world(path, wo);
  REQUIRE(w.boxes.size() >= 8u);
  const StereoRenderer procedural(w, rig);
  const PhotoRenderer photo(w, rig, no_vignetting());
  RenderOptions ro;
  ro.noise_sigma_dn = 0.0;
  std::vector<std::uint8_t> a(752 * 480), b(752 * 480);
  for (int k = 0; k < 40; k += 7) {
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.linear() = ums::so3::exp(Eigen::Vector3d(0.1, -0.2, 0.15 * k + 1.2));
    T_w_b.translation() = path[static_cast<std::size_t>(k)];
    for (int cam = 0; cam < 2; ++cam) {
      procedural.render(cam, T_w_b, ro, 1, a.data());
      photo.render(cam, &T_w_b, 1, ro, 1, b.data());
      long differ = 0;
      for (std::size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
      INFO("pose " << k << " cam " << cam);
      CHECK(differ == 0);
    }
  }
}

// Acceptance: the configured vignetting (corner / centre 0.65 left, 0.70 right) shows in the
// rendered image of a uniformly lit grey room; the irradiance (0.8) scales the image; the noise
// is read noise plus shot noise.
TEST_CASE("photo renderer: vignetting ratio, irradiance and shot noise in the image", "[sim][photo_renderer]") {
  const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
  World w;
  w.room_lo = Eigen::Vector3f(-6, -6, -3);
  w.room_hi = Eigen::Vector3f(6, 6, 5);
  w.materials = {flat_texture(200)};
  w.face_material = {0, 0, 0, 0, 0, 0};
  w.face_shade = {1, 1, 1, 1, 1, 1};
  w.lighting.ambient = 0.8f;
  const PhotoLensOptions lens;
  const PhotoRenderer r(w, rig, lens);
  const Eigen::Isometry3d T_w_b = body_looking_at_x(rig, 0.0);
  std::vector<std::uint8_t> img(752 * 480);
  RenderOptions quiet;
  quiet.noise_sigma_dn = 0.0;
  for (int cam = 0; cam < 2; ++cam) {
    r.render(cam, &T_w_b, 1, quiet, 1, img.data());
    auto at = [&](int u, int v) { return static_cast<double>(img[static_cast<std::size_t>(v) * 752 + u]); };
    const double centre = at(376, 240);
    const double corners = (at(0, 0) + at(751, 0) + at(0, 479) + at(751, 479)) / 4.0;
    INFO("cam " << cam << ": centre " << centre << " DN, corners " << corners << " DN");
    CHECK(centre == Approx(160.0).margin(1.0));  // 200 DN x irradiance 0.8
    CHECK(corners / centre == Approx(lens.vignetting[cam].corner_gain).margin(0.01));
  }
  // Noise: std over a central patch (vignetting < 0.5 % there) = sqrt(2^2 + 0.03 x 160) = 2.97 DN.
  RenderOptions noisy;
  r.render(0, &T_w_b, 1, noisy, 7, img.data());
  double s = 0, s2 = 0;
  int n = 0;
  for (int v = 200; v < 280; ++v)
    for (int u = 330; u < 420; ++u) {
      const double x = img[static_cast<std::size_t>(v) * 752 + u];
      s += x;
      s2 += x * x;
      ++n;
    }
  const double sd = std::sqrt(s2 / n - (s / n) * (s / n));
  CHECK(sd == Approx(std::sqrt(4.0 + 0.03 * 160.0)).epsilon(0.1));
}

// Motion blur: sub-exposures at poses yawing across the exposure smear a marker along the image
// row: its centroid is the mean of the sub-exposure projections, its spread grows by theirs.
TEST_CASE("photo renderer: motion blur averages the sub-exposures", "[sim][photo_renderer]") {
  const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
  const Eigen::Vector3d X(2.0, 80.0 / 256.0, 300.0 / 256.0);
  const World w = marker_world(X);
  const PhotoRenderer r(w, rig, no_vignetting());
  RenderOptions ro;
  ro.noise_sigma_dn = 0.0;
  const auto cam = ums::CameraT<double>::from_calibration(rig.cam[0]);
  Eigen::Isometry3d poses[4];
  double proj_u[4], mean_u = 0.0, mean_v = 0.0;
  for (int j = 0; j < 4; ++j) {
    poses[j] = body_looking_at_x(rig, (j - 1.5) * 0.004);  // 4 steps of 0.004 rad: ~1.8 px apart
    Eigen::Vector2d uv;
    REQUIRE(cam.project((poses[j] * rig.cam[0].T_b_c).inverse() * X, &uv));
    proj_u[j] = uv.x();
    mean_u += uv.x() / 4.0;
    mean_v += uv.y() / 4.0;
  }
  double spread_u = 0.0;
  for (double u : proj_u) spread_u += (u - mean_u) * (u - mean_u) / 4.0;
  std::vector<std::uint8_t> sharp(752 * 480), blurred(752 * 480);
  r.render(0, &poses[1], 1, ro, 1, sharp.data());
  r.render(0, poses, 4, ro, 1, blurred.data());
  const Moments ms = moments(sharp, 752, 480), mb = moments(blurred, 752, 480);
  INFO("projected mean u " << mean_u << ", blurred centroid " << mb.u << "; var_u sharp " << ms.var_u << ", blurred "
                           << mb.var_u << ", sub-exposure spread " << spread_u);
  CHECK(std::abs(mb.u - mean_u) < 0.15);
  CHECK(std::abs(mb.v - mean_v) < 0.15);
  CHECK(mb.var_u - ms.var_u == Approx(spread_u).epsilon(0.25));
  CHECK(mb.sum == Approx(ms.sum).epsilon(0.05));  // blur moves light, it does not add any
  CHECK_THROWS(r.render(0, poses, 0, ro, 1, blurred.data()));
}
