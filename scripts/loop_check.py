#!/usr/bin/env python3
"""Checks a replay's accepted loops against ground truth (issue 17's acceptance).

  scripts/loop_check.py RUN_DIR GROUNDTRUTH_CSV [--recent-s 20]

RUN_DIR holds loops.csv (umsvins replay --vocabulary). GROUNDTRUTH_CSV is EuRoC's
state_groundtruth_estimate0/data.csv (body = IMU poses, as the simulator writes them).
For every loop: the error of the measured T_loop_query against the ground truth's relative pose
(translation m, rotation deg); a loop is false when it is off by more than 0.1 m or 2 deg.
Revisits from ground truth: a pose within 1 m and 30 deg of yaw of a pose at least --recent-s
earlier (the closer's own exclusion window); printed as intervals with whether a loop fell in.
Exit 1 when a false loop was accepted."""
import argparse
import bisect
import math
import sys



def quat_to_rot(qw, qx, qy, qz):
    n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    w, x, y, z = qw / n, qx / n, qy / n, qz / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def pose(R, p):
    """(R, p): a rigid transform, R a 3x3 list, p a 3-list."""
    return (R, list(p))


def inv(T):
    R, p = T
    Rt = [[R[j][i] for j in range(3)] for i in range(3)]
    return (Rt, [-sum(Rt[i][k] * p[k] for k in range(3)) for i in range(3)])


def mul(A, B):
    Ra, pa = A
    Rb, pb = B
    R = [[sum(Ra[i][k] * Rb[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    return (R, [sum(Ra[i][k] * pb[k] for k in range(3)) + pa[i] for i in range(3)])


def norm(v):
    return math.sqrt(sum(x * x for x in v))


def read_groundtruth(path):
    t, T = [], []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = line.split(',')
        t.append(int(v[0]))
        T.append(pose(quat_to_rot(*map(float, v[4:8])), [float(x) for x in v[1:4]]))
    return t, T


def pose_at(t_gt, T_gt, t_ns):
    i = bisect.bisect_left(t_gt, t_ns)
    if i == len(t_gt):
        i -= 1
    if i > 0 and abs(t_gt[i - 1] - t_ns) < abs(t_gt[i] - t_ns):
        i -= 1
    if abs(t_gt[i] - t_ns) > 3_000_000:  # 3 ms
        raise ValueError(f"no ground truth within 3 ms of t = {t_ns} ns")
    return T_gt[i]


def stamp_ns(s):
    sec, _, frac = s.partition('.')
    return int(sec) * 1_000_000_000 + int((frac + '000000000')[:9])


def rot_deg(R):
    return math.degrees(math.acos(max(-1.0, min(1.0, (R[0][0] + R[1][1] + R[2][2] - 1) / 2))))


def check_loops(run_dir, t_gt, T_gt):
    rows, false_loops = [], 0
    for line in open(f"{run_dir}/loops.csv"):
        if line.startswith('#') or not line.strip():
            continue
        v = line.strip().split(',')
        tq, tc = stamp_ns(v[0]), stamp_ns(v[1])
        M = pose(quat_to_rot(float(v[14]), float(v[11]), float(v[12]), float(v[13])), [float(x) for x in v[8:11]])
        gt = mul(inv(pose_at(t_gt, T_gt, tc)), pose_at(t_gt, T_gt, tq))
        E = mul(inv(gt), M)
        e_m, e_deg = norm(E[1]), rot_deg(E[0])
        bad = e_m > 0.1 or e_deg > 2.0
        false_loops += bad
        sigma = (float(v[15]), float(v[16])) if len(v) > 16 else None
        refined = len(v) > 17 and v[17] == '1'
        rows.append((tq, tc, int(v[4]), e_m, e_deg, bad, int(v[7]), sigma, refined))
    return rows, false_loops


def revisits(t_gt, T_gt, recent_s, step=20):
    """Intervals (start, end) of ground-truth times that revisit an earlier place."""
    t = t_gt[::step]
    p = [T[1] for T in T_gt[::step]]
    yaw = [math.atan2(T[0][1][0], T[0][0][0]) for T in T_gt[::step]]
    hit = [False] * len(t)
    for i in range(len(t)):
        for j in range(len(t)):
            if t[j] >= t[i] - int(recent_s * 1e9):
                break
            dy = abs((yaw[j] - yaw[i] + math.pi) % (2 * math.pi) - math.pi)
            if dy < math.radians(30) and norm([p[j][k] - p[i][k] for k in range(3)]) < 1.0:
                hit[i] = True
                break
    out, start = [], None
    for i in range(len(t)):
        if hit[i] and start is None:
            start = t[i]
        if not hit[i] and start is not None:
            out.append((start, t[i - 1]))
            start = None
    if start is not None:
        out.append((start, t[-1]))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('run_dir')
    ap.add_argument('groundtruth')
    ap.add_argument('--recent-s', type=float, default=20.0)
    a = ap.parse_args()
    t_gt, T_gt = read_groundtruth(a.groundtruth)
    rows, false_loops = check_loops(a.run_dir, t_gt, T_gt)
    t0 = t_gt[0]
    for tq, tc, inl, e_m, e_deg, bad, reloc, sigma, refined in rows:
        stated = f"  sigma {sigma[0]:.4f} m {sigma[1]:.3f} deg" if sigma else ""
        print(f"loop {(tq - t0) * 1e-9:7.2f} s -> {(tc - t0) * 1e-9:7.2f} s  inliers {inl:3d}  "
              f"error {e_m:.4f} m {e_deg:.3f} deg{stated}{'  refined' if refined else ''}"
              f"{'  FALSE' if bad else ''}{'  (relocalization)' if reloc else ''}")
    errs = [r[3] for r in rows]
    print(f"loops: {len(rows)} accepted, {false_loops} false (> 0.1 m or 2 deg); "
          f"max error {max(errs) if errs else 0:.4f} m, {max([r[4] for r in rows]) if rows else 0:.3f} deg; "
          f"mean {sum(errs) / len(errs) if errs else 0:.4f} m, {sum(r[4] for r in rows) / len(rows) if rows else 0:.3f} deg; "
          f"{sum(1 for r in rows if r[8])} refined by the window")
    spans = revisits(t_gt, T_gt, a.recent_s)
    found = 0
    for s, e in spans:
        n = sum(1 for r in rows if s - 1e9 <= r[0] <= e + 1e9)
        found += n > 0
        print(f"revisit {(s - t0) * 1e-9:7.2f}-{(e - t0) * 1e-9:7.2f} s: {n} loops")
    print(f"revisits: {len(spans)} in ground truth, {found} with a loop")
    return 1 if false_loops else 0


if __name__ == '__main__':
    sys.exit(main())
