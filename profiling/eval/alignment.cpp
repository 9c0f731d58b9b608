#include "profiling/eval/alignment.hpp"

#include <cmath>

#include <Eigen/SVD>

namespace ums::eval {

bool parse_align_mode(const std::string& text, AlignMode* mode) {
  if (text == "none") *mode = AlignMode::kNone;
  else if (text == "se3") *mode = AlignMode::kSe3;
  else if (text == "sim3") *mode = AlignMode::kSim3;
  else if (text == "posyaw") *mode = AlignMode::kPosYaw;
  else return false;
  return true;
}

const char* align_mode_name(AlignMode mode) {
  switch (mode) {
    case AlignMode::kNone: return "none";
    case AlignMode::kSe3: return "se3";
    case AlignMode::kSim3: return "sim3";
    case AlignMode::kPosYaw: return "posyaw";
  }
  return "?";
}

Alignment align(const std::vector<Eigen::Vector3d>& p_est, const std::vector<Eigen::Vector3d>& p_gt,
                AlignMode mode) {
  Alignment a;
  const std::size_t n = std::min(p_est.size(), p_gt.size());
  if (mode == AlignMode::kNone || n == 0) return a;
  Eigen::Vector3d mu_x = Eigen::Vector3d::Zero(), mu_y = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mu_x += p_est[i];
    mu_y += p_gt[i];
  }
  mu_x /= static_cast<double>(n);
  mu_y /= static_cast<double>(n);

  if (mode == AlignMode::kPosYaw) {
    // Rotation about z only: maximize sum y_c . Rz(yaw) x_c, whose optimum is
    // yaw = atan2(sum (x_c cross y_c)_z, sum x_c.xy . y_c.xy).
    double s_cross = 0.0, s_dot = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d x = p_est[i] - mu_x, y = p_gt[i] - mu_y;
      s_cross += x.x() * y.y() - x.y() * y.x();
      s_dot += x.x() * y.x() + x.y() * y.y();
    }
    const double yaw = (s_cross == 0.0 && s_dot == 0.0) ? 0.0 : std::atan2(s_cross, s_dot);
    a.R_gt_est = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    a.t_gt_est = mu_y - a.R_gt_est * mu_x;
    return a;
  }
  if (n < 3) {
    a.t_gt_est = mu_y - mu_x;
    return a;
  }
  // Umeyama: cross-covariance Sigma = 1/n sum y_c x_c^T = U D V^T, R = U S V^T with S fixing
  // det(R) = +1, s = trace(D S) / sigma_x^2.
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  double var_x = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x = p_est[i] - mu_x, y = p_gt[i] - mu_y;
    sigma += y * x.transpose();
    var_x += x.squaredNorm();
  }
  sigma /= static_cast<double>(n);
  var_x /= static_cast<double>(n);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2, 2) = -1.0;
  a.R_gt_est = svd.matrixU() * S * svd.matrixV().transpose();
  if (mode == AlignMode::kSim3 && var_x > 0.0) {
    a.scale = (svd.singularValues().asDiagonal() * S).trace() / var_x;
  }
  a.t_gt_est = mu_y - a.scale * (a.R_gt_est * mu_x);
  return a;
}

}  // namespace ums::eval
