#!/usr/bin/env bash
# Regenerates the measured tables of docs/results.md: simulated flights of the shared EuRoC
# ground-truth trajectories, each `umsvins simulate` -> `umsvins replay` -> `umsvins eval`
# (ATE RMSE after SE(3) alignment), plus the initialization and mode figures of stats.json.
#
# Every flight is rendered in both simulator styles (docs/simulator.md): `procedural` (the
# project's own textures and IMU) and `photo` (textures cut from real EuRoC images, lens
# vignetting, uneven light, motion blur, an IMU from another generator with real-sized biases),
# so a figure that holds only on one renderer shows.
#
# Usage: scripts/results.sh [--quick] [--styles LIST] [--duration S] [--build DIR] [--work DIR] [--keep] [--write]
#   --quick   nominal on MH01 and V101, scenarios on V101 only, 20 s cuts (about 1/7 of the work)
#   default   nominal on all 7 shared trajectories, scenarios on MH01 and V102 (the paper's
#             30-run sequences: factory hall and small room), 60 s cuts
#   --styles  comma-separated simulator styles (default procedural,photo)
#   --duration  cut length in s instead of 60 (20 with --quick), e.g. 2 for a smoke test
#   --build   build folder holding board/host/umsvins (default build/host, as scripts/demo.sh)
#   --work    folder for the datasets and replays (default: a temporary folder, removed at exit)
#   --keep    keep each simulated dataset (about 0.5 GB per 60 s flight); default: deleted after use
#   --write   also put the table into docs/results.md between its results markers
# The tables go to stdout (markdown): accuracy per style, then the error budget per flight and
# style (profiling/eval error_budget, from each replay's stats.json); progress to stderr.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
shared="${UMS_SHARED_DIR:-$root/../shared}"
gt_dir="$shared/data/euroc/groundtruth"
build="$root/build/host"
work=""
quick=0
keep=0
write_doc=0
duration_override=""
styles="procedural,photo"

while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) quick=1 ;;
    --keep) keep=1 ;;
    --write) write_doc=1 ;;
    --build) build="$2"; shift ;;
    --duration) duration_override="$2"; shift ;;
    --styles) styles="$2"; shift ;;
    --work) work="$2"; shift ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "results: unknown option '$1' (see --help)" >&2; exit 64 ;;
  esac
  shift
done

umsvins="$build/board/host/umsvins"
[[ -x "$umsvins" ]] || { echo "results: no $umsvins (build it: scripts/demo.sh, or --build DIR)" >&2; exit 1; }
command -v python3 >/dev/null || { echo "results: needs python3 (scripts/deps.sh installs it)" >&2; exit 1; }
[[ -d "$gt_dir" ]] || { echo "results: no ground truth folder $gt_dir" >&2; exit 1; }
texture_dataset="$shared/data/euroc/V1_01_easy_micro"
IFS=',' read -ra style_list <<<"$styles"
for st in "${style_list[@]}"; do
  case "$st" in procedural|photo) ;; *) echo "results: unknown style '$st' (procedural, photo)" >&2; exit 64 ;; esac
done

if [[ -z "$work" ]]; then
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
else
  mkdir -p "$work"
fi

scenarios="standstill-start dark-start uniform-start textureless impulses"
if [[ $quick -eq 1 ]]; then
  duration=20
  nominal_flights="MH01 V101"
  scenario_flights="V101"
else
  duration=60
  nominal_flights="MH01 MH02 MH03 V101 V102 V103 V201"
  scenario_flights="MH01 V102"
fi
[[ -z "$duration_override" ]] || duration="$duration_override"

# One JSON record of a finished run (any file may be missing): ATE text, stats.json,
# trajectory.tum, and the dataset's ground truth (for the first moving frame).
record() {  # flight scenario style ate_text stats_json trajectory_tum groundtruth_csv cam0_csv
  python3 - "$@" <<'PY'
import json, math, os, sys
flight, scenario, style, ate, stats_path, tum_path, gt_path, cam_path = sys.argv[1:9]
stats = {}
if os.path.exists(stats_path):
    try:
        with open(stats_path) as f:
            stats = json.load(f)
    except ValueError as e:
        ate = ate + " (stats.json unreadable: %s)" % e
poses = 0
if os.path.exists(tum_path):
    with open(tum_path) as f:
        poses = len({l.split()[0] for l in f if l.strip() and not l.startswith("#")})
# First moving frame: the first ground-truth speed above 0.1 m/s, in s after the first image.
first_move_s = None
if os.path.exists(gt_path) and os.path.exists(cam_path):
    t_img = next(int(l.split(",")[0]) for l in open(cam_path) if l.strip() and not l.startswith("#"))
    for l in open(gt_path):
        if l.startswith("#") or not l.strip():
            continue
        v = l.split(",")
        if math.sqrt(sum(float(x) ** 2 for x in v[8:11])) > 0.1:
            first_move_s = max(0.0, (int(v[0]) - t_img) * 1e-9)
            break
print(json.dumps({"flight": flight, "scenario": scenario, "style": style, "ate": ate, "poses": poses,
                  "first_move_s": first_move_s, "stats": stats}))
PY
}

run_one() {  # flight scenario style
  local flight="$1" scenario="$2" style="$3"
  local name="${flight}_${scenario}_${style}"
  local ds="$work/$name" out="$work/$name.out"
  local ate="-"
  local style_args=(--style "$style")
  [[ "$style" != photo ]] || style_args+=(--texture-dataset "$texture_dataset")
  echo "results: $name: simulate ${duration} s" >&2
  if ! "$umsvins" simulate --trajectory "$gt_dir/${flight}_GT.txt" --scenario "$scenario" --seed 1 \
      "${style_args[@]}" --duration "$duration" --out "$ds" --quiet >"$work/$name.simulate.log" 2>&1; then
    record "$flight" "$scenario" "$style" "simulate failed: $(tail -n 1 "$work/$name.simulate.log")" \
      /nonexistent /nonexistent /nonexistent /nonexistent >>"$records"
    return
  fi
  echo "results: $name: replay" >&2
  local rc=0
  "$umsvins" replay "$ds" --out "$out" --quiet >"$work/$name.replay.log" 2>&1 || rc=$?
  if [[ $rc -ne 0 ]]; then
    ate="replay failed ($rc): $(tail -n 1 "$work/$name.replay.log")"
  elif [[ ! -s "$out/trajectory.tum" ]]; then
    ate="no trajectory"
  elif "$umsvins" eval --estimate "$out/trajectory.tum" \
      --groundtruth "$ds/mav0/state_groundtruth_estimate0/data.csv" --align se3 >"$work/$name.eval.txt" 2>&1; then
    ate="$(sed -n 's/^ATE trans \[m\]: rmse \([0-9.]*\).*/\1/p' "$work/$name.eval.txt")"
    [[ -n "$ate" ]] || ate="eval output not understood"
  else
    ate="eval failed: $(tail -n 1 "$work/$name.eval.txt")"
  fi
  record "$flight" "$scenario" "$style" "$ate" "$out/stats.json" "$out/trajectory.tum" \
    "$ds/mav0/state_groundtruth_estimate0/data.csv" "$ds/mav0/cam0/data.csv" >>"$records"
  [[ $keep -eq 1 ]] || rm -rf "$ds"
}

records="$work/records.jsonl"
: >"$records"
for f in $nominal_flights; do
  for st in "${style_list[@]}"; do run_one "$f" nominal "$st"; done
done
for f in $scenario_flights; do
  for sc in $scenarios; do
    for st in "${style_list[@]}"; do run_one "$f" "$sc" "$st"; done
  done
done

table="$work/results_table.md"
{
  echo "Measured $(date -u +%Y-%m-%d) at commit $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)" \
       "with \`scripts/results.sh$([[ $quick -eq 1 ]] && echo ' --quick')$([[ -n "$duration_override" ]] && echo " --duration $duration_override")\`: simulated ${duration} s cuts," \
       "seed 1, ATE RMSE after SE(3) alignment, styles ${styles}."
  echo
  python3 "$root/scripts/results_tables.py" "$records" "$styles"
} >"$table"
cat "$table"

if [[ $write_doc -eq 1 ]]; then
  python3 - "$root/docs/results.md" "$table" <<'PY'
import sys
doc_path, table_path = sys.argv[1:3]
doc = open(doc_path).read()
begin, end = "<!-- results:begin -->", "<!-- results:end -->"
if begin not in doc or end not in doc:
    sys.exit("results: %s has no %s ... %s markers" % (doc_path, begin, end))
head, rest = doc.split(begin, 1)
_, tail = rest.split(end, 1)
open(doc_path, "w").write(head + begin + "\n" + open(table_path).read() + end + tail)
PY
  echo "results: wrote the table into docs/results.md" >&2
fi
