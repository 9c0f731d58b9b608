#!/usr/bin/env python3
"""Paired ATE comparison of two configurations replayed by scripts/weights.sh.

weights.sh writes WORK/NAME/FLIGHT/stats.json. Name the runs PREFIX_GROUP_RUN, e.g.
whole_data_f1.0 and sparse_data_f1.0 (GROUP: the datasets' style, RUN: the perturbation such as
an F_threshold), and this script pairs every BASE_GROUP_RUN/FLIGHT with NEW_GROUP_RUN/FLIGHT.

Per group it prints the mean ATE of each configuration over the paired runs and the mean over the
pairs of log(ATE new / ATE base) with its standard error, and how many runs got worse or better.
The simulated flights are chaotic (a 1 % change of F_threshold moves a photo flight by up to
40 %), so a difference of a few per cent needs this spread beside it; the runs of one flight are
correlated, so the error is a lower bound.

Usage: ate_compare.py WORK BASE_PREFIX NEW_PREFIX
Exit status: 0, or 1 when no run pairs up.
"""
import json
import math
import os
import sys


def ate_m(path):
    with open(path) as f:
        value = json.load(f).get("accuracy", {}).get("ate_rmse_m")
    return value if isinstance(value, (int, float)) and value > 0 else None


def paired_runs(work, base, new):
    """{group: [(run/flight, ate_base, ate_new)]} for the runs both prefixes hold."""
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
            ate_a, ate_b = ate_m(a), ate_m(b)
            if ate_a is None or ate_b is None:
                print("ate_compare: %s or %s has no ATE" % (a, b), file=sys.stderr)
                continue
            groups.setdefault(group, []).append((suffix + "/" + flight, ate_a, ate_b))
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
    if len(argv) != 4:
        print(__doc__.strip(), file=sys.stderr)
        return 64
    work, base, new = argv[1:4]
    groups = paired_runs(work, base, new)
    if not groups:
        print("ate_compare: no run of %s_* in %s pairs with one of %s_*" % (base, work, new), file=sys.stderr)
        return 1
    print("| group | runs | mean ATE %s [mm] | mean ATE %s [mm] | mean log-ratio (se) | worse / better |" % (base, new))
    print("| --- | ---: | ---: | ---: | --- | --- |")
    for group in sorted(groups):
        n, mean_a, mean_b, mean, se, worse, better = summary(groups[group])
        print("| %s | %d | %.3f | %.3f | %+.1f %% (%.1f) | %d / %d |" %
              (group, n, 1000 * mean_a, 1000 * mean_b, 100 * mean, 100 * se, worse, better))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
