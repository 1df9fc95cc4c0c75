#!/usr/bin/env python3
"""Table of scripts/long_run.sh: obm-map's frame rate and resident set over a long drive.

usage: long_run_table.py SAMPLES_CSV RUN_DIR SEQUENCE_DIR [--block N]

SAMPLES_CSV holds elapsed_s, rss_mb, frame (sampled while obm-map ran); RUN_DIR is obm-map's output
folder (metrics.json); SEQUENCE_DIR the KITTI folder with poses.txt, for the distance driven.
Prints a Markdown table: per block of N frames, the wall time, frames/s and the largest resident
set seen in it, then the resident set's growth per km after the first block (least squares).
"""
import csv
import json
import math
import os
import sys


def main(argv):
    block = 2000
    args = [a for a in argv[1:]]
    if '--block' in args:
        i = args.index('--block')
        block = int(args[i + 1])
        del args[i:i + 2]
    if len(args) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    samples_csv, run_dir, seq_dir = args
    with open(samples_csv) as f:
        rows = [(float(r['elapsed_s']), float(r['rss_mb']), int(r['frame'])) for r in csv.DictReader(f)]
    if not rows:
        print(f'{samples_csv}: no samples', file=sys.stderr)
        return 1
    # Distance driven up to each frame, from the ground-truth positions (camera frame, metres).
    dist = [0.0]
    prev = None
    with open(os.path.join(seq_dir, 'poses.txt')) as f:
        for line in f:
            v = [float(x) for x in line.split()]
            p = (v[3], v[7], v[11])
            if prev is not None:
                dist.append(dist[-1] + math.dist(p, prev))
            prev = p
    n_frames = max(r[2] for r in rows)
    # Once the progress bar shows the last frame the app optimises the graph a last time and writes
    # its outputs (the final map, the MRPT files): reported apart, not as part of the last block.
    outputs = [r for t, r, fr in rows if fr == n_frames]
    last = [row for row in rows if row[2] < n_frames]
    end_t = min(t for t, _, fr in rows if fr == n_frames)
    rows = last + [(end_t, last[-1][1] if last else float('nan'), n_frames)]

    def time_at(frame):
        """First sample time at which the progress bar showed >= frame (None if never)."""
        for t, _, fr in rows:
            if fr >= frame:
                return t
        return None

    print('| frames | km | wall time [s] | frames/s | resident set, largest [MB] |')
    print('|---|---:|---:|---:|---:|')
    pts = []
    start = 0
    while start < n_frames:
        end = min(start + block, n_frames)
        t0, t1 = time_at(max(start, 1)), time_at(end)
        rss = max((r for _, r, fr in rows if start <= fr <= end), default=float('nan'))
        km = dist[min(end, len(dist) - 1)] / 1000.0
        rate = (end - max(start, 1)) / (t1 - t0) if t0 is not None and t1 is not None and t1 > t0 else float('nan')
        print(f'| {start}–{end} | {km:.1f} | {t1 if t1 is not None else float("nan"):.0f} | {rate:.1f} | {rss:.0f} |')
        start = end
    for t, r, fr in rows:
        if fr > block and fr < len(dist):
            pts.append((dist[fr] / 1000.0, r))
    if len(pts) >= 2:
        mx = sum(p[0] for p in pts) / len(pts)
        my = sum(p[1] for p in pts) / len(pts)
        sxx = sum((p[0] - mx) ** 2 for p in pts)
        slope = sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx if sxx > 0 else float('nan')
        print(f'\nResident set after frame {block}: {slope:.1f} MB per km (least squares over {len(pts)} samples); '
              f'peak while mapping {max(r for _, r, _ in rows):.0f} MB'
              + (f', while writing the outputs {max(outputs):.0f} MB.' if outputs else '.'))
    metrics = os.path.join(run_dir, 'metrics.json')
    if os.path.exists(metrics):
        with open(metrics) as f:
            m = json.load(f)
        keys = [k for k in ('frames', 'keyframes', 'ate_rmse_m', 't_err_percent', 'r_err_deg_per_100m', 'loops_accepted', 'loops_wrong', 'keyframes_dropped', 'frames_recovered', 'frames_bridged', 'map_restarts') if k in m]
        print('metrics.json: ' + ', '.join(f'{k} {m[k]}' for k in keys))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
