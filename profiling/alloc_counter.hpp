#pragma once
// Heap allocation counter. Linked into tests and programs (target ums_alloc_counter), it replaces
// the malloc family and the global operator new/delete with counting versions, so a test can prove
// that a hot path allocates nothing:
//
//   ums::AllocScope scope;
//   frontend.process(frame);
//   REQUIRE(scope.allocations() == 0);
//
// Counts are per thread (a scope sees only its own thread's allocations) plus a process total.
// Under sanitizers, which own malloc, the hooks are compiled out and available() says false.

#include <cstdint>

namespace ums {

struct AllocCounts {
  std::uint64_t allocations = 0;    // malloc/calloc/realloc/aligned/new calls on this thread
  std::uint64_t bytes = 0;          // bytes requested by them
  std::uint64_t deallocations = 0;  // free/delete calls on this thread
};

// True when the counting hooks are linked in (and not replaced by a sanitizer's allocator).
bool alloc_counter_available();

// This thread's counts since it started.
AllocCounts thread_alloc_counts();

// Allocations of every thread since the process started.
std::uint64_t process_allocations();

// Counts this thread's allocations between construction and the query.
class AllocScope {
 public:
  AllocScope() : start_(thread_alloc_counts()) {}
  std::uint64_t allocations() const { return thread_alloc_counts().allocations - start_.allocations; }
  std::uint64_t bytes() const { return thread_alloc_counts().bytes - start_.bytes; }
  std::uint64_t deallocations() const {
    return thread_alloc_counts().deallocations - start_.deallocations;
  }

 private:
  AllocCounts start_;
};

}  // namespace ums
