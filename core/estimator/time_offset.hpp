#pragma once
// The camera-IMU time offset td (t_imu = t_cam + td, s) as a state of the window: one copy for
// the solver (a 1-double block) and for the outputs. The pipeline's TimeAligner shifts every frame
// by an offset before the estimator sees it (the calibration's, then with estimate_td this
// block's value as it stood), which the frame carries (WindowFrame::td_applied_s); the solver
// moves the block, and the bearing residuals move each measurement by the difference along its
// image velocity (bearing_residual.hpp). Held at the calibration otherwise.

namespace ums {

class TimeOffset {
 public:
  // td_s: the calibration's offset, which the frames' stamps carry.
  void set(double td_s) {
    calibration_s_ = td_s;
    value_[0] = td_s;
  }
  double calibration_s() const { return calibration_s_; }
  double value_s() const { return value_[0]; }
  double* block() { return value_; }
  const double* block() const { return value_; }
  // Keeps the estimate within max_change_s of the calibration (the aligner's range: beyond it new
  // frames would carry a stale offset); true when it had to.
  bool clamp(double max_change_s) {
    const double lo = calibration_s_ - max_change_s, hi = calibration_s_ + max_change_s;
    if (value_[0] >= lo && value_[0] <= hi) return false;
    value_[0] = value_[0] < lo ? lo : value_[0] > hi ? hi : calibration_s_;  // NaN: the calibration
    return true;
  }
  void reset() { value_[0] = calibration_s_; }

 private:
  double value_[1] = {0.0};
  double calibration_s_ = 0.0;
};

}  // namespace ums
