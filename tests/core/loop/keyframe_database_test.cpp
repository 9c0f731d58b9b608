// The keyframe database: time-ordered links through reserve/commit/remove, the pool's capacity,
// the spatial decimation policy (which records it may and may not drop, and that it drops the one
// closest to its predecessor in metres + yaw at 1 m per 10 degrees), and its footprint.
#include "core/loop/keyframe_database.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace ums;
using namespace ums::loop;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Eigen::Isometry3d pose_xy_yaw(double x_m, double y_m, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, y_m, 1.0);
  return T;
}

// Reserves, fills and commits one keyframe; returns its slot.
std::uint32_t add(KeyframeDatabase* db, FrameId id, double x_m, double yaw_deg = 0.0, std::uint32_t session = 0) {
  std::uint32_t slot = 0;
  REQUIRE(db->reserve(&slot) == Status::kOk);
  KeyframeRecord& r = db->at(slot);
  r.id = id;
  r.t_ns = static_cast<std::int64_t>(id) * 100'000'000;
  r.session = session;
  r.T_odom_b = pose_xy_yaw(x_m, 0.0, yaw_deg);
  r.T_map_b = r.T_odom_b;
  db->commit(slot);
  return slot;
}

// The ids from oldest to newest following next, checking that prev mirrors next.
std::vector<FrameId> ids_in_order(const KeyframeDatabase& db) {
  std::vector<FrameId> ids;
  std::int32_t prev = -1;
  for (std::int32_t s = db.oldest(); s >= 0; s = db.at(static_cast<std::uint32_t>(s)).next) {
    CHECK(db.at(static_cast<std::uint32_t>(s)).prev == prev);
    ids.push_back(db.at(static_cast<std::uint32_t>(s)).id);
    prev = s;
  }
  CHECK(prev == db.newest());
  return ids;
}

FrameId picked_id(const KeyframeDatabase& db) {
  const std::int32_t s = db.pick_for_decimation();
  return s < 0 ? kNoFrame : db.at(static_cast<std::uint32_t>(s)).id;
}

}  // namespace

TEST_CASE("KeyframeDatabase: commit links records oldest to newest, remove relinks, slots are reused", "[loop]") {
  KeyframeDatabase db(2);
  CHECK(db.size() == 0);
  CHECK(db.oldest() == -1);
  CHECK(db.newest() == -1);

  std::uint32_t reserved = 0, again = 0;
  REQUIRE(db.reserve(&reserved) == Status::kOk);
  REQUIRE(db.reserve(&again) == Status::kOk);
  CHECK(again == reserved);  // an uncommitted reservation is not taken
  CHECK(db.size() == 0);

  std::uint32_t s[5];
  for (int i = 0; i < 5; ++i) s[i] = add(&db, static_cast<FrameId>(10 + i), i * 1.0);
  CHECK(db.size() == 5);
  CHECK(db.oldest() == static_cast<std::int32_t>(s[0]));
  CHECK(db.newest() == static_cast<std::int32_t>(s[4]));
  CHECK(ids_in_order(db) == std::vector<FrameId>{10, 11, 12, 13, 14});
  CHECK(db.at(s[0]).prev == -1);
  CHECK(db.at(s[4]).next == -1);

  db.remove(s[2]);  // the middle
  CHECK(db.size() == 4);
  CHECK(ids_in_order(db) == std::vector<FrameId>{10, 11, 13, 14});
  CHECK(db.at(s[1]).next == static_cast<std::int32_t>(s[3]));
  CHECK(db.at(s[3]).prev == static_cast<std::int32_t>(s[1]));

  db.remove(s[0]);  // the oldest
  CHECK(db.oldest() == static_cast<std::int32_t>(s[1]));
  CHECK(db.at(s[1]).prev == -1);
  db.remove(s[4]);  // the newest
  CHECK(db.newest() == static_cast<std::int32_t>(s[3]));
  CHECK(db.at(s[3]).next == -1);
  CHECK(ids_in_order(db) == std::vector<FrameId>{11, 13});

  // The last freed slot comes back, reset, and is linked as the newest.
  db.at(s[4]).loops = 3;
  db.at(s[4]).indexed = true;
  db.at(s[4]).features.push_back(LoopFeature{});
  db.at(s[4]).bow.push_back(BowEntry{5, 1.0f});
  std::uint32_t reused = 0;
  REQUIRE(db.reserve(&reused) == Status::kOk);
  CHECK(reused == s[4]);
  CHECK(db.at(reused).loops == 0);
  CHECK_FALSE(db.at(reused).indexed);
  CHECK(db.at(reused).features.empty());
  CHECK(db.at(reused).bow.empty());
  db.at(reused).id = 20;
  db.commit(reused);
  CHECK(ids_in_order(db) == std::vector<FrameId>{11, 13, 20});

  db.remove(s[1]);
  db.remove(s[3]);
  db.remove(reused);
  CHECK(db.size() == 0);
  CHECK(db.oldest() == -1);
  CHECK(db.newest() == -1);
}

TEST_CASE("KeyframeDatabase: full at kMaxKeyframes, reserve says kFull until a record is removed", "[loop]") {
  KeyframeDatabase db(60);
  std::vector<std::uint32_t> slots;
  for (std::size_t i = 0; i < capacity::kMaxKeyframes; ++i) {
    CHECK_FALSE(db.full());
    slots.push_back(add(&db, static_cast<FrameId>(i), 0.5 * static_cast<double>(i)));
  }
  CHECK(db.full());
  CHECK(db.size() == capacity::kMaxKeyframes);
  std::uint32_t slot = 12345;
  CHECK(db.reserve(&slot) == Status::kFull);
  CHECK(slot == 12345);  // untouched

  db.remove(slots[700]);
  CHECK_FALSE(db.full());
  REQUIRE(db.reserve(&slot) == Status::kOk);
  CHECK(slot == slots[700]);
  db.at(slot).id = 5000;
  db.commit(slot);
  CHECK(db.full());
  CHECK(db.at(static_cast<std::uint32_t>(db.newest())).id == 5000);
  CHECK(db.at(static_cast<std::uint32_t>(db.oldest())).id == 0);
}

TEST_CASE("KeyframeDatabase: decimation drops the keyframe closest to its predecessor, 1 m per 10 deg of yaw", "[loop]") {
  KeyframeDatabase db(2);
  add(&db, 0, 0.0);          // oldest: never (nothing spans it)
  add(&db, 1, 1.0);          // 1.0 m from its predecessor
  add(&db, 2, 1.9);          // 0.9 m: the smallest so far
  add(&db, 3, 1.9, 10.0);    // 0 m, 10 deg: counts 1.0
  add(&db, 4, 3.0, 10.0);    // 1.1 m
  add(&db, 5, 3.05, 10.0);   // protected (one of the 2 newest) although 0.05 m
  add(&db, 6, 3.1, 10.0);    // protected
  CHECK(picked_id(db) == 2);

  KeyframeDatabase turn(2);
  add(&turn, 0, 0.0);
  add(&turn, 1, 1.1);        // 1.1 m
  add(&turn, 2, 1.1, -10.0); // 10 deg the other way: 1.0, the smallest
  add(&turn, 3, 2.3, -10.0); // 1.2 m
  add(&turn, 4, 9.0);
  add(&turn, 5, 18.0);
  CHECK(picked_id(turn) == 2);

  // Yaw wraps: 179 deg to -179 deg is a 2 deg turn (0.2), not 358 deg.
  KeyframeDatabase wrap(2);
  add(&wrap, 0, 0.0, 179.0);
  add(&wrap, 1, 0.0, -179.0);  // 0.2
  add(&wrap, 2, 0.25, -179.0); // 0.25 m
  add(&wrap, 3, 9.0);
  add(&wrap, 4, 18.0);
  CHECK(picked_id(wrap) == 1);
}

TEST_CASE("KeyframeDatabase: decimation keeps the protected newest, loop ends, session starts and the oldest", "[loop]") {
  SECTION("only protected records and the oldest: nothing to drop") {
    KeyframeDatabase db(3);
    add(&db, 0, 0.0);
    CHECK(db.pick_for_decimation() == -1);
    add(&db, 1, 0.0);
    add(&db, 2, 0.0);
    add(&db, 3, 0.0);
    CHECK(db.pick_for_decimation() == -1);  // 1..3 are the 3 newest, 0 the oldest
    add(&db, 4, 0.0);
    CHECK(picked_id(db) == 1);              // now 1 is old enough
  }
  SECTION("the closest are the newest: the best older one goes instead") {
    KeyframeDatabase db(3);
    add(&db, 0, 0.0);
    add(&db, 1, 2.0);
    add(&db, 2, 3.5);   // 1.5 m
    add(&db, 3, 6.0);   // 2.5 m
    add(&db, 4, 6.01);
    add(&db, 5, 6.02);
    add(&db, 6, 6.03);
    CHECK(picked_id(db) == 2);
  }
  SECTION("a keyframe with a loop stays however close") {
    KeyframeDatabase db(1);
    add(&db, 0, 0.0);
    const std::uint32_t close = add(&db, 1, 0.01);
    add(&db, 2, 2.0);   // 1.99 m
    add(&db, 3, 2.5);   // 0.5 m
    add(&db, 4, 9.0);
    CHECK(picked_id(db) == 1);
    db.at(close).loops = 1;
    CHECK(picked_id(db) == 3);
  }
  SECTION("a session's first keyframe stays: its predecessor is in another odometry frame") {
    KeyframeDatabase db(1);
    add(&db, 0, 0.0, 0.0, 0);
    add(&db, 1, 3.0, 0.0, 0);
    add(&db, 2, 3.0, 0.0, 1);   // 0 m from its predecessor's coordinates, but in a new frame: stays
    add(&db, 3, 3.3, 0.0, 1);   // 0.3 m
    add(&db, 4, 9.0, 0.0, 1);
    CHECK(picked_id(db) == 3);
    KeyframeDatabase only_start(1);
    add(&only_start, 0, 0.0, 0.0, 0);
    add(&only_start, 1, 0.0, 0.0, 1);  // 0 m from its predecessor, yet a session start
    add(&only_start, 2, 5.0, 0.0, 1);
    CHECK(only_start.pick_for_decimation() == -1);
  }
  SECTION("after a drop the neighbours are spaced by the dropped one's span") {
    KeyframeDatabase db(1);
    add(&db, 0, 0.0);
    add(&db, 1, 0.4);
    const std::uint32_t s2 = add(&db, 2, 0.5);   // 0.1 m: first to go
    add(&db, 3, 1.0);                            // 0.5 m, then 0.6 m once 2 is gone
    add(&db, 4, 1.55);                           // 0.55 m
    add(&db, 5, 9.0);
    CHECK(picked_id(db) == 2);
    db.remove(s2);
    CHECK(picked_id(db) == 1);                   // 0.4 m
  }
}

TEST_CASE("KeyframeDatabase: footprint is the record pool and the free-slot stack", "[loop]") {
  KeyframeDatabase db(60);
  const std::size_t bytes = db.footprint_bytes();
  CHECK(bytes == capacity::kMaxKeyframes * (sizeof(KeyframeRecord) + sizeof(std::uint32_t)));
  // The features dominate: 2000 keyframes x 300 features of 56 bytes (descriptor, point, bearing).
  CHECK(bytes >= capacity::kMaxKeyframes * capacity::kMaxLoopFeaturesPerKeyframe * sizeof(LoopFeature));
  add(&db, 0, 0.0);
  CHECK(db.footprint_bytes() == bytes);  // allocated at construction, independent of the fill
}
