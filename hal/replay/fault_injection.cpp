#include "hal/replay/fault_injection.hpp"

#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "core/common/capacity.hpp"

namespace ums::hal {

namespace {

struct KindName {
  FaultKind kind;
  const char* name;
};
constexpr KindName kKinds[] = {
    {FaultKind::kImuGap, "imu-gap"},         {FaultKind::kImuNan, "imu-nan"},
    {FaultKind::kImuHuge, "imu-huge"},       {FaultKind::kImuDuplicate, "imu-dup"},
    {FaultKind::kImuSwap, "imu-swap"},       {FaultKind::kFrameGap, "frame-gap"},
    {FaultKind::kFrameDrop, "frame-drop"},   {FaultKind::kFrameFreeze, "frame-freeze"},
    {FaultKind::kFrameDuplicate, "frame-dup"}, {FaultKind::kRightLost, "right-lost"},
    {FaultKind::kBlackout, "blackout"},      {FaultKind::kClockJump, "clock-jump"},
    {FaultKind::kImagesEnd, "images-end"},
};

bool parse_number(const std::string& text, double* v) {
  std::istringstream in(text);
  in >> *v;
  return !text.empty() && in && in.peek() == std::char_traits<char>::eof() && std::isfinite(*v);
}

}  // namespace

const char* to_string(FaultKind kind) {
  for (const KindName& k : kKinds) {
    if (k.kind == kind) return k.name;
  }
  return "?";
}

bool parse_fault(const std::string& spec, Fault* out, std::string* error) {
  std::vector<std::string> parts;
  std::istringstream in(spec);
  for (std::string p; std::getline(in, p, ':');) parts.push_back(p);
  auto fail = [&](const std::string& why) {
    *error = "fault '" + spec + "': " + why + " (KIND:START_S:DURATION_S[:PARAM])";
    return false;
  };
  if (parts.size() < 2 || parts.size() > 4) return fail("2 to 4 fields");
  Fault f;
  bool known = false;
  for (const KindName& k : kKinds) {
    if (parts[0] == k.name) {
      f.kind = k.kind;
      known = true;
    }
  }
  if (!known) return fail("unknown kind '" + parts[0] + "'");
  if (!parse_number(parts[1], &f.start_s) || f.start_s < 0.0) return fail("start '" + parts[1] + "' is not a time >= 0");
  if (parts.size() >= 3 && (!parse_number(parts[2], &f.duration_s) || f.duration_s < 0.0)) {
    return fail("duration '" + parts[2] + "' is not a time >= 0");
  }
  if (parts.size() == 4 && !parse_number(parts[3], &f.param)) return fail("parameter '" + parts[3] + "' is not a number");
  if (f.kind == FaultKind::kFrameDrop && !(f.param > 0.0 && f.param <= 1.0)) return fail("frame-drop needs a probability in (0, 1]");
  if (f.kind == FaultKind::kClockJump && f.param == 0.0) return fail("clock-jump needs a jump in s");
  const bool needs_duration = f.kind != FaultKind::kImagesEnd && f.kind != FaultKind::kClockJump;
  if (needs_duration && !(f.duration_s > 0.0)) return fail("needs a duration > 0");
  *out = f;
  return true;
}

FaultInjector::FaultInjector(const Fault* faults, int count, std::uint64_t seed, MeasurementSink* out)
    : out_(out), rng_(seed) {
  if (count < 0 || count > kMaxFaults) throw std::invalid_argument("FaultInjector: at most 16 faults");
  bool images = false;
  for (int i = 0; i < count; ++i) {
    faults_[n_++] = faults[i];
    images = images || faults[i].kind == FaultKind::kFrameFreeze || faults[i].kind == FaultKind::kBlackout;
  }
  if (!images) return;
  buffer_bytes_ = static_cast<std::size_t>(capacity::kMaxImageWidth) * capacity::kMaxImageHeight;
  for (auto& b : frozen_) b = std::make_unique<std::uint8_t[]>(buffer_bytes_);
  black_ = std::make_unique<std::uint8_t[]>(buffer_bytes_);
  std::memset(black_.get(), 0, buffer_bytes_);
}

bool FaultInjector::active(const Fault& f, std::int64_t t_ns) const {
  const double s = 1e-9 * static_cast<double>(t_ns - t0_ns_);
  if (s < f.start_s) return false;
  if (f.kind == FaultKind::kImagesEnd || (f.kind == FaultKind::kClockJump && f.duration_s <= 0.0)) return true;
  return s < f.start_s + f.duration_s;
}

bool FaultInjector::any_active(FaultKind kind, std::int64_t t_ns) const {
  for (int i = 0; i < n_; ++i) {
    if (faults_[i].kind == kind && active(faults_[i], t_ns)) return true;
  }
  return false;
}

std::int64_t FaultInjector::restamp(std::int64_t t_ns) {
  std::int64_t shifted = t_ns;
  for (int i = 0; i < n_; ++i) {
    if (faults_[i].kind == FaultKind::kClockJump && active(faults_[i], t_ns)) {
      shifted += static_cast<std::int64_t>(faults_[i].param * 1e9);
    }
  }
  if (shifted != t_ns) ++counters_.restamped;
  return shifted;
}

void FaultInjector::on_imu(const ImuSample& sample) {
  if (t0_ns_ < 0) t0_ns_ = sample.t_ns;
  const std::int64_t t = sample.t_ns;
  if (any_active(FaultKind::kImuGap, t)) {
    ++counters_.imu_lost;
    return;
  }
  ImuSample s = sample;
  if (any_active(FaultKind::kImuNan, t)) {
    s.gyro_rad_s.setConstant(std::numeric_limits<double>::quiet_NaN());
    s.accel_m_s2.setConstant(std::numeric_limits<double>::quiet_NaN());
    ++counters_.imu_corrupted;
  } else if (any_active(FaultKind::kImuHuge, t)) {
    s.gyro_rad_s.setConstant(1e9);
    s.accel_m_s2.setConstant(1e9);
    ++counters_.imu_corrupted;
  }
  s.t_ns = restamp(t);
  if (any_active(FaultKind::kImuSwap, t)) {
    if (!have_swap_) {
      swap_held_ = s;
      have_swap_ = true;
      return;
    }
    out_->on_imu(s);  // the newer one first
    ++counters_.imu_reordered;
  } else if (!have_swap_) {
    out_->on_imu(s);
    if (any_active(FaultKind::kImuDuplicate, t)) {
      out_->on_imu(s);
      ++counters_.imu_extra;
    }
    return;
  } else {
    out_->on_imu(s);  // the interval ended with one held: it comes late
  }
  out_->on_imu(swap_held_);
  have_swap_ = false;
}

void FaultInjector::flush() {
  if (!have_swap_) return;
  out_->on_imu(swap_held_);
  have_swap_ = false;
}

void FaultInjector::remember(const StereoFrame& frame) {
  const ImageView* in[2] = {&frame.left, &frame.right};
  for (int c = 0; c < 2; ++c) {
    const ImageView& v = *in[c];
    const std::size_t bytes = static_cast<std::size_t>(v.width) * static_cast<std::size_t>(v.height);
    if (!v.valid() || bytes > buffer_bytes_) {
      frozen_view_[c] = ImageView{};
      continue;
    }
    frozen_view_[c] = copy_packed(v, frozen_[c].get());
  }
}

void FaultInjector::on_stereo(const StereoFrame& frame) {
  if (t0_ns_ < 0) t0_ns_ = frame.t_ns;
  const std::int64_t t = frame.t_ns;
  bool lost = any_active(FaultKind::kImagesEnd, t) || any_active(FaultKind::kFrameGap, t);
  for (int i = 0; i < n_ && !lost; ++i) {
    const Fault& f = faults_[i];
    if (f.kind == FaultKind::kFrameDrop && active(f, t)) lost = std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < f.param;
  }
  if (lost) {
    ++counters_.frames_lost;
    return;
  }
  StereoFrame f = frame;
  f.t_ns = restamp(t);
  bool altered = false;
  if (frozen_[0] != nullptr) {
    if (any_active(FaultKind::kFrameFreeze, t) && frozen_view_[0].valid()) {
      f.left = frozen_view_[0];
      f.right = frozen_view_[1];
      altered = true;
    } else {
      remember(frame);
    }
  }
  if (any_active(FaultKind::kBlackout, t)) {
    for (ImageView* v : {&f.left, &f.right}) {
      const std::size_t bytes = static_cast<std::size_t>(v->width) * static_cast<std::size_t>(v->height);
      if (v->valid() && bytes <= buffer_bytes_) *v = ImageView{black_.get(), v->width, v->height, v->width};
    }
    altered = true;
  }
  if (any_active(FaultKind::kRightLost, t)) {
    f.right = ImageView{};
    altered = true;
  }
  if (altered) ++counters_.frames_altered;
  out_->on_stereo(f);
  if (any_active(FaultKind::kFrameDuplicate, t)) {
    out_->on_stereo(f);
    ++counters_.frames_extra;
  }
}

}  // namespace ums::hal
