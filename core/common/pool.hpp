#pragma once
// Object pool with O(1) acquire/release over inline storage. Following ETL's ipool/pool split,
// algorithms take the capacity-erased IPool<T>; the owner declares Pool<T, N>. An exhausted pool
// returns nullptr (a status, never a throw) and counts the refusal, and the peak use is kept for
// the memory budget report (stats.json memory.pools.<name>).

#include <array>
#include <cstddef>
#include <cstdint>

#include "core/common/assert.hpp"

namespace ums {

template <typename T>
class IPool {
 public:
  T* acquire() {
    if (free_count_ == 0) {
      ++refused_;
      return nullptr;
    }
    const std::uint32_t slot = free_list_[--free_count_];
    in_use_[slot] = 1;
    const std::size_t used = capacity_ - free_count_;
    if (used > peak_) peak_ = used;
    items_[slot] = T{};
    return &items_[slot];
  }

  void release(T* item) {
    UMS_ASSERT(item != nullptr);
    const std::size_t slot = static_cast<std::size_t>(item - items_);
    UMS_ASSERT(slot < capacity_ && in_use_[slot] == 1);
    in_use_[slot] = 0;
    free_list_[free_count_++] = static_cast<std::uint32_t>(slot);
  }

  void release_all() {
    for (std::size_t i = 0; i < capacity_; ++i) {
      in_use_[i] = 0;
      free_list_[i] = static_cast<std::uint32_t>(capacity_ - 1 - i);
    }
    free_count_ = capacity_;
  }

  std::size_t capacity() const { return capacity_; }
  std::size_t in_use() const { return capacity_ - free_count_; }
  std::size_t peak() const { return peak_; }
  std::uint64_t refused() const { return refused_; }
  std::size_t index_of(const T* item) const { return static_cast<std::size_t>(item - items_); }
  T* at_index(std::size_t i) { return in_use_[i] ? &items_[i] : nullptr; }
  // The item at pool index i, which is in use (the owner's index says so).
  T& item(std::size_t i) {
    UMS_ASSERT(i < capacity_ && in_use_[i] == 1);
    return items_[i];
  }
  const T& item(std::size_t i) const {
    UMS_ASSERT(i < capacity_ && in_use_[i] == 1);
    return items_[i];
  }

 protected:
  IPool(T* items, std::uint32_t* free_list, std::uint8_t* in_use, std::size_t capacity)
      : items_(items), free_list_(free_list), in_use_(in_use), capacity_(capacity) {}
  ~IPool() = default;
  IPool(const IPool&) = delete;
  IPool& operator=(const IPool&) = delete;

 private:
  T* items_;
  std::uint32_t* free_list_;
  std::uint8_t* in_use_;
  std::size_t capacity_;
  std::size_t free_count_ = 0;
  std::size_t peak_ = 0;
  std::uint64_t refused_ = 0;
};

// Storage as the first base: bases are built in declaration order, so the arrays exist before
// IPool<T> takes pointers to them.
template <typename T, std::size_t N>
struct PoolStorage {
  std::array<T, N> storage_items{};
  std::array<std::uint32_t, N> storage_free_list{};
  std::array<std::uint8_t, N> storage_in_use{};
};

template <typename T, std::size_t N>
class Pool final : private PoolStorage<T, N>, public IPool<T> {
 public:
  Pool()
      : PoolStorage<T, N>(),
        IPool<T>(this->storage_items.data(), this->storage_free_list.data(), this->storage_in_use.data(), N) {
    this->release_all();
  }
  static constexpr std::size_t kStaticBytes =
      N * (sizeof(T) + sizeof(std::uint32_t) + sizeof(std::uint8_t));
};

}  // namespace ums
