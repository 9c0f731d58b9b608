#!/usr/bin/env bash
# Set-up + the main job: installs what is missing, builds (Release), then runs the estimator on
# the built-in simulated sequence (a 20 s flight of the EuRoC V1_01 trajectory, rendered once into
# out/demo/) and prints its ATE, then on the real EuRoC micro sequence (the vehicle at rest).
# Usage: scripts/demo.sh [dataset]   (a folder holding mav0/: run on it instead)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dataset="${1:-}"
build="$root/build/host"
out="$root/out/demo"
shared="$root/../shared"

"$root/scripts/deps.sh" host
mkdir -p "$root/build"

echo "== build ($build)"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >"$build.configure.log" 2>&1 \
  || { cat "$build.configure.log"; exit 1; }
cmake --build "$build" -j "$(nproc)" --target umsvins >"$build.build.log" 2>&1 \
  || { tail -n 80 "$build.build.log"; exit 1; }

umsvins="$build/board/host/umsvins"
summary() {  # the lines of a replay's stats.json a user looks at first
  grep -E '"(frames|duration_s|processing_s|success|time_s|case|ate_rmse_m|rotation_rmse_deg|heap_allocs_steady_state|saturated_samples)"' "$1/stats.json" | sed 's/^ */  /'
}

if [[ -n "$dataset" ]]; then
  [[ -d "$dataset/mav0" ]] || { echo "demo: no dataset at $dataset (expected a folder holding mav0/)" >&2; exit 1; }
  echo "== umsvins replay $dataset --out $out/replay"
  "$umsvins" replay "$dataset" --out "$out/replay"
  summary "$out/replay"
  exit 0
fi

sim="$out/sim_V101_20s"
if [[ ! -f "$sim/mav0/imu0/data.csv" ]]; then
  echo "== umsvins simulate (V1_01 trajectory, 20 s, nominal) --out $sim"
  "$umsvins" simulate --trajectory "$shared/data/euroc/groundtruth/V101_GT.txt" --scenario nominal \
    --seed 1 --duration 20 --out "$sim"
fi
echo "== umsvins replay $sim --out $out/sim"
"$umsvins" replay "$sim" --out "$out/sim"
summary "$out/sim"

micro="$shared/data/euroc/V1_01_easy_micro"
echo "== umsvins replay $micro --out $out/micro (real images, vehicle at rest)"
"$umsvins" replay "$micro" --out "$out/micro"
summary "$out/micro"
