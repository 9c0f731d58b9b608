#include "hal/sim/exposure.hpp"

#include <catch2/catch.hpp>

#include "core/math/se3.hpp"
#include "core/math/so3.hpp"

using namespace ums::sim;

TEST_CASE("exposure: sub-exposures follow the image motion and are bounded", "[sim][exposure]") {
  const ExposureOptions o;  // 4 ms, 1 px steps, at most 4
  const Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
  // 1 rad/s for 4 ms at f = 458 px: 1.83 px -> 2 sub-exposures.
  const Eigen::Isometry3d T_rot = ums::se3::make(ums::so3::exp_quat(Eigen::Vector3d(0, 0.004, 0)), Eigen::Vector3d::Zero());
  CHECK(exposure_blur_px(T0, T_rot, 458.0, 1.5) == Approx(1.832).epsilon(1e-3));
  CHECK(sub_exposure_count(exposure_blur_px(T0, T_rot, 458.0, 1.5), o) == 2);
  // 1.5 m/s for 4 ms with the near depth 1.5 m: 1.83 px as well.
  const Eigen::Isometry3d T_move = ums::se3::make(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.006, 0, 0));
  CHECK(exposure_blur_px(T0, T_move, 458.0, 1.5) == Approx(1.832).epsilon(1e-3));
  CHECK(sub_exposure_count(0.0, o) == 1);
  CHECK(sub_exposure_count(0.99, o) == 1);
  CHECK(sub_exposure_count(3.5, o) == 4);
  CHECK(sub_exposure_count(40.0, o) == 4);  // the cost bound
  ExposureOptions none = o;
  none.exposure_ms = 0.0;
  CHECK(sub_exposure_count(40.0, none) == 1);
  none.exposure_ms = 50.0;
  std::string err;
  CHECK_FALSE(none.validate(&err));
}

TEST_CASE("exposure: sub-exposure stamps are centred on the frame stamp and evenly spread", "[sim][exposure]") {
  const std::int64_t t = 1'000'000'000LL;
  CHECK(sub_exposure_time_ns(t, 4.0, 1, 0) == t);
  // n = 4 over 4 ms: -1.5, -0.5, +0.5, +1.5 ms.
  CHECK(sub_exposure_time_ns(t, 4.0, 4, 0) == t - 1'500'000);
  CHECK(sub_exposure_time_ns(t, 4.0, 4, 1) == t - 500'000);
  CHECK(sub_exposure_time_ns(t, 4.0, 4, 2) == t + 500'000);
  CHECK(sub_exposure_time_ns(t, 4.0, 4, 3) == t + 1'500'000);
}
