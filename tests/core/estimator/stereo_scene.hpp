#pragma once
// A window and stereo observations for the landmark tests: a rig 0.11 m apart along x (cameras
// looking along the body z, identity rotation), frames placed along x.

#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/estimator/landmark_map.hpp"
#include "core/estimator/state_blocks.hpp"
#include "core/estimator/window.hpp"

namespace ums::test {

struct StereoScene {
  Window window{PreintegrationOptions()};
  std::unique_ptr<FrameFeatures> ff = std::make_unique<FrameFeatures>();
  StereoScene() {
    Eigen::Isometry3d T_b_c1 = Eigen::Isometry3d::Identity();
    T_b_c1.translation().x() = 0.11;
    window.extrinsics().set(Eigen::Isometry3d::Identity(), T_b_c1);
  }
  // Observations of points p_w[0, n) (feature ids 1..n) from a new frame at x = x_m; stereo:
  // both cameras, else the left only. Returns the frame's slot, or -1 when the map dropped some.
  int add_frame(double x_m, const Eigen::Vector3d* p_w, int n, bool stereo, LandmarkMap* map) {
    WindowFrame& f = window.next();
    state::p(f.pose) = Eigen::Vector3d(x_m, 0, 0);
    window.push_next();
    const int slot = window.slot_of(f);
    window.choose_next_slot();
    ff->features.clear();
    for (int i = 0; i < n; ++i) {
      FeatureObservation o;
      o.id = static_cast<std::uint32_t>(i + 1);
      o.cls = stereo ? FeatureClass::k3D : FeatureClass::k2DLeft;
      const Eigen::Vector3d p0 = p_w[i] - Eigen::Vector3d(x_m, 0, 0);
      o.bearing_left = p0.normalized().cast<float>();
      o.bearing_right = (p0 - Eigen::Vector3d(0.11, 0, 0)).normalized().cast<float>();
      ff->features.push_back(o);
    }
    return map->ingest(*ff, slot, Eigen::Matrix3d::Identity()) == 0 ? slot : -1;
  }
};

}  // namespace ums::test
