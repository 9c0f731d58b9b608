#pragma once
// Real-time scheduling for the live app's device threads (IMU first: its FIFO is small), when the
// process may have it (root, CAP_SYS_NICE or an RLIMIT_RTPRIO grant, e.g. limits.conf rtprio).

namespace ums::d455 {

// SCHED_FIFO at `priority` (1..99) for the calling thread. False, with the thread unchanged, when
// the system refuses; the caller carries on at normal priority and says so.
bool set_realtime_priority(int priority);

}  // namespace ums::d455
