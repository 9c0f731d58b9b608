#!/usr/bin/env python3
"""A long flight for the bounded-memory check (issue 17): a shared ground-truth trajectory flown
forwards, then backwards along the same path, and so on, until --duration seconds.

  scripts/back_and_forth.py ../shared/data/euroc/groundtruth/V102_GT.txt bf.txt --duration 600

The output is in the same format as the input (`t[ns], x, y, z, qw, qx, qy, qz`, cam0, q = R_CW),
for `umsvins simulate --trajectory bf.txt --duration 0`. A backward leg visits the forward leg's
poses in reverse order at the same spacing, so position and attitude are continuous at every
turn; the velocity is continuous only where the input starts and ends at rest (V102 does: both
ends under 1 cm/s)."""
import argparse
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("trajectory")
    ap.add_argument("out")
    ap.add_argument("--duration", type=float, default=600.0, help="s of flight to write (default 600)")
    a = ap.parse_args()
    rows = []
    with open(a.trajectory) as f:
        for n, line in enumerate(f, 1):
            if line.startswith("#") or not line.strip():
                continue
            v = line.strip().split(",")
            if len(v) != 8:
                sys.exit(f"{a.trajectory}:{n}: expected 8 comma-separated values, got {len(v)}")
            rows.append((int(float(v[0])), v[1:]))
    if len(rows) < 2:
        sys.exit(f"{a.trajectory}: fewer than 2 poses")
    end_ns = rows[0][0] + int(a.duration * 1e9)
    with open(a.out, "w") as out:
        out.write("#timestamp [ns],x [m],y [m],z [m],qw,qx,qy,qz (back and forth from %s)\n" % a.trajectory)
        i, step, legs, written, t = 0, 1, 1, 0, rows[0][0]
        while t <= end_ns:
            out.write("%d,%s\n" % (t, ",".join(rows[i][1])))
            written += 1
            if not 0 <= i + step < len(rows):
                step, legs = -step, legs + 1  # turn: the next leg retraces this one
            t += abs(rows[i + step][0] - rows[i][0])
            i += step
    print(f"{a.out}: {written} poses, {legs} legs, {(end_ns - rows[0][0]) * 1e-9:.1f} s")


if __name__ == "__main__":
    main()
