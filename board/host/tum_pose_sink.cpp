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

const char* TumPoseSink::state_header() {
  return "# t_s,mode,keyframe,v_x,v_y,v_z [m/s],bg_x,bg_y,bg_z [rad/s],ba_x,ba_y,ba_z [m/s^2],"
         "landmarks_3d,landmarks_2d\n";
}

void TumPoseSink::on_frame_pose(const EstimatorOutput& out) {
  if (trajectory_ != nullptr) write_pose(trajectory_, out.t_ns, out.p_w_b, out.q_w_b);
  if (states_ != nullptr) {
    // Several short calls: glibc's printf takes a heap scratch buffer for a format with many
    // conversions (15 here), which the steady-state allocation count would see every frame.
    std::fprintf(states_, "%lld.%09lld,%s,%d,", static_cast<long long>(out.t_ns / 1000000000),
                 static_cast<long long>(out.t_ns % 1000000000), to_string(out.mode), out.keyframe ? 1 : 0);
    std::fprintf(states_, "%.5f,%.5f,%.5f,", out.v_w_b.x(), out.v_w_b.y(), out.v_w_b.z());
    std::fprintf(states_, "%.6f,%.6f,%.6f,", out.bg.x(), out.bg.y(), out.bg.z());
    std::fprintf(states_, "%.5f,%.5f,%.5f,%d,%d\n", out.ba.x(), out.ba.y(), out.ba.z(), out.n_3d_used,
                 out.n_2d_left_used + out.n_2d_right_used);
  }
  ++poses_written_;
}

void TumPoseSink::on_imu_pose(std::int64_t t_ns, const NavState& state) {
  if (imu_poses_ != nullptr) write_pose(imu_poses_, t_ns, state.p_w_b, state.q_w_b);
}

}  // namespace ums::cli
