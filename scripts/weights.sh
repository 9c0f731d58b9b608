#!/usr/bin/env bash
# Replays simulated flights under one configuration and prints one line per flight: the figures
# behind docs/results.md "Weights" (ATE, the 1 s and 10 s RPE, time to VIO after the first moving
# frame, the alignment's counters, CPU / real time). The datasets come from `umsvins simulate` (both styles: see
# docs/results.md for the commands); replays use --deterministic, so a line is reproducible.
#
# Usage: scripts/weights.sh NAME DATA_DIR "key: value;key: value" [FLIGHT...]
#   NAME      label of the configuration (a folder under --work)
#   DATA_DIR  folder holding one dataset per flight name (default flights: the 7 shared ones)
#   keys      config keys over the defaults ("" for the defaults), e.g. "imu_walk_scale: 2.0"
# Environment: UMSVINS (binary, default build/host/board/host/umsvins), WORK (default /tmp/weights).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[[ $# -ge 3 ]] || { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}"; exit 64; }
umsvins="${UMSVINS:-$root/build/host/board/host/umsvins}"
work="${WORK:-/tmp/weights}"
name="$1" data="$2" keys="$3"
shift 3
flights="${*:-MH01 MH02 MH03 V101 V102 V103 V201}"
[[ -x "$umsvins" ]] || { echo "weights: no $umsvins (scripts/demo.sh builds it)" >&2; exit 1; }

mkdir -p "$work/$name"
cfg="$work/$name/config.yaml"
{
  echo "%YAML:1.0"
  echo "max_cnt: 200"  # the default, so that the file is a map even when no key is given
  IFS=';' read -ra kv <<<"$keys"
  for k in "${kv[@]}"; do [[ -z "$k" ]] || echo "$k"; done
} >"$cfg"

for f in $flights; do
  out="$work/$name/$f"
  if ! "$umsvins" replay "$data/$f" --out "$out" --config "$cfg" --quiet --deterministic >"$out.log" 2>&1; then
    echo "$name $f: replay failed: $(tail -n 1 "$out.log")"
    continue
  fi
  python3 - "$name" "$f" "$out/stats.json" "$data/$f/mav0" <<'PY'
import json, math, sys
name, flight, stats_path, mav0 = sys.argv[1:5]
s = json.load(open(stats_path))
e = s.get("estimator", {})
t_img = next(int(l.split(",")[0]) for l in open(mav0 + "/cam0/data.csv") if l.strip() and not l.startswith("#"))
move = None
for l in open(mav0 + "/state_groundtruth_estimate0/data.csv"):
    if l.startswith("#") or not l.strip():
        continue
    v = l.split(",")
    if math.sqrt(sum(float(x) ** 2 for x in v[8:11])) > 0.1:
        move = max(0.0, (int(v[0]) - t_img) * 1e-9)
        break
vio = next((m["t_s"] for m in s.get("modes", []) if m.get("to") == "VIO"), None)
delay = "never" if vio is None else ("%.2f" % max(0.0, vio - move) if move is not None else "no motion")
cpu, dur = s.get("processing_cpu_s", 0.0), s.get("duration_s", 0.0)
acc = s.get("accuracy", {})
print("%-10s %-6s ATE %.4f m  RPE 1 s %.2f mm  10 s %.2f mm  VIO at %s s, %s s after the first motion  align %s tried / %s unobservable"
      "  CPU/real %.3f" % (name, flight, acc.get("ate_rmse_m", float("nan")),
                           1000 * acc.get("rpe_1s_m", float("nan")), 1000 * acc.get("rpe_10s_m", float("nan")),
                           "-" if vio is None else "%.2f" % vio, delay, e.get("align_attempts"),
                           e.get("align_unobservable"), cpu / dur if dur else float("nan")))
PY
done
