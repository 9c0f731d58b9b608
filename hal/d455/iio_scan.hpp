#pragma once
// IIO buffer scan records: the per-channel `type` description ("le:s16/32>>0"), the record layout
// derived from the enabled channels' indices, and extraction of one channel's value from a record
// (kernel Documentation/ABI/testing/sysfs-bus-iio, "in_*_type"; notes §4.3).

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/fixed_vector.hpp"

namespace ums::d455 {

struct IioChannelType {
  bool big_endian = false;
  bool is_signed = true;
  int bits = 0;          // realbits: meaningful bits after the shift
  int storage_bits = 0;  // container: 8, 16, 32 or 64
  int shift = 0;         // right shift applied before masking to `bits`
  int repeat = 1;        // "X<n>" repeat count (only 1 is supported for decoding)
};

// Parses "[bl]e:[su]<bits>/<storage>[X<repeat>]>><shift>". False for anything else.
bool parse_iio_type(const std::string& text, IioChannelType* out);

struct IioChannel {
  int index = 0;          // scan_elements/in_*_index
  IioChannelType type;
  int offset = 0;         // bytes from the start of the record
};

// Channels of one IIO device in record order. Offsets follow the kernel's rule: each channel is
// aligned to its own storage size, the record to the largest storage size.
class IioScanLayout {
 public:
  static constexpr std::size_t kMaxChannels = 8;
  // Adds an enabled channel; returns its slot (for at()) or -1 when full / invalid.
  int add(int index, const IioChannelType& type);
  // Computes offsets and the record size; false if a type is unusable (repeat != 1, storage not
  // 8/16/32/64, bits > storage).
  bool finalize();
  int record_bytes() const { return record_bytes_; }
  const IioChannel& at(int slot) const { return channels_[static_cast<std::size_t>(slot)]; }
  std::size_t size() const { return channels_.size(); }

 private:
  FixedVector<IioChannel, kMaxChannels> channels_;
  int order_[kMaxChannels] = {};
  int record_bytes_ = 0;
};

// The channel's value: container loaded with its endianness, shifted, masked to `bits`, and
// sign-extended from `bits` when signed (LRS sign-extends 16-bit data in 32-bit containers).
std::int64_t iio_extract(const std::uint8_t* record, const IioChannel& channel);

}  // namespace ums::d455
