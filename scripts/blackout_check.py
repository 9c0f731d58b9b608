#!/usr/bin/env python3
"""Relocalization after a blackout: a run with the blackout against the same flight without it.

Reads the blackout's end from the dataset's sim_events.csv and prints, per interval after the
images return, the largest distance between the two runs' poses at equal stamps, for the map
trajectory as flown (trajectory_map_live.tum: what the acceptance's "within 3 s" is about), the
final map trajectory (trajectory_map.tum) and the odometry (trajectory.tum).

usage: scripts/blackout_check.py DATASET_WITH_BLACKOUT RUN_WITH_BLACKOUT RUN_WITHOUT
"""
import sys


def read_tum(path):
    poses = {}
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = line.split()
        poses[round(float(v[0]), 3)] = [float(x) for x in v[1:4]]
    return poses


def blackout_end_s(dataset):
    for line in open(f"{dataset}/sim_events.csv"):
        v = line.strip().split(',')
        if len(v) == 2 and v[1] == 'blackout_end':
            return int(v[0]) * 1e-9
    sys.exit(f"{dataset}/sim_events.csv: no blackout_end event")


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__.strip().split('\n')[-1])
    dataset, with_run, without_run = sys.argv[1:]
    t_end = blackout_end_s(dataset)
    bins = [(0, 1), (1, 2), (2, 3), (3, 5), (5, 15), (15, 25)]
    print('after the images return | ' + ' | '.join(f'{a}-{b} s' for a, b in bins))
    for name in ['trajectory_map_live.tum', 'trajectory_map.tum', 'trajectory.tum']:
        a, b = read_tum(f"{with_run}/{name}"), read_tum(f"{without_run}/{name}")
        cells = []
        for lo, hi in bins:
            d = [sum((p[i] - b[t][i]) ** 2 for i in range(3)) ** 0.5
                 for t, p in a.items() if t in b and t_end + lo <= t < t_end + hi]
            cells.append(f"{max(d):.3f} m" if d else "-")
        print(f"{name}, max difference | " + ' | '.join(cells))


if __name__ == '__main__':
    main()
