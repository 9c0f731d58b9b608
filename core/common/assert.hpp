#pragma once
// One assert for programming errors (broken invariants, not bad input). Policy chosen at build:
// UMS_ASSERT_POLICY_ABORT (default) prints the place and aborts; UMS_ASSERT_POLICY_NONE compiles
// the checks out for release builds that must not pay for them.

#include <cstdio>
#include <cstdlib>

#if defined(UMS_ASSERT_POLICY_NONE)
#define UMS_ASSERT(cond) ((void)0)
#else
#define UMS_ASSERT(cond)                                                                   \
  ((cond) ? (void)0                                                                        \
          : (std::fprintf(stderr, "%s:%d: assertion failed: %s\n", __FILE__, __LINE__, #cond), \
             std::abort()))
#endif
