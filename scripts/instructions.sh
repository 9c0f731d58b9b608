#!/usr/bin/env bash
# Instructions per frame (valgrind callgrind): the machine-independent cost figure to compare
# commits and to estimate ARM time. Fixed synthetic sequence: V1_01's profile from 20 s, 3 s,
# seed 1 (61 stereo pairs). Prints instructions per frame for the front end, the back end (the
# estimator: IMU intake, window, solves, marginalization) and the whole pipeline (both + bookkeeping).
# --deterministic: the solver's second round is bounded by iterations, not by the wall clock that
# valgrind slows 20-50x (the count would otherwise depend on the machine). The same figures for
# the aarch64 build, counted under qemu: scripts/instructions_aarch64.sh.
# Usage: scripts/instructions.sh [build_dir] [dataset] [config]   (default build/host, built by
#   scripts/demo.sh, and the sequence above; a dataset is a EuRoC folder holding mav0/; a config
#   is a VINS-style YAML passed to `umsvins replay --config`, e.g. to price a knob)
# Also prints the whole process (start-up, reading and PNG decoding included) per frame.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build/host}"
dataset="${2:-}"
config=()
if [[ -n "${3:-}" ]]; then
  [[ -f "$3" ]] || { echo "instructions: config $3: no such file" >&2; exit 64; }
  config=(--config "$3")
fi
umsvins="$build/board/host/umsvins"
[[ -x "$umsvins" ]] || { echo "instructions: build first (scripts/demo.sh builds $umsvins)" >&2; exit 1; }
command -v valgrind >/dev/null || { echo "instructions: needs valgrind (apt-get install valgrind)" >&2; exit 1; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
if [[ -z "$dataset" ]]; then
  dataset="$work/ds"
  "$umsvins" simulate --trajectory "$root/../shared/data/euroc/groundtruth/V101_GT.txt" --start 20 \
    --duration 3 --seed 1 --out "$dataset" --quiet >/dev/null
fi
[[ -d "$dataset/mav0" ]] || { echo "instructions: $dataset: not a EuRoC dataset (no mav0/)" >&2; exit 64; }

count() {  # toggle-collect pattern (empty: the whole process) -> instructions inside it
  local toggle=()
  [[ -n "$1" ]] && toggle=(--toggle-collect="$1")
  valgrind --tool=callgrind --callgrind-out-file="$work/cg.out" "${toggle[@]}" \
    "$umsvins" replay "$dataset" "${config[@]}" --out "$work/out" --quiet --deterministic >/dev/null 2>"$work/vg.log"
  grep -E '^==[0-9]+== Collected' "$work/vg.log" | awk '{print $4}'
}

frontend=$(count 'ums::Frontend::process*')
backend_frames=$(count 'ums::Estimator::add_frame*')
backend_imu=$(count 'ums::Estimator::add_imu*')
total=$(count 'ums::cli::ReplayPipeline::on_*')
process=$(count '')
frames=$(grep -o '"frames": [0-9]*' "$work/out/stats.json" | awk '{print $2}')
printf 'frames %d\nfrontend %.1f M instructions/frame\nbackend %.1f M instructions/frame\ntotal %.1f M instructions/frame\n' \
  "$frames" "$(echo "$frontend / $frames / 1000000" | bc -l)" \
  "$(echo "($backend_frames + $backend_imu) / $frames / 1000000" | bc -l)" "$(echo "$total / $frames / 1000000" | bc -l)"
printf 'process %.1f M instructions/frame\n' "$(echo "$process / $frames / 1000000" | bc -l)"
