#pragma once
// VioPipeline's back end on a second core (issue 19; the paper runs two threads): a
// BackendExecutor whose tasks run in submission order on a thread of its own. The caller's
// thread then runs the front end of frame k+1 while this one runs the estimator on frame k.
//
// A fixed ring of capacity::kBackendTasks tasks; submit() waits for room when it is full (the
// back end fell behind by that many IMU samples: the front end waits rather than lose a sample).
// Allocates only when constructed (the thread) and when a task throws (the exception).

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>

#include "core/common/capacity.hpp"
#include "core/pipeline/backend_executor.hpp"

namespace ums::cli {

class BackendThread final : public BackendExecutor {
 public:
  BackendThread();             // starts the thread
  ~BackendThread() override;   // runs what is queued, then ends the thread
  BackendThread(const BackendThread&) = delete;
  BackendThread& operator=(const BackendThread&) = delete;

  void submit(Task task, void* context, std::uint32_t arg) override;
  void wait_idle() override;

  // Any thread.
  double cpu_s() const;                  // CPU time the thread has used (s)
  std::uint64_t allocations() const {    // heap allocations the thread has made (profiling hooks)
    return allocations_.load(std::memory_order_relaxed);
  }
  std::uint64_t tasks() const { return tasks_.load(std::memory_order_relaxed); }
  std::uint64_t full_waits() const { return full_waits_.load(std::memory_order_relaxed); }  // submits that waited for room

 private:
  struct Entry {
    Task task = nullptr;
    void* context = nullptr;
    std::uint32_t arg = 0;
  };
  static constexpr std::size_t kCapacity = capacity::kBackendTasks;

  void run();
  void rethrow_locked(std::unique_lock<std::mutex>& lock);

  std::mutex mutex_;
  std::condition_variable has_work_, has_room_, idle_;
  Entry ring_[kCapacity];
  std::size_t head_ = 0, count_ = 0;
  bool busy_ = false;   // a task is running
  bool stop_ = false;
  std::exception_ptr error_;  // the first exception a task threw, until rethrown
  std::atomic<std::uint64_t> allocations_{0}, tasks_{0}, full_waits_{0};
  std::thread thread_;  // last: starts once everything above exists
};

}  // namespace ums::cli
