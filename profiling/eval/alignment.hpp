#pragma once
// Least-squares alignment of an estimated trajectory to ground truth (Umeyama 1991): find
// s, R, t minimizing sum_i |y_i - (s R x_i + t)|^2 over matched positions x_i (estimate) and y_i
// (ground truth). SE(3) fixes s = 1; Sim(3) frees s (monocular / scale checks); position+yaw
// restricts R to a rotation about gravity (z), the 4 degrees of freedom a VIO cannot observe.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::eval {

enum class AlignMode : std::uint8_t { kNone, kSe3, kSim3, kPosYaw };

// Parses "none", "se3", "sim3", "posyaw"; false on anything else.
bool parse_align_mode(const std::string& text, AlignMode* mode);
const char* align_mode_name(AlignMode mode);

struct Alignment {
  double scale = 1.0;                                    // s (1 unless Sim(3))
  Eigen::Matrix3d R_gt_est = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_gt_est = Eigen::Vector3d::Zero();   // m
  Eigen::Vector3d apply(const Eigen::Vector3d& p_est) const { return scale * (R_gt_est * p_est) + t_gt_est; }
};

// Needs >= 3 pairs (>= 1 for kPosYaw and kNone); returns identity when there are too few.
Alignment align(const std::vector<Eigen::Vector3d>& p_est, const std::vector<Eigen::Vector3d>& p_gt,
                AlignMode mode);

}  // namespace ums::eval
