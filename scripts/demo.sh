#!/usr/bin/env bash
# Set-up + the main job: installs what is missing, builds (Release), and runs umsvins on the
# default sequence, then prints the result.
# Usage: scripts/demo.sh [dataset]   (default: ../shared/data/euroc/V1_01_easy_micro)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dataset="${1:-$root/../shared/data/euroc/V1_01_easy_micro}"
build="$root/build/host"
out="$root/out/demo"

"$root/scripts/deps.sh" host
mkdir -p "$root/build"

echo "== build ($build)"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >"$build.configure.log" 2>&1 \
  || { cat "$build.configure.log"; exit 1; }
cmake --build "$build" -j "$(nproc)" --target umsvins >"$build.build.log" 2>&1 \
  || { tail -n 80 "$build.build.log"; exit 1; }

if [[ ! -d "$dataset/mav0" ]]; then
  echo "demo: no dataset at $dataset (expected a folder holding mav0/)" >&2
  exit 1
fi

echo "== umsvins replay $dataset --out $out"
"$build/board/host/umsvins" replay "$dataset" --out "$out"
echo "== $out/stats.json"
cat "$out/stats.json"
