#!/usr/bin/env bash
# Instructions per frame (valgrind callgrind): the machine-independent cost figure to compare
# commits and to estimate ARM time. Fixed synthetic sequence: V1_01's profile from 20 s, 3 s,
# seed 1 (61 stereo pairs). Prints instructions per frame for the front end, the back end (the
# estimator: IMU intake, window, solves, marginalization) and the whole pipeline (both + bookkeeping).
# Usage: scripts/instructions.sh [build_dir]   (default build/host, built by scripts/demo.sh)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build/host}"
umsvins="$build/board/host/umsvins"
[[ -x "$umsvins" ]] || { echo "instructions: build first (scripts/demo.sh builds $umsvins)" >&2; exit 1; }
command -v valgrind >/dev/null || { echo "instructions: needs valgrind (apt-get install valgrind)" >&2; exit 1; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$umsvins" simulate --trajectory "$root/../shared/data/euroc/groundtruth/V101_GT.txt" --start 20 \
  --duration 3 --seed 1 --out "$work/ds" --quiet >/dev/null

count() {  # toggle-collect pattern -> total instructions inside it
  valgrind --tool=callgrind --callgrind-out-file="$work/cg.out" --toggle-collect="$1" \
    "$umsvins" replay "$work/ds" --out "$work/out" --quiet >/dev/null 2>"$work/vg.log"
  grep -E '^==[0-9]+== Collected' "$work/vg.log" | awk '{print $4}'
}

frontend=$(count 'ums::Frontend::process*')
backend_frames=$(count 'ums::Estimator::add_frame*')
backend_imu=$(count 'ums::Estimator::add_imu*')
total=$(count 'ums::cli::ReplayPipeline::on_*')
frames=$(grep -o '"frames": [0-9]*' "$work/out/stats.json" | awk '{print $2}')
printf 'frames %d\nfrontend %.1f M instructions/frame\nbackend %.1f M instructions/frame\ntotal %.1f M instructions/frame\n' \
  "$frames" "$(echo "$frontend / $frames / 1000000" | bc -l)" \
  "$(echo "($backend_frames + $backend_imu) / $frames / 1000000" | bc -l)" "$(echo "$total / $frames / 1000000" | bc -l)"
