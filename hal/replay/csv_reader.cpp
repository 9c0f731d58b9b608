#include "hal/replay/csv_reader.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace ums::hal {

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

char* trim(char* begin, char* end) {
  while (begin < end && is_blank(*begin)) ++begin;
  while (end > begin && is_blank(end[-1])) --end;
  *end = '\0';
  return begin;
}

}  // namespace

CsvReader::CsvReader() : buffer_(new char[kBufferBytes + 1]) {}

CsvReader::~CsvReader() { close(); }

void CsvReader::open(const std::string& path) {
  close();
  std::snprintf(path_, sizeof(path_), "%s", path.c_str());
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw std::runtime_error(path + ": cannot open (" + std::strerror(errno) + ")");
  begin_ = end_ = 0;
  eof_ = false;
  at_start_ = true;
  line_ = 0;
  field_count_ = 0;
  error_[0] = '\0';
}

void CsvReader::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

CsvReader::Result CsvReader::fail(const char* format, ...) {
  int n = std::snprintf(error_, sizeof(error_), "%s:%ld: ", path_, line_);
  if (n < 0) n = 0;
  if (static_cast<std::size_t>(n) < sizeof(error_)) {
    va_list args;
    va_start(args, format);
    std::vsnprintf(error_ + n, sizeof(error_) - static_cast<std::size_t>(n), format, args);
    va_end(args);
  }
  return Result::kError;
}

bool CsvReader::fill() {
  if (eof_) return false;
  if (begin_ > 0) {  // keep the partial line at the front
    std::memmove(buffer_.get(), buffer_.get() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (end_ == kBufferBytes) return false;  // a line longer than the buffer
  ssize_t n;
  do {
    n = ::read(fd_, buffer_.get() + end_, kBufferBytes - end_);
  } while (n < 0 && errno == EINTR);
  if (n <= 0) {
    eof_ = true;
    return false;
  }
  end_ += static_cast<std::size_t>(n);
  return true;
}

CsvReader::Result CsvReader::next() {
  if (fd_ < 0) return fail("file is not open");
  for (;;) {
    // Find the end of the next line, reading more when the buffer holds only part of it.
    char* base = buffer_.get();
    void* newline = std::memchr(base + begin_, '\n', end_ - begin_);
    while (newline == nullptr) {
      const std::size_t had = end_ - begin_;
      if (!fill()) {
        if (!eof_) {
          ++line_;
          return fail("line longer than %zu bytes", kBufferBytes);
        }
        break;
      }
      base = buffer_.get();
      newline = std::memchr(base + begin_ + had, '\n', end_ - begin_ - had);
    }
    char* line_begin = base + begin_;
    char* line_end;
    if (newline != nullptr) {
      line_end = static_cast<char*>(newline);
      begin_ = static_cast<std::size_t>(line_end - base) + 1;
    } else {
      if (begin_ == end_) return Result::kEnd;  // clean end of file
      line_end = base + end_;                   // last line without '\n' (buffer has +1 byte)
      begin_ = end_;
    }
    ++line_;
    if (at_start_) {
      at_start_ = false;
      if (line_end - line_begin >= 3 && std::memcmp(line_begin, "\xEF\xBB\xBF", 3) == 0) line_begin += 3;
    }
    char* text = trim(line_begin, line_end);
    if (*text == '\0' || *text == '#') continue;

    field_count_ = 0;
    char* start = text;
    for (char* p = text;; ++p) {
      if (*p == ',' || *p == '\0') {
        const bool last = *p == '\0';
        if (field_count_ == kMaxFields) return fail("more than %zu columns", kMaxFields);
        fields_[field_count_++] = trim(start, p);
        if (last) break;
        start = p + 1;
      }
    }
    return Result::kRow;
  }
}

bool CsvReader::field_int64(std::size_t i, std::int64_t* value) const {
  const char* s = fields_[i];
  const char* end = s + std::strlen(s);
  if (s != end && *s == '+') ++s;
  const auto r = std::from_chars(s, end, *value);
  return r.ec == std::errc() && r.ptr == end && s != end;
}

bool CsvReader::field_double(std::size_t i, double* value) const {
  const char* s = fields_[i];
  const char* end = s + std::strlen(s);
  if (s != end && *s == '+') ++s;
  const auto r = std::from_chars(s, end, *value);
  return r.ec == std::errc() && r.ptr == end && s != end && std::isfinite(*value);
}

}  // namespace ums::hal
