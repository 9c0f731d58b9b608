#include "hal/d455/realtime.hpp"

#include <catch2/catch.hpp>

#include <pthread.h>
#include <sched.h>

#include <thread>

TEST_CASE("set_realtime_priority gives SCHED_FIFO or leaves the thread as it was", "[d455][realtime]") {
  std::thread t([] {
    int policy_before = -1;
    sched_param before{};
    REQUIRE(pthread_getschedparam(pthread_self(), &policy_before, &before) == 0);
    CHECK_FALSE(ums::d455::set_realtime_priority(0));    // out of range
    CHECK_FALSE(ums::d455::set_realtime_priority(100));
    const bool ok = ums::d455::set_realtime_priority(10);
    int policy = -1;
    sched_param now{};
    REQUIRE(pthread_getschedparam(pthread_self(), &policy, &now) == 0);
    if (ok) {
      CHECK(policy == SCHED_FIFO);
      CHECK(now.sched_priority == 10);
    } else {  // unprivileged: refused, unchanged
      CHECK(policy == policy_before);
      CHECK(now.sched_priority == before.sched_priority);
    }
  });
  t.join();
}
