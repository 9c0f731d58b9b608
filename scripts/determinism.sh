#!/usr/bin/env bash
# Determinism across architectures (issue 8): a short synthetic flight, rendered once on the host,
# replayed by the host binary and by the aarch64 binary under qemu-user (single-threaded replay,
# --deterministic: the solver's second round bounded by iterations, not by qemu's slow wall clock);
# the two trajectories must agree to 1e-6 m at every frame. Needs UMS_PORTABLE_FP (the default).
# Usage: scripts/determinism.sh [host_build_dir] [aarch64_build_dir]   (defaults build/host build/aarch64)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
host="${1:-$root/build/host}/board/host/umsvins"
arm="${2:-$root/build/aarch64}/board/host/umsvins"
shared="$root/../shared"
for b in "$host" "$arm"; do [[ -x "$b" ]] || { echo "determinism: $b not built" >&2; exit 1; }; done

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$host" simulate --trajectory "$shared/data/euroc/groundtruth/V101_GT.txt" --scenario nominal --seed 1 \
  --duration 6 --out "$work/data" --quiet >/dev/null
"$host" replay "$work/data" --out "$work/host" --quiet --deterministic >/dev/null
qemu-aarch64 -L / "$arm" replay "$work/data" --out "$work/aarch64" --quiet --deterministic >/dev/null

# Same number of poses, same stamps, positions within 1e-6 m.
awk 'FNR == NR { if ($1 !~ /^#/) { t[++n] = $1; x[n] = $2; y[n] = $3; z[n] = $4 } next }
     $1 !~ /^#/ { ++m; if ($1 != t[m]) { printf "determinism: stamp %s vs %s at pose %d\n", t[m], $1, m; bad = 1 }
                  d = $2 - x[m]; if (d < 0) d = -d; if (d > w) w = d
                  d = $3 - y[m]; if (d < 0) d = -d; if (d > w) w = d
                  d = $4 - z[m]; if (d < 0) d = -d; if (d > w) w = d }
     END { if (m != n || n == 0) { printf "determinism: %d host poses, %d aarch64 poses\n", n, m; exit 1 }
           printf "determinism: %d poses, largest host/aarch64 position difference %.3g m (limit 1e-6 m)\n", n, w
           if (bad || w > 1e-6) exit 1 }' "$work/host/trajectory.tum" "$work/aarch64/trajectory.tum"
