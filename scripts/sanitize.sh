#!/usr/bin/env bash
# Builds the product and its tests with sanitizers (clang, -DUMS_SANITIZE=..., the allocation
# hooks off) and runs them under ctest. docs/robustness.md, "Sanitizers".
# Usage: scripts/sanitize.sh [asan|tsan] [ctest -R regex]   (default asan, every test)
#   asan: ASan + UBSan (build/asan), the whole host suite, including the mavlink_decode tests that
#         run the (sanitized) umsvins binary as a subprocess.
#   tsan: ThreadSanitizer (build/tsan), only the tests that run more than one thread (the regex
#         tsan_tests below) and only the executables they need.
# Exits non-zero when a test fails or any sanitizer report shows up in the tests' output.
# Environment: UMS_SAN_JOBS (build and ctest jobs, default nproc), UMS_SAN_NICE (nice level of
# the build and the tests, default 0), UMS_SAN_TARGETS (asan: the targets to build, space-separated,
# default all; a regex run needs only its test executables, plus umsvins for mavlink_decode).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
kind="${1:-asan}"
jobs="${UMS_SAN_JOBS:-$(nproc)}"
nice_level="${UMS_SAN_NICE:-0}"

# Every test that starts a thread: the live command and replay --two-core (test_cli), the back end's
# thread (test_backend_thread), test_loop_session (replay/live
# --loop), the D455 thread bridge, SPSC ring, recorder and real-time tests (test_d455), the loop
# worker, the allocation counter's per-thread test (test_profiling) and the renderers, which draw
# the two cameras on two threads (test_sim; the mavlink_decode tests run umsvins simulate and
# live-like replays too).
tsan_tests='^(test_cli|test_backend_thread|test_loop_session|test_loop_worker|test_d455|test_profiling|test_sim):|^mavlink_decode:'
tsan_targets=(test_cli test_backend_thread test_loop_session test_loop_worker test_d455 test_profiling test_sim umsvins)

sup="$root/tests/sanitizers"
case "$kind" in
  asan)
    sanitize="address,undefined"
    regex="${2:-}"
    read -r -a targets <<<"${UMS_SAN_TARGETS:-all}"
    ;;
  tsan)
    sanitize="thread"
    regex="${2:-$tsan_tests}"
    targets=("${tsan_targets[@]}")
    ;;
  *) echo "usage: scripts/sanitize.sh [asan|tsan] [ctest -R regex]" >&2; exit 64 ;;
esac

# clang and its sanitizer runtimes (the same packages as the fuzz build), the host packages and
# node-mavlink for the mavlink_decode tests.
"$root/scripts/deps.sh" fuzz

build="$root/build/$kind"
mkdir -p "$root/build"
launcher=()
if command -v ccache >/dev/null; then
  # ccache does not cache files built against a precompiled header: one or the other.
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DUMS_PCH=OFF)
fi
started=$(date +%s)
echo "== $kind: configure and build ($build, -fsanitize=$sanitize)"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DUMS_SANITIZE="$sanitize" \
  -DUMS_BUILD_BENCHMARKS=OFF -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ "${launcher[@]}" \
  >"$build.configure.log" 2>&1 || { cat "$build.configure.log"; exit 1; }
nice -n "$nice_level" cmake --build "$build" -j "$jobs" --target "${targets[@]}" >"$build.build.log" 2>&1 \
  || { tail -n 80 "$build.build.log"; echo "$kind: build failed (log: $build.build.log)"; exit 1; }
built=$(date +%s)
echo "$kind: built in $(( built - started )) s"

# halt_on_error / exitcode: the first report ends the process with a non-zero status, so the test
# fails, and a umsvins subprocess's report fails the Python test that checks its exit status.
# UBSan: -fno-sanitize-recover=undefined already makes every report fatal.
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:abort_on_error=0:exitcode=1:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=1"
export LSAN_OPTIONS="suppressions=$sup/lsan.supp:print_suppressions=0:exitcode=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$sup/ubsan.supp"
export TSAN_OPTIONS="halt_on_error=1:exitcode=66:second_deadlock_stack=1:print_suppressions=0:suppressions=$sup/tsan.supp"
export ASAN_SYMBOLIZER_PATH="${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer || true)}"
export TSAN_SYMBOLIZER_PATH="$ASAN_SYMBOLIZER_PATH"

echo "== $kind: ctest${regex:+ -R '$regex'}"
status=0
(cd "$build" && nice -n "$nice_level" ctest -j "$jobs" --output-on-failure ${regex:+-R "$regex"}) || status=1
# Belt and braces: a report from a process whose exit status nobody checks (none known) still fails.
log="$build/Testing/Temporary/LastTest.log"
reports=$(grep -cE "ERROR: (AddressSanitizer|LeakSanitizer)|runtime error:|WARNING: ThreadSanitizer" "$log" || true)
if [[ "$reports" -ne 0 ]]; then
  echo "$kind: $reports sanitizer report(s) in $log:"
  grep -nE "ERROR: (AddressSanitizer|LeakSanitizer)|runtime error:|WARNING: ThreadSanitizer|SUMMARY:" "$log" | head -n 20
  status=1
fi
echo "$kind: tests in $(( $(date +%s) - built )) s, build + tests $(( $(date +%s) - started )) s; reports $reports"
exit $status
