#pragma once
// Progress on long runs: redrawn in place on a terminal, plain lines (every 10%) otherwise, so
// logs of CI and of a board's serial console stay readable.

#include <cstdio>

namespace ums {

class Progress {
 public:
  // total = 0: unknown total (counts only).
  Progress(const char* label, unsigned long total, std::FILE* out = stderr);
  void update(unsigned long done, const char* detail = nullptr);
  void finish(const char* detail = nullptr);

 private:
  const char* label_;
  unsigned long total_;
  std::FILE* out_;
  bool tty_;
  int last_decile_ = -1;
  double last_draw_s_ = -1.0;
  bool finished_ = false;
};

}  // namespace ums
