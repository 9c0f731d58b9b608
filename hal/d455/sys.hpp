#pragma once
// The thin system-call seam of the D455 HAL. The V4L2 and IIO state machines call the kernel only
// through Sys (character devices) and SysFs (sysfs attributes and folders), so tests drive the real
// state machines with a fake kernel and a sysfs tree built in a temporary folder.
//
// Sys returns -errno on failure (never sets errno, never throws): the hot path stays exception-free
// and a fake can inject ENODEV, EAGAIN or EINVAL precisely.

#include <poll.h>
#include <sys/types.h>

#include <cstddef>
#include <string>
#include <vector>

namespace ums::d455 {

class Sys {
 public:
  virtual ~Sys() = default;
  // Returns a file descriptor >= 0 or -errno.
  virtual int open(const char* path, int flags) = 0;
  virtual int close(int fd) = 0;
  // Returns >= 0 on success or -errno.
  virtual int ioctl(int fd, unsigned long request, void* arg) = 0;
  // Returns the mapping or nullptr (MAP_FAILED is never returned through the seam).
  virtual void* mmap(std::size_t length, int prot, int flags, int fd, off_t offset) = 0;
  virtual int munmap(void* addr, std::size_t length) = 0;
  // Returns the number of ready descriptors, 0 on timeout, or -errno.
  virtual int poll(pollfd* fds, nfds_t nfds, int timeout_ms) = 0;
  // Returns bytes read (0 = end of file) or -errno.
  virtual ssize_t read(int fd, void* buf, std::size_t count) = 0;
};

// The real kernel (sys_linux.cpp). Retries EINTR.
class LinuxSys final : public Sys {
 public:
  int open(const char* path, int flags) override;
  int close(int fd) override;
  int ioctl(int fd, unsigned long request, void* arg) override;
  void* mmap(std::size_t length, int prot, int flags, int fd, off_t offset) override;
  int munmap(void* addr, std::size_t length) override;
  int poll(pollfd* fds, nfds_t nfds, int timeout_ms) override;
  ssize_t read(int fd, void* buf, std::size_t count) override;
};

// A view of sysfs and /dev rooted at a configurable folder ("" = the real root), used at start-up
// only (it allocates strings). Paths given to it are absolute-looking ("/sys/class/...") and are
// prefixed with the root; resolve() returns canonical paths with the root stripped again.
class SysFs {
 public:
  explicit SysFs(std::string root = "") : root_(std::move(root)) {}

  const std::string& root() const { return root_; }
  // The path to hand to Sys::open for a rooted path ("/dev/video2" -> "<root>/dev/video2").
  std::string host_path(const std::string& path) const { return root_ + path; }

  bool exists(const std::string& path) const;
  // Reads a small attribute, trailing newline and spaces removed. False if unreadable.
  bool read_text(const std::string& path, std::string* out) const;
  // Writes an attribute (no newline appended). False if the write failed.
  bool write_text(const std::string& path, const std::string& value) const;
  // Entry names in a folder (not "." or ".."), sorted; empty if the folder does not exist.
  std::vector<std::string> list(const std::string& dir) const;
  // Canonical form of a rooted path with symlinks followed, root prefix stripped; "" on failure.
  std::string resolve(const std::string& path) const;

 private:
  std::string root_;
};

// The number at the end of a name ("video12" -> 12, "iio:device3" -> 3); -1 if none.
int trailing_number(const std::string& name);

}  // namespace ums::d455
