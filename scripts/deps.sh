#!/usr/bin/env bash
# Installs the Debian packages the build, the tests and the aarch64 cross build need.
# Idempotent and quiet when everything is there. Usage: scripts/deps.sh [host|aarch64|armhf|all]
set -euo pipefail

want="${1:-all}"

host_pkgs=(cmake ninja-build g++ pkg-config libeigen3-dev libopencv-core-dev libopencv-imgproc-dev
           libpng-dev catch2 python3 chromium)
bench_pkgs=(libceres-dev)
arm64_pkgs=(g++-aarch64-linux-gnu qemu-user libopencv-core-dev:arm64 libopencv-imgproc-dev:arm64
            libpng-dev:arm64 zlib1g-dev:arm64)
# armhf: the cross compiler's own sysroot only (Debian 12's :armhf OpenCV is not co-installable here).
armhf_pkgs=(g++-arm-linux-gnueabihf qemu-user)

pkgs=("${host_pkgs[@]}" "${bench_pkgs[@]}")
if [[ "$want" == "aarch64" || "$want" == "all" ]]; then
  pkgs+=("${arm64_pkgs[@]}")
fi
if [[ "$want" == "armhf" || "$want" == "all" ]]; then
  pkgs+=("${armhf_pkgs[@]}")
fi

missing=()
for p in "${pkgs[@]}"; do
  # dpkg-query prints "install ok installed" only for a fully installed package.
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

echo "deps: installing ${missing[*]}"
sudo_cmd=()
[[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
if printf '%s\n' "${missing[@]}" | grep -q ':arm64'; then
  if ! dpkg --print-foreign-architectures | grep -qx arm64; then
    "${sudo_cmd[@]}" dpkg --add-architecture arm64
  fi
fi
export DEBIAN_FRONTEND=noninteractive
# A mirror in mid-sync can fail one index; the install below still works from the others.
"${sudo_cmd[@]}" apt-get update -qq || echo "deps: apt-get update reported errors, installing anyway" >&2
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "deps: done"
