// Map files of the loop closer (LoopCloser::save_map / load_map; docs/loop-closure.md "Map files").
//
//   "UMSMAP01" | u32 version | u32 vocabulary checksum | u32 calibration hash | u32 keyframes |
//   u32 loops | keyframes: u32 id, i64 t_ns, u32 session, f64 p[3], f64 q[4] (x y z w, T_map_b),
//   u16 features, features: u64 descriptor[4], f32 p_b[3], f32 bearing_c0[3] |
//   loops: u32 loop keyframe, u32 query keyframe (indices in file order), f64 p[3], f64 q[4]
//   (T_loop_query) | u32 CRC-32 of everything before
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "core/loop/byte_io.hpp"
#include "core/loop/loop_closer.hpp"

namespace ums::loop {

namespace {

constexpr char kMagic[8] = {'U', 'M', 'S', 'M', 'A', 'P', '0', '1'};
constexpr std::uint32_t kVersion = 1;

void put_pose(ByteWriter& w, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  for (int i = 0; i < 3; ++i) w.put<double>(T.translation()[i]);
  w.put<double>(q.x()), w.put<double>(q.y()), w.put<double>(q.z()), w.put<double>(q.w());
}

// false: not finite or not a unit quaternion.
bool get_pose(ByteReader& r, Eigen::Isometry3d* T) {
  double v[7];
  for (double& x : v) x = r.get<double>();
  for (double x : v)
    if (!std::isfinite(x)) return false;
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (std::abs(q.norm() - 1.0) > 1e-6) return false;
  T->setIdentity();
  T->linear() = q.normalized().toRotationMatrix();
  T->translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return true;
}

std::runtime_error unusable(const std::string& source, const std::string& why) {
  return std::runtime_error(source + ": not a usable map: " + why);
}

}  // namespace

std::vector<std::uint8_t> LoopCloser::save_map() const {
  std::vector<std::uint8_t> out;
  ByteWriter w(&out);
  w.put_bytes(kMagic, sizeof(kMagic));
  w.put<std::uint32_t>(kVersion);
  w.put<std::uint32_t>(vocabulary_.checksum());
  w.put<std::uint32_t>(calibration_hash_);
  // File order: the placed keyframes in time order; node_of_ maps a slot to its file index.
  std::uint32_t n = 0;
  for (std::int32_t s = db_->oldest(); s >= 0; s = db_->at(s).next) {
    node_of_[s] = db_->at(s).placed ? static_cast<std::int32_t>(n++) : -1;
  }
  std::uint32_t n_loops = 0;
  for (std::size_t l = 0; l < n_loops_; ++l) n_loops += node_of_[loops_[l].c_slot] >= 0 && node_of_[loops_[l].q_slot] >= 0;
  w.put<std::uint32_t>(n);
  w.put<std::uint32_t>(n_loops);
  for (std::int32_t s = db_->oldest(); s >= 0; s = db_->at(s).next) {
    if (node_of_[s] < 0) continue;
    const KeyframeRecord& r = db_->at(s);
    w.put<std::uint32_t>(r.id);
    w.put<std::int64_t>(r.t_ns);
    w.put<std::uint32_t>(r.session);
    put_pose(w, r.T_map_b);
    w.put<std::uint16_t>(static_cast<std::uint16_t>(r.features.size()));
    for (const LoopFeature& f : r.features) {
      w.put_bytes(f.descriptor.data(), sizeof(Descriptor));
      w.put_bytes(f.p_b.data(), 3 * sizeof(float));
      w.put_bytes(f.bearing_c0.data(), 3 * sizeof(float));
    }
  }
  for (std::size_t l = 0; l < n_loops_; ++l) {
    const std::int32_t a = node_of_[loops_[l].c_slot], b = node_of_[loops_[l].q_slot];
    if (a < 0 || b < 0) continue;
    w.put<std::uint32_t>(static_cast<std::uint32_t>(a));
    w.put<std::uint32_t>(static_cast<std::uint32_t>(b));
    put_pose(w, loops_[l].T_c_q);
  }
  w.put<std::uint32_t>(crc32(out.data(), out.size()));
  return out;
}

void LoopCloser::check_map_header(const std::vector<std::uint8_t>& bytes, const std::string& source,
                                  std::uint32_t* n_keyframes, std::uint32_t* n_loops) const {
  if (started_ || db_->size() > 0) throw unusable(source, "a map loads into a closer that has seen no keyframe");
  if (bytes.size() < sizeof(kMagic) + 6 * 4) throw unusable(source, "truncated (" + std::to_string(bytes.size()) + " bytes)");
  if (std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) throw unusable(source, "no UMSMAP01 magic");
  std::uint32_t crc = 0;
  std::memcpy(&crc, bytes.data() + bytes.size() - 4, 4);
  if (crc != crc32(bytes.data(), bytes.size() - 4)) throw unusable(source, "CRC mismatch (corrupt or truncated)");
  ByteReader r(bytes.data() + sizeof(kMagic), bytes.size() - sizeof(kMagic) - 4);
  const std::uint32_t version = r.get<std::uint32_t>();
  if (version != kVersion) throw unusable(source, "version " + std::to_string(version) + ", this build reads 1");
  if (r.get<std::uint32_t>() != vocabulary_.checksum()) throw unusable(source, "made with another vocabulary");
  if (r.get<std::uint32_t>() != calibration_hash_) throw unusable(source, "made with another camera calibration");
  *n_keyframes = r.get<std::uint32_t>();
  *n_loops = r.get<std::uint32_t>();
  if (*n_keyframes > capacity::kMaxKeyframes) throw unusable(source, std::to_string(*n_keyframes) + " keyframes, capacity " + std::to_string(capacity::kMaxKeyframes));
  if (*n_loops > capacity::kMaxLoopEdges) throw unusable(source, std::to_string(*n_loops) + " loops, capacity " + std::to_string(capacity::kMaxLoopEdges));
}

// One pass over the records: with apply == false it only checks (so that a bad file changes
// nothing), with apply == true it fills the database, the index and the loop edges.
void LoopCloser::read_map_records(const std::vector<std::uint8_t>& bytes, const std::string& source,
                                  std::uint32_t n_keyframes, std::uint32_t n_loops, bool apply) {
  ByteReader r(bytes.data() + sizeof(kMagic) + 5 * 4, bytes.size() - sizeof(kMagic) - 5 * 4 - 4);
  for (std::uint32_t k = 0; k < n_keyframes; ++k) {
    KeyframeRecord scratch_record;
    std::uint32_t slot = 0;
    if (apply && db_->reserve(&slot) != Status::kOk) throw unusable(source, "database full");
    KeyframeRecord& rec = apply ? db_->at(slot) : scratch_record;
    rec.id = r.get<std::uint32_t>();
    rec.t_ns = r.get<std::int64_t>();
    rec.session = r.get<std::uint32_t>();
    if (!get_pose(r, &rec.T_map_b) && !r.failed()) throw unusable(source, "keyframe " + std::to_string(k) + ": pose not a rigid transform");
    if (rec.session >= 0x80000000u) throw unusable(source, "keyframe " + std::to_string(k) + ": session " + std::to_string(rec.session));
    // Each saved session keeps its own odometry edges; the map poses stand in for the odometry.
    rec.T_odom_b = rec.T_map_b;
    rec.placed = true;
    rec.loops = 0;  // counted from the loop list: the file's word is not trusted for decimation
    const std::uint16_t n_features = r.get<std::uint16_t>();
    if (n_features > capacity::kMaxLoopFeaturesPerKeyframe) throw unusable(source, "keyframe " + std::to_string(k) + ": " + std::to_string(n_features) + " features, capacity " + std::to_string(capacity::kMaxLoopFeaturesPerKeyframe));
    rec.features.clear();
    for (std::uint16_t i = 0; i < n_features; ++i) {
      LoopFeature f;
      r.get_bytes(f.descriptor.data(), sizeof(Descriptor));
      r.get_bytes(f.p_b.data(), 3 * sizeof(float));
      r.get_bytes(f.bearing_c0.data(), 3 * sizeof(float));
      if (!f.p_b.allFinite() || !f.bearing_c0.allFinite()) throw unusable(source, "keyframe " + std::to_string(k) + ": a point is not finite");
      rec.features.push_back(f);
    }
    if (r.failed()) throw unusable(source, "truncated in keyframe " + std::to_string(k));
    if (apply) commit_loaded(slot);
  }
  for (std::uint32_t l = 0; l < n_loops; ++l) {
    const std::uint32_t a = r.get<std::uint32_t>(), b = r.get<std::uint32_t>();
    Eigen::Isometry3d T;
    if (!get_pose(r, &T) || r.failed() || a >= n_keyframes || b >= n_keyframes || a == b) {
      throw unusable(source, "loop " + std::to_string(l) + " is malformed");
    }
    if (apply) {
      loops_[n_loops_++] = LoopEdge{slot_of_[a], slot_of_[b], T, options_.loop_sigma_p_m,
                                    options_.loop_sigma_yaw_deg * M_PI / 180.0};
      ++db_->at(slot_of_[a]).loops;
      ++db_->at(slot_of_[b]).loops;
    }
  }
  if (r.remaining() != 0) throw unusable(source, std::to_string(r.remaining()) + " bytes after the last record");
}

void LoopCloser::commit_loaded(std::uint32_t slot) {
  KeyframeRecord& rec = db_->at(slot);
  const std::int32_t prev = db_->newest();
  const bool same_session = prev >= 0 && db_->at(prev).session == rec.session;
  rec.path_m = !same_session ? 0.0 : db_->at(prev).path_m + (rec.T_map_b.translation() - db_->at(prev).T_map_b.translation()).norm();
  session_ = std::max(session_, rec.session);
  for (std::size_t i = 0; i < rec.features.size(); ++i) scratch_[i] = rec.features[i].descriptor;
  vocabulary_.transform(scratch_.get(), rec.features.size(), &rec.bow);
  db_->commit(slot);
  slot_of_[loaded_keyframes_++] = slot;
  if (rec.features.size() >= static_cast<std::size_t>(options_.min_features) && index_->add(slot, rec.bow) == Status::kOk) {
    rec.indexed = true;
  }
}

void LoopCloser::load_map(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  std::uint32_t n_keyframes = 0, n_loops = 0;
  session_ = 0;
  check_map_header(bytes, source, &n_keyframes, &n_loops);
  read_map_records(bytes, source, n_keyframes, n_loops, false);
  read_map_records(bytes, source, n_keyframes, n_loops, true);
  // The map's sessions are placed; the run's first levelled keyframe starts the next session,
  // unplaced until its first loop.
  started_ = true;
  epoch_ = 0xFFFFFFFFu;
  session_placed_ = true;
  stats_.sessions = 1;
}

}  // namespace ums::loop
