#!/usr/bin/env bash
# Renders the 7 shared flights of docs/results.md (60 s each, `umsvins simulate`) in one style and
# with one seed, for accuracy studies that need more than one realization of each flight.
#
# The seed draws everything random in a flight: image and IMU noise, IMU biases, the procedural
# textures and lights, the photo style's hall (wall distances, which real images become
# textures). The flights are chaotic: two builds that differ only in the rounding of one sum give
# trajectories 1.8 mm apart after 30 s, and a single seed's ATE moves by tens of per cent from
# such a change (docs/performance.md, "An ensemble of seeds"). A change is judged on the paired
# per-run ratios over several seeds (scripts/ate_compare.py), not on seed 1 alone.
#
# Usage: scripts/render_flights.sh SEED procedural|photo OUT_DIR [FLIGHT...]
#   writes OUT_DIR/<FLIGHT> for each flight (default MH01 MH02 MH03 V101 V102 V103 V201); a
#   flight already complete there with the same seed and style (its `.done` marker) is kept, any
#   other is rendered again. About 60-150 s per flight on this machine, 0.5 GB each.
# Environment: UMSVINS (binary, default build/host/board/host/umsvins), UMS_SHARED_DIR.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
shared="${UMS_SHARED_DIR:-$root/../shared}"
[[ $# -ge 3 ]] || { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}"; exit 64; }
seed="$1" style="$2" out="$3"
shift 3
[[ "$seed" =~ ^[0-9]+$ ]] || { echo "render_flights: seed '$seed' is not a non-negative integer" >&2; exit 64; }
case "$style" in
  procedural) style_args=() ;;
  photo)
    textures="$shared/data/euroc/V1_01_easy_micro"
    [[ -d "$textures/mav0" ]] || { echo "render_flights: photo style needs the real images $textures" >&2; exit 1; }
    style_args=(--style photo --texture-dataset "$textures") ;;
  *) echo "render_flights: style '$style': procedural or photo" >&2; exit 64 ;;
esac
umsvins="${UMSVINS:-$root/build/host/board/host/umsvins}"
[[ -x "$umsvins" ]] || { echo "render_flights: no $umsvins (scripts/demo.sh builds it)" >&2; exit 1; }
flights="${*:-MH01 MH02 MH03 V101 V102 V103 V201}"

mkdir -p "$out"
for f in $flights; do
  gt="$shared/data/euroc/groundtruth/${f}_GT.txt"
  [[ -f "$gt" ]] || { echo "render_flights: no ground truth $gt" >&2; exit 1; }
  stamp="seed $seed style $style duration 60"
  [[ -f "$out/$f/.done" && "$(cat "$out/$f/.done")" == "$stamp" ]] && continue
  rm -rf "${out:?}/$f"
  t0=$(date +%s)
  "$umsvins" simulate --trajectory "$gt" --seed "$seed" --duration 60 ${style_args[@]+"${style_args[@]}"} --out "$out/$f" --quiet >/dev/null
  echo "$stamp" >"$out/$f/.done"
  echo "render_flights: $style seed $seed $f in $(( $(date +%s) - t0 )) s" >&2
done
