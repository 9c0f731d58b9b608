#include "profiling/progress.hpp"

#include <unistd.h>

#include <chrono>

namespace ums {
namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

Progress::Progress(const char* label, unsigned long total, std::FILE* out)
    : label_(label), total_(total), out_(out), tty_(isatty(fileno(out)) == 1) {}

void Progress::update(unsigned long done, const char* detail) {
  if (finished_) return;
  if (tty_) {
    const double t = now_s();
    if (t - last_draw_s_ < 0.1) return;  // redraw at most 10 times a second
    last_draw_s_ = t;
    if (total_ > 0) {
      std::fprintf(out_, "\r%s %lu/%lu (%3.0f%%) %s\033[K", label_, done, total_,
                   100.0 * static_cast<double>(done) / static_cast<double>(total_),
                   detail != nullptr ? detail : "");
    } else {
      std::fprintf(out_, "\r%s %lu %s\033[K", label_, done, detail != nullptr ? detail : "");
    }
    std::fflush(out_);
    return;
  }
  if (total_ == 0) return;
  const int decile = static_cast<int>(10 * done / total_);
  if (decile == last_decile_ || decile >= 10) return;
  last_decile_ = decile;
  std::fprintf(out_, "%s %lu/%lu (%d%%) %s\n", label_, done, total_, decile * 10,
               detail != nullptr ? detail : "");
  std::fflush(out_);
}

void Progress::finish(const char* detail) {
  if (finished_) return;
  finished_ = true;
  if (tty_) std::fprintf(out_, "\r\033[K");
  std::fprintf(out_, "%s done %s\n", label_, detail != nullptr ? detail : "");
  std::fflush(out_);
}

}  // namespace ums
