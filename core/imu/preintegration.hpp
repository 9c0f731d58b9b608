#pragma once
// IMU preintegration between two frames i and j (paper Section III-A.2, midpoint integration as
// in VINS-Fusion), in the body frame of i, independent of the states at i and j:
//   alpha  (delta position, m), beta (delta velocity, m/s), gamma (delta rotation R_bi_bj),
// with the 15x15 covariance of the error state [dalpha, dtheta, dbeta, dba, dbg] (the row order
// of the residual of eq. 1) and the Jacobians of alpha/beta/gamma with respect to the biases
// used for the first-order bias correction. The raw samples are kept in a fixed-capacity buffer
// so that the whole interval can be repropagated when the bias estimate moves too far from the
// linearisation point. Derivation: docs/math-imu.md.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>

#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"
#include "core/common/imu_sample.hpp"
#include "core/common/status.hpp"
#include "core/imu/imu_noise.hpp"

namespace ums {

struct PreintegrationOptions {
  ImuNoise noise;
  // Bias change since linearisation beyond which the first-order correction is replaced by a
  // repropagation over the stored samples (VINS-Fusion uses the same two values).
  double repropagate_accel_bias_m_s2 = 0.10;  // m/s^2, any axis
  double repropagate_gyro_bias_rad_s = 0.01;  // rad/s, any axis
  // Samples per interval (first sample included); at most the compile-time capacity.
  std::size_t max_samples = capacity::kMaxImuSamplesBetweenFrames;  // count

  void validate() const;  // throws std::invalid_argument naming the field and value
};

// Linear interpolation of a sample at t_ns between a (before) and b (after), for the frame
// boundaries; a.t_ns < b.t_ns.
ImuSample interpolate_imu(const ImuSample& a, const ImuSample& b, std::int64_t t_ns);

class Preintegration {
 public:
  using Matrix15 = Eigen::Matrix<double, 15, 15>;
  using Matrix15x6 = Eigen::Matrix<double, 15, 6>;
  // Error-state / residual row offsets (paper eq. 1 order used by the whole project).
  static constexpr int kP = 0, kTheta = 3, kV = 6, kBa = 9, kBg = 12;

  explicit Preintegration(const PreintegrationOptions& options = PreintegrationOptions());

  // Starts a new interval at `first` (the sample at frame i's time, interpolated by the caller
  // when needed) with linearisation biases ba (m/s^2) and bg (rad/s). kInvalidInput on NaN/Inf.
  Status reset(const ImuSample& first, const Eigen::Vector3d& ba, const Eigen::Vector3d& bg);

  // Integrates one more sample (midpoint rule with the previous one) and stores it.
  // kInvalidInput: not finite or t_ns not after the previous sample (nothing changes).
  // kFull: the buffer holds max_samples already; the sample is NOT integrated (the caller
  // counts the drop and should close the interval).
  Status add(const ImuSample& sample);

  // Re-integrates every stored sample with new linearisation biases.
  void repropagate(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg);
  // True when (ba, bg) moved beyond the options' thresholds from the linearisation biases.
  bool needs_repropagation(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg) const;
  // repropagate() if needs_repropagation(); returns whether it did.
  bool repropagate_if_needed(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg);

  // Deltas corrected to first order for biases (ba, bg) (gamma through Exp, see docs).
  void corrected(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg, Eigen::Vector3d* alpha,
                 Eigen::Vector3d* beta, Eigen::Quaterniond* gamma) const;

  // Motion the IMU did not measure (samples lost inside the interval): its variance is added to
  // the deltas' covariance, rotation var_theta_rad2 per axis, velocity var_v_m2_s2 per axis, the
  // position through the velocity error held for lever_s, and var_p_m2 per axis of position on
  // its own. Kept until reset() (also over repropagations). Without it a factor across a hole
  // claims the IMU's full precision.
  struct UnmodelledMotion {
    double var_theta_rad2 = 0.0;
    double var_v_m2_s2 = 0.0;
    double lever_s = 0.0;  // s, position error = velocity error * lever_s
    double var_p_m2 = 0.0;
  };
  void add_unmodelled_motion(const UnmodelledMotion& u);
  const UnmodelledMotion& unmodelled_motion() const { return unmodelled_; }
  bool has_unmodelled_motion() const {
    return unmodelled_.var_theta_rad2 > 0.0 || unmodelled_.var_v_m2_s2 > 0.0 || unmodelled_.var_p_m2 > 0.0;
  }
  // Upper Cholesky factor U of the inverse covariance (U^T U = P^-1): r_whitened = U r.
  // kSingular if the covariance is not positive definite (e.g. fewer than two samples).
  Status sqrt_information(Matrix15* U) const;
  // The P that sqrt_information() whitens with: the covariance, symmetrised, plus the
  // unmodelled motion's variances.
  Matrix15 whitened_covariance() const;
  // U of a given P (as sqrt_information()).
  static Status sqrt_information_of(const Matrix15& P, Matrix15* U);

  const Eigen::Vector3d& alpha() const { return alpha_; }     // m, in body frame i
  const Eigen::Vector3d& beta() const { return beta_; }       // m/s, in body frame i
  const Eigen::Quaterniond& gamma() const { return gamma_; }  // R_bi_bj
  const Matrix15& covariance() const { return covariance_; }
  // d(error state at j)/d(bias at i): columns [ba(3), bg(3)], rows as the error state.
  const Matrix15x6& bias_jacobian() const { return bias_jacobian_; }
  Eigen::Matrix3d d_alpha_d_ba() const { return bias_jacobian_.block<3, 3>(kP, 0); }
  Eigen::Matrix3d d_alpha_d_bg() const { return bias_jacobian_.block<3, 3>(kP, 3); }
  Eigen::Matrix3d d_beta_d_ba() const { return bias_jacobian_.block<3, 3>(kV, 0); }
  Eigen::Matrix3d d_beta_d_bg() const { return bias_jacobian_.block<3, 3>(kV, 3); }
  Eigen::Matrix3d d_gamma_d_bg() const { return bias_jacobian_.block<3, 3>(kTheta, 3); }

  const Eigen::Vector3d& linearization_ba() const { return ba_; }
  const Eigen::Vector3d& linearization_bg() const { return bg_; }
  double dt_s() const { return 1e-9 * static_cast<double>(t_last_ns() - t_first_ns()); }
  std::int64_t t_first_ns() const { return samples_.empty() ? 0 : samples_[0].t_ns; }
  std::int64_t t_last_ns() const { return samples_.empty() ? 0 : samples_.back().t_ns; }
  std::size_t num_samples() const { return samples_.size(); }
  const ImuSample& sample(std::size_t k) const { return samples_[k]; }
  std::uint64_t repropagations() const { return repropagations_; }
  const PreintegrationOptions& options() const { return options_; }

 private:
  // One midpoint step's error-state transition blocks (rows alpha, theta, beta; docs in step()).
  struct StepTransition {
    double dt_s;
    Eigen::Matrix3d F_tt, G, M;          // theta<-theta, theta<-bg, 2 * acc<-bg
    Eigen::Matrix3d F_at, F_aba, F_abg;  // alpha<-theta, alpha<-ba, alpha<-bg
    Eigen::Matrix3d F_vt, F_vba, F_vbg;  // beta<-theta, beta<-ba, beta<-bg
  };

  void clear_deltas();
  void step(const ImuSample& s0, const ImuSample& s1);
  void propagate_covariance(const StepTransition& f);
  void add_step_noise(const StepTransition& f);
  void propagate_bias_jacobian(const StepTransition& f);

  PreintegrationOptions options_;
  FixedVector<ImuSample, capacity::kMaxImuSamplesBetweenFrames> samples_;
  Eigen::Vector3d ba_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d alpha_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d beta_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond gamma_ = Eigen::Quaterniond::Identity();
  Matrix15 covariance_ = Matrix15::Zero();
  Matrix15x6 bias_jacobian_ = Matrix15x6::Zero();
  std::uint64_t repropagations_ = 0;
  UnmodelledMotion unmodelled_;
};

}  // namespace ums
