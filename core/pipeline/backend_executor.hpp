#pragma once
// Where VioPipeline runs its back end: the estimator and everything after it (poses, the frame
// observer, keyframe images and keyframes). Without an executor it runs inline, on the caller's
// thread; a board with a second core supplies one that runs the tasks on a thread of its own
// (board/host/backend_thread.hpp), so that the front end of frame k+1 runs while the back end of
// frame k does (the paper's two threads). Core owns no thread: this is the seam.

#include <cstdint>

namespace ums {

class BackendExecutor {
 public:
  using Task = void (*)(void* context, std::uint32_t arg);

  virtual ~BackendExecutor() = default;
  // Runs task(context, arg) after every task submitted before it, one at a time. Never holds more
  // than capacity::kBackendTasks tasks waiting (blocks instead, or runs some): VioPipeline reuses
  // its IMU task entries on that bound. Rethrows (once) an exception a task threw. Allocates nothing.
  virtual void submit(Task task, void* context, std::uint32_t arg) = 0;
  // Returns once every task submitted so far has run; rethrows (once) an exception a task threw.
  virtual void wait_idle() = 0;
};

}  // namespace ums
