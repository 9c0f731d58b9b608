#!/usr/bin/env python3
"""Estimated camera extrinsics against the truth (issue 18's planted extrinsic error).

  scripts/extrinsic_check.py RUN_DIR TRUE_DATASET

RUN_DIR: a replay with estimate_extrinsic (its stats.json "extrinsic" object holds T_b_c per
camera). TRUE_DATASET: a dataset whose mav0/camN/sensor.yaml holds the true T_BS (the same
preset simulated without --extrinsic-error-*). Prints per camera the rotation (deg) and
translation (mm) left between the estimate and the truth, and the stereo baseline's change."""
import json
import math
import re
import sys


def true_T(dataset, cam):
    text = open(f"{dataset}/mav0/cam{cam}/sensor.yaml").read()
    block = text[text.index('T_BS'):]
    data = re.search(r'data:\s*\[([^\]]*)\]', block).group(1)
    v = [float(x) for x in data.replace('\n', ' ').split(',')]
    return [v[0:3], v[4:7], v[8:11]], [v[3], v[7], v[11]]


def quat_to_R(x, y, z, w):
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def angle_deg(Ra, Rb):
    tr = sum(Ra[k][i] * Rb[k][i] for i in range(3) for k in range(3))  # trace(Ra^T Rb)
    return math.degrees(math.acos(max(-1.0, min(1.0, (tr - 1) / 2))))


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    run, dataset = sys.argv[1:]
    e = json.load(open(f"{run}/stats.json"))['extrinsic']
    print(f"estimated {e['estimated']}, released {e['released_s']} s")
    p_est = []
    for c in (0, 1):
        R_true, p_true = true_T(dataset, c)
        R_est = quat_to_R(*e[f'cam{c}_q_b_c'])
        p = e[f'cam{c}_p_b_c_m']
        p_est.append(p)
        err_mm = 1e3 * math.dist(p, p_true)
        print(f"cam{c}: rotation {angle_deg(R_true, R_est):.3f} deg, translation {err_mm:.2f} mm from the truth")
    b_true = math.dist(true_T(dataset, 0)[1], true_T(dataset, 1)[1])
    print(f"baseline {1e3 * math.dist(*p_est):.3f} mm, truth {1e3 * b_true:.3f} mm")
    return 0


if __name__ == '__main__':
    sys.exit(main())
