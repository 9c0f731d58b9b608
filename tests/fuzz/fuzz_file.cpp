#include "tests/fuzz/fuzz_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

namespace ums::fuzz {

namespace {

std::string make_scratch_dir() {
  // /dev/shm is tmpfs on Linux; elsewhere fall back to the temporary folder.
  const char* base = ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
  std::string dir = std::string(base) + "/ums_fuzz." + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  return dir;
}

struct ScratchDir {
  std::string path = make_scratch_dir();
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

}  // namespace

const std::string& scratch_dir() {
  static const ScratchDir dir;
  return dir.path;
}

std::string write_file(const std::string& name, const std::uint8_t* data, std::size_t size) {
  std::string path = scratch_dir() + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) {  // first write into a sub-folder
    std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    f = std::fopen(path.c_str(), "wb");
  }
  if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
  return path;
}

std::string write_file(const std::string& name, const std::string& text) {
  return write_file(name, reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

std::string copy_file(const std::string& source, const std::string& name) {
  std::FILE* in = std::fopen(source.c_str(), "rb");
  if (in == nullptr) {
    std::fprintf(stderr, "fuzz: cannot read %s\n", source.c_str());
    std::abort();
  }
  std::string text;
  char chunk[4096];
  for (std::size_t n; (n = std::fread(chunk, 1, sizeof(chunk), in)) > 0;) text.append(chunk, n);
  std::fclose(in);
  return write_file(name, text);
}

std::size_t split_parts(const std::uint8_t* data, std::size_t size, std::string* parts, std::size_t max_parts) {
  static constexpr char kSeparator[] = "\n--\n";
  const std::string all(reinterpret_cast<const char*>(data), size);
  std::size_t n = 0, at = 0;
  while (n + 1 < max_parts) {
    const std::size_t hit = all.find(kSeparator, at);
    if (hit == std::string::npos) break;
    parts[n++] = all.substr(at, hit + 1 - at);  // keeps the line's '\n'
    at = hit + sizeof(kSeparator) - 1;
  }
  parts[n++] = all.substr(at);
  return n;
}

}  // namespace ums::fuzz
