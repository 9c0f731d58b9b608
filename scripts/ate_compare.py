#!/usr/bin/env python3
"""Paired ATE (or 1 s / 10 s RPE) comparison of two configurations replayed by scripts/weights.sh.

weights.sh writes WORK/NAME/FLIGHT/stats.json. Name the runs PREFIX_GROUP_RUN, e.g.
whole_data_f1.0 and sparse_data_f1.0 (GROUP: the datasets' style, RUN: the perturbation such as
an F_threshold), and this script pairs every BASE_GROUP_RUN/FLIGHT with NEW_GROUP_RUN/FLIGHT.

Per group it prints the mean of the metric for each configuration over the paired runs and the
mean over the pairs of log(new / base) with its standard error, and how many runs got worse or
better. The simulated flights are chaotic (a 1 % change of F_threshold moves a photo flight's
ATE by up to 40 %), so a difference of a few per cent needs this spread beside it; runs of one
rendering (perturbations such as F_threshold) are correlated, so there the error is a lower
bound: render more seeds instead (scripts/render_flights.sh).

--metric rpe1s compares stats.json's accuracy.rpe_1s_m instead (the mean translation error over
1 s segments): a per-frame change moves it about 4x less chaotically than the ATE (per-run sd of
the log-ratio under a rounding change 4.6 % against 19 %: docs/performance.md, "An ensemble of
seeds"), so it resolves changes of a few per cent with a few dozen runs. stats.json files written
before it existed (2026-12-06) have no rpe_1s_m.

--metric rpe10s compares accuracy.rpe_10s_m, the mean error over 10 s segments: it sees a change
of the drift rate, which the 1 s RPE does not (fewer detections left the 1 s RPE unchanged and
raised the 10 s RPE and the ATE: docs/performance.md, session 31), with about half the ATE's
per-run spread. stats.json files written before 2026-12-07 have no rpe_10s_m.

Usage: ate_compare.py [--metric ate|rpe1s|rpe10s] WORK BASE_PREFIX NEW_PREFIX
Exit status: 0, or 1 when no run pairs up.
"""
import json
import math
import os
import sys


METRICS = {"ate": ("ate_rmse_m", "ATE"), "rpe1s": ("rpe_1s_m", "RPE 1 s"), "rpe10s": ("rpe_10s_m", "RPE 10 s")}


def metric_m(path, key):
    with open(path) as f:
        value = json.load(f).get("accuracy", {}).get(key)
    return value if isinstance(value, (int, float)) and value > 0 else None


def paired_runs(work, base, new, key="ate_rmse_m"):
    """{group: [(run/flight, value_base, value_new)]} for the runs both prefixes hold."""
    groups = {}
    for name in sorted(os.listdir(work)):
        if not name.startswith(base + "_"):
            continue
        suffix = name[len(base) + 1:]
        other = os.path.join(work, new + "_" + suffix)
        if not os.path.isdir(other):
            continue
        group = suffix.split("_")[0]
        for flight in sorted(os.listdir(os.path.join(work, name))):
            a = os.path.join(work, name, flight, "stats.json")
            b = os.path.join(other, flight, "stats.json")
            if not (os.path.isfile(a) and os.path.isfile(b)):
                continue
            v_base, v_new = metric_m(a, key), metric_m(b, key)
            if v_base is None or v_new is None:
                print("ate_compare: %s or %s has no %s" % (a, b, key), file=sys.stderr)
                continue
            groups.setdefault(group, []).append((suffix + "/" + flight, v_base, v_new))
    return groups


def summary(pairs):
    n = len(pairs)
    ratios = [math.log(b / a) for _, a, b in pairs]
    mean = sum(ratios) / n
    se = math.sqrt(sum((r - mean) ** 2 for r in ratios) / (n - 1) / n) if n > 1 else float("nan")
    worse = sum(1 for _, a, b in pairs if b > a)
    better = sum(1 for _, a, b in pairs if b < a)
    mean_a = sum(a for _, a, _ in pairs) / n
    mean_b = sum(b for _, _, b in pairs) / n
    return n, mean_a, mean_b, mean, se, worse, better


def main(argv):
    args = argv[1:]
    metric = "ate"
    if args and args[0].startswith("--metric="):
        metric = args[0][len("--metric="):]
        args = args[1:]
    elif len(args) >= 2 and args[0] == "--metric":
        metric = args[1]
        args = args[2:]
    if metric not in METRICS:
        print("ate_compare: unknown --metric '%s' (ate, rpe1s or rpe10s)" % metric, file=sys.stderr)
        print(__doc__.strip(), file=sys.stderr)
        return 64
    if len(args) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 64
    work, base, new = args
    key, label = METRICS[metric]
    groups = paired_runs(work, base, new, key)
    if not groups:
        print("ate_compare: no run of %s_* in %s pairs with one of %s_* holding %s" % (base, work, new, key),
              file=sys.stderr)
        return 1
    print("| group | runs | mean %s %s [mm] | mean %s %s [mm] | mean log-ratio (se) | worse / better |" %
          (label, base, label, new))
    print("| --- | ---: | ---: | ---: | --- | --- |")
    for group in sorted(groups):
        n, mean_a, mean_b, mean, se, worse, better = summary(groups[group])
        print("| %s | %d | %.3f | %.3f | %+.1f %% (%.1f) | %d / %d |" %
              (group, n, 1000 * mean_a, 1000 * mean_b, 100 * mean, 100 * se, worse, better))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
