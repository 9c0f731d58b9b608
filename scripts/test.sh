#!/usr/bin/env bash
# Builds and runs the tests: on the host, then cross-built for aarch64 under qemu-user (plus the
# host-vs-aarch64 trajectory check, scripts/determinism.sh), then cross-built for 32-bit armhf
# under qemu-user (the solver alone when OpenCV for armhf cannot be installed). host and all also
# run the fuzz smoke: every libFuzzer harness over its committed seeds (scripts/fuzz.sh all seeds),
# so the harnesses keep building and the seeds keep passing.
# `all` (what CI runs, 40 min on 2 cores) leaves the [slow] tests out of the two qemu suites:
# whole-sequence replays and rendered flights, over 10 s each under qemu (cmake/UmsTesting.cmake);
# the host runs every one of them, and the determinism check replays a flight on aarch64 that must
# match the host's to the byte. `full` is `all` with every test under qemu too (the release check,
# about an hour); `aarch64` and `armhf` alone also run every test of their suite.
# Usage: scripts/test.sh [host|aarch64|armhf|all|full]   (default all)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
want="${1:-all}"
case "$want" in host|aarch64|armhf|all|full) ;; *) echo "usage: scripts/test.sh [host|aarch64|armhf|all|full]" >&2; exit 64 ;; esac
emulated_spec=""
[[ "$want" == "all" ]] && emulated_spec="~[.]~[slow]"  # not hidden, not slow
[[ "$want" == "full" ]] && want=all

"$root/scripts/deps.sh" "$want"

jobs="$(nproc)"
status=0

run_suite() {  # name build_dir [cmake args...]
  local name="$1" dir="$2"; shift 2
  echo "== $name: configure and build ($dir)"
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >"$dir.configure.log" 2>&1 \
    || { cat "$dir.configure.log"; return 1; }
  cmake --build "$dir" -j "$jobs" >"$dir.build.log" 2>&1 \
    || { tail -n 80 "$dir.build.log"; echo "$name: build failed (log: $dir.build.log)"; return 1; }
  echo "== $name: ctest"
  (cd "$dir" && ctest -j "$jobs" --output-on-failure --timeout 900)
}

mkdir -p "$root/build"
if [[ "$want" == "host" || "$want" == "all" ]]; then
  run_suite host "$root/build/host" -DUMS_TEST_SPEC= || status=1
  # A host build for x86-64-v3 (cmake/UmsHostIsa.cmake) runs the AVX2 kernels; their SSE2 siblings,
  # what a baseline build (-DUMS_HOST_ISA=baseline) runs, get the front-end and solver tests here.
  if grep -q "Host instruction set: x86-64-v3" "$root/build/host.configure.log" 2>/dev/null; then
    echo "== host-sse2: the baseline x86-64 build's front-end and solver tests (the SSE2 kernels)"
    sse2="$root/build/host-sse2"
    if cmake -S "$root" -B "$sse2" -G Ninja -DCMAKE_BUILD_TYPE=Release -DUMS_HOST_ISA=baseline \
         -DUMS_BUILD_BENCHMARKS=OFF -DUMS_TEST_SPEC= >"$sse2.configure.log" 2>&1 &&
       cmake --build "$sse2" -j "$jobs" --target test_frontend test_solver >"$sse2.build.log" 2>&1; then
      "$sse2/tests/core/frontend/test_frontend" >"$sse2.test.log" 2>&1 && "$sse2/tests/solver/test_solver" >>"$sse2.test.log" 2>&1 \
        && grep -E "^All tests passed" "$sse2.test.log" \
        || { tail -n 60 "$sse2.test.log"; echo "host-sse2: tests failed (log: $sse2.test.log)"; status=1; }
    else
      tail -n 60 "$sse2.build.log" 2>/dev/null; echo "host-sse2: configure or build failed (logs: $sse2.*.log)"; status=1
    fi
  fi
  echo "== fuzz smoke: each harness over its seeds (scripts/fuzz.sh all ${UMS_FUZZ_SMOKE_S:-seeds})"
  "$root/scripts/fuzz.sh" all "${UMS_FUZZ_SMOKE_S:-seeds}" || status=1
fi
if [[ "$want" == "aarch64" || "$want" == "all" ]]; then
  run_suite aarch64 "$root/build/aarch64" \
    -DCMAKE_TOOLCHAIN_FILE="$root/toolchains/aarch64-linux-gnu.cmake" -DUMS_BUILD_BENCHMARKS=OFF \
    "-DUMS_TEST_SPEC=$emulated_spec" || status=1
fi
if [[ "$want" == "all" && -x "$root/build/host/board/host/umsvins" && -x "$root/build/aarch64/board/host/umsvins" ]]; then
  echo "== determinism: host vs aarch64 (qemu) on a 6 s flight"
  "$root/scripts/determinism.sh" "$root/build/host" "$root/build/aarch64" || status=1
fi
if [[ "$want" == "armhf" || "$want" == "all" ]]; then
  if dpkg-query -W -f='${Status}' libopencv-imgproc-dev:armhf 2>/dev/null | grep -q "install ok installed"; then
    run_suite armhf "$root/build/armhf" \
      -DCMAKE_TOOLCHAIN_FILE="$root/toolchains/arm-linux-gnueabihf.cmake" -DUMS_BUILD_BENCHMARKS=OFF \
      "-DUMS_TEST_SPEC=$emulated_spec" || status=1
  else
    echo "== armhf: no OpenCV for armhf (scripts/deps.sh said why): the solver only"
    run_suite armhf-solver "$root/build/armhf-solver" \
      -DCMAKE_TOOLCHAIN_FILE="$root/toolchains/arm-linux-gnueabihf.cmake" -DUMS_SOLVER_ONLY=ON \
      "-DUMS_TEST_SPEC=$emulated_spec" || status=1
  fi
fi
exit $status
