#!/usr/bin/env python3
"""Map reuse against ground truth (issue 17's acceptance), with no alignment of the second run.

  scripts/map_reuse_check.py FIRST_RUN_DIR SECOND_RUN_DIR GROUNDTRUTH_CSV

The first run (umsvins replay ... --save-map F) defines the map frame. Its trajectory_map.tum is
aligned to the ground truth once (4-DoF: yaw and translation; both frames are levelled to
gravity), which expresses the ground truth in the map frame. The second run (--load-map F) is
then compared as it is: its map poses against that ground truth, as flown (trajectory_map_live.tum)
and in the final map (trajectory_map.tum). Prints the RMSE and the maximum (m) of each, and how
long after its first frame the second run had its first map pose in flight."""
import bisect
import math
import sys


def read_tum(path):
    out = []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = line.split()
        sec, _, frac = v[0].partition('.')
        out.append((int(sec) * 1_000_000_000 + int((frac + '000000000')[:9]), [float(x) for x in v[1:4]]))
    return out


def read_gt(path):
    t, p = [], []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = line.split(',')
        t.append(int(v[0]))
        p.append([float(x) for x in v[1:4]])
    return t, p


def gt_at(t_gt, p_gt, t_ns):
    i = min(bisect.bisect_left(t_gt, t_ns), len(t_gt) - 1)
    if i > 0 and abs(t_gt[i - 1] - t_ns) < abs(t_gt[i] - t_ns):
        i -= 1
    return p_gt[i] if abs(t_gt[i] - t_ns) < 3_000_000 else None


def align_4dof(src, dst):
    """yaw, t with dst ~ Rz(yaw) src + t (least squares)."""
    n = len(src)
    cs = [sum(p[k] for p in src) / n for k in range(3)]
    cd = [sum(p[k] for p in dst) / n for k in range(3)]
    sx = sum((a[0] - cs[0]) * (b[0] - cd[0]) + (a[1] - cs[1]) * (b[1] - cd[1]) for a, b in zip(src, dst))
    sy = sum((a[0] - cs[0]) * (b[1] - cd[1]) - (a[1] - cs[1]) * (b[0] - cd[0]) for a, b in zip(src, dst))
    yaw = math.atan2(sy, sx)
    c, s = math.cos(yaw), math.sin(yaw)
    t = [cd[0] - (c * cs[0] - s * cs[1]), cd[1] - (s * cs[0] + c * cs[1]), cd[2] - cs[2]]
    return yaw, t


def apply(yaw, t, p):
    c, s = math.cos(yaw), math.sin(yaw)
    return [c * p[0] - s * p[1] + t[0], s * p[0] + c * p[1] + t[1], p[2] + t[2]]


def main():
    if len(sys.argv) != 4:
        print(__doc__)
        return 2
    first, second, gt_path = sys.argv[1:]
    t_gt, p_gt = read_gt(gt_path)
    run1 = [(t, p, gt_at(t_gt, p_gt, t)) for t, p in read_tum(f"{first}/trajectory_map.tum")]
    run1 = [r for r in run1 if r[2] is not None]
    yaw, t = align_4dof([r[1] for r in run1], [r[2] for r in run1])
    print(f"first run aligned to ground truth: yaw {math.degrees(yaw):.2f} deg, t {t[0]:.3f} {t[1]:.3f} {t[2]:.3f} m")
    odom = read_tum(f"{second}/trajectory.tum")
    for name in ['trajectory_map_live.tum', 'trajectory_map.tum']:
        poses = read_tum(f"{second}/{name}")
        errs = []
        for tt, p in poses:
            g = gt_at(t_gt, p_gt, tt)
            if g is not None:
                errs.append(math.dist(apply(yaw, t, p), g))
        if not errs:
            print(f"second run, {name}: no map pose (never placed in the map)")
            return 1
        rmse = math.sqrt(sum(e * e for e in errs) / len(errs))
        print(f"second run, {name}, with no alignment: {len(errs)} of {len(odom)} frames, "
              f"first {(poses[0][0] - odom[0][0]) * 1e-9:.2f} s after its first pose; "
              f"RMSE {rmse:.4f} m, max {max(errs):.4f} m")
    return 0


if __name__ == '__main__':
    sys.exit(main())
