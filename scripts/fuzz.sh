#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz (a separate clang build, build/fuzz, with
# ASan+UBSan) and runs each for the given seconds from its committed seed corpus.
# Usage: scripts/fuzz.sh [target|all] [seconds|seeds]   (defaults: all 60)
#   seeds: each committed seed once, no mutation (the CI smoke: the harnesses build and the seeds
#   pass, deterministically; the open OpenCV YAML hang, docs/robustness.md, keeps mutation out).
# Prints per target the executions, new inputs kept and the outcome; exits non-zero when any
# target crashed, timed out (> 1 s per input), ran out of memory or reported a sanitizer error.
# Reproducer inputs go to build/fuzz-artifacts/<target>/, inputs found that add coverage to
# build/fuzz-corpus/<target>/ (reused by the next run); nothing is written into the sources.
# Environment: UMS_FUZZ_JOBS (build jobs, default nproc), UMS_FUZZ_NICE (nice level of the build
# and the runs, default 0).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
want="${1:-all}"
seconds="${2:-60}"
jobs="${UMS_FUZZ_JOBS:-$(nproc)}"
nice_level="${UMS_FUZZ_NICE:-0}"
[[ "$seconds" == seeds || ( "$seconds" =~ ^[0-9]+$ && "$seconds" -ge 1 ) ]] \
  || { echo "usage: scripts/fuzz.sh [target|all] [seconds >= 1 | seeds]" >&2; exit 64; }

mapfile -t all_targets < <(sed -n 's/^ums_add_fuzzer(\([a-z0-9_]*\))/\1/p' "$root/tests/fuzz/CMakeLists.txt")
if [[ "$want" == "all" ]]; then
  targets=("${all_targets[@]}")
elif printf '%s\n' "${all_targets[@]}" | grep -qx "$want"; then
  targets=("$want")
else
  echo "fuzz: unknown target '$want'; targets: all ${all_targets[*]}" >&2
  exit 64
fi

"$root/scripts/deps.sh" fuzz

build="$root/build/fuzz"
mkdir -p "$root/build"
started=$(date +%s)
echo "== fuzz: configure and build ($build)"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DUMS_FUZZ=ON \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ >"$build.configure.log" 2>&1 \
  || { cat "$build.configure.log"; exit 1; }
build_targets=()
for t in "${targets[@]}"; do build_targets+=("${t}_fuzz"); done
nice -n "$nice_level" cmake --build "$build" -j "$jobs" --target "${build_targets[@]}" >"$build.build.log" 2>&1 \
  || { tail -n 80 "$build.build.log"; echo "fuzz: build failed (log: $build.build.log)"; exit 1; }
echo "fuzz: built in $(( $(date +%s) - started )) s"

status=0
printf '%-22s %12s %8s %8s  %s\n' target executions exec/s corpus result
for t in "${targets[@]}"; do
  corpus="$root/build/fuzz-corpus/$t"
  artifacts="$root/build/fuzz-artifacts/$t"
  log="$root/build/fuzz-logs/$t.log"
  mkdir -p "$corpus" "$artifacts" "$(dirname "$log")"
  rc=0
  # The working corpus first: libFuzzer writes new inputs there; the seeds are only read.
  if [[ "$seconds" == seeds ]]; then
    run_args=(-runs=0 "$root/tests/fuzz/corpus/$t")
  else
    run_args=(-max_total_time="$seconds" "$corpus" "$root/tests/fuzz/corpus/$t")
  fi
  nice -n "$nice_level" "$build/tests/fuzz/${t}_fuzz" -timeout=1 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$artifacts/" "${run_args[@]}" >"$log" 2>&1 || rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  kept=$(find "$corpus" -type f | wc -l)
  if [[ $rc -eq 0 ]] && ! grep -qE "ERROR: (AddressSanitizer|UndefinedBehaviorSanitizer|LeakSanitizer|libFuzzer)|runtime error:" "$log"; then
    result=ok
  else
    result="FAILED (exit $rc; log $log; reproducer in $artifacts/)"
    status=1
  fi
  printf '%-22s %12s %8s %8s  %s\n' "$t" "${execs:-?}" "${rate:-?}" "$kept" "$result"
  if [[ "$result" != ok ]]; then grep -m 3 -E "ERROR:|runtime error:|SUMMARY:" "$log" || true; fi
done
echo "fuzz: done in $(( $(date +%s) - started )) s"
exit $status
