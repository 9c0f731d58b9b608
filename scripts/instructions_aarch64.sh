#!/usr/bin/env bash
# Instructions per frame of the aarch64 release binary (-mcpu=cortex-a72, scripts/build-arm.sh
# rpi4), counted on the aarch64 code itself: qemu-user runs it with a TCG plugin
# (scripts/qemu_insn_stages.c) that counts every guest instruction, and per stage those executed
# while the stage's functions are active, callees included: the same functions as callgrind's
# --toggle-collect in scripts/instructions.sh, so the two architectures compare stage by stage.
#   front end  ums::Frontend::process
#   back end   ums::Estimator::add_frame + ums::Estimator::add_imu
#   pipeline   ums::cli::ReplayPipeline::on_* (front end + back end + the pipeline's bookkeeping;
#              not the dataset's reading and PNG decoding)
# Replays run with --deterministic: the solver's second round is bounded by iterations, not by the
# wall clock, which qemu and valgrind slow down 20-50x (without it the count depends on the host).
#
# qemu runs the binary as a Cortex-A72 (-cpu cortex-a72), so the C library picks the routines
# it would pick on the board (with qemu's default CPU it takes SVE and LSE variants).
#
# Usage: scripts/instructions_aarch64.sh [--x86] [--cycles] [--config=FILE] [--function=LABEL=PREFIX ...] [dataset...]
#   default datasets (rendered by the host build, scripts/demo.sh builds it): the V1_01 profile
#   from 20 s for 3 s, seed 1, at 752x480 (scripts/instructions.sh's sequence) and with the D455
#   camera at 848x480, and the real micro sequence ../shared/data/euroc/V1_01_easy_micro.
#   --x86: also count each run with callgrind on the host build (scripts/instructions.sh), side by side.
#   --cycles: also estimate the pipeline's cycles per frame on a Cortex-A72 model: the blocks it ran
#     through llvm-mca, the loads through a simulated Raspberry Pi 4 cache (32 KiB 2-way L1D, 1 MiB
#     16-way L2), printed under the run's line (scripts/cycle_model.py; about 3x slower).
#   --config=FILE: replay every run with this VINS-style YAML (`umsvins replay --config`), e.g. to
#     price a knob such as max_steps_per_solve.
#   --function=LABEL=PREFIX (up to 5): also count, on aarch64, the instructions while any function
#     whose demangled name starts with PREFIX is active (callees included), printed per frame
#     under the run's line; e.g. --function=klt=ums::klt_track --function='jtj=ums::solver::Problem::accumulate_two_row'.
# Installs what it needs: the cross compiler and qemu-user (scripts/deps.sh aarch64; with --cycles
# also llvm-mc and llvm-mca, scripts/deps.sh cycles), and qemu's
# plugin header, taken from Debian's qemu source package (a deb-src entry is added when missing).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
x86=0
cycles=0
datasets=()
fn_labels=()
fn_prefixes=()
config=()
config_file=""
for a in "$@"; do
  case "$a" in
    --x86) x86=1 ;;
    --cycles) cycles=1 ;;
    --config=*)
      config_file="${a#--config=}"
      [[ -f "$config_file" ]] || { echo "instructions_aarch64: --config: $config_file: no such file" >&2; exit 64; }
      config_file="$(cd "$(dirname "$config_file")" && pwd)/$(basename "$config_file")"
      config=(--config "$config_file") ;;
    --function=*=*)
      spec="${a#--function=}"
      fn_labels+=("${spec%%=*}")
      fn_prefixes+=("${spec#*=}")
      [[ ${#fn_labels[@]} -le 5 ]] || { echo "instructions_aarch64: at most 5 --function options (the plugin follows 8 labels)" >&2; exit 64; }
      [[ "${fn_labels[-1]}" =~ ^[A-Za-z0-9_]+$ ]] || { echo "instructions_aarch64: --function label '${fn_labels[-1]}' must be letters, digits or _" >&2; exit 64; }
      ;;
    -h|--help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | grep '^#' | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "instructions_aarch64: unknown option '$a' (--x86, --cycles, --config=FILE, --function=LABEL=PREFIX)" >&2; exit 64 ;;
    *) [[ -d "$a/mav0" ]] || { echo "instructions_aarch64: $a: not a EuRoC dataset (no mav0/)" >&2; exit 64; }
       datasets+=("$(cd "$a" && pwd)") ;;
  esac
done

host_umsvins="$root/build/host/board/host/umsvins"
plugin_dir="$root/build/qemu-plugin"
arm_build="$root/build/arm-rpi4"
arm_umsvins="$arm_build/board/host/umsvins"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

plugin_header() {  # qemu-plugin.h of the installed qemu's release, from Debian's source package
  local header="$plugin_dir/include/qemu-plugin.h"
  [[ -f "$header" ]] && return 0
  local version
  version=$(qemu-aarch64 --version | sed -n 's/^qemu-aarch64 version \([0-9]*\.[0-9]*\).*/\1/p')
  echo "instructions_aarch64: fetching qemu-plugin.h (qemu $version source package)"
  local sudo_cmd=()
  [[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
  if ! apt-get source --download-only --print-uris qemu >/dev/null 2>&1; then
    # A deb-src entry for the same mirror and suites as the system's deb entry.
    "${sudo_cmd[@]}" tee /etc/apt/sources.list.d/ums-deb-src.sources >/dev/null <<'EOF'
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
    # A mirror mid-sync can fail the update for an index this script does not need (2026-12-05:
    # bookworm-security's armhf list); the source package may still be reachable.
    "${sudo_cmd[@]}" apt-get update -qq ||
      echo "instructions_aarch64: warning: apt-get update failed; fetching the qemu source package anyway" >&2
  fi
  (cd "$work" && apt-get source --download-only -qq qemu >/dev/null 2>&1) ||
    { echo "instructions_aarch64: cannot download Debian's qemu source package (deb-src entry, network?)" >&2; exit 1; }
  local orig
  orig=$(ls "$work"/qemu_*.orig.tar.* | head -n 1)
  tar -xf "$orig" -C "$work" --wildcards '*/include/qemu/qemu-plugin.h'
  local got
  got=$(find "$work" -path '*/include/qemu/qemu-plugin.h' | head -n 1)
  [[ "$got" == *"qemu-$version"* ]] || echo "instructions_aarch64: warning: header from $got, qemu is $version" >&2
  mkdir -p "$(dirname "$header")"
  cp "$got" "$header"
}

build_plugin() {
  local so="$plugin_dir/libqemu_insn_stages.so" src="$root/scripts/qemu_insn_stages.c"
  if [[ ! -f "$so" || "$src" -nt "$so" ]]; then
    gcc -O2 -Wall -Wextra -Werror -shared -fPIC -I"$plugin_dir/include" -o "$so" "$src"
  fi
  echo "$so"
}

# The Raspberry Pi 4's Cortex-A72 caches: 32 KiB 2-way L1D per core, 1 MiB 16-way L2 (shared).
cache_args="cache=32768:2:1048576:16"
self_test() {  # the plugin on a program whose counts are known: nested calls, a tail call
  cat >"$work/selftest.c" <<'SRC'
#define NOPS(n) __asm__ volatile(".rept " #n "\n nop\n .endr")
__attribute__((noinline)) void leaf(void) { NOPS(500); }
__attribute__((noinline)) void middle(void) { NOPS(200); leaf(); } /* ends in a tail call at -O2 */
__attribute__((noinline)) void outer(void) { NOPS(1000); middle(); NOPS(100); }
/* The cache model's checks (32 KiB 2-way L1, 1 MiB 16-way L2, 64-byte lines, LRU), stage sweep:
   4 MiB read twice (every line misses L1 and L2 both times: 131,072), 512 KiB read twice 16 bytes
   at a time (L1 misses both times, L2 the first time only: 16,384 and 8,192; qemu reports each
   128-bit load as two 8-byte ones, which must still read as one strided stream), 16 KiB read 8
   times (cold the first time only: 256 each); stage conflict: three lines 16 KiB apart, one L1
   set, read in turn 3,000 times (a 2-way LRU L1 misses every time, L2 only at first). */
static volatile long big[1 << 19], small[1 << 11], conflicting[3 << 11];
typedef long Pair __attribute__((vector_size(16)));
static volatile Pair mid[1 << 15];
__attribute__((noinline)) long sweep(void) {
  long s = 0;
  for (int p = 0; p < 2; ++p) for (int i = 0; i < (1 << 19); ++i) s += big[i];
  for (int p = 0; p < 2; ++p) for (int i = 0; i < (1 << 15); ++i) { const Pair x = mid[i]; s += x[0] + x[1]; }
  for (int p = 0; p < 8; ++p) for (int i = 0; i < (1 << 11); ++i) s += small[i];
  return s;
}
__attribute__((noinline)) long conflict(void) {
  long s = 0;
  for (int i = 0; i < 3000; ++i) s += conflicting[(i % 3) << 11];
  return s;
}
int main(void) { for (int i = 0; i < 10; ++i) outer(); leaf(); return (int)(sweep() + conflict()); }
SRC
  aarch64-linux-gnu-gcc -O2 -o "$work/selftest" "$work/selftest.c"
  local nm_out="$work/selftest.nm" args stage
  aarch64-linux-gnu-nm -S --defined-only "$work/selftest" >"$nm_out"
  args=$(awk '$4 == "main" {printf "main=0x%s", $1}' "$nm_out")
  args+=$(awk '$4 ~ /^(leaf|middle|outer|sweep|conflict)$/ {printf ",fn=%s:0x%s:0x%s", $4, $1, $2}' "$nm_out")
  for stage in sweep conflict; do
    qemu-aarch64 -cpu cortex-a72 -L / -plugin "$1,out=$work/selftest.$stage,$args,$cache_args,block_stage=$stage" \
      "$work/selftest"
  done
  # Per call: outer 1000 + 200 + 500 + 100 nops, middle 700, leaf 500, plus a few instructions of
  # call, prologue and return each; leaf is entered 10 times by middle's tail call and once by main.
  awk '$1 == "stage" { n[$2] = $3 } $1 == "entries" { e[$2] = $3 } $1 == "returns" { r[$2] = $3 }
       $1 == "l1_misses" { l1[$2] = $3 } $1 == "l2_misses" { l2[$2] = $3 } $1 == "vcpus" { vcpus = $3 }
       END { ok = n["outer"] >= 18000 && n["outer"] <= 18300 && e["outer"] == 10 && r["outer"] == 10 &&
                  n["middle"] >= 7000 && n["middle"] <= 7100 && e["middle"] == 10 && r["middle"] == 10 &&
                  n["leaf"] >= 5500 && n["leaf"] <= 5560 && e["leaf"] == 11 && r["leaf"] == 11 && vcpus == 1 &&
                  l1["load"] >= 147712 && l1["load"] <= 148212 && l2["load"] >= 139520 && l2["load"] <= 140020 &&
                  l1["irregular_load"] <= 100
             exit ok ? 0 : 1 }' "$work/selftest.sweep" \
    || { echo "instructions_aarch64: the plugin's self-test failed (stage sweep):" >&2; cat "$work/selftest.sweep" >&2; exit 1; }
  awk '$1 == "l1_misses" { l1[$2] = $3 } $1 == "l2_misses" { l2[$2] = $3 }
       END { exit l1["load"] >= 3000 && l1["load"] <= 3100 && l2["load"] <= 50 ? 0 : 1 }' "$work/selftest.conflict" \
    || { echo "instructions_aarch64: the plugin's self-test failed (stage conflict):" >&2; cat "$work/selftest.conflict" >&2; exit 1; }
}

symbol_args() {  # binary -> the plugin's main= and fn= arguments, from nm (C++ names demangled)
  local nm_out="$work/nm.txt"
  aarch64-linux-gnu-nm -C -S --defined-only "$1" >"$nm_out"
  local main_addr
  main_addr=$(awk '$4 == "main" {print $1}' "$nm_out")
  [[ -n "$main_addr" ]] || { echo "instructions_aarch64: no 'main' in $1 (stripped?)" >&2; exit 1; }
  printf 'main=0x%s' "$main_addr"
  # Lines: address size type name...; the name starts at the 4th field.
  awk '$3 ~ /^[tTwW]$/ {
         name = $0; sub(/^[^ ]+ [^ ]+ [^ ]+ /, "", name)
         label = ""
         if (index(name, "ums::Frontend::process(") == 1) label = "frontend"
         else if (index(name, "ums::Estimator::add_frame(") == 1 || index(name, "ums::Estimator::add_imu(") == 1) label = "backend"
         else if (index(name, "ums::cli::ReplayPipeline::on_") == 1) label = "pipeline"
         if (label != "") printf ",fn=%s:0x%s:0x%s", label, $1, $2
       }' "$nm_out"
  local i
  for i in "${!fn_labels[@]}"; do
    local found
    found=$(awk -v pre="${fn_prefixes[$i]}" -v label="${fn_labels[$i]}" '$3 ~ /^[tTwW]$/ {
              name = $0; sub(/^[^ ]+ [^ ]+ [^ ]+ /, "", name)
              if (index(name, pre) == 1) printf ",fn=%s:0x%s:0x%s", label, $1, $2
            }' "$nm_out")
    [[ -n "$found" ]] || { echo "instructions_aarch64: --function: no function of $1 starts with '${fn_prefixes[$i]}'" >&2; exit 64; }
    printf '%s' "$found"
  done
}

count_aarch64() {  # dataset tag -> "frames frontend backend pipeline process" (M per frame)
  local ds="$1" tag="$2" args
  args=$(symbol_args "$arm_umsvins")
  local n_fns
  n_fns=$(grep -o ',fn=' <<<"$args" | wc -l)
  # The plugin's table (kMaxFns in scripts/qemu_insn_stages.c): a prefix such as
  # ums::solver::Problem::linearize also matches linearize_landmark, linearize_prior, ...
  [[ $n_fns -le 64 ]] || { echo "instructions_aarch64: the stages and --function prefixes match $n_fns functions; the plugin follows at most 64 (use longer prefixes)" >&2; exit 64; }
  local model_args=""
  [[ $cycles -eq 1 ]] && model_args=",blocks=$work/$tag.blocks,block_stage=pipeline,$cache_args"
  qemu-aarch64 -cpu cortex-a72 -L / -plugin "$plugin,out=$work/$tag.counts,$args$model_args" "$arm_umsvins" replay "$ds" \
    "${config[@]}" --out "$work/$tag.arm" --quiet --deterministic >/dev/null
  local c="$work/$tag.counts"
  field() { awk -v k="$1" -v l="$2" '$1 == k && $2 == l {print $3}' "$c"; }
  if [[ "$(field bias_found -)" != 1 || "$(field stack_overflows -)" != 0 ]]; then
    echo "instructions_aarch64: $tag: the plugin did not find main or overflowed its call stack" >&2
    cat "$c" >&2
    exit 1
  fi
  for label in frontend backend pipeline "${fn_labels[@]}"; do
    local entries returns
    entries=$(field entries "$label")
    returns=$(field returns "$label")
    if [[ -z "$entries" || "$entries" -eq 0 || "$entries" != "$returns" ]]; then
      echo "instructions_aarch64: $tag: stage '$label' not followed (entries $entries, returns $returns):" \
        "the figures would be wrong" >&2
      cat "$c" >&2
      exit 1
    fi
  done
  local frames
  frames=$(grep -o '"frames": [0-9]*' "$work/$tag.arm/stats.json" | awk '{print $2}')
  if [[ $cycles -eq 1 ]]; then
    # $(...) clears errexit: a failed model must stop the run by hand.
    [[ "$(field vcpus -)" == 1 ]] || { echo "instructions_aarch64: $tag: --cycles needs one thread" >&2; exit 1; }
    python3 "$root/scripts/cycle_model.py" "$work/$tag.blocks" "$c" --frames "$frames" --nm "$work/nm.txt" \
      >"$work/$tag.model" || exit 1
  fi
  local extra=""
  for label in "${fn_labels[@]}"; do extra+=" $(field stage "$label")"; done
  awk -v f="$frames" -v fe="$(field stage frontend)" -v be="$(field stage backend)" -v pipe="$(field stage pipeline)" \
    -v all="$(field total -)" -v extra="$extra" 'BEGIN {
      printf "%d %.1f %.1f %.1f %.1f", f, fe / f / 1e6, be / f / 1e6, pipe / f / 1e6, all / f / 1e6
      n = split(extra, e, " "); for (i = 1; i <= n; ++i) printf " %.2f", e[i] / f / 1e6
      printf "\n" }'
}

count_x86() {  # dataset -> "frames frontend backend pipeline process" (M per frame, callgrind)
  "$root/scripts/instructions.sh" "$root/build/host" "$1" "$config_file" \
    | awk '{ v[$1] = $2 } END { print v["frames"], v["frontend"], v["backend"], v["total"], v["process"] }'
}

if [[ $cycles -eq 1 ]]; then "$root/scripts/deps.sh" cycles >/dev/null; else "$root/scripts/deps.sh" aarch64 >/dev/null; fi
plugin_header
plugin=$(build_plugin)
self_test "$plugin"
[[ $cycles -eq 1 ]] && python3 "$root/scripts/cycle_model.py" --self-test >/dev/null
if [[ ! -x "$arm_umsvins" || -n "$(find "$root/core" "$root/hal" "$root/board" "$root/solver" -newer "$arm_umsvins" -name '*.[ch]pp' -print -quit)" ]]; then
  echo "instructions_aarch64: building $arm_umsvins (scripts/build-arm.sh rpi4)"
  "$root/scripts/build-arm.sh" rpi4 >/dev/null
fi
if [[ ${#datasets[@]} -eq 0 || $x86 -eq 1 ]]; then
  [[ -x "$host_umsvins" ]] || { echo "instructions_aarch64: build the host first (scripts/demo.sh builds $host_umsvins)" >&2; exit 1; }
fi
if [[ $x86 -eq 1 ]]; then
  command -v valgrind >/dev/null || { echo "instructions_aarch64: --x86 needs valgrind (apt-get install valgrind)" >&2; exit 1; }
fi
if [[ ${#datasets[@]} -eq 0 ]]; then
  gt="$root/../shared/data/euroc/groundtruth/V101_GT.txt"
  "$host_umsvins" simulate --trajectory "$gt" --start 20 --duration 3 --seed 1 --out "$work/V101_20s_752" --quiet >/dev/null
  "$host_umsvins" simulate --trajectory "$gt" --start 20 --duration 3 --seed 1 --camera d455 \
    --out "$work/V101_20s_d455" --quiet >/dev/null
  datasets=("$work/V101_20s_752" "$work/V101_20s_d455" "$root/../shared/data/euroc/V1_01_easy_micro")
fi

printf '%-22s %-24s %6s %10s %10s %10s %10s\n' dataset arch frames "front end" "back end" pipeline process
printf '%-22s %-24s %6s %10s %10s %10s %10s\n' "" "" "" "M/frame" "M/frame" "M/frame" "M/frame"
for ds in "${datasets[@]}"; do
  tag=$(basename "$ds")
  runs=("aarch64 qemu cortex-a72")
  [[ $x86 -eq 1 ]] && runs+=("x86-64 callgrind")
  for arch in "${runs[@]}"; do
    if [[ "$arch" == aarch64* ]]; then line=$(count_aarch64 "$ds" "$tag"); else line=$(count_x86 "$ds"); fi
    read -r frames fe be pipe process extra <<<"$line"
    printf '%-22s %-24s %6d %10s %10s %10s %10s\n' "$tag" "$arch" "$frames" "$fe" "$be" "$pipe" "$process"
    if [[ "$arch" == aarch64* && ${#fn_labels[@]} -gt 0 ]]; then
      read -ra values <<<"$extra"
      for i in "${!fn_labels[@]}"; do
        printf '%-22s %-24s %6s %10s M/frame  (%s*)\n' "" "  ${fn_labels[$i]}" "" "${values[$i]}" "${fn_prefixes[$i]}"
      done
    fi
    if [[ "$arch" == aarch64* && $cycles -eq 1 ]]; then
      echo "  Cortex-A72 model of the pipeline (scripts/cycle_model.py):"
      sed 's/^/    /' "$work/$tag.model"
    fi
  done
done
