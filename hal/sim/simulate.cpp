#include "hal/sim/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>

#include "core/math/se3.hpp"
#include "core/math/so3.hpp"
#include "hal/sim/car_route.hpp"
#include "hal/sim/decimated_imu.hpp"
#include "hal/replay/euroc_writer.hpp"
#include "hal/sim/random_vector.hpp"

namespace ums::sim {
namespace {

constexpr double kKnotDt = 0.05;  // s: control points at the 20 Hz ground-truth rate

Eigen::Isometry3d make_T(const double m[16]) {
  Eigen::Matrix4d M;
  for (int i = 0; i < 16; ++i) M(i / 4, i % 4) = m[i];
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(M.block<3, 3>(0, 0)).normalized().toRotationMatrix();
  T.translation() = M.block<3, 1>(0, 3);
  return T;
}

struct Sample {
  std::int64_t t_ns;
  Eigen::Vector3d p_w_b;
  Eigen::Quaterniond q_w_b;
};

std::vector<Sample> read_groundtruth_body(const std::string& path, const Eigen::Isometry3d& T_b_c0) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<Sample> out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    std::int64_t t_ns = 0;
    bool first = true;
    while (std::getline(ss, cell, ',')) {
      if (first) {
        t_ns = std::strtoll(cell.c_str(), nullptr, 10);
        first = false;
      } else {
        char* end = nullptr;
        v.push_back(std::strtod(cell.c_str(), &end));
        if (end == cell.c_str()) throw std::runtime_error(path + ":" + std::to_string(n) + ": not a number '" + cell + "'");
      }
    }
    if (v.size() < 7) throw std::runtime_error(path + ":" + std::to_string(n) + ": needs >= 8 columns");
    Sample s;
    s.t_ns = t_ns;
    Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    q.normalize();
    if (v.size() == 7) {
      // Shared *_GT.txt: cam0 position, q = R_CW. Body: T_w_b = T_w_c0 * T_b_c0^-1.
      Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
      T_w_c.linear() = q.conjugate().toRotationMatrix();
      T_w_c.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
      const Eigen::Isometry3d T_w_b = T_w_c * T_b_c0.inverse();
      s.p_w_b = T_w_b.translation();
      s.q_w_b = Eigen::Quaterniond(T_w_b.rotation());
    } else {
      s.p_w_b = Eigen::Vector3d(v[0], v[1], v[2]);
      s.q_w_b = q;
    }
    if (!out.empty() && t_ns <= out.back().t_ns) continue;
    out.push_back(s);
  }
  if (out.size() < 8) throw std::runtime_error(path + ": fewer than 8 poses");
  return out;
}

// Built-in: a 70 s figure-eight at 1-1.5 m/s with height changes, camera looking along the
// direction of travel (tilted 15 deg down), body from the camera through T_b_c0.
std::vector<Sample> builtin_trajectory(const Eigen::Isometry3d& T_b_c0) {
  std::vector<Sample> out;
  for (int k = 0; k <= 1400; ++k) {
    const double t = k * kKnotDt;
    const double w = 2.0 * M_PI / 35.0;
    const Eigen::Vector3d p(3.0 * std::sin(w * t), 2.0 * std::sin(2.0 * w * t), 1.4 + 0.4 * std::sin(0.7 * w * t));
    const Eigen::Vector3d v(3.0 * w * std::cos(w * t), 4.0 * w * std::cos(2.0 * w * t), 0.0);
    const double yaw = std::atan2(v.y(), v.x()) + 0.4 * std::sin(0.5 * t);
    const Eigen::Vector3d z(std::cos(yaw) * std::cos(0.26), std::sin(yaw) * std::cos(0.26), -std::sin(0.26));
    const Eigen::Vector3d x = Eigen::Vector3d::UnitZ().cross(z).normalized() * -1.0;
    Eigen::Matrix3d R_w_c;
    R_w_c.col(0) = x;
    R_w_c.col(1) = z.cross(x);
    R_w_c.col(2) = z;
    Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
    T_w_c.linear() = R_w_c;
    T_w_c.translation() = p;
    const Eigen::Isometry3d T_w_b = T_w_c * T_b_c0.inverse();
    out.push_back({1'000'000'000'000LL + static_cast<std::int64_t>(k) * 50'000'000LL, T_w_b.translation(),
                   Eigen::Quaterniond(T_w_b.rotation())});
  }
  return out;
}

Sample interpolate(const std::vector<Sample>& s, std::int64_t t_ns) {
  auto it = std::lower_bound(s.begin(), s.end(), t_ns, [](const Sample& a, std::int64_t t) { return a.t_ns < t; });
  if (it == s.begin()) return s.front();
  if (it == s.end()) return s.back();
  const Sample& b = *it;
  const Sample& a = *(it - 1);
  const double f = static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  return {t_ns, a.p_w_b + f * (b.p_w_b - a.p_w_b), a.q_w_b.slerp(f, b.q_w_b)};
}

}  // namespace

bool parse_scenario(const std::string& name, Scenario* scenario) {
  for (Scenario s : kAllScenarios) {
    if (name == scenario_name(s)) {
      *scenario = s;
      return true;
    }
  }
  for (Scenario s : kCarScenarios) {
    if (name == scenario_name(s)) {
      *scenario = s;
      return true;
    }
  }
  return false;
}

bool is_car_scenario(Scenario scenario) { return scenario == Scenario::kCarTurn || scenario == Scenario::kCarLoop; }

const char* scenario_name(Scenario s) {
  switch (s) {
    case Scenario::kNominal: return "nominal";
    case Scenario::kStandstillStart: return "standstill-start";
    case Scenario::kUniformStart: return "uniform-start";
    case Scenario::kDarkStart: return "dark-start";
    case Scenario::kTextureless: return "textureless";
    case Scenario::kImpulses: return "impulses";
    case Scenario::kRightDropout: return "right-dropout";
    case Scenario::kBlackout: return "blackout";
    case Scenario::kCarTurn: return "car-turn";
    case Scenario::kCarLoop: return "car-loop";
  }
  return "?";
}

bool parse_style(const std::string& name, SimStyle* style) {
  if (name == "procedural") *style = SimStyle::kProcedural;
  else if (name == "photo") *style = SimStyle::kPhoto;
  else return false;
  return true;
}

const char* style_name(SimStyle style) { return style == SimStyle::kPhoto ? "photo" : "procedural"; }

bool parse_camera_preset(const std::string& name, CameraPreset* preset) {
  if (name == "euroc") *preset = CameraPreset::kEuroc;
  else if (name == "d455") *preset = CameraPreset::kD455;
  else return false;
  return true;
}

RigCalibration rig_preset(CameraPreset preset) {
  RigCalibration rig;
  if (preset == CameraPreset::kEuroc) {
    static const double T0[16] = {0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
                                  0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
                                  -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
                                  0, 0, 0, 1};
    static const double T1[16] = {0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556,
                                  0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024,
                                  -0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038,
                                  0, 0, 0, 1};
    const double K[2][4] = {{458.654, 457.296, 367.215, 248.375}, {457.587, 456.134, 379.999, 255.238}};
    const std::array<double, 4> D[2] = {{-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05},
                                        {-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05}};
    for (int c = 0; c < 2; ++c) {
      CameraCalibration& cc = rig.cam[c];
      cc.model = CameraModel::kPinholeRadTan;
      cc.width = 752;
      cc.height = 480;
      cc.rate_hz = 20.0;
      cc.fx = K[c][0]; cc.fy = K[c][1]; cc.cx = K[c][2]; cc.cy = K[c][3];
      cc.distortion = D[c];
      cc.T_b_c = make_T(c == 0 ? T0 : T1);
    }
    rig.imu = ImuCalibration{};  // ADIS16448 densities (EuRoC imu0/sensor.yaml) are the defaults
    return rig;
  }
  // D455: IR pair at 848x480 (HFOV ~87 deg -> fx ~ 424 / tan(43.5 deg) ~ 447 px), rectified
  // (zero distortion), 95 mm baseline; IMU axes taken parallel to the camera's (RealSense reports
  // its IMU in the depth frame's orientation), small lever arm. Not a device calibration.
  for (int c = 0; c < 2; ++c) {
    CameraCalibration& cc = rig.cam[c];
    cc.model = CameraModel::kPinholeRadTan;
    cc.width = 848;
    cc.height = 480;
    cc.rate_hz = 20.0;
    cc.fx = cc.fy = 430.0;
    cc.cx = 424.0;
    cc.cy = 240.0;
    cc.distortion = {0.0, 0.0, 0.0, 0.0};
    cc.T_b_c = Eigen::Isometry3d::Identity();
    cc.T_b_c.translation() = Eigen::Vector3d(-0.03 + 0.095 * c, 0.005, 0.016);
  }
  // BMI055: gyro 0.014 deg/s/sqrt(Hz), accel 150 ug/sqrt(Hz) (datasheet); random walks assumed.
  rig.imu.gyro_noise_density = 0.014 * M_PI / 180.0;
  rig.imu.accel_noise_density = 150e-6 * 9.81;
  rig.imu.gyro_random_walk = 2.0e-5;
  rig.imu.accel_random_walk = 3.0e-4;
  return rig;
}

bool SimOptions::validate(std::string* error) const {
  auto bad = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (out_dir.empty()) return bad("simulate: out_dir is required");
  if (!(camera_rate_hz > 0.0 && camera_rate_hz <= 200.0)) return bad("simulate: camera_rate_hz must be in (0, 200] Hz");
  if (!(imu_rate_hz >= camera_rate_hz && imu_rate_hz <= 2000.0)) return bad("simulate: imu_rate_hz must be in [camera rate, 2000] Hz");
  if (!(gravity_m_s2 > 0.0)) return bad("simulate: gravity_m_s2 must be > 0");
  if (!(start_s >= 0.0)) return bad("simulate: start_s must be >= 0");
  if (!(blackout_s > 0.0 && blackout_s <= 120.0)) return bad("simulate: --blackout-s must be in (0, 120] s");
  if (!(initial_gyro_bias_sigma_rad_s >= 0.0 && initial_accel_bias_sigma_m_s2 >= 0.0)) return bad("simulate: bias sigmas must be >= 0");
  if (accel_rate_hz != 0.0) {
    const double every = imu_rate_hz / accel_rate_hz;
    if (!(accel_rate_hz > 0.0 && every >= 1.0 && std::abs(every - std::round(every)) < 1e-9)) {
      return bad("simulate: accel_rate_hz must divide the IMU rate (" + std::to_string(imu_rate_hz) + " Hz)");
    }
  }
  if (!(std::abs(td_s) <= 0.1)) return bad("simulate: --td-ms must be within +-100 ms");
  if (!(extrinsic_error_deg >= 0.0 && extrinsic_error_deg <= 10.0)) return bad("simulate: --extrinsic-error-deg must be in [0, 10]");
  if (!(extrinsic_error_m >= 0.0 && extrinsic_error_m <= 0.1)) return bad("simulate: --extrinsic-error-mm must be in [0, 100]");
  if (is_car_scenario(scenario)) {
    const std::string name = scenario_name(scenario);
    if (!trajectory_path.empty()) return bad("simulate: scenario " + name + " drives its own route: --trajectory must be empty");
    if (start_s != 0.0) return bad("simulate: scenario " + name + " starts at the route's start: --start must be 0");
    if (style != SimStyle::kProcedural) return bad("simulate: scenario " + name + " exists in the procedural style only");
    if (!street.validate(error)) return false;
  }
  if (imu_model == ImuModel::kRealistic && !imu_errors.validate(error)) return false;
  if (style == SimStyle::kPhoto) {
    if (texture_dataset.empty()) {
      return bad("simulate: style photo needs texture_dataset (--texture-dataset DIR: an EuRoC dataset folder holding mav0/)");
    }
    if (!(imu_internal_rate_hz >= imu_rate_hz && imu_internal_rate_hz <= 20000.0)) {
      return bad("simulate: imu_internal_rate_hz must be in [imu rate, 20000] Hz");
    }
    if (!(initial_gyro_bias_max_rad_s >= 0.0 && initial_accel_bias_max_m_s2 >= 0.0)) return bad("simulate: bias bounds must be >= 0");
    if (!exposure.validate(error) || !photo_world.validate(error) || !lens.validate(error)) return false;
  }
  return world.validate(error) && render.validate(error);
}

Eigen::Isometry3d SimTrajectory::T_w_b(std::int64_t t_ns) const {
  if (style == SimStyle::kPhoto) return se3.evaluate(t_ns);
  const SplineState s = spline.evaluate(t_ns);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = s.q_w_b.toRotationMatrix();
  T.translation() = s.p_w_b;
  return T;
}

namespace {

// Uniform 20 Hz control poses of the cut, with the scenario prefix in front.
struct ControlPoints {
  std::vector<Eigen::Quaterniond> q;
  std::vector<Eigen::Vector3d> p;
  std::int64_t first_ns = 0;  // start of the cut (the flight)
  int prefix = 0;             // control points before the flight
};

ControlPoints cut_control_points(const SimOptions& o, const RigCalibration& rig) {
  const Eigen::Isometry3d& T_b_c0 = rig.cam[0].T_b_c;
  const std::vector<Sample> raw =
      o.trajectory_path.empty() ? builtin_trajectory(T_b_c0) : read_groundtruth_body(o.trajectory_path, T_b_c0);
  const std::int64_t dt_ns = static_cast<std::int64_t>(kKnotDt * 1e9);
  ControlPoints c;
  c.first_ns = raw.front().t_ns + static_cast<std::int64_t>(o.start_s * 1e9);
  std::int64_t last = raw.back().t_ns;
  if (o.duration_s > 0.0) last = std::min(last, c.first_ns + static_cast<std::int64_t>(o.duration_s * 1e9));
  if (last - c.first_ns < 4 * dt_ns) throw std::runtime_error("simulate: the cut leaves less than 0.2 s of trajectory");
  // Control points: uniform knots covering [first - dt, last + dt] (the spline is valid from the
  // second to the second-last knot).
  for (std::int64_t t = c.first_ns - dt_ns; t <= last + dt_ns; t += dt_ns) {
    const Sample s = interpolate(raw, t);
    // Keep the quaternion hemisphere continuous (relative logs are taken anyway).
    Eigen::Quaterniond qs = s.q_w_b;
    if (!c.q.empty() && c.q.back().dot(qs) < 0.0) qs.coeffs() *= -1.0;
    c.q.push_back(qs);
    c.p.push_back(s.p_w_b);
  }
  return c;
}

void add_scenario_prefix(Scenario scenario, ControlPoints* c) {
  auto& q = c->q;
  auto& p = c->p;
  if (scenario == Scenario::kStandstillStart) {
    c->prefix = static_cast<int>(std::lround(5.0 / kKnotDt));
    q.insert(q.begin(), static_cast<std::size_t>(c->prefix), q.front());
    p.insert(p.begin(), static_cast<std::size_t>(c->prefix), p.front());
  } else if (scenario == Scenario::kUniformStart) {
    // Constant velocity: the flight's initial velocity, at least 0.5 m/s (EuRoC flights start at
    // rest); horizontal direction of the first 2 s of travel when the start is at rest.
    c->prefix = static_cast<int>(std::lround(6.0 / kKnotDt));
    Eigen::Vector3d v = (p[2] - p[0]) / (2.0 * kKnotDt);
    if (v.norm() < 0.5) {
      Eigen::Vector3d dir = p[std::min<std::size_t>(40, p.size() - 1)] - p[0];
      dir.z() = 0.0;
      if (dir.norm() < 1e-3) dir = Eigen::Vector3d::UnitX();
      v = 0.5 * dir.normalized();
    }
    std::vector<Eigen::Quaterniond> qp(static_cast<std::size_t>(c->prefix), q.front());
    std::vector<Eigen::Vector3d> pp;
    for (int k = c->prefix; k >= 1; --k) pp.push_back(p.front() - v * (k * kKnotDt));
    q.insert(q.begin(), qp.begin(), qp.end());
    p.insert(p.begin(), pp.begin(), pp.end());
  }
}

// Car scenarios: the route's camera poses every knot (from one knot before its start) turned into
// body poses through T_b_c0; duration_s cuts the route short.
ControlPoints car_control_points(const SimOptions& o, const RigCalibration& rig) {
  const CarRoute route = o.scenario == Scenario::kCarTurn ? CarRoute::kTurn : CarRoute::kLoop;
  const Eigen::Isometry3d T_c0_b = rig.cam[0].T_b_c.inverse();
  ControlPoints c;
  c.first_ns = 1'000'000'000'000LL;
  for (const CarPose& pose : car_camera_poses(route, kKnotDt, o.duration_s)) {
    Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
    T_w_c.linear() = pose.R_w_c;
    T_w_c.translation() = pose.p_w_c;
    const Eigen::Isometry3d T_w_b = T_w_c * T_c0_b;
    Eigen::Quaterniond q(T_w_b.rotation());
    if (!c.q.empty() && c.q.back().dot(q) < 0.0) q.coeffs() *= -1.0;
    c.q.push_back(q);
    c.p.push_back(T_w_b.translation());
  }
  return c;
}

}  // namespace

SimTrajectory make_trajectory(const SimOptions& o, const RigCalibration& rig) {
  ControlPoints c = is_car_scenario(o.scenario) ? car_control_points(o, rig) : cut_control_points(o, rig);
  add_scenario_prefix(o.scenario, &c);
  const std::int64_t dt_ns = static_cast<std::int64_t>(kKnotDt * 1e9);
  SimTrajectory tr;
  tr.style = o.style;
  const std::int64_t t0 = c.first_ns - dt_ns - static_cast<std::int64_t>(c.prefix) * dt_ns;
  tr.flight_begin_ns = c.first_ns;
  if (o.style == SimStyle::kPhoto) {
    std::vector<Eigen::Isometry3d> T(c.q.size());
    for (std::size_t k = 0; k < c.q.size(); ++k) T[k] = se3::make(c.q[k], c.p[k]);
    tr.se3.init(t0, kKnotDt, std::move(T));
    // The IMU's integration window reaches beyond its first and last stamp.
    const std::int64_t margin = decimated_imu_margin_ns(o.imu_rate_hz);
    tr.t_begin_ns = tr.se3.start_ns() + margin;
    tr.t_end_ns = tr.se3.end_ns() - margin;
    tr.flight_begin_ns = std::max(tr.flight_begin_ns, tr.t_begin_ns);
  } else {
    tr.spline.init(t0, kKnotDt, std::move(c.q), std::move(c.p));
    tr.t_begin_ns = tr.spline.start_ns();
    tr.t_end_ns = tr.spline.end_ns();
  }
  return tr;
}

namespace {

int accel_every(const SimOptions& o) {
  return o.accel_rate_hz > 0.0 ? static_cast<int>(std::lround(o.imu_rate_hz / o.accel_rate_hz)) : 1;
}

// The realistic model's errors, before a slower accelerometer is interpolated (so it samples the
// vibration at its own rate, as the real one does).
void add_realistic_errors(const SimOptions& o, ImuTrack* track) {
  if (o.imu_model != ImuModel::kRealistic) return;
  apply_imu_errors(o.imu_errors, draw_imu_errors(o.imu_errors, o.seed), o.seed, track);
}

}  // namespace

ImuTrack generate_imu(const SimTrajectory& tr, const ImuCalibration& imu, const SimOptions& o) {
  if (tr.style == SimStyle::kPhoto) {
    DecimatedImuOptions d;
    d.output_rate_hz = o.imu_rate_hz;
    d.internal_rate_hz = o.imu_internal_rate_hz;
    d.gravity_m_s2 = o.gravity_m_s2;
    d.gyro_bias_max_rad_s = o.initial_gyro_bias_max_rad_s;
    d.accel_bias_max_m_s2 = o.initial_accel_bias_max_m_s2;
    d.impulses = o.scenario == Scenario::kImpulses;
    d.seed = o.seed;
    ImuTrack track = generate_decimated_imu(tr.se3, tr.t_begin_ns, tr.t_end_ns, imu, d);
    add_realistic_errors(o, &track);
    interpolate_accel(accel_every(o), &track);
    return track;
  }
  ImuTrack track;
  std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ULL + 17);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto nvec = [&] { return draw_vector3([&] { return n01(rng); }); };
  const double dt = 1.0 / o.imu_rate_hz;
  const std::int64_t dt_ns = static_cast<std::int64_t>(std::llround(1e9 / o.imu_rate_hz));
  // Discrete white noise std = density * sqrt(rate); bias random walk step = rw * sqrt(dt).
  // A slower accelerometer (accel_rate_hz) averages over its longer period: less white noise per
  // sample, then interpolated onto the gyro's stamps below.
  const double sg = imu.gyro_noise_density / std::sqrt(dt);
  const double sa = o.accel_rate_hz > 0.0 && o.accel_rate_hz < o.imu_rate_hz ? imu.accel_noise_density * std::sqrt(o.accel_rate_hz)
                                                                             : imu.accel_noise_density / std::sqrt(dt);
  const double rg = imu.gyro_random_walk * std::sqrt(dt), ra = imu.accel_random_walk * std::sqrt(dt);
  Eigen::Vector3d bg = o.initial_gyro_bias_sigma_rad_s * nvec();
  Eigen::Vector3d ba = o.initial_accel_bias_sigma_m_s2 * nvec();
  const Eigen::Vector3d g_w(0.0, 0.0, -o.gravity_m_s2);
  std::vector<double> yaw_rate;
  for (std::int64_t t = tr.t_begin_ns; t <= tr.t_end_ns; t += dt_ns) {
    const SplineState s = tr.spline.evaluate(t);
    ImuSample m;
    m.t_ns = t;
    m.gyro_rad_s = s.omega_b_rad_s + bg + sg * nvec();
    m.accel_m_s2 = s.q_w_b.conjugate() * (s.a_w_b - g_w) + ba + sa * nvec();
    hal::GroundTruthState gt;
    gt.t_ns = t;
    gt.p_w_b = s.p_w_b;
    gt.q_w_b = s.q_w_b;
    gt.v_w_b = s.v_w_b;
    gt.gyro_bias_rad_s = bg;
    gt.accel_bias_m_s2 = ba;
    track.samples.push_back(m);
    track.truth.push_back(gt);
    yaw_rate.push_back(std::abs((s.q_w_b * s.omega_b_rad_s).z()));
    bg += rg * nvec();
    ba += ra * nvec();
  }
  add_realistic_errors(o, &track);
  interpolate_accel(accel_every(o), &track);
  if (o.scenario == Scenario::kImpulses) {
    add_impulses(yaw_rate, o.imu_rate_hz, static_cast<double>(tr.t_end_ns - tr.t_begin_ns) * 1e-9, rng, n01, &track);
  }
  return track;
}

void apply_timing_preset(CameraPreset preset, SimOptions* o) {
  const bool d455 = preset == CameraPreset::kD455;
  o->camera_rate_hz = d455 ? 30.0 : 20.0;
  o->imu_rate_hz = 200.0;
  o->accel_rate_hz = d455 ? 100.0 : 0.0;
}

RigCalibration written_calibration(const RigCalibration& truth, const SimOptions& o) {
  RigCalibration rig = truth;
  if (o.extrinsic_error_deg == 0.0 && o.extrinsic_error_m == 0.0) return rig;
  std::mt19937_64 rng(o.seed * 0x2545F4914F6CDD1DULL + 29);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::Vector3d axis = draw_vector3([&] { return n01(rng); }).normalized();
  const Eigen::Vector3d dir = draw_vector3([&] { return n01(rng); }).normalized();
  // The same body-side change for both cameras: T_b_c' = E * T_b_c keeps T_c0_c1.
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.linear() = Eigen::AngleAxisd(o.extrinsic_error_deg * M_PI / 180.0, axis).toRotationMatrix();
  E.translation() = o.extrinsic_error_m * dir;
  for (CameraCalibration& c : rig.cam) c.T_b_c = E * c.T_b_c;
  return rig;
}

namespace {

// The world of a run and the style's renderer over it.
struct Scene {
  World world;
  std::unique_ptr<StereoRenderer> procedural;
  std::unique_ptr<PhotoRenderer> photo;
};

// Builds *scene in place (the renderers keep a reference to scene->world). No world is built
// when no frame is rendered (IMU-only runs in tests).
void make_scene(const SimOptions& o, const SimTrajectory& tr, const RigCalibration& rig, int total, Scene* scene) {
  if (total == 0) return;
  std::vector<Eigen::Vector3d> path;
  for (std::int64_t t = tr.t_begin_ns; t <= tr.t_end_ns; t += 100'000'000LL) path.push_back(tr.T_w_b(t).translation());
  const std::uint32_t world_seed = static_cast<std::uint32_t>(o.seed * 2654435761ULL);
  const bool textureless = o.scenario == Scenario::kTextureless;
  if (o.style == SimStyle::kPhoto) {
    PhotoWorldOptions wo = o.photo_world;
    wo.seed = world_seed;
    wo.textureless_walls = wo.textureless_walls || textureless;
    const PhotoSource source = load_photo_source(o.texture_dataset);
    scene->world = make_photo_world(path, wo, source);
    scene->photo = std::make_unique<PhotoRenderer>(scene->world, rig, o.lens);
    return;
  }
  if (is_car_scenario(o.scenario)) {
    StreetOptions so = o.street;
    so.seed = world_seed;
    scene->world = make_street_world(path, so);
  } else {
    WorldOptions wo = o.world;
    wo.seed = world_seed;
    wo.textureless_walls = o.world.textureless_walls || textureless;
    scene->world = make_world(path, wo);
  }
  scene->procedural = std::make_unique<StereoRenderer>(scene->world, rig);
}

// Renders the pair of frame k at t_ns; returns the sub-exposures per camera (procedural: 1).
int render_pair(const Scene& scene, const SimTrajectory& tr, const SimOptions& o, const RigCalibration& rig, int k,
                std::int64_t t_ns, const RenderOptions& ro, std::uint8_t* left, std::uint8_t* right) {
  const std::uint64_t noise_key = o.seed * 1000003ULL + static_cast<std::uint64_t>(k);
  if (scene.procedural) {
    scene.procedural->render_stereo(tr.T_w_b(t_ns), ro, noise_key, left, right);
    return 1;
  }
  // Photo: exposure centred on the stamp, sub-exposures from the image motion during it.
  const double ms = o.exposure.exposure_ms;
  const std::int64_t half_ns = static_cast<std::int64_t>(std::llround(0.5e6 * ms));
  const double blur_px =
      exposure_blur_px(tr.T_w_b(t_ns - half_ns), tr.T_w_b(t_ns + half_ns), rig.cam[0].fx, o.exposure.near_depth_m);
  const int n = sub_exposure_count(blur_px, o.exposure);
  Eigen::Isometry3d poses[kMaxSubExposures];
  for (int j = 0; j < n; ++j) poses[j] = tr.T_w_b(sub_exposure_time_ns(t_ns, ms, n, j));
  scene.photo->render_stereo(poses, n, ro, noise_key, left, right);
  return n;
}

// The blackout in integer nanoseconds, so that the black frames and sim_events.csv agree exactly.
struct BlackoutSpan {
  std::int64_t begin_ns, end_ns;
};
BlackoutSpan blackout_span(const SimOptions& o, const SimTrajectory& tr) {
  const std::int64_t mid_ns = tr.t_begin_ns + (tr.t_end_ns - tr.t_begin_ns) / 2;
  const std::int64_t half_ns = std::llround(o.blackout_s * 0.5e9);
  return {mid_ns - half_ns, mid_ns + half_ns};
}

void write_events(const SimOptions& o, const SimTrajectory& tr, const ImuTrack& imu, double mid_s) {
  std::ofstream ev(o.out_dir + "/sim_events.csv");
  ev << "#scenario " << scenario_name(o.scenario) << ", seed " << o.seed << ", style " << style_name(o.style) << "\n";
  if (o.td_s != 0.0 || o.extrinsic_error_deg != 0.0 || o.extrinsic_error_m != 0.0 || accel_every(o) > 1) {
    ev << "#sensors: td_s " << o.td_s << ", extrinsic error " << o.extrinsic_error_deg << " deg " << o.extrinsic_error_m
       << " m (not in the calibration written), accelerometer " << o.imu_rate_hz / accel_every(o) << " Hz\n";
  }
  if (o.imu_model == ImuModel::kRealistic) ev << imu_errors_header(o.imu_errors, draw_imu_errors(o.imu_errors, o.seed));
  ev << "#t_ns,event\n";
  ev << tr.t_begin_ns << ",begin\n" << tr.flight_begin_ns << ",flight_begin\n";
  for (std::size_t i : imu.impulse_index) ev << imu.samples[i].t_ns << ",imu_impulse\n";
  if (o.scenario == Scenario::kDarkStart) ev << tr.t_begin_ns + 3'000'000'000LL << ",dark_end\n";
  if (o.scenario == Scenario::kRightDropout) {
    const auto mid_ns = tr.t_begin_ns + static_cast<std::int64_t>(mid_s * 1e9);
    ev << mid_ns - 2'000'000'000LL << ",right_dropout_begin\n" << mid_ns + 2'000'000'000LL << ",right_dropout_end\n";
  }
  if (o.scenario == Scenario::kBlackout) {
    const BlackoutSpan span = blackout_span(o, tr);
    ev << span.begin_ns << ",blackout_begin\n" << span.end_ns << ",blackout_end\n";
  }
  ev << tr.t_end_ns << ",end\n";
  if (!ev) throw std::runtime_error(o.out_dir + "/sim_events.csv: write failed");
}

void write_imu(hal::EurocWriter& writer, const ImuTrack& imu) {
  for (std::size_t i = 0; i < imu.samples.size(); ++i) {
    if (writer.write_imu(imu.samples[i]) != Status::kOk || writer.write_groundtruth(imu.truth[i]) != Status::kOk) {
      throw std::runtime_error(writer.error());
    }
  }
}

// The scenarios that black out images: the first 3 s (dark start), the right image for 4 s around
// the middle (right dropout), both images during the blackout span.
void blank_for_scenario(const SimOptions& o, std::int64_t t_ns, double ts, double mid_s, const BlackoutSpan& blackout,
                        std::vector<std::uint8_t>* left, std::vector<std::uint8_t>* right) {
  const bool dark = (o.scenario == Scenario::kDarkStart && ts < 3.0) ||
                    (o.scenario == Scenario::kBlackout && t_ns >= blackout.begin_ns && t_ns < blackout.end_ns);
  const bool right_out = o.scenario == Scenario::kRightDropout && ts >= mid_s - 2.0 && ts < mid_s + 2.0;
  if (dark) std::fill(left->begin(), left->end(), 0);
  if (dark || right_out) std::fill(right->begin(), right->end(), 0);
}

}  // namespace

int simulate(const SimOptions& o, std::string* error, const ProgressCallback& progress, SimStats* stats) {
  if (!o.validate(error)) return 1;
  try {
    RigCalibration rig = rig_preset(o.camera_preset);
    for (auto& c : rig.cam) c.rate_hz = o.camera_rate_hz;
    rig.imu.rate_hz = o.imu_rate_hz;
    rig.imu.gravity_m_s2 = o.gravity_m_s2;
    const SimTrajectory tr = make_trajectory(o, rig);
    const ImuTrack imu = generate_imu(tr, rig.imu, o);

    const std::int64_t frame_dt_ns = static_cast<std::int64_t>(std::llround(1e9 / o.camera_rate_hz));
    int total = static_cast<int>((tr.t_end_ns - tr.t_begin_ns) / frame_dt_ns) + 1;
    if (o.max_frames >= 0) total = std::min(total, o.max_frames);
    Scene scene;
    make_scene(o, tr, rig, total, &scene);

    std::filesystem::create_directories(o.out_dir);
    hal::EurocWriter writer;
    writer.open(o.out_dir, written_calibration(rig, o), true);
    write_imu(writer, imu);
    const double mid_s = 0.5 * static_cast<double>(tr.t_end_ns - tr.t_begin_ns) * 1e-9;
    const BlackoutSpan blackout = blackout_span(o, tr);
    std::vector<std::uint8_t> left(static_cast<std::size_t>(rig.cam[0].width) * rig.cam[0].height);
    std::vector<std::uint8_t> right(static_cast<std::size_t>(rig.cam[1].width) * rig.cam[1].height);
    SimStats counts;
    const std::int64_t td_ns = std::llround(o.td_s * 1e9);
    for (int k = 0; k < total; ++k) {
      const std::int64_t t = tr.t_begin_ns + k * frame_dt_ns;
      const double ts = static_cast<double>(t - tr.t_begin_ns) * 1e-9;
      RenderOptions ro = o.render;
      if (o.exposure_change) ro.exposure_gain *= 1.0 + 0.35 * std::sin(2.0 * M_PI * ts / 8.0);
      const int n = render_pair(scene, tr, o, rig, k, t, ro, left.data(), right.data());
      counts.sub_exposures += n;
      counts.max_sub_exposures = std::max(counts.max_sub_exposures, n);
      blank_for_scenario(o, t, ts, mid_s, blackout, &left, &right);
      StereoFrame f;
      f.t_ns = t - td_ns;  // the camera's clock
      f.seq = static_cast<std::uint64_t>(k);
      f.left = ImageView{left.data(), rig.cam[0].width, rig.cam[0].height, rig.cam[0].width};
      f.right = ImageView{right.data(), rig.cam[1].width, rig.cam[1].height, rig.cam[1].width};
      if (writer.write_stereo(f) != Status::kOk) throw std::runtime_error(writer.error());
      ++counts.frames;
      if (progress) progress(k + 1, total);
    }
    writer.close();
    write_events(o, tr, imu, mid_s);
    if (stats) *stats = counts;
  } catch (const std::exception& e) {
    if (error) *error = e.what();
    return 1;
  }
  return 0;
}

}  // namespace ums::sim
