#!/usr/bin/env bash
# Release builds of umsvins for ARM boards, stripped, one per CPU target, with their sizes.
# Usage: scripts/build-arm.sh [board...]   boards: rpi4 (Cortex-A72), rpi5 (Cortex-A76, also
# RK3588's big cores), orin (Cortex-A78AE), all aarch64; rpi4-armhf (Cortex-A72 in 32-bit mode,
# for a 32-bit OS). Default: all four. Output: out/arm/<board>/umsvins.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/deps.sh" all

declare -A mcpu=([rpi4]=cortex-a72 [rpi5]=cortex-a76 [orin]=cortex-a78ae [rpi4-armhf]=cortex-a72)
boards=("$@")
[[ ${#boards[@]} -eq 0 ]] && boards=(rpi4 rpi5 orin rpi4-armhf)

mkdir -p "$root/build" "$root/out/arm"
for board in "${boards[@]}"; do
  cpu="${mcpu[$board]:-}"
  [[ -n "$cpu" ]] || { echo "build-arm: unknown board '$board' (rpi4, rpi5, orin, rpi4-armhf)" >&2; exit 64; }
  dir="$root/build/arm-$board"
  toolchain=aarch64-linux-gnu
  flags="-mcpu=$cpu"
  if [[ "$board" == *-armhf ]]; then
    toolchain=arm-linux-gnueabihf
    flags="-mcpu=$cpu -mfpu=neon-fp-armv8 -mfloat-abi=hard"
    dpkg-query -W -f='${Status}' libopencv-imgproc-dev:armhf 2>/dev/null | grep -q "install ok installed" \
      || { echo "build-arm: $board needs OpenCV for armhf, which scripts/deps.sh could not install" >&2; exit 1; }
  fi
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_TOOLCHAIN_FILE="$root/toolchains/$toolchain.cmake" \
    -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
    -DUMS_BUILD_TESTS=OFF -DUMS_BUILD_BENCHMARKS=OFF >"$dir.configure.log" 2>&1 \
    || { cat "$dir.configure.log"; exit 1; }
  cmake --build "$dir" -j "$(nproc)" --target umsvins >"$dir.build.log" 2>&1 \
    || { tail -n 60 "$dir.build.log"; exit 1; }
  mkdir -p "$root/out/arm/$board"
  "$toolchain-strip" -o "$root/out/arm/$board/umsvins" "$dir/board/host/umsvins"
  printf '%-10s -mcpu=%-13s %9d bytes  out/arm/%s/umsvins\n' "$board" "$cpu" \
    "$(stat -c %s "$root/out/arm/$board/umsvins")" "$board"
done
