#include "profiling/alloc_counter.hpp"

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <new>

// glibc exports its allocator under these names; forwarding to them lets us interpose malloc and
// friends for the whole process (shared libraries included: OpenCV's and Eigen's buffers are
// counted too), without dlsym and its allocation during start-up.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* ptr, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void __libc_free(void* ptr);
}

namespace {

// Trivial thread-locals: initial-exec TLS in the executable, safe to touch inside malloc.
thread_local std::uint64_t t_allocations = 0;
thread_local std::uint64_t t_bytes = 0;
thread_local std::uint64_t t_deallocations = 0;
std::atomic<std::uint64_t> g_allocations{0};

#if UMS_ALLOC_HOOKS
inline void count_alloc(std::size_t size) {
  ++t_allocations;
  t_bytes += size;
  g_allocations.fetch_add(1, std::memory_order_relaxed);
}

inline void count_free(const void* ptr) {
  if (ptr != nullptr) ++t_deallocations;
}
#endif

}  // namespace

namespace ums {

#if UMS_ALLOC_HOOKS
bool alloc_counter_available() { return true; }
#else
bool alloc_counter_available() { return false; }
#endif

AllocCounts thread_alloc_counts() { return AllocCounts{t_allocations, t_bytes, t_deallocations}; }

std::uint64_t process_allocations() { return g_allocations.load(std::memory_order_relaxed); }

}  // namespace ums

#if UMS_ALLOC_HOOKS

extern "C" {

void* malloc(std::size_t size) {
  count_alloc(size);
  return __libc_malloc(size);
}

void* calloc(std::size_t n, std::size_t size) {
  count_alloc(n * size);
  return __libc_calloc(n, size);
}

void* realloc(void* ptr, std::size_t size) {
  count_alloc(size);
  return __libc_realloc(ptr, size);
}

void free(void* ptr) {
  count_free(ptr);
  __libc_free(ptr);
}

void* memalign(std::size_t alignment, std::size_t size) {
  count_alloc(size);
  return __libc_memalign(alignment, size);
}

void* aligned_alloc(std::size_t alignment, std::size_t size) {
  count_alloc(size);
  return __libc_memalign(alignment, size);
}

int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  count_alloc(size);
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}

}  // extern "C"

// operator new goes through our malloc: one count per allocation, and new_handler semantics kept.
void* operator new(std::size_t size) {
  for (;;) {
    if (void* p = malloc(size == 0 ? 1 : size)) return p;
    std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}
void* operator new[](std::size_t size) { return operator new(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return malloc(size == 0 ? 1 : size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return malloc(size == 0 ? 1 : size); }
void* operator new(std::size_t size, std::align_val_t al) {
  void* p = nullptr;
  if (posix_memalign(&p, static_cast<std::size_t>(al), size == 0 ? 1 : size) != 0) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t size, std::align_val_t al) { return operator new(size, al); }
void operator delete(void* p) noexcept { free(p); }
void operator delete[](void* p) noexcept { free(p); }
void operator delete(void* p, std::size_t) noexcept { free(p); }
void operator delete[](void* p, std::size_t) noexcept { free(p); }
void operator delete(void* p, std::align_val_t) noexcept { free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { free(p); }

#endif  // UMS_ALLOC_HOOKS
