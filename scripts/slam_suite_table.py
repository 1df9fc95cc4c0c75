#!/usr/bin/env python3
"""Markdown table of the obm-map robustness suite (scripts/slam_suite.sh).

    scripts/slam_suite_table.py OUT_DIR

Reads OUT_DIR/runs/SEQ.PIPELINE/ (metrics.json, timing.json, frames.csv, trajectory_kitti.txt and
the ground truth named in metrics.json) and prints one row per run. A "silent" frame is one
obm-map reports as tracked whose motion since the previous frame is off by more than 0.2 m or 1
degree from the ground truth's: a slide nobody was told about. "wrong loops" are accepted loop
closures whose relative pose is off the ground truth's by more than 0.5 m or 2 degrees (obm-map's
metrics.json, `loops_wrong`).
"""
import json
import math
import os
import sys

SILENT_TRANSLATION = 0.2  # [m]
SILENT_ROTATION_DEG = 1.0


def read_kitti(path):
    """KITTI pose file -> list of 3x4 row-major matrices (lists of 12 floats)."""
    out = []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            v = line.split()
            if not v:
                continue
            if len(v) != 12:
                sys.exit("slam_suite_table.py: %s line %d: %d numbers, expected 12" % (path, n, len(v)))
            out.append([float(x) for x in v])
    return out


def relative(a, b):
    """a^-1 b for 3x4 rigid transforms: (R, t) as (9-list row-major, 3-list)."""
    Ra = [[a[0], a[1], a[2]], [a[4], a[5], a[6]], [a[8], a[9], a[10]]]
    ta = [a[3], a[7], a[11]]
    Rb = [[b[0], b[1], b[2]], [b[4], b[5], b[6]], [b[8], b[9], b[10]]]
    tb = [b[3], b[7], b[11]]
    R = [[sum(Ra[k][i] * Rb[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    t = [sum(Ra[k][i] * (tb[k] - ta[k]) for k in range(3)) for i in range(3)]
    return R, t


def motion_error(gt0, gt1, est0, est1):
    """Translation [m] and rotation [deg] of (gt0^-1 gt1)^-1 (est0^-1 est1)."""
    Rg, tg = relative(gt0, gt1)
    Re, te = relative(est0, est1)
    R = [[sum(Rg[k][i] * Re[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    t = [sum(Rg[k][i] * (te[k] - tg[k]) for k in range(3)) for i in range(3)]
    c = max(-1.0, min(1.0, 0.5 * (R[0][0] + R[1][1] + R[2][2] - 1.0)))
    return math.sqrt(sum(x * x for x in t)), math.degrees(math.acos(c))


def frame_statuses(path):
    status = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            status.append(line.split(",")[2])
    return status


def silent_frames(run, metrics):
    # obm-sim writes poses.txt (KITTI format, one pose per frame) next to every sequence; the
    # ground truth obm-map read may be another format (an RGB-D folder's groundtruth.txt).
    gt_path = os.path.join(metrics.get("input", ""), "poses.txt")
    if not os.path.exists(gt_path):
        gt_path = metrics.get("ground_truth")
    est_path = os.path.join(run, "trajectory_kitti.txt")
    if not gt_path or not os.path.exists(gt_path) or not os.path.exists(est_path):
        return None
    gt, est = read_kitti(gt_path), read_kitti(est_path)
    status = frame_statuses(os.path.join(run, "frames.csv"))
    n = min(len(gt), len(est), len(status))
    silent = 0
    for i in range(1, n):
        if status[i] != "tracked":
            continue
        dt, dr = motion_error(gt[i - 1], gt[i], est[i - 1], est[i])
        if dt > SILENT_TRANSLATION or dr > SILENT_ROTATION_DEG:
            silent += 1
    return silent


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    runs_dir = os.path.join(out, "runs")
    names = sorted(d for d in os.listdir(runs_dir) if os.path.isdir(os.path.join(runs_dir, d)))
    order = ["corridor", "open_road", "urban", "turn_gaps", "turn_jumps", "long_gaps", "revisits",
             "revisit_gaps", "offset_revisits", "indoor_walk", "indoor_fast", "indoor_plain"]
    names.sort(key=lambda n: (order.index(n.split(".")[0]) if n.split(".")[0] in order else 99, n))
    print("| sequence | pipeline | frames | length | t_err [%] | r_err [°/100 m] | ATE RMSE | recovered "
          "| bridged | restarts | loops | wrong loops | silent frames | frames/s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in names:
        run = os.path.join(runs_dir, name)
        try:
            m = json.load(open(os.path.join(run, "metrics.json")))
            t = json.load(open(os.path.join(run, "timing.json")))
        except OSError:
            continue
        seq, _, pipeline = name.partition(".")
        fmt = lambda x, f: "—" if x is None else f.format(x)
        silent = silent_frames(run, m)
        label = m["matcher"]
        if pipeline.startswith("obmnet_"):  # slam_suite.sh --model NAME=...
            label += " (%s)" % pipeline[len("obmnet_"):]
        print("| %s | %s | %d | %.0f m | %s | %s | %.3f m | %d | %d | %d | %d | %s | %s | %.1f |" % (
            seq, label, m["frames"], m["ground_truth_length_m"],
            fmt(m.get("t_err_percent"), "{:.3f}"), fmt(m.get("r_err_deg_per_100m"), "{:.3f}"),
            m["ate_rmse_m"], m["frames_recovered"], m["frames_bridged"], m["map_restarts"],
            m["loops_accepted"], fmt(m.get("loops_wrong"), "{:d}"), fmt(silent, "{:d}"),
            t["frames_per_second"]))


if __name__ == "__main__":
    main()
