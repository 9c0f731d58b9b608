// The back end's second thread: tasks in submission order, wait_idle, a full ring that waits
// rather than drops, an exception that reaches the submitter once, and no allocation per task.

#include "board/host/backend_thread.hpp"

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"

namespace {

struct Log {
  std::vector<std::uint32_t> order;  // reserved: appending never allocates
  std::thread::id thread;
  std::atomic<bool> gate{true};      // the first task spins until it opens
};

void record(void* context, std::uint32_t arg) {
  auto* log = static_cast<Log*>(context);
  while (!log->gate.load()) std::this_thread::yield();
  log->order.push_back(arg);
  log->thread = std::this_thread::get_id();
}

void fail(void*, std::uint32_t arg) {
  if (arg == 7) throw std::runtime_error("task 7 failed");
}

}  // namespace

TEST_CASE("backend thread: tasks run in submission order on one other thread, wait_idle waits for all") {
  Log log;
  log.order.reserve(4096);
  ums::cli::BackendThread backend;
  for (std::uint32_t i = 0; i < 1000; ++i) backend.submit(&record, &log, i);
  backend.wait_idle();
  REQUIRE(log.order.size() == 1000);
  bool in_order = true;
  for (std::uint32_t i = 0; i < 1000; ++i) in_order = in_order && log.order[i] == i;
  CHECK(in_order);
  CHECK(log.thread != std::this_thread::get_id());
  CHECK(backend.tasks() == 1000);
  CHECK(backend.cpu_s() >= 0.0);
}

TEST_CASE("backend thread: a full ring makes the submitter wait, nothing is dropped") {
  Log log;
  log.order.reserve(4096);
  ums::cli::BackendThread backend;
  log.gate = false;  // the first task holds the thread: the ring fills behind it
  const std::uint32_t n = static_cast<std::uint32_t>(ums::capacity::kBackendTasks) + 50;
  std::thread opener([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    log.gate = true;
  });
  for (std::uint32_t i = 0; i < n; ++i) backend.submit(&record, &log, i);
  backend.wait_idle();
  opener.join();
  REQUIRE(log.order.size() == n);
  CHECK(log.order.back() == n - 1);
  CHECK(backend.full_waits() >= 1);
}

TEST_CASE("backend thread: a task's exception reaches the submitter once, later tasks still run") {
  Log log;
  log.order.reserve(64);
  ums::cli::BackendThread backend;
  log.gate = false;  // held until all ten are queued: submit() itself would rethrow a failure
  backend.submit(&record, &log, 1000);
  for (std::uint32_t i = 0; i < 10; ++i) backend.submit(&fail, nullptr, i);
  log.gate = true;
  CHECK_THROWS_WITH(backend.wait_idle(), "task 7 failed");
  log.order.clear();
  backend.submit(&record, &log, 42);
  CHECK_NOTHROW(backend.wait_idle());
  REQUIRE(log.order.size() == 1);
  CHECK(log.order[0] == 42);
}

TEST_CASE("backend thread: submitting and running allocate nothing on either thread") {
  if (!ums::alloc_counter_available()) return;  // sanitizer builds own malloc
  Log log;
  log.order.reserve(4096);
  ums::cli::BackendThread backend;
  backend.submit(&record, &log, 0);
  backend.wait_idle();
  const std::uint64_t worker_before = backend.allocations();
  ums::AllocScope scope;
  for (std::uint32_t i = 1; i < 2000; ++i) backend.submit(&record, &log, i);
  backend.wait_idle();
  CHECK(scope.allocations() == 0);
  CHECK(backend.allocations() == worker_before);
}
