#include "core/estimator/window.hpp"

#include <catch2/catch.hpp>
#include <set>

#include "core/estimator/state_blocks.hpp"

namespace {

// Appends a frame at t_ns; returns its id.
ums::FrameId push(ums::Window* w, std::int64_t t_ns) {
  ums::WindowFrame& f = w->next();
  f.t_ns = t_ns;
  w->push_next();
  w->choose_next_slot();
  return f.id;
}

// Frames at (1, 2, 3) and (4, 5, 6), the second moving at (1, 0, 0) m/s.
void two_frames(ums::Window* w) {
  push(w, 1);
  push(w, 2);
  ums::state::p(w->at(0).pose) = Eigen::Vector3d(1, 2, 3);
  ums::state::p(w->at(1).pose) = Eigen::Vector3d(4, 5, 6);
  ums::state::v(w->at(1).sb) = Eigen::Vector3d(1, 0, 0);
}

}  // namespace

TEST_CASE("Window: FrameIds are monotonic and never reused while slots are recycled", "[estimator][window]") {
  ums::Window w{ums::PreintegrationOptions()};
  std::set<ums::FrameId> seen;
  std::set<int> slots_used;
  ums::FrameId last = ums::kNoFrame;
  for (int k = 0; k < 200; ++k) {
    const ums::FrameId id = push(&w, 1000 + k);
    CHECK(seen.insert(id).second);                       // never reused
    if (last != ums::kNoFrame) CHECK(id == last + 1);    // monotonic
    last = id;
    slots_used.insert(w.slot_at(w.size() - 1));
    // Slide like the estimator: oldest out (keyframe) or second newest out.
    if (w.size() == static_cast<int>(ums::capacity::kWindowSize)) {
      w.erase(k % 3 == 0 ? 0 : w.size() - 2);
      w.choose_next_slot();
    }
    REQUIRE(w.size() <= static_cast<int>(ums::capacity::kWindowSize));
    REQUIRE(w.next_slot() >= 0);
    CHECK(w.position_of(w.next_slot()) < 0);  // the next slot is never one in use
  }
  CHECK(slots_used.size() >= ums::capacity::kWindowSize);  // slots are recycled
  // Frames are found by id, in time order, and a frame that left is not found.
  for (int p = 0; p < w.size(); ++p) {
    CHECK(w.slot_of_id(w.at(p).id) == w.slot_at(p));
    if (p > 0) CHECK(w.at(p).t_ns > w.at(p - 1).t_ns);
  }
  CHECK(w.slot_of_id(0) == -1);
  CHECK(w.slot_of_id(ums::kNoFrame) == -1);
}

TEST_CASE("Window: rotation about a pivot keeps the pivot and rotates poses and velocities", "[estimator][window]") {
  ums::Window w{ums::PreintegrationOptions()};
  two_frames(&w);
  ums::WindowFrame& a = w.at(0);
  ums::WindowFrame& b = w.at(1);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  w.rotate(R, ums::state::p(b.pose));
  CHECK((ums::state::p(b.pose) - Eigen::Vector3d(4, 5, 6)).norm() < 1e-12);
  CHECK((ums::state::p(a.pose) - Eigen::Vector3d(7, 2, 3)).norm() < 1e-12);   // (-3,-3) turned by 90 deg about b
  CHECK((ums::state::v(b.sb) - Eigen::Vector3d(0, 1, 0)).norm() < 1e-12);
  CHECK(ums::quat_of(a.pose).angularDistance(Eigen::Quaterniond(R)) < 1e-12);
}

// The gauge hold moves the window so that one point (the oldest frame) lands where it was.
TEST_CASE("Window: a rigid move takes `from` to `to` and turns the rest about it", "[estimator][window]") {
  ums::Window w{ums::PreintegrationOptions()};
  two_frames(&w);
  ums::WindowFrame& a = w.at(0);
  ums::WindowFrame& b = w.at(1);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  w.move(R, Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0, 0, 0));
  CHECK(ums::state::p(a.pose).norm() < 1e-12);
  CHECK((ums::state::p(b.pose) - Eigen::Vector3d(-3, 3, 3)).norm() < 1e-12);  // (3,3,3) turned by 90 deg
  CHECK((ums::state::v(b.sb) - Eigen::Vector3d(0, 1, 0)).norm() < 1e-12);
  CHECK(ums::quat_of(b.pose).angularDistance(Eigen::Quaterniond(R)) < 1e-12);
}

TEST_CASE("Extrinsics: fixed keeps the calibration bit for bit, floating follows the blocks", "[estimator][window]") {
  ums::Extrinsics e;
  Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
  T0.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T0.translation() = Eigen::Vector3d(0.01, -0.02, 0.03);
  Eigen::Isometry3d T1 = T0;
  T1.translation().x() += 0.11;
  e.set(T0, T1);
  e.block(0)[0] += 0.01;  // a solver step
  e.sync();
  CHECK(e.T_b_c(0).matrix() == T0.matrix());  // fixed: untouched
  e.set_floating(true);
  e.sync();
  CHECK(std::abs(e.T_b_c(0).translation().x() - (T0.translation().x() + 0.01)) < 1e-15);
  CHECK((e.T_b_c(1).matrix() - T1.matrix()).norm() < 1e-12);
}
