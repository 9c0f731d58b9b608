#!/usr/bin/env python3
"""The tables of docs/results.md from scripts/results.sh's run records (one JSON object per line:
flight, scenario, style, ate text, poses, first_move_s, the replay's stats.json).

Usage: results_tables.py RECORDS_JSONL STYLES   (STYLES: comma-separated, the column order)
"""
import json
import sys


def vio_time_s(stats):
    for change in stats.get("modes", []) or []:
        if isinstance(change, dict) and change.get("to") == "VIO":
            return change.get("t_s")
    return None


def fmt(x, spec, missing="-"):
    return spec % x if isinstance(x, (int, float)) else missing


def vio_delay(rec):
    """s from the first moving frame to VIO (0 when VIO came first, as at a standstill start)."""
    t = vio_time_s(rec["stats"])
    if t is None:
        return "never"
    move = rec.get("first_move_s")
    if move is None:
        return fmt(t, "%.2f") + " (no motion)"
    return "%.2f" % max(0.0, t - move)


def init_case(rec):
    init = rec["stats"].get("init")
    if not isinstance(init, dict) or "success" not in init:
        return "-"
    if not init.get("success"):
        return "failed"
    return {"standstill": "rest", "visual-imu alignment": "align"}.get(init.get("case"), init.get("case") or "?")


def pose_share(rec):
    frames = rec["stats"].get("frames")
    return fmt(100.0 * rec["poses"] / frames, "%.1f") if frames else "-"


def load(rec):
    s = rec["stats"]
    cpu, dur = s.get("processing_cpu_s"), s.get("duration_s")
    return fmt(cpu / dur, "%.3f") if isinstance(cpu, (int, float)) and isinstance(dur, (int, float)) and dur > 0 else "-"


def modes_seen(rec):
    seen = []
    for change in rec["stats"].get("modes", []) or []:
        if not isinstance(change, dict):
            continue
        for m in ([change.get("from")] if not seen else []) + [change.get("to")]:
            if m is not None and (not seen or seen[-1] != m):
                seen.append(m)
    return " > ".join(seen) if seen else "-"


def accuracy_table(rows, styles):
    head = ["flight (simulated)", "scenario"]
    head += ["ATE RMSE [m] %s" % s for s in styles]
    head += ["VIO after first motion [s] %s" % "/".join(styles), "init %s" % "/".join(styles),
             "frames with pose [%%] %s" % "/".join(styles), "modes seen (%s)" % styles[0],
             "CPU / real time %s" % "/".join(styles)]
    print("| " + " | ".join(head) + " |")
    print("|" + " --- |" * len(head))
    for (flight, scenario), by_style in rows:
        cells = [flight, scenario]
        cells += [by_style[s]["ate"] if s in by_style else "-" for s in styles]
        for fn in (vio_delay, init_case, pose_share):
            cells.append(" / ".join(fn(by_style[s]) if s in by_style else "-" for s in styles))
        first = by_style.get(styles[0])
        cells.append(modes_seen(first) if first else "-")
        cells.append(" / ".join(load(by_style[s]) if s in by_style else "-" for s in styles))
        print("| " + " | ".join(cells) + " |")


def budget_cells(rec):
    b = (rec["stats"].get("accuracy") or {}).get("budget")
    if not isinstance(b, dict):
        return ["-"] * 7
    phases = b.get("phases") or {}

    def phase(name):
        p = phases.get(name) or {}
        if not p.get("poses"):
            return "-"
        return "%s in %.1f s" % (fmt(p.get("ate_rmse_m"), "%.4f"), p.get("duration_s", 0.0))

    w = b.get("worst_window") or {}
    worst = "-" if not w.get("found") else "%s at %.1f-%.1f s (%s)" % (
        fmt(w.get("rmse_m"), "%.4f"), w.get("start_s", 0.0), w.get("end_s", 0.0), w.get("mode", "?"))
    return [fmt(b.get("ate_rmse_m"), "%.4f"), phase("VO"), phase("VIO"), fmt(b.get("scale_error_pct"), "%+.2f"),
            fmt(b.get("yaw_drift_deg_per_min"), "%+.2f"), fmt(b.get("final_drift_pct"), "%.2f"), worst]


def budget_table(rows, styles):
    head = ["flight", "scenario", "style", "ATE [m]", "VO phase: ATE [m]", "VIO phase: ATE [m]",
            "scale error [%]", "yaw drift [deg/min]", "final drift [% of path]", "worst 5 s: RMSE [m]"]
    print("| " + " | ".join(head) + " |")
    print("|" + " --- |" * len(head))
    for (flight, scenario), by_style in rows:
        for s in styles:
            if s in by_style:
                print("| " + " | ".join([flight, scenario, s] + budget_cells(by_style[s])) + " |")


def main():
    records_path, styles = sys.argv[1], sys.argv[2].split(",")
    rows, index = [], {}
    with open(records_path) as f:
        for line in f:
            if not line.strip():
                continue
            rec = json.loads(line)
            key = (rec["flight"], rec["scenario"])
            if key not in index:
                index[key] = {}
                rows.append((key, index[key]))
            index[key][rec["style"]] = rec
    accuracy_table(rows, styles)
    print()
    print("Error budget (profiling/eval error_budget; docs/evaluation.md defines each figure):")
    print()
    budget_table(rows, styles)


if __name__ == "__main__":
    main()
