#!/usr/bin/env python3
"""scripts/ate_compare.py on a made-up weights.sh work folder: pairing, the figures, the errors."""
import json
import math
import os
import subprocess
import sys
import tempfile

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts", "ate_compare.py")


def write_run(work, name, flight, ate_m, rpe_m=None, rpe10_m=None):
    os.makedirs(os.path.join(work, name, flight))
    stats = {"accuracy": {"ate_rmse_m": ate_m}} if ate_m is not None else {"accuracy": {}}
    if rpe_m is not None:
        stats["accuracy"]["rpe_1s_m"] = rpe_m
    if rpe10_m is not None:
        stats["accuracy"]["rpe_10s_m"] = rpe10_m
    with open(os.path.join(work, name, flight, "stats.json"), "w") as f:
        json.dump(stats, f)


def run(*args):
    p = subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def main():
    failures = []

    def check(ok, what):
        if not ok:
            failures.append(what)

    with tempfile.TemporaryDirectory() as work:
        write_run(work, "base_data_f1.0", "MH01", 0.002, 0.0010, 0.004)
        write_run(work, "base_data_f1.0", "V101", 0.004, 0.0020, 0.008)
        write_run(work, "new_data_f1.0", "MH01", 0.001, 0.0011, 0.008)   # ATE halved, RPE 1 s +10 %, 10 s doubled
        write_run(work, "new_data_f1.0", "V101", 0.004, 0.0022, 0.008)   # ATE the same, RPE 1 s +10 %, 10 s the same
        write_run(work, "base_ph_f1.0", "MH01", 0.010)
        write_run(work, "new_ph_f1.0", "MH01", 0.020)     # doubled
        write_run(work, "base_ph_f1.0", "V102", 0.010)    # no partner: left out
        write_run(work, "base_ph_f0.99", "MH01", 0.010)   # no new_ph_f0.99 run: left out
        write_run(work, "base_ph_f1.01", "MH01", 0.010)
        write_run(work, "new_ph_f1.01", "MH01", None)     # no ATE: warned, left out
        code, out, err = run(work, "base", "new")
        check(code == 0, "exit 0 with pairs, got %d (%s)" % (code, err))
        rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
                for line in out.splitlines() if line.startswith("| data") or line.startswith("| ph")}
        # data: log(0.5) and log(1): mean -34.7 %, se = |log 0.5| / 2 = 34.7 %.
        half = 100 * math.log(0.5)
        check(rows.get("data") == ["2", "3.000", "2.500", "%+.1f %% (%.1f)" % (half / 2, -half / 2), "0 / 1"],
              "data row %s" % rows.get("data"))
        # ph: one pair, doubled: +69.3 %, no spread from one run.
        check(rows.get("ph") == ["1", "10.000", "20.000", "%+.1f %% (nan)" % (-half), "1 / 0"], "ph row %s" % rows.get("ph"))
        check("has no ate_rmse_m" in err, "missing ATE not reported: %r" % err)
        # The 1 s RPE of the same runs: both +10 %, no spread; ph has none (warned, left out).
        code, out, err = run("--metric", "rpe1s", work, "base", "new")
        check(code == 0, "rpe1s: exit 0 with pairs, got %d (%s)" % (code, err))
        check("mean RPE 1 s base [mm]" in out, "rpe1s header: %r" % out)
        rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
                for line in out.splitlines() if line.startswith("| data") or line.startswith("| ph")}
        tenth = 100 * math.log(1.1)
        check(rows.get("data") == ["2", "1.500", "1.650", "%+.1f %% (%.1f)" % (tenth, 0.0), "2 / 0"],
              "rpe1s data row %s" % rows.get("data"))
        check("ph" not in rows and "has no rpe_1s_m" in err, "rpe1s ph: %s, %r" % (rows.get("ph"), err))
        code, _, err = run("--metric", "rmse", work, "base", "new")
        check(code == 64 and "unknown --metric 'rmse'" in err, "unknown metric: exit %d, %r" % (code, err[:80]))
        # The 10 s RPE: doubled and the same, as the data ATE halved and the same (mirrored).
        code, out10, err = run("--metric", "rpe10s", work, "base", "new")
        rows10 = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
                  for line in out10.splitlines() if line.startswith("| data")}
        check(code == 0 and "mean RPE 10 s base [mm]" in out10, "rpe10s: exit %d, %r" % (code, out10[:120]))
        check(rows10.get("data") == ["2", "6.000", "8.000", "%+.1f %% (%.1f)" % (-half / 2, -half / 2), "1 / 0"],
              "rpe10s data row %s" % rows10.get("data"))
        code, out2, _ = run("--metric=rpe1s", work, "base", "new")
        check(code == 0 and out2 == out, "--metric=rpe1s: exit %d" % code)
        code, out, err = run(work, "base", "other")
        check(code == 1 and "pairs with one of other_*" in err, "no pairs: exit %d, %r" % (code, err))
        code, _, err = run(work, "base")
        check(code == 64 and "Usage" in err, "usage: exit %d" % code)
    for f in failures:
        print("FAILED:", f)
    print("ate_compare_test: %d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
