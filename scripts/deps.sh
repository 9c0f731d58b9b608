#!/usr/bin/env bash
# Installs the Debian packages the build, the tests and the aarch64 cross build need.
# Idempotent and quiet when everything is there. Usage: scripts/deps.sh [host|aarch64|armhf|fuzz|cycles|all]
# (fuzz: the host packages plus clang and its libFuzzer/sanitizer runtimes, for scripts/fuzz.sh;
# cycles: the aarch64 packages plus llvm-mc and llvm-mca, for scripts/instructions_aarch64.sh --cycles)
set -euo pipefail

want="${1:-all}"

host_pkgs=(cmake ninja-build g++ pkg-config libeigen3-dev libopencv-core-dev libopencv-imgproc-dev
           libpng-dev catch2 python3 chromium)
bench_pkgs=(libceres-dev)
arm64_pkgs=(g++-aarch64-linux-gnu qemu-user libopencv-core-dev:arm64 libopencv-imgproc-dev:arm64
            libpng-dev:arm64 zlib1g-dev:arm64)
armhf_pkgs=(g++-arm-linux-gnueabihf qemu-user)
# -fsanitize=fuzzer,address,undefined: Debian's clang and the runtime libraries matching its version.
fuzz_pkgs=(clang libclang-rt-14-dev)
# llvm-mc (disassembler) and llvm-mca (Cortex-A72 pipeline model): scripts/cycle_model.py.
cycles_pkgs=(llvm-14)
# The whole product on armhf needs OpenCV and libpng for :armhf. Best effort: on 2026-11-22 a
# mirror mid-sync made them uninstallable; then scripts/test.sh builds and tests the solver only.
armhf_lib_pkgs=(libopencv-core-dev:armhf libopencv-imgproc-dev:armhf libpng-dev:armhf zlib1g-dev:armhf)

pkgs=("${host_pkgs[@]}" "${bench_pkgs[@]}")
if [[ "$want" == "aarch64" || "$want" == "cycles" || "$want" == "all" ]]; then
  pkgs+=("${arm64_pkgs[@]}")
fi
if [[ "$want" == "cycles" ]]; then
  pkgs+=("${cycles_pkgs[@]}")
fi
if [[ "$want" == "armhf" || "$want" == "all" ]]; then
  pkgs+=("${armhf_pkgs[@]}")
fi
if [[ "$want" == "fuzz" || "$want" == "all" ]]; then
  pkgs+=("${fuzz_pkgs[@]}")
fi

missing_of() {  # package... -> the ones not fully installed
  local p
  for p in "$@"; do
    # dpkg-query prints "install ok installed" only for a fully installed package.
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      echo "$p"
    fi
  done
}
mapfile -t missing < <(missing_of "${pkgs[@]}")
optional=()
if [[ "$want" == "armhf" || "$want" == "all" ]]; then
  mapfile -t optional < <(missing_of "${armhf_lib_pkgs[@]}")
fi

# The tests' independent MAVLink decoder: node-mavlink from the npm registry, pinned, into
# build/node (not in git). Node.js itself comes with the machine, or from Debian when missing.
install_node_deps() {
  local root dir want_version=2.3.0
  root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
  dir="$root/build/node"
  if [[ -f "$dir/node_modules/node-mavlink/package.json" ]] &&
     grep -q "\"version\": \"$want_version\"" "$dir/node_modules/node-mavlink/package.json"; then
    return 0
  fi
  echo "deps: installing node-mavlink@$want_version into $dir (npm)"
  mkdir -p "$dir"
  npm install --prefix "$dir" --no-save --no-package-lock --no-audit --no-fund --loglevel=error \
    "node-mavlink@$want_version" >/dev/null
}

if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  missing_node=(nodejs npm)
else
  missing_node=()
fi
if [[ ${#missing[@]} -eq 0 && ${#optional[@]} -eq 0 && ${#missing_node[@]} -eq 0 ]]; then
  install_node_deps
  exit 0
fi
missing+=("${missing_node[@]}")

sudo_cmd=()
[[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
for arch in arm64 armhf; do
  if printf '%s\n' "${missing[@]}" "${optional[@]}" | grep -q ":$arch"; then
    if ! dpkg --print-foreign-architectures | grep -qx "$arch"; then
      "${sudo_cmd[@]}" dpkg --add-architecture "$arch"
    fi
  fi
done
export DEBIAN_FRONTEND=noninteractive
apt_update() {  # [apt options...]
  "${sudo_cmd[@]}" apt-get update -qq "$@" || echo "deps: apt-get update reported errors, installing anyway" >&2
}
install_missing() {
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}
# A mirror in mid-sync can fail one index; the install below still works from the others.
apt_update
if [[ ${#missing[@]} -gt 0 ]]; then
  echo "deps: installing ${missing[*]}"
  if ! install_missing; then
    # Seen 2026-12-06: a half-synced armhf security index also kept the arm64 one from being
    # fetched, so the :arm64 libraries could not match the host's security versions. Fetch the
    # indexes of the host and arm64 alone (armhf libraries are optional) and try again.
    echo "deps: retrying with the host's and arm64's package indexes alone" >&2
    apt_update -o "APT::Architectures::=$(dpkg --print-architecture)" -o "APT::Architectures::=arm64"
    install_missing
  fi
fi
if [[ ${#optional[@]} -gt 0 ]]; then
  echo "deps: installing ${optional[*]} (optional: armhf beyond the solver)"
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${optional[@]}" >/dev/null \
    || echo "deps: the armhf libraries could not be installed: the armhf build covers the solver only" >&2
fi
install_node_deps
echo "deps: done"
