#pragma once
// A vector with inline storage of capacity N: push is O(1) and fails with Status::kFull instead
// of allocating. Elements must be default-constructible (storage is a plain array, so the type
// stays trivially usable in pools and static objects).

#include <array>
#include <cstddef>

#include "core/common/assert.hpp"
#include "core/common/status.hpp"

namespace ums {

template <typename T, std::size_t N>
class FixedVector {
 public:
  static constexpr std::size_t kCapacity = N;

  std::size_t size() const { return size_; }
  static constexpr std::size_t capacity() { return N; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == N; }
  void clear() { size_ = 0; }

  Status push_back(const T& value) {
    if (size_ == N) return Status::kFull;
    data_[size_++] = value;
    return Status::kOk;
  }
  void pop_back() {
    UMS_ASSERT(size_ > 0);
    --size_;
  }
  // Shrinks or grows within capacity; new elements keep whatever the storage held.
  Status resize(std::size_t n) {
    if (n > N) return Status::kFull;
    size_ = n;
    return Status::kOk;
  }
  // O(1) removal that does not keep order: the last element moves into the hole.
  void swap_remove(std::size_t i) {
    UMS_ASSERT(i < size_);
    data_[i] = data_[size_ - 1];
    --size_;
  }

  T& operator[](std::size_t i) {
    UMS_ASSERT(i < size_);
    return data_[i];
  }
  const T& operator[](std::size_t i) const {
    UMS_ASSERT(i < size_);
    return data_[i];
  }
  T& back() { return (*this)[size_ - 1]; }
  const T& back() const { return (*this)[size_ - 1]; }

  T* begin() { return data_.data(); }
  T* end() { return data_.data() + size_; }
  const T* begin() const { return data_.data(); }
  const T* end() const { return data_.data() + size_; }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }

 private:
  std::array<T, N> data_{};
  std::size_t size_ = 0;
};

}  // namespace ums
