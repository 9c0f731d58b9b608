#!/usr/bin/env bash
# Release builds of umsvins for ARM boards, stripped, one per CPU target, with their sizes.
# Usage: scripts/build-arm.sh [board...]   boards: rpi4 (Cortex-A72), rpi5 (Cortex-A76, also
# RK3588's big cores), orin (Cortex-A78AE). Default: all. Output: out/arm/<board>/umsvins.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/deps.sh" aarch64

declare -A mcpu=([rpi4]=cortex-a72 [rpi5]=cortex-a76 [orin]=cortex-a78ae)
boards=("$@")
[[ ${#boards[@]} -eq 0 ]] && boards=(rpi4 rpi5 orin)

mkdir -p "$root/build" "$root/out/arm"
for board in "${boards[@]}"; do
  cpu="${mcpu[$board]:-}"
  [[ -n "$cpu" ]] || { echo "build-arm: unknown board '$board' (rpi4, rpi5, orin)" >&2; exit 64; }
  dir="$root/build/arm-$board"
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_TOOLCHAIN_FILE="$root/toolchains/aarch64-linux-gnu.cmake" \
    -DCMAKE_CXX_FLAGS="-mcpu=$cpu" -DCMAKE_C_FLAGS="-mcpu=$cpu" \
    -DUMS_BUILD_TESTS=OFF -DUMS_BUILD_BENCHMARKS=OFF >"$dir.configure.log" 2>&1 \
    || { cat "$dir.configure.log"; exit 1; }
  cmake --build "$dir" -j "$(nproc)" --target umsvins >"$dir.build.log" 2>&1 \
    || { tail -n 60 "$dir.build.log"; exit 1; }
  mkdir -p "$root/out/arm/$board"
  aarch64-linux-gnu-strip -o "$root/out/arm/$board/umsvins" "$dir/board/host/umsvins"
  printf '%-5s -mcpu=%-13s %9d bytes  out/arm/%s/umsvins\n' "$board" "$cpu" \
    "$(stat -c %s "$root/out/arm/$board/umsvins")" "$board"
done
