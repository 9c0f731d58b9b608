#include "hal/d455/realtime.hpp"

#include <pthread.h>
#include <sched.h>

namespace ums::d455 {

bool set_realtime_priority(int priority) {
  if (priority < 1 || priority > 99) return false;
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
}

}  // namespace ums::d455
