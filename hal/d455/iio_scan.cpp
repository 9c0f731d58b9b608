#include "hal/d455/iio_scan.hpp"

#include <cstdio>
#include <cstring>

namespace ums::d455 {

bool parse_iio_type(const std::string& text, IioChannelType* out) {
  IioChannelType t;
  char endian = 0, sign = 0;
  int bits = 0, storage = 0, shift = 0, repeat = 1, consumed = 0;
  if (std::sscanf(text.c_str(), "%ce:%c%d/%dX%d>>%d%n", &endian, &sign, &bits, &storage, &repeat,
                  &shift, &consumed) == 6 &&
      static_cast<std::size_t>(consumed) == text.size()) {
  } else if (repeat = 1, consumed = 0,
             std::sscanf(text.c_str(), "%ce:%c%d/%d>>%d%n", &endian, &sign, &bits, &storage, &shift,
                         &consumed) == 5 &&
                 static_cast<std::size_t>(consumed) == text.size()) {
  } else {
    return false;
  }
  if ((endian != 'l' && endian != 'b') || (sign != 's' && sign != 'u')) return false;
  if (bits <= 0 || storage <= 0 || bits > storage || shift < 0 || shift >= storage || repeat < 1) return false;
  t.big_endian = endian == 'b';
  t.is_signed = sign == 's';
  t.bits = bits;
  t.storage_bits = storage;
  t.shift = shift;
  t.repeat = repeat;
  *out = t;
  return true;
}

int IioScanLayout::add(int index, const IioChannelType& type) {
  IioChannel c;
  c.index = index;
  c.type = type;
  if (channels_.push_back(c) != Status::kOk) return -1;
  return static_cast<int>(channels_.size()) - 1;
}

bool IioScanLayout::finalize() {
  const int n = static_cast<int>(channels_.size());
  for (int i = 0; i < n; ++i) order_[i] = i;
  for (int i = 1; i < n; ++i) {  // insertion sort by scan index (n <= 8)
    for (int j = i; j > 0 && channels_[static_cast<std::size_t>(order_[j])].index <
                                 channels_[static_cast<std::size_t>(order_[j - 1])].index; --j) {
      const int tmp = order_[j];
      order_[j] = order_[j - 1];
      order_[j - 1] = tmp;
    }
  }
  int offset = 0, largest = 1;
  for (int k = 0; k < n; ++k) {
    IioChannel& c = channels_[static_cast<std::size_t>(order_[k])];
    const int sb = c.type.storage_bits;
    if (c.type.repeat != 1 || (sb != 8 && sb != 16 && sb != 32 && sb != 64)) return false;
    const int bytes = sb / 8;
    offset = (offset + bytes - 1) / bytes * bytes;
    c.offset = offset;
    offset += bytes;
    if (bytes > largest) largest = bytes;
  }
  record_bytes_ = (offset + largest - 1) / largest * largest;
  return n > 0;
}

std::int64_t iio_extract(const std::uint8_t* record, const IioChannel& channel) {
  const int bytes = channel.type.storage_bits / 8;
  const std::uint8_t* p = record + channel.offset;
  std::uint64_t raw = 0;
  for (int i = 0; i < bytes; ++i) {
    const int b = channel.type.big_endian ? i : bytes - 1 - i;
    raw = (raw << 8) | p[b];
  }
  raw >>= channel.type.shift;
  const int bits = channel.type.bits;
  if (bits < 64) raw &= (std::uint64_t{1} << bits) - 1;
  if (channel.type.is_signed && bits < 64 && (raw >> (bits - 1)) & 1u) {
    raw |= ~((std::uint64_t{1} << bits) - 1);
  }
  std::int64_t v;
  std::memcpy(&v, &raw, sizeof v);
  return v;
}

}  // namespace ums::d455
