#include "board/host/tum_pose_sink.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/estimator/estimator.hpp"
#include "core/imu/propagation.hpp"

namespace ums::cli {

namespace {

// One TUM line (t_s x y z qx qy qz qw).
void write_pose(std::FILE* f, std::int64_t t_ns, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  std::fprintf(f, "%lld.%09lld %.7f %.7f %.7f %.9f %.9f %.9f %.9f\n", static_cast<long long>(t_ns / 1000000000),
               static_cast<long long>(t_ns % 1000000000), p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
}

}  // namespace

void TumPoseSink::on_frame_pose(const EstimatorOutput& out) {
  if (trajectory_ != nullptr) write_pose(trajectory_, out.t_ns, out.p_w_b, out.q_w_b);
  ++poses_written_;
}

void TumPoseSink::on_imu_pose(std::int64_t t_ns, const NavState& state) {
  if (imu_poses_ != nullptr) write_pose(imu_poses_, t_ns, state.p_w_b, state.q_w_b);
}

}  // namespace ums::cli
