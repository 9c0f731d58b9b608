// The loop closer end to end on synthetic keyframes: each keyframe looks at a textured wall
// 2.5-4.5 m ahead (value noise rendered into a 752 x 480 image through a 460 px pinhole), its
// features are fixed points of that wall (so a revisit describes the same physical points from a
// different pose), its observations carry stereo points with depth noise in a drifted odometry
// frame. A 25 m circle that comes back to the first wall must close a loop whose relative pose is
// right and whose map frame removes the planted drift, also when the drift was planted during a
// blackout (blind keyframes: the first loop must put the map where the images say); a circle
// that comes back to unseen walls must close none; non-levelled and undescribed keyframes are
// counted and left out; a new odometry session is unplaced until a loop relocalizes it; and
// feeding keyframes allocates nothing.
#include "core/loop/loop_closer.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "profiling/alloc_counter.hpp"

using namespace ums;
using namespace ums::loop;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr int kWidthPx = 752, kHeightPx = 480;
constexpr double kFocalPx = 460.0, kCxPx = 376.0, kCyPx = 240.0;
constexpr double kKeyframeDt_s = 0.5;

// cam0 looks along body x (camera x = -body y, camera y = -body z), 5 cm ahead of the body origin.
Eigen::Isometry3d camera_in_body() {
  Eigen::Isometry3d T_b_c0 = Eigen::Isometry3d::Identity();
  T_b_c0.linear() << 0, 0, 1,
                    -1, 0, 0,
                     0, -1, 0;
  T_b_c0.translation() = Eigen::Vector3d(0.05, 0.0, 0.0);
  return T_b_c0;
}

// T_b_i: the IMU in the rig's body frame. The estimator's body (the keyframes') is the IMU, so the
// scenario's camera_in_body() is the camera in the IMU frame whatever T_b_i is.
RigCalibration make_rig(const Eigen::Isometry3d& T_b_i = Eigen::Isometry3d::Identity()) {
  RigCalibration rig;
  rig.imu.T_b_i = T_b_i;
  for (CameraCalibration& cam : rig.cam) {
    cam.model = CameraModel::kPinholeRadTan;
    cam.width = kWidthPx;
    cam.height = kHeightPx;
    cam.rate_hz = 20.0;
    cam.fx = cam.fy = kFocalPx;
    cam.cx = kCxPx;
    cam.cy = kCyPx;
    cam.distortion = {0.0, 0.0, 0.0, 0.0};
    cam.T_b_c = T_b_i * camera_in_body();
  }
  Eigen::Isometry3d T_i_c1 = camera_in_body();
  T_i_c1.translation().y() -= 0.095;  // a D455-like baseline (unused by the closer)
  rig.cam[1].T_b_c = T_b_i * T_i_c1;
  return rig;
}

Eigen::Isometry3d level_pose(double x_m, double y_m, double z_m, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, y_m, z_m);
  return T;
}

double yaw_of(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

double angle_deg(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle() / kDeg; }

// ---- the world: one textured vertical wall per place ------------------------------------------

std::uint32_t mix(std::uint32_t x) {  // a 32-bit integer hash (lowbias32)
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

double lattice(std::int64_t i, std::int64_t j, std::uint32_t seed) {
  const std::uint32_t h = mix(static_cast<std::uint32_t>(i) * 0x9E3779B1U ^ mix(static_cast<std::uint32_t>(j) + seed * 0x85EBCA77U));
  return static_cast<double>(h & 0xFFFFU) / 65535.0;
}

// Bilinear value noise of the lattice with cells of cell_m.
double value_noise(double a_m, double b_m, double cell_m, std::uint32_t seed) {
  const double x = a_m / cell_m, y = b_m / cell_m;
  const double fx = std::floor(x), fy = std::floor(y);
  const auto i = static_cast<std::int64_t>(fx), j = static_cast<std::int64_t>(fy);
  const double u = x - fx, v = y - fy;
  return (1 - u) * (1 - v) * lattice(i, j, seed) + u * (1 - v) * lattice(i + 1, j, seed) +
         (1 - u) * v * lattice(i, j + 1, seed) + u * v * lattice(i + 1, j + 1, seed);
}

struct Wall {
  Eigen::Vector3d p0_w = Eigen::Vector3d::Zero();   // a point of the wall, m
  Eigen::Vector3d e1_w = Eigen::Vector3d::UnitY();  // horizontal in-plane axis
  Eigen::Vector3d e2_w = Eigen::Vector3d::UnitZ();  // vertical in-plane axis
  Eigen::Vector3d n_w = -Eigen::Vector3d::UnitX();  // normal
  std::uint32_t seed = 0;                           // its texture and its feature points

  // Grey level at wall coordinates (a, b) in metres: two octaves of value noise, 6 and 2 cm.
  std::uint8_t grey(double a_m, double b_m) const {
    const double g = 0.75 * value_noise(a_m, b_m, 0.06, seed) + 0.25 * value_noise(a_m, b_m, 0.02, seed + 7919U);
    return static_cast<std::uint8_t>(std::lround(20.0 + 215.0 * g));
  }
  // Where the ray from o_w along d_w meets the wall (false when it does not, ahead).
  bool intersect(const Eigen::Vector3d& o_w, const Eigen::Vector3d& d_w, Eigen::Vector3d* x_w) const {
    const double den = n_w.dot(d_w);
    if (std::abs(den) < 1e-9) return false;
    const double t = n_w.dot(p0_w - o_w) / den;
    if (t <= 0.0) return false;
    *x_w = o_w + t * d_w;
    return true;
  }
};

// A vertical wall 3.2 m ahead of the body, turned 20 deg about the vertical so that its depth in
// the image runs from about 2.5 m (left edge) to 4.5 m (right edge).
Wall wall_ahead(const Eigen::Isometry3d& T_w_b, std::uint32_t seed) {
  Wall w;
  const Eigen::Vector3d forward = T_w_b.linear().col(0);
  w.p0_w = T_w_b.translation() + 3.2 * forward;
  w.n_w = Eigen::AngleAxisd(20.0 * kDeg, Eigen::Vector3d::UnitZ()) * -forward;
  w.e2_w = Eigen::Vector3d::UnitZ();
  w.e1_w = w.e2_w.cross(w.n_w).normalized();
  w.seed = seed;
  return w;
}

// The wall's feature points: a 0.35 m lattice in wall coordinates, each jittered by up to
// +-0.1 m by its own hash (the corners a detector finds again from another pose).
Eigen::Vector3d wall_point(const Wall& w, int i, int j) {
  const double ja = (lattice(i, j, w.seed + 101U) - 0.5) * 0.2, jb = (lattice(i, j, w.seed + 202U) - 0.5) * 0.2;
  return w.p0_w + (0.35 * i + ja) * w.e1_w + (0.35 * j + jb) * w.e2_w;
}

struct Image {
  std::vector<std::uint8_t> pixels = std::vector<std::uint8_t>(static_cast<std::size_t>(kWidthPx) * kHeightPx, 0);
  ImageView view() const { return ImageView{pixels.data(), kWidthPx, kHeightPx, kWidthPx}; }
};

// The left image of the wall seen from camera pose T_w_c0 (grey 0 where no wall).
void render(const Wall& w, const Eigen::Isometry3d& T_w_c0, Image* image) {
  for (int v = 0; v < kHeightPx; ++v) {
    for (int u = 0; u < kWidthPx; ++u) {
      const Eigen::Vector3d d_w = T_w_c0.linear() * Eigen::Vector3d((u - kCxPx) / kFocalPx, (v - kCyPx) / kFocalPx, 1.0);
      Eigen::Vector3d x_w;
      std::uint8_t g = 0;
      if (w.intersect(T_w_c0.translation(), d_w, &x_w)) g = w.grey((x_w - w.p0_w).dot(w.e1_w), (x_w - w.p0_w).dot(w.e2_w));
      image->pixels[static_cast<std::size_t>(v) * kWidthPx + u] = g;
    }
  }
}

// ---- keyframes -----------------------------------------------------------------------------------

struct KeyframeInput {
  FrameId id = kNoFrame;
  std::int64_t t_ns = 0;
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();  // truth
  Image image;
  std::unique_ptr<FrameFeatures> features = std::make_unique<FrameFeatures>();
  std::unique_ptr<MarginalizedKeyframe> keyframe = std::make_unique<MarginalizedKeyframe>();
};

class Scenario {
 public:
  Scenario() : T_b_c0_(camera_in_body()), rng_(11) {}

  // The keyframe at true body pose T_w_b looking at `wall`, as the odometry (frame `epoch`) has it
  // at T_odom_b: features at the wall points visible in the image, stereo points with 0.5 % depth
  // noise and bearings with 0.3 px of noise, in the odometry frame.
  std::unique_ptr<KeyframeInput> keyframe(FrameId id, double t_s, const Eigen::Isometry3d& T_w_b,
                                          const Eigen::Isometry3d& T_odom_b, const Wall& wall,
                                          std::uint32_t epoch = 0) {
    auto in = std::make_unique<KeyframeInput>();
    in->id = id;
    in->t_ns = static_cast<std::int64_t>(std::llround(t_s * 1e9));
    in->T_w_b = T_w_b;
    const Eigen::Isometry3d T_w_c0 = T_w_b * T_b_c0_;
    render(wall, T_w_c0, &in->image);
    FrameFeatures& ff = *in->features;
    ff.t_ns = in->t_ns;
    MarginalizedKeyframe& k = *in->keyframe;
    k.id = id;
    k.t_ns = in->t_ns;
    k.odometry_epoch = epoch;
    k.gravity_aligned = true;
    k.T_odom_b = T_odom_b;
    const Eigen::Isometry3d T_c0_w = T_w_c0.inverse();
    std::normal_distribution<double> n01(0.0, 1.0);
    for (int i = -25; i <= 25; ++i) {
      for (int j = -15; j <= 15; ++j) {
        const Eigen::Vector3d p_c = T_c0_w * wall_point(wall, i, j);
        if (p_c.z() < 0.5) continue;
        const Eigen::Vector2d uv(kFocalPx * p_c.x() / p_c.z() + kCxPx, kFocalPx * p_c.y() / p_c.z() + kCyPx);
        if (uv.x() < 20.0 || uv.x() > kWidthPx - 21.0 || uv.y() < 20.0 || uv.y() > kHeightPx - 21.0) continue;
        if (ff.features.full()) continue;
        FeatureObservation f;
        f.id = next_feature_id_++;
        f.cls = FeatureClass::k3D;
        f.track_length = 5;
        f.uv_left_px = uv.cast<float>();
        const Eigen::Vector2d uv_noisy = uv + 0.3 * Eigen::Vector2d(n01(rng_), n01(rng_));
        const Eigen::Vector3d bearing = Eigen::Vector3d((uv_noisy.x() - kCxPx) / kFocalPx, (uv_noisy.y() - kCyPx) / kFocalPx, 1.0).normalized();
        f.xy_left = (bearing.head<2>() / bearing.z()).cast<float>();
        f.bearing_left = bearing.cast<float>();
        ff.features.push_back(f);
        ++ff.n_3d;
        KeyframeObservation o;
        o.landmark_id = f.id;
        o.has_left = o.has_right = o.stereo = o.has_point = true;
        o.bearing_left = f.bearing_left;
        o.p_odom = T_odom_b * (T_b_c0_ * (p_c * (1.0 + 0.005 * n01(rng_))));
        k.observations.push_back(o);
      }
    }
    return in;
  }

 private:
  Eigen::Isometry3d T_b_c0_;
  std::mt19937 rng_;
  std::uint32_t next_feature_id_ = 1;
};

void feed(LoopCloser* closer, const KeyframeInput& in) {
  closer->on_keyframe_image(in.id, in.t_ns, in.image.view(), *in.features);
  closer->on_keyframe(*in.keyframe);
}

// A vocabulary trained on 20 walls that no test flies past (k = 8, 3 levels: 512 words).
const Vocabulary& vocabulary() {
  static const Vocabulary voc = [] {
    Scenario s;
    BriefDescriber describer(kWidthPx, kHeightPx);
    std::vector<std::vector<Descriptor>> images;
    for (std::uint32_t seed = 9000; seed < 9020; ++seed) {
      const Eigen::Isometry3d T_w_b = level_pose(0.0, 0.0, 1.5, 0.3 * (seed - 9000));
      const auto in = s.keyframe(seed, 0.0, T_w_b, T_w_b, wall_ahead(T_w_b, seed));
      describer.set_image(in->image.view());
      images.emplace_back();
      for (const FeatureObservation& f : in->features->features) {
        Descriptor d;
        if (describer.describe(f.uv_left_px.x(), f.uv_left_px.y(), &d)) images.back().push_back(d);
      }
    }
    VocabularyParams p;
    p.k = 8;
    p.levels = 3;
    return Vocabulary::train(images, p);
  }();
  return voc;
}

// ---- the flight ----------------------------------------------------------------------------------

// Truth: a level circle of radius 4 m growing by 3 mm per keyframe (the second pass is ~0.18 m
// outside the first), counterclockwise from the origin heading +x, `per_lap` keyframes per lap.
Eigen::Isometry3d circle_pose(int k, int per_lap) {
  const double phi = 2.0 * kPi * k / per_lap;
  const double r_m = 4.0 + 0.003 * k;
  return level_pose(r_m * std::sin(phi), 4.0 - r_m * std::cos(phi), 1.5, phi);
}

// Dead reckoning from truth[0] with every step's yaw off by yaw_drift_rad and a creep of
// bias_m per step in the odometry frame (an accelerometer bias's): the 4-DoF drift of a VIO.
// Only the steps into keyframes first_step..last_step drift; the others follow the truth's
// increments exactly.
// growing: the translation drift of step k is bias_m * (k - first_step + 1), dead reckoning's
// (its velocity error grows with the time since the images went), not bias_m every step.
std::vector<Eigen::Isometry3d> drifted(const std::vector<Eigen::Isometry3d>& truth, double yaw_drift_rad,
                                       const Eigen::Vector3d& bias_m, std::size_t first_step = 1,
                                       std::size_t last_step = ~std::size_t{0}, bool growing = false) {
  std::vector<Eigen::Isometry3d> odom{truth[0]};
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const bool drifts = k >= first_step && k <= last_step;
    const Eigen::Isometry3d T_rel = truth[k - 1].inverse() * truth[k];
    Eigen::Isometry3d T = odom.back();
    const double times = growing ? static_cast<double>(k - first_step + 1) : 1.0;
    T.translation() += odom.back().linear() * T_rel.translation() + (drifts ? Eigen::Vector3d(times * bias_m) : Eigen::Vector3d::Zero());
    T.linear() = Eigen::AngleAxisd(yaw_of(odom.back()) + yaw_of(truth[k]) - yaw_of(truth[k - 1]) + (drifts ? yaw_drift_rad : 0.0),
                                   Eigen::Vector3d::UnitZ()).toRotationMatrix();
    odom.push_back(T);
  }
  return odom;
}

struct Flight {
  std::vector<std::unique_ptr<KeyframeInput>> keyframes;
  std::vector<Eigen::Isometry3d> truth, odom;
  int first_return = 0;  // index of the first keyframe back at the start
};

// 60 keyframes 0.5 s apart around the circle (30 s, 25 m), then `n_return` more at the start.
// Keyframes 0 and 1 look at wall 0; every other outbound keyframe at a wall of its own; the
// return keyframes at wall 0 again (revisit_wall) or at walls never seen (!revisit_wall). The
// odometry drifts by 2 deg of yaw and 1 mm per keyframe along x: 0.21 m and 2.1 deg at the return.
std::unique_ptr<Flight> circle_flight(bool revisit_wall, int n_return = 3) {
  constexpr int kPerLap = 60;
  auto f = std::make_unique<Flight>();
  for (int k = 0; k < kPerLap + n_return; ++k) f->truth.push_back(circle_pose(k, kPerLap));
  f->odom = drifted(f->truth, 2.0 / kPerLap * kDeg, Eigen::Vector3d(0.001, 0.0, 0.0));
  f->first_return = kPerLap;
  Scenario s;
  const Wall wall0 = wall_ahead(f->truth[0], 1);
  for (int k = 0; k < kPerLap + n_return; ++k) {
    const bool returning = k >= kPerLap;
    Wall w = wall_ahead(f->truth[k], 1000U + static_cast<std::uint32_t>(k));
    if (k <= 1 || (returning && revisit_wall)) w = wall0;
    f->keyframes.push_back(s.keyframe(static_cast<FrameId>(100 + k), kKeyframeDt_s * k, f->truth[k], f->odom[k], w));
  }
  return f;
}

std::uint64_t total_rejected(const LoopStats& st) {
  std::uint64_t n = 0;
  for (std::uint64_t r : st.rejected_by) n += r;
  return n;
}

std::string rejections(const LoopStats& st) {
  std::string s;
  for (int g = 0; g < static_cast<int>(LoopGate::kCount); ++g)
    s += std::string(to_string(static_cast<LoopGate>(g))) + " " + std::to_string(st.rejected_by[g]) + ", ";
  return s;
}

// The circle back to the first wall with a blackout: keyframes kBlindFirst..kBlindLast (10 of
// them, 5 s, 4.2 m of the circle) see nothing (black image, no features, no observations), and
// the dead reckoning through them drifts by 0.4 m (along odometry x) and 3 deg of yaw; before and
// after it the odometry follows the truth exactly. At the return the 3 deg have also turned the
// second half of the circle: the odometry is off by 0.80 m and 3 deg there.
constexpr int kBlindFirst = 20, kBlindLast = 29;

std::unique_ptr<Flight> blackout_flight(int n_return = 1, bool growing_drift = false) {
  constexpr int kPerLap = 60;
  constexpr int kBlind = kBlindLast - kBlindFirst + 1;
  auto f = std::make_unique<Flight>();
  for (int k = 0; k < kPerLap + n_return; ++k) f->truth.push_back(circle_pose(k, kPerLap));
  if (growing_drift) {
    // Dead reckoning until the first keyframe with images again: 11 steps, 0.4 m in all.
    constexpr int kSteps = kBlind + 1;
    f->odom = drifted(f->truth, 3.0 / kSteps * kDeg, Eigen::Vector3d(0.4 / (kSteps * (kSteps + 1) / 2), 0.0, 0.0),
                      kBlindFirst, kBlindLast + 1, true);
  } else {
    f->odom = drifted(f->truth, 3.0 / kBlind * kDeg, Eigen::Vector3d(0.4 / kBlind, 0.0, 0.0), kBlindFirst, kBlindLast);
  }
  f->first_return = kPerLap;
  Scenario s;
  const Wall wall0 = wall_ahead(f->truth[0], 1);
  for (int k = 0; k < kPerLap + n_return; ++k) {
    const auto id = static_cast<FrameId>(100 + k);
    if (k >= kBlindFirst && k <= kBlindLast) {  // a black image: no features, no observations
      auto in = std::make_unique<KeyframeInput>();
      in->id = in->keyframe->id = id;
      in->t_ns = in->features->t_ns = in->keyframe->t_ns = static_cast<std::int64_t>(std::llround(kKeyframeDt_s * k * 1e9));
      in->T_w_b = f->truth[k];
      in->keyframe->gravity_aligned = true;
      in->keyframe->T_odom_b = f->odom[k];
      f->keyframes.push_back(std::move(in));
      continue;
    }
    Wall w = wall_ahead(f->truth[k], 1000U + static_cast<std::uint32_t>(k));
    if (k <= 1 || k >= kPerLap) w = wall0;
    f->keyframes.push_back(s.keyframe(id, kKeyframeDt_s * k, f->truth[k], f->odom[k], w));
  }
  return f;
}

// The flight fed until its first accepted loop, and where that left the newest keyframe.
struct FirstLoop {
  bool closed = false;
  std::size_t newest = 0;                                  // keyframe index: the loop's query
  FrameId loop = kNoFrame;                                 // the keyframe it closed to
  Eigen::Isometry3d error = Eigen::Isometry3d::Identity();  // truth^-1 * its map pose
  std::uint64_t not_indexed = 0;                           // keyframes under min_features
  std::uint64_t refused_by_graph = 0;                      // loop.rejected_by.pose_graph
  std::string stats;
};

FirstLoop first_loop(const Flight& flight, const LoopOptions& options) {
  LoopCloser closer(options, make_rig(), vocabulary());
  FirstLoop r;
  for (std::size_t k = 0; k < flight.keyframes.size() && closer.stats().accepted == 0; ++k) {
    feed(&closer, *flight.keyframes[k]);
    r.newest = k;
  }
  const LoopStats& st = closer.stats();
  r.not_indexed = st.keyframes_not_indexed;
  r.refused_by_graph = st.rejected_by[static_cast<int>(LoopGate::kPoseGraph)];
  r.stats = "keyframes " + std::to_string(st.keyframes_in) + ", not indexed " + std::to_string(st.keyframes_not_indexed) +
            ", queries " + std::to_string(st.queries) + ", candidates " + std::to_string(st.candidates) +
            ", accepted " + std::to_string(st.accepted) + "; rejected: " + rejections(st);
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();
  r.closed = st.accepted == 1 && closer.num_events() == 1 &&
             closer.event(0).query == flight.keyframes[r.newest]->id && closer.map_from_odometry(0, &T_map_odom);
  if (closer.num_events() > 0) r.loop = closer.event(0).loop;
  r.error = flight.truth[r.newest].inverse() * (T_map_odom * flight.odom[r.newest]);
  return r;
}

}  // namespace

TEST_CASE("LoopCloser: a circle back to the first wall closes a loop and the map frame removes the drift", "[loop][slow]") {
  const auto flight = circle_flight(true);
  LoopCloser closer(LoopOptions{}, make_rig(), vocabulary());
  for (const auto& k : flight->keyframes) feed(&closer, *k);
  const LoopStats& st = closer.stats();
  const std::size_t newest = flight->keyframes.size() - 1;
  const Eigen::Isometry3d planted = flight->truth[newest].inverse() * flight->odom[newest];
  INFO("keyframes " << st.keyframes_in << ", not indexed " << st.keyframes_not_indexed << ", queries " << st.queries
                    << " (skipped " << st.queries_skipped << "), candidates " << st.candidates << ", accepted "
                    << st.accepted << "; rejected: " << rejections(st) << " planted drift "
                    << planted.translation().norm() << " m, " << std::abs(yaw_of(planted)) / kDeg << " deg");
  CHECK(st.keyframes_in == flight->keyframes.size());
  CHECK(st.keyframes_not_indexed == 0);
  CHECK(closer.database().size() == flight->keyframes.size());
  REQUIRE(st.accepted >= 1);
  REQUIRE(closer.num_events() == st.accepted);
  CHECK(planted.translation().norm() > 0.18);  // the drift the loop has to remove
  CHECK(std::abs(yaw_of(planted)) > 1.5 * kDeg);

  for (std::size_t e = 0; e < closer.num_events(); ++e) {
    const LoopEvent& ev = closer.event(e);
    const int q = static_cast<int>(ev.query) - 100, c = static_cast<int>(ev.loop) - 100;
    // Every loop joins a return keyframe to one that saw wall 0 the first time.
    CHECK(q >= flight->first_return);
    CHECK((c == 0 || c == 1));
    if (q < flight->first_return || c < 0 || c > 1) continue;
    const Eigen::Isometry3d T_c_q_true = flight->truth[c].inverse() * flight->truth[q];
    const double e_m = (ev.T_loop_query.translation() - T_c_q_true.translation()).norm();
    const double e_deg = angle_deg(T_c_q_true.linear().transpose() * ev.T_loop_query.linear());
    INFO("loop " << e << ": query " << q << " -> keyframe " << c << ", " << ev.inliers << " inliers, relative pose error "
                 << e_m * 1e3 << " mm, " << e_deg << " deg; correction " << ev.correction_m << " m, "
                 << ev.correction_deg << " deg");
    CHECK(ev.inliers >= 25);
    CHECK_FALSE(ev.relocalization);
    CHECK(e_m < 0.02);
    CHECK(e_deg < 0.3);
  }

  Eigen::Isometry3d T_map_odom;
  REQUIRE(closer.map_from_odometry(0, &T_map_odom));
  CHECK(closer.corrections() >= 1);
  const Eigen::Isometry3d T_map_b = T_map_odom * flight->odom[newest];
  const Eigen::Isometry3d error = flight->truth[newest].inverse() * T_map_b;
  INFO("newest keyframe: odometry off by " << planted.translation().norm() << " m, " << angle_deg(planted.linear())
                                           << " deg; map off by " << error.translation().norm() << " m, "
                                           << angle_deg(error.linear()) << " deg");
  // Measured: 0.206 m and 2.07 deg of drift left 0.014 m and 0.57 deg (two loops). The yaw keeps
  // ~30 %: the loop edge's 0.5 deg sigma is as wide as the odometry chain's yaw uncertainty over
  // 60 edges (0.062 deg each), although the loops measured it to 0.02-0.04 deg.
  CHECK(error.translation().norm() < 0.05);
  CHECK(angle_deg(error.linear()) < 0.5 * angle_deg(planted.linear()));
}

// The keyframes are the estimator's, whose body is the IMU: with the IMU away from the rig's body
// origin the closer must see the camera in the IMU frame (T_b_i^-1 * T_b_c), not T_b_c. Taking
// T_b_c for it (before) put every stereo point 0.3 m and 90 deg off and closed no loop here.
TEST_CASE("LoopCloser: the camera is placed in the IMU frame when the rig's body is not the IMU", "[loop][slow]") {
  Eigen::Isometry3d T_b_i = Eigen::Isometry3d::Identity();
  T_b_i.linear() = Eigen::AngleAxisd(0.5 * kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_b_i.translation() = Eigen::Vector3d(0.1, -0.2, 0.15);
  const auto flight = circle_flight(true);
  LoopCloser closer(LoopOptions{}, make_rig(T_b_i), vocabulary());
  LoopCloser same_camera(LoopOptions{}, make_rig(), vocabulary());
  // The same camera in the IMU frame: the same calibration for the map files.
  CHECK(closer.calibration_hash() == same_camera.calibration_hash());
  for (const auto& k : flight->keyframes) feed(&closer, *k);
  INFO("rejected: " << rejections(closer.stats()));
  REQUIRE(closer.stats().accepted >= 1);
  for (std::size_t e = 0; e < closer.num_events(); ++e) {
    const LoopEvent& ev = closer.event(e);
    const int q = static_cast<int>(ev.query) - 100, c = static_cast<int>(ev.loop) - 100;
    REQUIRE((c == 0 || c == 1));
    const Eigen::Isometry3d T_c_q_true = flight->truth[c].inverse() * flight->truth[q];
    CHECK((ev.T_loop_query.translation() - T_c_q_true.translation()).norm() < 0.02);  // m
    CHECK(angle_deg(T_c_q_true.linear().transpose() * ev.T_loop_query.linear()) < 0.3);
  }
}

TEST_CASE("LoopCloser: after a blackout the first loop puts the map where the images say (blind_sigma_scale)", "[loop][slow]") {
  const auto flight = blackout_flight();
  const std::size_t back = static_cast<std::size_t>(flight->first_return);
  const Eigen::Isometry3d planted = flight->truth[back].inverse() * flight->odom[back];
  INFO("planted at the return: " << planted.translation().norm() << " m, " << angle_deg(planted.linear()) << " deg");
  CHECK(planted.translation().norm() > 0.5);  // the 0.4 m plus the 3 deg turning the second half
  CHECK(angle_deg(planted.linear()) == Approx(3.0).margin(0.01));

  const FirstLoop blind = first_loop(*flight, LoopOptions{});
  LoopOptions trusting;
  trusting.blind_sigma_scale = 1.0;  // the dead reckoning through the blackout weighed as VIO
  trusting.blind_drift_time_s = 1e12;
  const FirstLoop seen = first_loop(*flight, trusting);
  const double blind_m = blind.error.translation().norm(), blind_deg = angle_deg(blind.error.linear());
  const double seen_m = seen.error.translation().norm(), seen_deg = angle_deg(seen.error.linear());
  INFO("blind_sigma_scale 100: " << blind.stats << " keyframe " << blind.newest << " off by " << blind_m << " m, "
                                 << blind_deg << " deg");
  INFO("blind_sigma_scale 1: " << seen.stats << " keyframe " << seen.newest << " off by " << seen_m << " m, "
                               << seen_deg << " deg");
  // The blind keyframes are kept (they carry the odometry chain) but not indexed.
  CHECK(blind.not_indexed == static_cast<std::uint64_t>(kBlindLast - kBlindFirst + 1));
  // The first return keyframe closes to wall 0.
  REQUIRE(blind.closed);
  CHECK(blind.newest == back);
  CHECK((blind.loop == 100 || blind.loop == 101));
  CHECK(blind.refused_by_graph == 0);
  // Measured: of 0.80 m and 3.0 deg at the return, 100x blind sigmas leave 0.0014 m and 0.0003 deg
  // (the loop measurement's own error: the 11 edges touching a blind keyframe take the whole
  // correction). Trusting the blackout's dead reckoning, the solved graph cannot take the loop
  // within 5 of its sigmas (~1 mm here) against a chain of stiff edges: every return loop is
  // refused (gate pose_graph) and the map stays where the dead reckoning put it. (With the former
  // constant 0.03 m / 0.5 deg loop sigmas and no such check it was pulled to 0.18 m.)
  CHECK(blind_m < 0.02);
  CHECK(blind_deg < 0.1);
  CHECK_FALSE(seen.closed);
  CHECK(seen.refused_by_graph >= 1);
  CHECK(seen_m > 0.5);
  CHECK(seen_m > 10.0 * blind_m);
}

// Where the first loop after a blackout leaves the keyframes flown blind: dead reckoning's drift
// grows with the time since the images went (here each step drifts one step's worth more than the
// one before, 0.4 m and 3 deg in all over 11 steps, 5.5 s), and the blind edges' sigmas growing
// with that time (blind_drift_time_s) let the correction follow it; with constant blind sigmas
// the graph spreads it evenly and leaves the middle of the stretch off. Measured: worst blind
// keyframe 0.033 m growing, 0.107 m flat; the return keyframe 1.4 mm either way.
TEST_CASE("LoopCloser: the blind stretch is corrected in the shape of dead reckoning's drift (blind_drift_time_s)", "[loop][slow]") {
  const auto flight = blackout_flight(1, true);
  const auto worst_blind_m = [&](const LoopOptions& options, double* at_return_m) {
    LoopCloser closer(options, make_rig(), vocabulary());
    for (std::size_t k = 0; k < flight->keyframes.size() && closer.stats().accepted == 0; ++k) feed(&closer, *flight->keyframes[k]);
    REQUIRE(closer.stats().accepted == 1);
    double worst_m = 0.0;
    const KeyframeDatabase& db = closer.database();
    for (std::int32_t s = db.oldest(); s >= 0; s = db.at(s).next) {
      const KeyframeRecord& r = db.at(s);
      const auto k = static_cast<std::size_t>(r.id - 100);
      const double e_m = (r.T_map_b.translation() - flight->truth[k].translation()).norm();
      if (k >= static_cast<std::size_t>(kBlindFirst) && k <= static_cast<std::size_t>(kBlindLast)) worst_m = std::max(worst_m, e_m);
      if (k == static_cast<std::size_t>(flight->first_return)) *at_return_m = e_m;
    }
    return worst_m;
  };
  LoopOptions flat;
  flat.blind_drift_time_s = 1e12;  // the blind sigmas 100x, not growing
  double growing_return_m = 0.0, flat_return_m = 0.0;
  const double growing_m = worst_blind_m(LoopOptions{}, &growing_return_m);
  const double flat_m = worst_blind_m(flat, &flat_return_m);
  INFO("worst blind keyframe: growing sigmas " << growing_m << " m, flat " << flat_m << " m; at the return "
       << growing_return_m << " / " << flat_return_m << " m");
  CHECK(growing_return_m < 0.02);
  CHECK(flat_return_m < 0.02);
  CHECK(growing_m < 0.5 * flat_m);
}

TEST_CASE("LoopCloser: a circle back to walls never seen closes no loop, every candidate's rejection is counted", "[loop]") {
  const auto flight = circle_flight(false, 10);
  LoopCloser closer(LoopOptions{}, make_rig(), vocabulary());
  for (const auto& k : flight->keyframes) feed(&closer, *k);
  const LoopStats& st = closer.stats();
  INFO("queries " << st.queries << ", candidates " << st.candidates << "; rejected: " << rejections(st));
  CHECK(st.accepted == 0);
  CHECK(closer.num_events() == 0);
  CHECK(closer.corrections() == 0);
  CHECK(st.queries == flight->keyframes.size());  // no loop, so no query skipped
  // Keyframes 41-69 are more than 20 s after the first: up to 3 candidates each (84 measured).
  CHECK(st.candidates >= 60);
  CHECK(total_rejected(st) == st.candidates);
  Eigen::Isometry3d T_map_odom;
  REQUIRE(closer.map_from_odometry(0, &T_map_odom));  // the first levelled frame is the map
  CHECK(T_map_odom.isApprox(Eigen::Isometry3d::Identity()));
}

TEST_CASE("LoopCloser: keyframes not levelled, without an image or with few features are counted and not indexed", "[loop][slow]") {
  Scenario s;
  LoopCloser closer(LoopOptions{}, make_rig(), vocabulary());
  const Eigen::Isometry3d T0 = circle_pose(0, 60);
  Eigen::Isometry3d T_map_odom;

  // Visual odometry before the frame is levelled: described, but not kept (the map is 4-DoF).
  auto vo = s.keyframe(1, 0.0, T0, T0, wall_ahead(T0, 1));
  vo->keyframe->gravity_aligned = false;
  feed(&closer, *vo);
  CHECK(closer.stats().keyframes_in == 1);
  CHECK(closer.stats().keyframes_not_levelled == 1);
  CHECK(closer.database().size() == 0);
  CHECK(closer.stats().sessions == 0);
  CHECK_FALSE(closer.map_from_odometry(0, &T_map_odom));

  // Levelled but its image never came (it was not a keyframe when it arrived): kept in the pose
  // graph's chain, not in the index. The first levelled frame is the map.
  const Eigen::Isometry3d T1 = circle_pose(1, 60);
  auto blind = s.keyframe(2, 0.5, T1, T1, wall_ahead(T1, 2));
  closer.on_keyframe(*blind->keyframe);
  CHECK(closer.stats().keyframes_without_image == 1);
  CHECK(closer.stats().sessions == 1);
  REQUIRE(closer.database().size() == 1);
  const KeyframeRecord& r = closer.database().at(static_cast<std::uint32_t>(closer.database().newest()));
  CHECK(r.id == 2);
  CHECK(r.features.empty());
  CHECK_FALSE(r.indexed);
  REQUIRE(closer.map_from_odometry(0, &T_map_odom));
  CHECK(T_map_odom.isApprox(Eigen::Isometry3d::Identity()));

  // An image with 20 3D features (min_features is 30): kept, not indexed, not queried.
  const Eigen::Isometry3d T2 = circle_pose(2, 60);
  auto sparse = s.keyframe(3, 1.0, T2, T2, wall_ahead(T2, 3));
  REQUIRE(sparse->keyframe->observations.size() > 100);
  sparse->keyframe->observations.resize(20);
  feed(&closer, *sparse);
  CHECK(closer.stats().keyframes_not_indexed == 1);
  CHECK(closer.stats().queries == 0);
  CHECK(closer.database().size() == 2);
  CHECK(closer.database().at(static_cast<std::uint32_t>(closer.database().newest())).features.size() == 20);

  // 2D features and landmarks without depth are not loop features.
  const Eigen::Isometry3d T3 = circle_pose(3, 60);
  auto mixed = s.keyframe(4, 1.5, T3, T3, wall_ahead(T3, 4));
  const std::size_t n_obs = mixed->keyframe->observations.size();
  for (std::size_t i = 0; i < n_obs; i += 3) mixed->keyframe->observations[i].stereo = false;
  for (std::size_t i = 1; i < n_obs; i += 3) mixed->keyframe->observations[i].has_point = false;
  feed(&closer, *mixed);
  const KeyframeRecord& m = closer.database().at(static_cast<std::uint32_t>(closer.database().newest()));
  CHECK(m.features.size() == n_obs / 3);
  CHECK(m.indexed);
  CHECK(closer.stats().keyframes_in == 4);
}

TEST_CASE("LoopCloser: a new odometry session has no map pose until a loop to the first one relocalizes it", "[loop][slow]") {
  Scenario s;
  LoopCloser closer(LoopOptions{}, make_rig(), vocabulary());
  const Wall wall0 = wall_ahead(circle_pose(0, 60), 1);
  // Session 0: 10 keyframes around the start of the circle, odometry = truth (the map is the world).
  for (int k = 0; k < 10; ++k) {
    const Eigen::Isometry3d T = circle_pose(k, 60);
    feed(&closer, *s.keyframe(static_cast<FrameId>(100 + k), kKeyframeDt_s * k, T, T,
                              k <= 1 ? wall0 : wall_ahead(T, 1000U + static_cast<std::uint32_t>(k))));
  }
  Eigen::Isometry3d T_map_odom;
  REQUIRE(closer.map_from_odometry(0, &T_map_odom));
  CHECK(closer.stats().accepted == 0);

  // The estimator resets: epoch 1, an odometry frame 40 deg and metres away from the first.
  const Eigen::Isometry3d T_odom1_w = level_pose(-3.0, 2.0, -1.5, 40.0 * kDeg);
  for (int k = 10; k < 13; ++k) {
    const Eigen::Isometry3d T = circle_pose(k, 60);
    feed(&closer, *s.keyframe(static_cast<FrameId>(100 + k), kKeyframeDt_s * k, T, T_odom1_w * T,
                              wall_ahead(T, 1000U + static_cast<std::uint32_t>(k)), 1));
  }
  CHECK(closer.stats().sessions == 2);
  CHECK_FALSE(closer.map_from_odometry(1, &T_map_odom));
  CHECK_FALSE(closer.map_from_odometry(0, &T_map_odom));  // not the current odometry frame any more
  CHECK(closer.stats().relocalizations == 0);

  // Back at the first wall (0.18 m outside the first pass), 7 s after the first keyframe.
  const Eigen::Isometry3d T_back = circle_pose(60, 60);
  feed(&closer, *s.keyframe(200, 7.0, T_back, T_odom1_w * T_back, wall0, 1));
  const LoopStats& st = closer.stats();
  INFO("queries " << st.queries << ", candidates " << st.candidates << ", accepted " << st.accepted
                  << "; rejected: " << rejections(st));
  REQUIRE(st.accepted == 1);
  CHECK(st.relocalizations == 1);
  REQUIRE(closer.num_events() == 1);
  CHECK(closer.event(0).relocalization);
  CHECK(closer.event(0).query == 200);
  REQUIRE(closer.map_from_odometry(1, &T_map_odom));
  // The map is the world (session 0's odometry was exact): T_map_odom1 must be T_w_odom1.
  const Eigen::Isometry3d error = T_odom1_w * T_map_odom;
  INFO("T_map_odom1 off by " << error.translation().norm() << " m, " << angle_deg(error.linear()) << " deg");
  CHECK(error.translation().norm() < 0.02);
  CHECK(angle_deg(error.linear()) < 0.3);
  const Eigen::Isometry3d map_error = T_back.inverse() * T_map_odom * (T_odom1_w * T_back);
  CHECK(map_error.translation().norm() < 0.02);
  CHECK(closer.corrections() >= 1);
  // Both frames are levelled: the placement is a yaw and a translation, never a tilt.
  CHECK((T_map_odom.linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm() < 1e-12);
}

TEST_CASE("LoopCloser: describing, keeping, querying, verifying and closing a loop allocate nothing", "[loop][slow]") {
  const auto flight = circle_flight(true);  // every input built before the count
  LoopCloser closer(LoopOptions{}, make_rig(), vocabulary());
  AllocScope scope;
  for (const auto& k : flight->keyframes) feed(&closer, *k);
  const auto allocations = scope.allocations();
  INFO("counter available " << alloc_counter_available() << ": allocations " << allocations << " ("
                             << scope.bytes() << " bytes) over " << flight->keyframes.size()
                             << " keyframes; footprint " << closer.footprint_bytes() << " bytes");
  REQUIRE(closer.stats().accepted >= 1);  // the count covered a verification and a pose-graph solve
  if (alloc_counter_available()) CHECK(allocations == 0);
}

TEST_CASE("LoopCloser: a full database makes room by decimation, allocating nothing", "[loop][slow]") {
  LoopCloser closer(LoopOptions{}, make_rig(), vocabulary());
  // Keyframes without images (cheap: no descriptors) 0.1 m apart; every 10th one 1 m further.
  MarginalizedKeyframe k;
  k.gravity_aligned = true;
  double x_m = 0.0;
  const std::size_t n = capacity::kMaxKeyframes + 50;
  AllocScope scope;
  for (std::size_t i = 0; i < n; ++i) {
    x_m += (i % 10 == 0) ? 1.0 : 0.1;
    k.id = static_cast<FrameId>(i);
    k.t_ns = static_cast<std::int64_t>(i) * 500'000'000;
    k.T_odom_b = level_pose(x_m, 0.0, 1.5, 0.0);
    closer.on_keyframe(k);
  }
  const auto allocations = scope.allocations();
  CHECK(closer.database().size() == capacity::kMaxKeyframes);
  CHECK(closer.stats().keyframes_decimated == 50);
  CHECK(closer.stats().keyframes_without_image == n);
  // The oldest, the newest 60 and every keyframe 1 m from its predecessor stay: 0.1 m steps go.
  CHECK(closer.database().at(static_cast<std::uint32_t>(closer.database().oldest())).id == 0);
  std::size_t after_jump = 0;
  for (std::int32_t t = closer.database().oldest(); t >= 0; t = closer.database().at(static_cast<std::uint32_t>(t)).next)
    after_jump += closer.database().at(static_cast<std::uint32_t>(t)).id % 10 == 0 ? 1 : 0;
  CHECK(after_jump == n / 10);
  std::int32_t s = closer.database().newest();
  for (int i = 0; i < 60; ++i, s = closer.database().at(static_cast<std::uint32_t>(s)).prev)
    CHECK(closer.database().at(static_cast<std::uint32_t>(s)).id == static_cast<FrameId>(n - 1 - i));
  if (alloc_counter_available()) CHECK(allocations == 0);
}


TEST_CASE("LoopCloser: an accepted loop asks the window to measure it again, the loop edge takes the blend", "[loop][relocation]") {
  const auto flight = circle_flight(true, 1);
  LoopCloser closer(LoopOptions{}, make_rig(), vocabulary());
  for (const auto& k : flight->keyframes) feed(&closer, *k);
  REQUIRE(closer.stats().accepted == 1);
  const LoopEvent ev = closer.event(0);
  const KeyframeInput& q = *flight->keyframes.back();
  REQUIRE(ev.query == q.id);

  RelocationRequest request;
  REQUIRE(closer.take_relocation(&request));
  CHECK_FALSE(closer.take_relocation(&request));  // taken once
  CHECK(request.query == ev.query);
  CHECK(request.loop == ev.loop);
  CHECK(request.odometry_epoch == 0);
  CHECK((request.T_odom_q.matrix() - q.keyframe->T_odom_b.matrix()).norm() < 1e-12);
  CHECK((request.T_q_loop.matrix() - ev.T_loop_query.inverse().matrix()).norm() < 1e-9);
  // The verifier's inliers, named by the query's landmarks.
  CHECK(request.matches.size() == static_cast<std::size_t>(ev.inliers));
  std::size_t known = 0;
  for (const RelocationMatch& m : request.matches) {
    for (const KeyframeObservation& o : q.keyframe->observations) known += o.landmark_id == m.landmark_id ? 1 : 0;
  }
  CHECK(known == request.matches.size());

  // What the window could not use changes nothing.
  const int c = static_cast<int>(ev.loop) - 100;
  const Eigen::Isometry3d T_c_q_true = flight->truth[c].inverse() * flight->truth[flight->keyframes.size() - 1];
  const std::uint32_t corrections = closer.corrections();
  RelocationResult result;
  result.query = ev.query;
  result.loop = ev.loop;
  result.residuals = result.inliers = 0;
  closer.on_relocated(result);
  CHECK(closer.stats().relocation_too_few == 1);
  result.residuals = result.inliers = 80;
  result.T_loop_query = T_c_q_true * level_pose(0.2, 0.0, 0.0, 0.0);  // 0.2 m from the truth: too far
  closer.on_relocated(result);
  CHECK(closer.stats().relocation_too_far == 1);
  result.loop = ev.loop + 1;  // a loop the closer does not have
  result.T_loop_query = T_c_q_true;
  closer.on_relocated(result);
  CHECK(closer.stats().relocation_stale == 1);
  CHECK(closer.corrections() == corrections);
  CHECK_FALSE(closer.event(0).refined);

  // The window's measurement (here the truth) and the verified one, of equal weight, become the
  // loop's; the map moves.
  result.loop = ev.loop;
  closer.on_relocated(result);
  CHECK(closer.stats().relocations_refined == 1);
  CHECK(closer.corrections() == corrections + 1);
  CHECK(closer.event(0).refined);
  const Eigen::Isometry3d& blended = closer.event(0).T_loop_query;
  CHECK((blended.translation() - 0.5 * (ev.T_loop_query.translation() + T_c_q_true.translation())).norm() < 1e-12);
  const double to_verified = angle_deg(blended.linear().transpose() * ev.T_loop_query.linear());
  const double to_window = angle_deg(blended.linear().transpose() * T_c_q_true.linear());
  CHECK(to_verified == Approx(to_window).margin(1e-9));

  LoopOptions loose;
  loose.tight_relocation = false;
  LoopCloser without(loose, make_rig(), vocabulary());
  for (const auto& k : flight->keyframes) feed(&without, *k);
  CHECK(without.stats().accepted == 1);
  CHECK_FALSE(without.take_relocation(&request));
  CHECK(without.stats().relocation_requests == 0);
}
