#pragma once
// Camera-to-camera transforms between the window's frames, shared by the visual residuals.
//
// A window solve evaluates some 1500 bearing residuals per pass but they connect only a few dozen
// (host frame, host camera, target frame, target camera) combinations. Every residual of one
// combination needs the same rotation products (R_ct_ch = R_b_ct^T R_w_bt^T R_w_bh R_b_ch and its
// factors), so they are formed once per combination and pass instead of once per residual.
//
// The cache reads pose blocks in the estimator's memory (7 doubles [p, q.x, q.y, q.z, q.w], which
// the solver overwrites with its trial values in place). Products are valid until invalidate():
// the solver calls it before every evaluation pass (it is the problem's EvaluationCallback), and
// whoever evaluates bound residuals outside a solve must call it after moving any block.
// About 270 kB: create it once at start-up on the heap. Not thread-safe (one solve at a time).

#include <cstdint>

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "solver/evaluation_callback.hpp"

namespace ums {

class RelativePoseCache final : public solver::EvaluationCallback {
 public:
  static constexpr int kMaxFrames = static_cast<int>(capacity::kWindowSize) + 1;  // the estimator's frame slots
  static constexpr int kCameras = 2;

  // The products of one (host frame h, host camera ch, target frame t, target camera ct).
  struct Pair {
    Eigen::Matrix3d R_ct_ch;  // host camera -> target camera
    Eigen::Vector3d p_ct_ch;  // m, host camera origin in the target camera
    Eigen::Matrix3d R_ct_w;   // world -> target camera (d/d position of either body)
    Eigen::Matrix3d R_ct_bh;  // host body -> target camera (d/d rotation of the host body)
    Eigen::Matrix3d R_b_ch;   // host camera -> host body (its extrinsic)
    Eigen::Vector3d p_b_ch;   // m
    Eigen::Matrix3d R_b_ct;   // target camera -> target body
    Eigen::Vector3d p_b_ct;   // m
  };

  // Start-up: where frame slot s's pose block and camera c's extrinsic block (T_b_c) live.
  void bind_frame(int slot, const double* pose);
  void bind_extrinsic(int cam, const double* T_b_c);
  const double* frame(int slot) const { return frame_[slot].values; }
  const double* extrinsic(int cam) const { return ext_[cam].values; }

  // Forgets every product: the blocks may have moved.
  void invalidate() { ++epoch_; }
  void prepare_for_evaluation() override { invalidate(); }

  // The products at the blocks' values (as of the first lookup since invalidate()). No
  // allocation; the slots and cameras must be bound. Inline: nearly every lookup is a hit (one
  // residual in a hundred forms its pair).
  const Pair& pair(int host_slot, int host_cam, int target_slot, int target_cam) {
    Entry& e = entries_[host_slot][target_slot][host_cam][target_cam];
    return e.epoch == epoch_ ? e.pair : form(e, host_slot, host_cam, target_slot, target_cam);
  }

  // The stereo pair of one frame (host camera ch, target camera ct): the extrinsics alone,
  // R_ct_ch = R_b_ct^T R_b_ch and p_ct_ch = R_b_ct^T (p_b_ch - p_b_ct); the body pose cancels.
  struct CameraPair {
    Eigen::Matrix3d R_ct_ch;
    Eigen::Vector3d p_ct_ch;  // m
  };
  const CameraPair& camera_pair(int host_cam, int target_cam) {
    CameraEntry& e = camera_entries_[host_cam][target_cam];
    return e.epoch == epoch_ ? e.pair : form_cameras(e, host_cam, target_cam);
  }

 private:
  struct Source {
    const double* values = nullptr;
    std::uint64_t epoch = 0;  // R and p are valid when it equals epoch_
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
  };
  struct Entry {
    std::uint64_t epoch = 0;  // the pair is valid when it equals epoch_
    Pair pair;
  };
  struct CameraEntry {
    std::uint64_t epoch = 0;
    CameraPair pair;
  };
  void refresh(Source& s);
  const Pair& form(Entry& e, int host_slot, int host_cam, int target_slot, int target_cam);
  const CameraPair& form_cameras(CameraEntry& e, int host_cam, int target_cam);

  std::uint64_t epoch_ = 1;
  Source frame_[kMaxFrames];
  Source ext_[kCameras];
  Entry entries_[kMaxFrames][kMaxFrames][kCameras][kCameras];
  CameraEntry camera_entries_[kCameras][kCameras];
};

}  // namespace ums
