#!/usr/bin/env bash
# Behaviour check for refactors: replays the same datasets with two builds of umsvins
# (--deterministic) and compares the trajectories byte for byte.
# Datasets: the real EuRoC micro sequence, 60 s nominal flights of MH01 V102 V201 MH03 and 20 s
# uniform-start and dark-start cuts of V101 (rendered once, by the new build's simulator).
# Usage: scripts/same-trajectories.sh OLD_UMSVINS NEW_UMSVINS [WORK_DIR]
#   e.g. build an older commit in a worktree, then
#   scripts/same-trajectories.sh /tmp/old/build/board/host/umsvins build/host/board/host/umsvins
# Exit 0 when every trajectory is identical, 1 otherwise.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
shared="${UMS_SHARED_DIR:-$root/../shared}"
old="${1:?usage: scripts/same-trajectories.sh OLD_UMSVINS NEW_UMSVINS [WORK_DIR]}"
new="${2:?usage: scripts/same-trajectories.sh OLD_UMSVINS NEW_UMSVINS [WORK_DIR]}"
work="${3:-}"
for b in "$old" "$new"; do [[ -x "$b" ]] || { echo "same-trajectories: $b is not an executable" >&2; exit 1; }; done
if [[ -z "$work" ]]; then work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT; else mkdir -p "$work"; fi

gt="$shared/data/euroc/groundtruth"
render() {  # name trajectory scenario duration
  [[ -d "$work/data/$1" ]] || "$new" simulate --trajectory "$gt/$2_GT.txt" --scenario "$3" --seed 1 \
    --duration "$4" --out "$work/data/$1" --quiet >/dev/null
}
mkdir -p "$work/data"
ln -sfn "$shared/data/euroc/V1_01_easy_micro" "$work/data/micro"
for t in MH01 V102 V201 MH03; do echo "same-trajectories: rendering $t (60 s)" >&2; render "$t" "$t" nominal 60; done
render V101u V101 uniform-start 20
render V101d V101 dark-start 20

status=0
for d in micro MH01 V102 V201 MH03 V101u V101d; do
  "$old" replay "$work/data/$d" --out "$work/old/$d" --quiet --deterministic >/dev/null
  "$new" replay "$work/data/$d" --out "$work/new/$d" --quiet --deterministic >/dev/null
  if cmp -s "$work/old/$d/trajectory.tum" "$work/new/$d/trajectory.tum"; then
    echo "$d: identical ($(wc -l < "$work/new/$d/trajectory.tum") poses)"
  else
    echo "$d: DIFFERENT"; status=1
  fi
done
exit $status
