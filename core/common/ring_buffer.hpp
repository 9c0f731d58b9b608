#pragma once
// Fixed-capacity FIFO. push on a full ring returns Status::kFull and leaves the ring unchanged:
// the owner decides whether to drop the new item or pop the oldest, and counts the drop.

#include <array>
#include <cstddef>

#include "core/common/assert.hpp"
#include "core/common/status.hpp"

namespace ums {

template <typename T, std::size_t N>
class RingBuffer {
  static_assert(N > 0, "a ring needs room");

 public:
  static constexpr std::size_t kCapacity = N;

  std::size_t size() const { return size_; }
  static constexpr std::size_t capacity() { return N; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == N; }
  void clear() {
    head_ = 0;
    size_ = 0;
  }

  Status push(const T& value) {
    if (size_ == N) return Status::kFull;
    data_[(head_ + size_) % N] = value;
    ++size_;
    return Status::kOk;
  }
  Status pop(T* out) {
    if (size_ == 0) return Status::kEmpty;
    if (out != nullptr) *out = data_[head_];
    head_ = (head_ + 1) % N;
    --size_;
    return Status::kOk;
  }
  // i = 0 is the oldest element.
  const T& operator[](std::size_t i) const {
    UMS_ASSERT(i < size_);
    return data_[(head_ + i) % N];
  }
  T& operator[](std::size_t i) {
    UMS_ASSERT(i < size_);
    return data_[(head_ + i) % N];
  }
  const T& front() const { return (*this)[0]; }
  const T& back() const { return (*this)[size_ - 1]; }

 private:
  std::array<T, N> data_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

}  // namespace ums
