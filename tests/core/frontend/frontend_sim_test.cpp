// The front end on the simulator (hal/sim): images rendered in memory along a real EuRoC V1_01
// ground-truth cut, so every tracked pixel can be checked against the projection of the world
// point it started on (issue 6, synthetic acceptance), and the 2D share can be compared between
// the nominal and the textureless world.

#include "core/frontend/frontend.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <vector>

#include "core/camera/camera.hpp"
#include "hal/sim/photo_renderer.hpp"
#include "hal/sim/photo_texture.hpp"
#include "hal/sim/photo_world.hpp"
#include "hal/sim/renderer.hpp"
#include "hal/sim/simulate.hpp"
#include "tests/common/emulation.hpp"
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

// A short cut of the shared V1_01 ground truth with its world, renderer and per-frame poses,
// in either rendering style.
struct SimSequence {
  ums::sim::SimStyle style = ums::sim::SimStyle::kProcedural;
  ums::RigCalibration rig;
  World world;
  std::vector<Eigen::Isometry3d> T_w_b;  // per frame
  std::vector<std::int64_t> t_ns;
};

SimSequence make_sequence(bool textureless, int frames, ums::sim::SimStyle style = ums::sim::SimStyle::kProcedural) {
  SimSequence s;
  s.style = style;
  ums::sim::SimOptions o;
  o.trajectory_path = ums::test::groundtruth_dir() + "/V101_GT.txt";
  o.scenario = textureless ? ums::sim::Scenario::kTextureless : ums::sim::Scenario::kNominal;
  o.start_s = kStartS;
  o.duration_s = static_cast<double>(frames + 1) / kCameraRateHz;
  o.camera_rate_hz = kCameraRateHz;
  o.style = style;
  s.rig = ums::sim::rig_preset(ums::sim::CameraPreset::kEuroc);
  for (auto& c : s.rig.cam) c.rate_hz = kCameraRateHz;
  const ums::sim::SimTrajectory tr = ums::sim::make_trajectory(o, s.rig);
  // World as simulate() builds it (path every 0.1 s, seed scrambled the same way), with smaller
  // test textures to keep the start-up cheap under qemu.
  std::vector<Eigen::Vector3d> path;
  for (std::int64_t t = tr.t_begin_ns; t <= tr.t_end_ns; t += 100'000'000LL) path.push_back(tr.T_w_b(t).translation());
  const auto seed = static_cast<std::uint32_t>(o.seed * 2654435761ULL);
  if (style == ums::sim::SimStyle::kPhoto) {
    ums::sim::PhotoWorldOptions wo;
    wo.seed = seed;
    wo.textureless_walls = textureless;
    wo.texture_size = 512;
    s.world = ums::sim::make_photo_world(path, wo, ums::sim::load_photo_source(ums::test::euroc_micro_dir()));
  } else {
    ums::sim::WorldOptions wo;
    wo.seed = seed;
    wo.textureless_walls = textureless;
    wo.texture_size = 512;
    s.world = ums::sim::make_world(path, wo);
  }
  const std::int64_t dt_ns = static_cast<std::int64_t>(std::llround(1e9 / kCameraRateHz));
  for (int k = 0; k < frames; ++k) {
    const std::int64_t t = tr.t_begin_ns + k * dt_ns;
    s.T_w_b.push_back(tr.T_w_b(t));
    s.t_ns.push_back(t);
  }
  return s;
}

// Renders frame k of s into left/right: the procedural renderer, or the photo one with its lens
// and light effects (one sub-exposure: the pose is exact at the stamp).
class SequenceRenderer {
 public:
  explicit SequenceRenderer(const SimSequence& s) : s_(s) {
    if (s.style == ums::sim::SimStyle::kPhoto) {
      photo_ = std::make_unique<ums::sim::PhotoRenderer>(s.world, s.rig, ums::sim::PhotoLensOptions{});
    } else {
      procedural_ = std::make_unique<ums::sim::StereoRenderer>(s.world, s.rig);
    }
  }
  void render(int k, std::uint8_t* left, std::uint8_t* right) const {
    const ums::sim::RenderOptions ro;  // default sensor noise
    const std::uint64_t key = 1000003ULL + static_cast<std::uint64_t>(k);
    if (photo_) {
      photo_->render_stereo(&s_.T_w_b[k], 1, ro, key, left, right);
    } else {
      procedural_->render_stereo(s_.T_w_b[k], ro, key, left, right);
    }
  }

 private:
  const SimSequence& s_;
  std::unique_ptr<ums::sim::StereoRenderer> procedural_;
  std::unique_ptr<ums::sim::PhotoRenderer> photo_;
};

// Runs the front end over the rendered sequence (default options, sensor noise on, the
// ground-truth rotation as the gyro hint) and calls on_frame(k, features) per frame.
template <typename F>
void run_frontend(const SimSequence& s, F&& on_frame) {
  const SequenceRenderer renderer(s);
  ums::Frontend fe(ums::FrontendOptions{}, s.rig);
  const int W = s.rig.cam[0].width, H = s.rig.cam[0].height;
  std::vector<std::uint8_t> left(static_cast<std::size_t>(W) * H), right(left.size());
  ums::FrameFeatures ff;
  for (int k = 0; k < static_cast<int>(s.T_w_b.size()); ++k) {
    renderer.render(k, left.data(), right.data());
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
  double sum_3d = 0;

  double rms_left() const { return std::sqrt(sum_sq_left / std::max(1, n_left)); }
  double rms_right() const { return std::sqrt(sum_sq_right / std::max(1, n_right)); }
  double rms_young() const { return std::sqrt(sum_sq_young / std::max(1, n_young)); }
  double rms_old() const { return std::sqrt(sum_sq_old / std::max(1, n_old)); }
  Eigen::Vector2d bias() const { return sum_err / std::max(1, n_left + n_right); }
  double outlier_share() const {
    return static_cast<double>(n_outliers) / std::max(1, n_left + n_right + n_outliers);
  }
};

constexpr double kOutlierPx = 2.0;

// One tracked pixel against the projection of the feature's world point.
void add_error(const Eigen::Vector2d& uv, const Eigen::Vector2d& uv_true, int cam, int track_length, TrackErrors* e) {
  const double err2 = (uv - uv_true).squaredNorm();
  if (err2 > kOutlierPx * kOutlierPx) {
    ++e->n_outliers;
    return;
  }
  (cam == 0 ? e->sum_sq_left : e->sum_sq_right) += err2;
  ++(cam == 0 ? e->n_left : e->n_right);
  e->sum_err += uv - uv_true;
  if (track_length <= 4) {
    e->sum_sq_young += err2;
    ++e->n_young;
  } else if (track_length >= 12) {
    e->sum_sq_old += err2;
    ++e->n_old;
  }
}

// Every feature's first pixel is cast into the world with the true pose and the renderer's
// geometry; in every later frame that world point, projected with the true pose, must lie where
// the front end tracked the feature (left, and right for 3D features). Outliers (> 2 px: e.g.
// corners on a depth edge, where the cast point lies on one surface and the tracked corner is
// formed by both) are counted apart, the RMS is over the inliers.
TrackErrors measure_tracks(const SimSequence& s) {
  const ums::CameraD cam[2] = {ums::CameraD::from_calibration(s.rig.cam[0]), ums::CameraD::from_calibration(s.rig.cam[1])};
  std::map<std::uint32_t, Eigen::Vector3d> X_w;  // world point per feature id (from its first observation)
  TrackErrors e;
  run_frontend(s, [&](int k, const ums::FrameFeatures& ff) {
    e.sum_3d += ff.n_3d;
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
        add_error((c == 0 ? ob.uv_left_px : ob.uv_right_px).cast<double>(), uv_true, c, ob.track_length, &e);
      }
    }
  });
  const Eigen::Vector2d bias = e.bias();
  std::printf("[frontend][sim] %s, %d frames: %d world points (%d casts failed), mean 3D %.1f; "
              "RMS left %.3f px over %d, right %.3f px over %d; outliers (> %.0f px) %d = %.2f %%; "
              "RMS at track length <= 4: %.3f px over %d, >= 12: %.3f px over %d; mean error (%.3f, %.3f) px\n",
              ums::sim::style_name(s.style), static_cast<int>(s.T_w_b.size()), e.n_points, e.n_cast_failed,
              e.sum_3d / static_cast<double>(s.T_w_b.size()), e.rms_left(), e.n_left, e.rms_right(), e.n_right,
              kOutlierPx, e.n_outliers, 100.0 * e.outlier_share(), e.rms_young(), e.n_young, e.rms_old(), e.n_old,
              bias.x(), bias.y());
  return e;
}

}  // namespace

// Acceptance (synthetic): tracks agree with the projected ground truth to a fraction of a pixel.
TEST_CASE("Simulator (V1_01 cut, EuRoC rig, noise on): tracks agree with the projected ground truth", "[frontend][sim][slow]") {
  const TrackErrors e = measure_tracks(make_sequence(false, kFrames));
  CHECK(e.n_points >= 150);
  CHECK(e.n_left >= 1000);
  CHECK(e.n_right >= 500);
  // Measured 0.39 px host / 0.40 px aarch64 (the rendered images differ slightly there), left
  // and right alike: sub-pixel with margin. The error is unbiased and grows with the track
  // length like a random walk of frame-to-frame KLT steps (0.16 / 0.25 px for young tracks,
  // ~0.5 px after 12+ frames); docs/frontend.md has the numbers.
  CHECK(e.rms_left() < 0.6);
  CHECK(e.rms_right() < 0.6);
  CHECK(e.rms_young() < 0.4);
  CHECK(e.rms_old() < 1.0);
  CHECK(e.bias().norm() < 0.1);
  CHECK(e.outlier_share() < 0.08);
}

// The same on the photo style: textures cut from real images, vignetting, uneven light, the
// larger room (far walls), so the front end is not measured on its own renderer only.
TEST_CASE("Simulator, photo style (V1_01 cut): tracks agree with the projected ground truth", "[frontend][sim][photo]") {
  if (ums::test::skip_heavy_under_emulation()) return;
  const TrackErrors e = measure_tracks(make_sequence(false, kFrames, ums::sim::SimStyle::kPhoto));
  CHECK(e.n_points >= 150);
  CHECK(e.n_left >= 1000);
  CHECK(e.n_right >= 500);
  // Measured 0.53 px left and right (procedural: 0.39), 0.31 px for young tracks and 0.70 px
  // after 12+ frames, 6.4 % beyond 2 px (procedural 2 %: more depth edges, boxes and pillars in
  // front of far walls). The growth with track length is the patch's change of appearance with
  // the view, not KLT resampling: refining every track against the patch of its first frame left
  // it unchanged (0.58 / 0.72 px after 12+ frames; docs/frontend.md).
  CHECK(e.rms_left() < 0.7);
  CHECK(e.rms_right() < 0.7);
  CHECK(e.rms_young() < 0.45);
  CHECK(e.rms_old() < 1.0);
  CHECK(e.bias().norm() < 0.1);
  CHECK(e.outlier_share() < 0.10);
}

// Acceptance (synthetic): the same cut in the textureless world (walls and ceiling flat grey)
// has a higher 2D share (2D-left + 2D-right over all features) than the nominal world.
TEST_CASE("Simulator (V1_01 cut): the 2D share rises in the textureless world", "[frontend][sim][slow]") {
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
