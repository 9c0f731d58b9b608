// The front end on the simulator (hal/sim): images rendered in memory along a real EuRoC V1_01
// ground-truth cut, so every tracked pixel can be checked against the projection of the world
// point it started on (issue 6, synthetic acceptance), and the 2D share can be compared between
// the nominal and the textureless world.

#include "core/frontend/frontend.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include "core/camera/camera.hpp"
#include "hal/sim/renderer.hpp"
#include "hal/sim/simulate.hpp"
#include "tests/common/test_paths.hpp"

namespace {

using ums::sim::World;

constexpr int kFrames = 20;            // accuracy run: 1 s at 20 Hz, cheap under qemu, long enough for tracks
constexpr int kFramesTexture = 10;     // texture comparison: per world (two worlds rendered)
constexpr double kStartS = 20.0;       // s into V1_01: the MAV is flying (not at rest)
constexpr double kCameraRateHz = 20.0;

// Distance along the unit ray o + t d (world) to the first surface of the world: the room seen
// from inside, or a box seen from outside (the same geometry the renderer intersects). Returns
// false when no surface is hit in front of the camera.
bool cast_ray(const World& w, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* t_hit) {
  const Eigen::Vector3d room_lo = w.room_lo.cast<double>(), room_hi = w.room_hi.cast<double>();
  double best = 1e30;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) continue;
    const double t = ((d[a] > 0 ? room_hi[a] : room_lo[a]) - o[a]) / d[a];
    if (t > 0 && t < best) best = t;
  }
  for (const ums::sim::Box& b : w.boxes) {
    const Eigen::Vector3d lo = b.lo.cast<double>(), hi = b.hi.cast<double>();
    double tn = -1e30, tf = 1e30;
    for (int a = 0; a < 3; ++a) {
      if (std::abs(d[a]) < 1e-12) {
        if (o[a] < lo[a] || o[a] > hi[a]) tn = 1e30;
        continue;
      }
      double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
      if (t0 > t1) std::swap(t0, t1);
      tn = std::max(tn, t0);
      tf = std::min(tf, t1);
    }
    if (tn <= tf && tn > 1e-4 && tn < best) best = tn;
  }
  if (best >= 1e29) return false;
  *t_hit = best;
  return true;
}

// A short cut of the shared V1_01 ground truth with its world, renderer and per-frame poses.
struct SimSequence {
  ums::RigCalibration rig;
  World world;
  std::vector<Eigen::Isometry3d> T_w_b;  // per frame
  std::vector<std::int64_t> t_ns;
};

SimSequence make_sequence(bool textureless, int frames) {
  SimSequence s;
  ums::sim::SimOptions o;
  o.trajectory_path = ums::test::groundtruth_dir() + "/V101_GT.txt";
  o.scenario = textureless ? ums::sim::Scenario::kTextureless : ums::sim::Scenario::kNominal;
  o.start_s = kStartS;
  o.duration_s = static_cast<double>(frames + 1) / kCameraRateHz;
  o.camera_rate_hz = kCameraRateHz;
  s.rig = ums::sim::rig_preset(ums::sim::CameraPreset::kEuroc);
  for (auto& c : s.rig.cam) c.rate_hz = kCameraRateHz;
  const ums::sim::SimTrajectory tr = ums::sim::make_trajectory(o, s.rig);
  // World as simulate() builds it (path every 0.1 s, seed scrambled the same way), with the
  // smaller test texture to keep the start-up cheap under qemu.
  std::vector<Eigen::Vector3d> path;
  for (std::int64_t t = tr.t_begin_ns; t <= tr.t_end_ns; t += 100'000'000LL) path.push_back(tr.spline.evaluate(t).p_w_b);
  ums::sim::WorldOptions wo;
  wo.seed = static_cast<std::uint32_t>(o.seed * 2654435761ULL);
  wo.textureless_walls = textureless;
  wo.texture_size = 512;
  s.world = ums::sim::make_world(path, wo);
  const std::int64_t dt_ns = static_cast<std::int64_t>(std::llround(1e9 / kCameraRateHz));
  for (int k = 0; k < frames; ++k) {
    const std::int64_t t = tr.t_begin_ns + k * dt_ns;
    const ums::sim::SplineState st = tr.spline.evaluate(t);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = st.q_w_b.toRotationMatrix();
    T.translation() = st.p_w_b;
    s.T_w_b.push_back(T);
    s.t_ns.push_back(t);
  }
  return s;
}

// Runs the front end over the rendered sequence (default options, sensor noise on, the
// ground-truth rotation as the gyro hint) and calls on_frame(k, features) per frame.
template <typename F>
void run_frontend(const SimSequence& s, F&& on_frame) {
  const ums::sim::StereoRenderer renderer(s.world, s.rig);
  ums::Frontend fe(ums::FrontendOptions{}, s.rig);
  const int W = s.rig.cam[0].width, H = s.rig.cam[0].height;
  std::vector<std::uint8_t> left(static_cast<std::size_t>(W) * H), right(left.size());
  ums::FrameFeatures ff;
  const ums::sim::RenderOptions ro;  // default sensor noise
  for (int k = 0; k < static_cast<int>(s.T_w_b.size()); ++k) {
    renderer.render_stereo(s.T_w_b[k], ro, 1000003ULL + static_cast<std::uint64_t>(k), left.data(), right.data());
    ums::StereoFrame f;
    f.t_ns = s.t_ns[k];
    f.seq = static_cast<std::uint64_t>(k);
    f.left = ums::ImageView{left.data(), W, H, W};
    f.right = ums::ImageView{right.data(), W, H, W};
    Eigen::Quaterniond q_hint;
    const Eigen::Quaterniond* hint = nullptr;
    if (k > 0) {
      const Eigen::Matrix3d R_w_c0_prev = (s.T_w_b[k - 1] * s.rig.cam[0].T_b_c).linear();
      const Eigen::Matrix3d R_w_c0_curr = (s.T_w_b[k] * s.rig.cam[0].T_b_c).linear();
      q_hint = Eigen::Quaterniond(R_w_c0_prev.transpose() * R_w_c0_curr);
      hint = &q_hint;
    }
    REQUIRE(fe.process(f, hint, &ff) == ums::Status::kOk);
    on_frame(k, ff);
  }
}

struct TrackErrors {
  double sum_sq_left = 0, sum_sq_right = 0;
  int n_left = 0, n_right = 0, n_outliers = 0;
  double sum_sq_young = 0, sum_sq_old = 0;  // track_length <= 4, >= 12 (KLT drift grows with it)
  int n_young = 0, n_old = 0;
  Eigen::Vector2d sum_err = Eigen::Vector2d::Zero();  // px, bias check (left + right)
  int n_points = 0, n_cast_failed = 0;
  double mean_3d = 0;
};

}  // namespace

// Acceptance (synthetic): every feature's first pixel is cast into the world with the true pose
// and the renderer's geometry; in every later frame that world point, projected with the true
// pose, must lie where the front end tracked the feature (left, and right for 3D features).
// Outliers (> 2 px: e.g. corners on a depth edge, where the cast point lies on one surface and
// the tracked corner is formed by both) are counted and bounded, the RMS is over the inliers.
TEST_CASE("Simulator (V1_01 cut, EuRoC rig, noise on): tracks agree with the projected ground truth", "[frontend][sim]") {
  const SimSequence s = make_sequence(false, kFrames);
  const ums::CameraD cam[2] = {ums::CameraD::from_calibration(s.rig.cam[0]), ums::CameraD::from_calibration(s.rig.cam[1])};
  std::map<std::uint32_t, Eigen::Vector3d> X_w;  // world point per feature id (from its first observation)
  TrackErrors e;
  double sum_3d = 0;
  constexpr double kOutlierPx = 2.0;
  run_frontend(s, [&](int k, const ums::FrameFeatures& ff) {
    sum_3d += ff.n_3d;
    const Eigen::Isometry3d T_w_c[2] = {s.T_w_b[k] * s.rig.cam[0].T_b_c, s.T_w_b[k] * s.rig.cam[1].T_b_c};
    for (const ums::FeatureObservation& ob : ff.features) {
      auto it = X_w.find(ob.id);
      const bool first = it == X_w.end();
      if (first) {
        // Cast from the camera that saw it first (left unless a 2D-right feature).
        const int c = ob.has_left() ? 0 : 1;
        const Eigen::Vector2f uv = c == 0 ? ob.uv_left_px : ob.uv_right_px;
        Eigen::Vector3d b_c;
        double t = 0;
        if (!cam[c].unproject(uv.cast<double>(), &b_c) ||
            !cast_ray(s.world, T_w_c[c].translation(), T_w_c[c].linear() * b_c, &t)) {
          ++e.n_cast_failed;
          continue;
        }
        it = X_w.emplace(ob.id, T_w_c[c].translation() + t * (T_w_c[c].linear() * b_c)).first;
        ++e.n_points;
      }
      for (int c = 0; c < 2; ++c) {
        const bool has = c == 0 ? ob.has_left() : ob.has_right();
        if (!has) continue;
        // At the first observation the casting camera agrees by construction; the other camera
        // (the stereo match of a new 3D feature) is still a real check.
        if (first && (c == 0) == ob.has_left()) continue;
        Eigen::Vector2d uv_true;
        if (!cam[c].project(T_w_c[c].inverse() * it->second, &uv_true)) {
          ++e.n_outliers;
          continue;
        }
        const Eigen::Vector2d uv = (c == 0 ? ob.uv_left_px : ob.uv_right_px).cast<double>();
        const double err2 = (uv - uv_true).squaredNorm();
        if (err2 > kOutlierPx * kOutlierPx) {
          ++e.n_outliers;
          continue;
        }
        (c == 0 ? e.sum_sq_left : e.sum_sq_right) += err2;
        ++(c == 0 ? e.n_left : e.n_right);
        e.sum_err += uv - uv_true;
        if (ob.track_length <= 4) {
          e.sum_sq_young += err2;
          ++e.n_young;
        } else if (ob.track_length >= 12) {
          e.sum_sq_old += err2;
          ++e.n_old;
        }
      }
    }
  });
  const int n = e.n_left + e.n_right;
  const double rms_left = std::sqrt(e.sum_sq_left / std::max(1, e.n_left));
  const double rms_right = std::sqrt(e.sum_sq_right / std::max(1, e.n_right));
  const double rms_all = std::sqrt((e.sum_sq_left + e.sum_sq_right) / std::max(1, n));
  const double rms_young = std::sqrt(e.sum_sq_young / std::max(1, e.n_young));
  const double rms_old = std::sqrt(e.sum_sq_old / std::max(1, e.n_old));
  const Eigen::Vector2d bias = e.sum_err / std::max(1, n);
  const double outlier_share = static_cast<double>(e.n_outliers) / std::max(1, n + e.n_outliers);
  std::printf("[frontend][sim] %d frames: %d world points (%d casts failed), mean 3D %.1f; "
              "RMS left %.3f px over %d, right %.3f px over %d, all %.3f px; outliers (> %.0f px) %d = %.2f %%; "
              "RMS at track length <= 4: %.3f px over %d, >= 12: %.3f px over %d; mean error (%.3f, %.3f) px\n",
              kFrames, e.n_points, e.n_cast_failed, sum_3d / kFrames, rms_left, e.n_left, rms_right, e.n_right, rms_all,
              kOutlierPx, e.n_outliers, 100.0 * outlier_share, rms_young, e.n_young, rms_old, e.n_old, bias.x(), bias.y());
  CHECK(e.n_points >= 150);
  CHECK(e.n_left >= 1000);
  CHECK(e.n_right >= 500);
  // Measured 0.39 px host / 0.40 px aarch64 (the rendered images differ slightly there), left
  // and right alike: sub-pixel with margin. The error is unbiased and grows with the track
  // length like a random walk of frame-to-frame KLT steps (0.16 / 0.25 px for young tracks,
  // ~0.5 px after 12+ frames); docs/frontend.md has the numbers.
  CHECK(rms_left < 0.6);
  CHECK(rms_right < 0.6);
  CHECK(rms_young < 0.4);
  CHECK(rms_old < 1.0);
  CHECK(bias.norm() < 0.1);
  CHECK(outlier_share < 0.08);
}

// Acceptance (synthetic): the same cut in the textureless world (walls and ceiling flat grey)
// has a higher 2D share (2D-left + 2D-right over all features) than the nominal world.
TEST_CASE("Simulator (V1_01 cut): the 2D share rises in the textureless world", "[frontend][sim]") {
  double share[2] = {0, 0}, mean_3d[2] = {0, 0}, mean_all[2] = {0, 0};
  for (int tl = 0; tl < 2; ++tl) {
    const SimSequence s = make_sequence(tl == 1, kFramesTexture);
    double n_2d = 0, n_3d = 0;
    run_frontend(s, [&](int, const ums::FrameFeatures& ff) {
      n_2d += ff.n_2d_left + ff.n_2d_right;
      n_3d += ff.n_3d;
    });
    share[tl] = n_2d / std::max(1.0, n_2d + n_3d);
    mean_3d[tl] = n_3d / kFramesTexture;
    mean_all[tl] = (n_2d + n_3d) / kFramesTexture;
    std::printf("[frontend][sim] %s: 2D share %.3f, mean 3D %.1f, mean features %.1f per frame\n",
                tl ? "textureless" : "nominal", share[tl], mean_3d[tl], mean_all[tl]);
  }
  CHECK(share[1] > share[0] + 0.05);
  CHECK(mean_3d[1] < mean_3d[0]);
}
