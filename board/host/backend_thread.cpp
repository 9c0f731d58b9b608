#include "board/host/backend_thread.hpp"

#include <pthread.h>
#include <ctime>

#include "profiling/alloc_counter.hpp"

namespace ums::cli {

BackendThread::BackendThread() : thread_([this] { run(); }) {}

BackendThread::~BackendThread() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  has_work_.notify_one();
  thread_.join();
}

void BackendThread::submit(Task task, void* context, std::uint32_t arg) {
  std::unique_lock<std::mutex> lock(mutex_);
  rethrow_locked(lock);
  if (count_ == kCapacity) {
    full_waits_.fetch_add(1, std::memory_order_relaxed);
    has_room_.wait(lock, [this] { return count_ < kCapacity; });
  }
  ring_[(head_ + count_) % kCapacity] = Entry{task, context, arg};
  ++count_;
  lock.unlock();
  has_work_.notify_one();
}

void BackendThread::wait_idle() {
  std::unique_lock<std::mutex> lock(mutex_);
  idle_.wait(lock, [this] { return count_ == 0 && !busy_; });
  rethrow_locked(lock);
}

void BackendThread::rethrow_locked(std::unique_lock<std::mutex>& lock) {
  if (error_ == nullptr) return;
  std::exception_ptr e = error_;
  error_ = nullptr;
  lock.unlock();
  std::rethrow_exception(e);
}

void BackendThread::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    has_work_.wait(lock, [this] { return count_ > 0 || stop_; });
    if (count_ == 0) return;  // stopped, and nothing left
    const Entry e = ring_[head_];
    head_ = (head_ + 1) % kCapacity;
    --count_;
    busy_ = true;
    lock.unlock();
    has_room_.notify_one();
    try {
      e.task(e.context, e.arg);
    } catch (...) {
      const std::lock_guard<std::mutex> error_lock(mutex_);
      if (error_ == nullptr) error_ = std::current_exception();
    }
    allocations_.store(thread_alloc_counts().allocations, std::memory_order_relaxed);
    tasks_.fetch_add(1, std::memory_order_relaxed);
    lock.lock();
    busy_ = false;
    if (count_ == 0) idle_.notify_all();
  }
}

double BackendThread::cpu_s() const {
  clockid_t clock = 0;
  timespec ts{};
  if (pthread_getcpuclockid(const_cast<std::thread&>(thread_).native_handle(), &clock) != 0 ||
      clock_gettime(clock, &ts) != 0) {
    return 0.0;
  }
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace ums::cli
