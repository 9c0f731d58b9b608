#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hal/d455/sys.hpp"

namespace ums::d455 {

namespace {
template <typename F>
auto retry_eintr(F f) -> decltype(f()) {
  for (;;) {
    auto r = f();
    if (r < 0 && errno == EINTR) continue;
    return r < 0 ? static_cast<decltype(r)>(-errno) : r;
  }
}
}  // namespace

int LinuxSys::open(const char* path, int flags) {
  return retry_eintr([&] { return ::open(path, flags | O_CLOEXEC); });
}
int LinuxSys::close(int fd) { return ::close(fd) < 0 ? -errno : 0; }
int LinuxSys::ioctl(int fd, unsigned long request, void* arg) {
  return retry_eintr([&] { return ::ioctl(fd, request, arg); });
}
void* LinuxSys::mmap(std::size_t length, int prot, int flags, int fd, off_t offset) {
  void* p = ::mmap(nullptr, length, prot, flags, fd, offset);
  return p == MAP_FAILED ? nullptr : p;
}
int LinuxSys::munmap(void* addr, std::size_t length) { return ::munmap(addr, length) < 0 ? -errno : 0; }
int LinuxSys::poll(pollfd* fds, nfds_t nfds, int timeout_ms) {
  return retry_eintr([&] { return ::poll(fds, nfds, timeout_ms); });
}
ssize_t LinuxSys::read(int fd, void* buf, std::size_t count) {
  return retry_eintr([&] { return ::read(fd, buf, count); });
}

bool SysFs::exists(const std::string& path) const {
  std::error_code ec;
  return std::filesystem::exists(root_ + path, ec);
}

bool SysFs::read_text(const std::string& path, std::string* out) const {
  std::ifstream in(root_ + path);
  if (!in) return false;
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string s = ss.str();
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r' || s.back() == '\0')) {
    s.pop_back();
  }
  *out = s;
  return true;
}

bool SysFs::write_text(const std::string& path, const std::string& value) const {
  // sysfs needs one write() per attribute; std::ofstream would truncate-create, which is fine for
  // the temp-folder trees and equivalent on sysfs (O_TRUNC is ignored there).
  std::ofstream out(root_ + path, std::ios::out | std::ios::trunc);
  if (!out) return false;
  out << value;
  out.flush();
  return static_cast<bool>(out);
}

std::vector<std::string> SysFs::list(const std::string& dir) const {
  std::vector<std::string> names;
  std::error_code ec;
  std::filesystem::directory_iterator it(root_ + dir, ec);
  if (ec) return names;
  for (const auto& e : it) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string SysFs::resolve(const std::string& path) const {
  std::error_code ec;
  std::filesystem::path p = std::filesystem::canonical(root_ + path, ec);
  if (ec) return {};
  std::string s = p.string();
  if (!root_.empty()) {
    std::error_code ec2;
    std::string root = std::filesystem::canonical(root_, ec2).string();
    if (ec2 || s.compare(0, root.size(), root) != 0) return {};
    s = s.substr(root.size());
    if (s.empty()) s = "/";
  }
  return s;
}

int trailing_number(const std::string& name) {
  std::size_t end = name.size();
  std::size_t begin = end;
  while (begin > 0 && name[begin - 1] >= '0' && name[begin - 1] <= '9') --begin;
  if (begin == end) return -1;
  return std::atoi(name.c_str() + begin);
}

}  // namespace ums::d455
