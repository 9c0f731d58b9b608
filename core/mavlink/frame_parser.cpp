#include "core/mavlink/frame_parser.hpp"

#include <cstring>

#include "core/mavlink/crc_x25.hpp"

namespace ums::mavlink {

FrameParser::FrameParser(const MessageSpec* specs, std::size_t n_specs) : specs_(specs), n_specs_(n_specs) {}

const MessageSpec* FrameParser::find(std::uint32_t id) const {
  for (std::size_t i = 0; i < n_specs_; ++i)
    if (specs_[i].id == id) return &specs_[i];
  return nullptr;
}

bool FrameParser::push(std::uint8_t byte) {
  if (have_ == 0 && byte != 0xFD) {
    ++counters_.skipped_bytes;
    return false;
  }
  frame_[have_++] = byte;
  if (have_ == kHeaderBytes) {
    const bool is_signed = (frame_[2] & 0x01) != 0;
    need_ = kHeaderBytes + frame_[1] + 2 + (is_signed ? 13 : 0);
  }
  if (have_ < kHeaderBytes || have_ < need_) return false;
  const bool ok = finish();
  have_ = 0;
  need_ = 0;
  return ok;
}

bool FrameParser::finish() {
  const std::uint8_t len = frame_[1];
  const std::uint32_t id = static_cast<std::uint32_t>(frame_[7]) | (static_cast<std::uint32_t>(frame_[8]) << 8) |
                           (static_cast<std::uint32_t>(frame_[9]) << 16);
  const MessageSpec* spec = find(id);
  if (spec == nullptr) {
    ++counters_.unknown_id;
    return false;
  }
  std::uint16_t crc = crc_x25(frame_ + 1, kHeaderBytes - 1 + len);
  crc = crc_accumulate(spec->crc_extra, crc);
  const std::uint16_t got = static_cast<std::uint16_t>(frame_[kHeaderBytes + len] |
                                                       (frame_[kHeaderBytes + len + 1] << 8));
  if (crc != got) {
    ++counters_.bad_crc;
    return false;
  }
  message_.id = id;
  message_.system_id = frame_[5];
  message_.component_id = frame_[6];
  message_.len = len;
  std::memset(message_.payload, 0, sizeof(message_.payload));
  std::memcpy(message_.payload, frame_ + kHeaderBytes, len);
  ++counters_.accepted;
  return true;
}

}  // namespace ums::mavlink
