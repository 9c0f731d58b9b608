#!/usr/bin/env bash
# Regenerates the measured tables of docs/results.md: simulated flights of the shared EuRoC
# ground-truth trajectories, each `umsvins simulate` -> `umsvins replay` -> `umsvins eval`
# (ATE RMSE after SE(3) alignment), plus the initialization and mode figures of stats.json.
#
# Usage: scripts/results.sh [--quick] [--duration S] [--build DIR] [--work DIR] [--keep] [--write]
#   --quick   nominal on MH01 and V101, scenarios on V101 only, 20 s cuts (about 1/7 of the work)
#   default   nominal on all 7 shared trajectories, scenarios on MH01 and V102 (the paper's
#             30-run sequences: factory hall and small room), 60 s cuts
#   --duration  cut length in s instead of 60 (20 with --quick), e.g. 2 for a smoke test
#   --build   build folder holding board/host/umsvins (default build/host, as scripts/demo.sh)
#   --work    folder for the datasets and replays (default: a temporary folder, removed at exit)
#   --keep    keep each simulated dataset (about 0.5 GB per 60 s flight); default: deleted after use
#   --write   also put the table into docs/results.md between its results markers
# The table goes to stdout (markdown); progress to stderr.
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

while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) quick=1 ;;
    --keep) keep=1 ;;
    --write) write_doc=1 ;;
    --build) build="$2"; shift ;;
    --duration) duration_override="$2"; shift ;;
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

# One markdown row from a finished run: ATE text, stats.json, trajectory.tum (either may be missing).
row() {  # flight scenario ate_text stats_json trajectory_tum
  python3 - "$@" <<'PY'
import json, os, sys
flight, scenario, ate, stats_path, tum_path = sys.argv[1:6]
stats = {}
if os.path.exists(stats_path):
    try:
        with open(stats_path) as f:
            stats = json.load(f)
    except ValueError as e:
        ate = ate + " (stats.json unreadable: %s)" % e
frames = stats.get("frames")
poses = 0
if os.path.exists(tum_path):
    with open(tum_path) as f:
        poses = len({l.split()[0] for l in f if l.strip() and not l.startswith("#")})
share = "-" if not frames else "%.1f" % (100.0 * poses / frames)
init = stats.get("init")
if not isinstance(init, dict) or "success" not in init:
    init_text = "-"
elif init.get("success"):
    t = init.get("time_s")
    init_text = ("%.2f" % t if isinstance(t, (int, float)) else "yes") + \
        (" (case %s)" % init["case"] if init.get("case") not in (None, "") else "")
else:
    init_text = "failed"
seen = []
def see(m):
    if m is not None and (not seen or seen[-1] != str(m)):
        seen.append(str(m))
# modes: a list of changes {t_s, from, to, reason} (or {t, mode}): the modes in the order entered.
for change in stats.get("modes", []) or []:
    if isinstance(change, dict):
        if not seen:
            see(change.get("from"))
        see(change.get("to", change.get("mode")))
    else:
        see(change)
modes = " > ".join(seen) if seen else "-"
cpu, dur = stats.get("processing_cpu_s"), stats.get("duration_s")
load = "%.3f" % (cpu / dur) if isinstance(cpu, (int, float)) and isinstance(dur, (int, float)) and dur > 0 else "-"
print("| %s | %s | %s | %s | %s | %s | %s |" % (flight, scenario, ate, share, init_text, modes, load))
PY
}

run_one() {  # flight scenario
  local flight="$1" scenario="$2"
  local name="${flight}_${scenario}"
  local ds="$work/$name" out="$work/$name.out"
  local ate="-"
  echo "results: $name: simulate ${duration} s" >&2
  if ! "$umsvins" simulate --trajectory "$gt_dir/${flight}_GT.txt" --scenario "$scenario" --seed 1 \
      --duration "$duration" --out "$ds" --quiet >"$work/$name.simulate.log" 2>&1; then
    row "$flight" "$scenario" "simulate failed: $(tail -n 1 "$work/$name.simulate.log")" /nonexistent /nonexistent
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
  row "$flight" "$scenario" "$ate" "$out/stats.json" "$out/trajectory.tum"
  [[ $keep -eq 1 ]] || rm -rf "$ds"
}

table="$work/results_table.md"
{
  echo "Measured $(date -u +%Y-%m-%d) at commit $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)" \
       "with \`scripts/results.sh$([[ $quick -eq 1 ]] && echo ' --quick')$([[ -n "$duration_override" ]] && echo " --duration $duration_override")\`: simulated ${duration} s cuts," \
       "seed 1, ATE RMSE after SE(3) alignment."
  echo
  echo "| flight (simulated) | scenario | ATE RMSE [m] | frames with pose [%] | init time [s] | modes seen | CPU / real time |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  for f in $nominal_flights; do run_one "$f" nominal; done
  for f in $scenario_flights; do
    for s in $scenarios; do run_one "$f" "$s"; done
  done
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
