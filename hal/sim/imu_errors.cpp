#include "hal/sim/imu_errors.hpp"

#include <cmath>
#include <random>
#include <sstream>
#include <vector>

#include "hal/sim/imu_track.hpp"

namespace ums::sim {

namespace {

// The errors' own streams: other constants than every other draw in hal/sim, so the ideal
// output (which never constructs them) is unchanged and the two do not correlate.
std::mt19937_64 draw_stream(std::uint64_t seed) { return std::mt19937_64(seed * 0xD1B54A32D192ED03ULL + 41); }
std::mt19937_64 vibration_stream(std::uint64_t seed) { return std::mt19937_64(seed * 0xA0761D6478BD642FULL + 43); }

// diag(1 + s) (I + N): s uniform in +-scale_max, N off-diagonal uniform in +-misalignment_max.
Eigen::Matrix3d draw_matrix(double scale_max, double misalignment_max_rad, std::mt19937_64& rng, Eigen::Vector3d* scale) {
  std::uniform_real_distribution<double> u11(-1.0, 1.0);
  Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) {
    (*scale)(i) = scale_max * u11(rng);
    for (int j = 0; j < 3; ++j) {
      if (i != j) N(i, j) = misalignment_max_rad * u11(rng);
    }
  }
  return (Eigen::Vector3d::Ones() + *scale).asDiagonal() * (Eigen::Matrix3d::Identity() + N);
}

// Per axis a random sign and a magnitude uniform in [0.5, 1] x drift.
Eigen::Vector3d draw_drift_end(double drift, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> mag(0.5, 1.0);
  std::bernoulli_distribution sign(0.5);
  Eigen::Vector3d d;
  for (int i = 0; i < 3; ++i) {
    const double s = sign(rng) ? 1.0 : -1.0;  // sign, then size: one draw per statement
    d(i) = s * drift * mag(rng);
  }
  return d;
}

// Narrow-band noise on one axis: a sum of sinusoids with frequencies uniform in the band and
// random phases. Enough components (kTones) make it look Gaussian and its envelope wander, as
// rotor speeds that drift apart do; the amplitude gives the configured RMS (each tone a^2 / 2).
struct VibrationAxis {
  static constexpr int kTones = 24;
  double freq_hz[kTones] = {};
  double phase_rad[kTones] = {};
  double amplitude = 0.0;
  double at(double t_s) const {
    double v = 0.0;
    for (int k = 0; k < kTones; ++k) v += std::sin(2.0 * M_PI * freq_hz[k] * t_s + phase_rad[k]);
    return amplitude * v;
  }
};

VibrationAxis draw_vibration_axis(const ImuErrorOptions& o, double rms, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> band(o.vibration_centre_hz - 0.5 * o.vibration_width_hz,
                                              o.vibration_centre_hz + 0.5 * o.vibration_width_hz);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  VibrationAxis axis;
  for (int k = 0; k < VibrationAxis::kTones; ++k) {
    axis.freq_hz[k] = band(rng);
    axis.phase_rad[k] = phase(rng);
  }
  axis.amplitude = rms * std::sqrt(2.0 / VibrationAxis::kTones);
  return axis;
}

void append_vector(std::ostringstream& s, const char* name, const Eigen::Vector3d& v) {
  s << ", " << name << " " << v(0) << " " << v(1) << " " << v(2);
}

void append_matrix(std::ostringstream& s, const char* name, const Eigen::Matrix3d& M) {
  s << ", " << name;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) s << " " << M(i, j);
  }
}

}  // namespace

bool parse_imu_model(const std::string& name, ImuModel* model) {
  if (name == "ideal") *model = ImuModel::kIdeal;
  else if (name == "realistic") *model = ImuModel::kRealistic;
  else return false;
  return true;
}

const char* imu_model_name(ImuModel model) { return model == ImuModel::kRealistic ? "realistic" : "ideal"; }

bool select_imu_errors(const std::string& list, ImuErrorOptions* o) {
  bool vibration = false, scale = false, misalignment = false, drift = false;
  std::stringstream names(list);
  std::string name;
  while (std::getline(names, name, ',')) {
    const bool all = name == "all";
    if (!all && name != "vibration" && name != "scale" && name != "misalignment" && name != "drift") return false;
    vibration = vibration || all || name == "vibration";
    scale = scale || all || name == "scale";
    misalignment = misalignment || all || name == "misalignment";
    drift = drift || all || name == "drift";
  }
  if (!vibration) o->vibration_accel_rms_m_s2 = o->vibration_gyro_rms_rad_s = 0.0;
  if (!scale) o->gyro_scale_max = o->accel_scale_max = 0.0;
  if (!misalignment) o->gyro_misalignment_max_rad = o->accel_misalignment_max_rad = 0.0;
  if (!drift) o->gyro_drift_rad_s = o->accel_drift_m_s2 = 0.0;
  return true;
}

bool ImuErrorOptions::validate(std::string* error) const {
  auto bad = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (!(vibration_width_hz >= 0.0 && vibration_centre_hz - 0.5 * vibration_width_hz > 0.0)) {
    return bad("imu errors: the vibration band must lie above 0 Hz");
  }
  if (!(vibration_accel_rms_m_s2 >= 0.0 && vibration_gyro_rms_rad_s >= 0.0)) return bad("imu errors: vibration RMS must be >= 0");
  if (!(gyro_scale_max >= 0.0 && gyro_scale_max < 0.5 && accel_scale_max >= 0.0 && accel_scale_max < 0.5)) {
    return bad("imu errors: scale bounds must be in [0, 0.5)");
  }
  if (!(gyro_misalignment_max_rad >= 0.0 && gyro_misalignment_max_rad < 0.1 && accel_misalignment_max_rad >= 0.0 &&
        accel_misalignment_max_rad < 0.1)) {
    return bad("imu errors: misalignment bounds must be in [0, 0.1) rad");
  }
  if (!(gyro_drift_rad_s >= 0.0 && accel_drift_m_s2 >= 0.0)) return bad("imu errors: drifts must be >= 0");
  if (!(drift_time_constant_s > 0.0)) return bad("imu errors: drift_time_constant_s must be > 0");
  return true;
}

ImuErrorDraw draw_imu_errors(const ImuErrorOptions& o, std::uint64_t seed) {
  std::mt19937_64 rng = draw_stream(seed);
  ImuErrorDraw d;
  d.M_gyro = draw_matrix(o.gyro_scale_max, o.gyro_misalignment_max_rad, rng, &d.gyro_scale);
  d.M_accel = draw_matrix(o.accel_scale_max, o.accel_misalignment_max_rad, rng, &d.accel_scale);
  d.gyro_drift_end_rad_s = draw_drift_end(o.gyro_drift_rad_s, rng);
  d.accel_drift_end_m_s2 = draw_drift_end(o.accel_drift_m_s2, rng);
  return d;
}

void apply_imu_errors(const ImuErrorOptions& o, const ImuErrorDraw& d, std::uint64_t seed, ImuTrack* track) {
  if (track->samples.empty()) return;
  std::mt19937_64 rng = vibration_stream(seed);
  VibrationAxis gyro_vib[3], accel_vib[3];
  for (VibrationAxis& a : gyro_vib) a = draw_vibration_axis(o, o.vibration_gyro_rms_rad_s, rng);
  for (VibrationAxis& a : accel_vib) a = draw_vibration_axis(o, o.vibration_accel_rms_m_s2, rng);
  const std::int64_t t0_ns = track->samples.front().t_ns;
  for (std::size_t i = 0; i < track->samples.size(); ++i) {
    ImuSample& m = track->samples[i];
    hal::GroundTruthState& gt = track->truth[i];
    const double t_s = static_cast<double>(m.t_ns - t0_ns) * 1e-9;
    const double ramp = 1.0 - std::exp(-t_s / o.drift_time_constant_s);
    const Eigen::Vector3d dg = ramp * d.gyro_drift_end_rad_s, da = ramp * d.accel_drift_end_m_s2;
    const Eigen::Vector3d vg(gyro_vib[0].at(t_s), gyro_vib[1].at(t_s), gyro_vib[2].at(t_s));
    const Eigen::Vector3d va(accel_vib[0].at(t_s), accel_vib[1].at(t_s), accel_vib[2].at(t_s));
    // The bias stays outside M (it is the sensor's offset, added after its sensitivity).
    m.gyro_rad_s = d.M_gyro * (m.gyro_rad_s - gt.gyro_bias_rad_s) + gt.gyro_bias_rad_s + dg + vg;
    m.accel_m_s2 = d.M_accel * (m.accel_m_s2 - gt.accel_bias_m_s2) + gt.accel_bias_m_s2 + da + va;
    gt.gyro_bias_rad_s += dg;
    gt.accel_bias_m_s2 += da;
  }
}

std::string imu_errors_header(const ImuErrorOptions& o, const ImuErrorDraw& d) {
  std::ostringstream s;
  s.precision(6);
  s << "#imu_model: realistic, vibration " << o.vibration_centre_hz << " Hz +- " << 0.5 * o.vibration_width_hz
    << " Hz, accel " << o.vibration_accel_rms_m_s2 << " m/s^2 rms, gyro " << o.vibration_gyro_rms_rad_s
    << " rad/s rms, drift tau " << o.drift_time_constant_s << " s";
  append_vector(s, "gyro_scale", d.gyro_scale);
  append_vector(s, "accel_scale", d.accel_scale);
  append_matrix(s, "M_gyro", d.M_gyro);
  append_matrix(s, "M_accel", d.M_accel);
  append_vector(s, "gyro_drift_end_rad_s", d.gyro_drift_end_rad_s);
  append_vector(s, "accel_drift_end_m_s2", d.accel_drift_end_m_s2);
  s << " (none of it in sensor.yaml)\n";
  return s.str();
}

}  // namespace ums::sim
