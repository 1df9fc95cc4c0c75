#!/usr/bin/env python3
"""The clock offset between a trajectory and a TUM ground truth, and loops judged with it.

    scripts/tum_time_offset.py RUN_DIR GROUNDTRUTH.txt [--offset S] [--scan FROM TO STEP]

RUN_DIR is an obm-map output folder (trajectory_tum.txt; frames.csv and loops.csv for the loop
part) or an obm-o3d-odometry one (trajectory_tum.txt only). The ground truth is read at each pose's
time stamp + offset, interpolated (positions linearly, rotations by slerp) instead of taken from
the nearest sample as TUM's associate.py does: at the 40-145 deg/s of a hand-held camera turning
fast, 10 ms of clock offset is already 0.4-1.5 deg.

Prints (1) the one-frame RPE rotation RMSE of the trajectory against the truth for each offset of
the scan (default -50 ... +20 ms, step 5 ms): where the RPE is lowest, the truth and the depth time
stamps agree; and (2) with loops.csv, each accepted loop's error against the truth read at
--offset (default 0), with the wrong-loop bounds of obm-map (> 0.5 m or 2 deg) and the truth's own
angular rate at both ends.
"""
import argparse
import bisect
import csv
import math
import os
import sys


def qmul(a, b):
    x1, y1, z1, w1 = a
    x2, y2, z2, w2 = b
    return (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)


def qinv(q):
    return (-q[0], -q[1], -q[2], q[3])


def qrot(q, v):
    return qmul(qmul(q, (v[0], v[1], v[2], 0.0)), qinv(q))[:3]


def slerp(a, b, u):
    d = sum(x * y for x, y in zip(a, b))
    if d < 0:
        b, d = tuple(-x for x in b), -d
    if d > 0.9995:
        r = tuple(x + (y - x) * u for x, y in zip(a, b))
    else:
        th = math.acos(d)
        r = tuple((math.sin((1 - u) * th) * x + math.sin(u * th) * y) / math.sin(th)
                  for x, y in zip(a, b))
    n = math.sqrt(sum(x * x for x in r))
    return tuple(x / n for x in r)


def relative(A, B):
    """A^-1 B for poses (t, q)."""
    qi = qinv(A[1])
    return (qrot(qi, [B[0][k] - A[0][k] for k in range(3)]), qmul(qi, B[1]))


def angle_deg(q):
    return math.degrees(2.0 * math.acos(min(1.0, abs(q[3]))))


def read_tum(path):
    rows = []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            if line.startswith('#') or not line.strip():
                continue
            v = line.replace(',', ' ').split()
            if len(v) != 8:
                sys.exit(f'{path}:{n}: expected 8 numbers (t tx ty tz qx qy qz qw), got {len(v)}')
            v = [float(x) for x in v]
            rows.append((v[0], (v[1:4], tuple(v[4:8]))))
    return rows


class Truth:
    def __init__(self, path):
        self.rows = sorted(read_tum(path))
        self.t = [r[0] for r in self.rows]

    def at(self, t):
        """The pose at time t, interpolated; None outside the truth's time span."""
        if t < self.t[0] or t > self.t[-1]:
            return None
        i = min(max(bisect.bisect_left(self.t, t), 1), len(self.t) - 1)
        (ta, A), (tb, B) = self.rows[i - 1], self.rows[i]
        if tb - ta > 0.05:  # a gap in the motion capture: no truth there
            return None
        u = (t - ta) / (tb - ta)
        return ([A[0][k] + (B[0][k] - A[0][k]) * u for k in range(3)], slerp(A[1], B[1], u))

    def rate_deg_s(self, t, h=1.0 / 60.0):
        a, b = self.at(t - h), self.at(t + h)
        return angle_deg(relative(a, b)[1]) / (2 * h) if a and b else float('nan')


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('run')
    ap.add_argument('groundtruth')
    ap.add_argument('--offset', type=float, default=0.0, help='[s] added to the stamps (loops)')
    ap.add_argument('--scan', type=float, nargs=3, default=(-0.05, 0.02, 0.005),
                    metavar=('FROM', 'TO', 'STEP'), help='[s] offsets of the RPE scan')
    a = ap.parse_args()
    truth = Truth(a.groundtruth)
    est = read_tum(os.path.join(a.run, 'trajectory_tum.txt'))

    print('offset [ms]  RPE rot RMSE [deg]  pairs')
    lo, hi, step = a.scan
    best = None
    for k in range(int(round((hi - lo) / step)) + 1):
        off = lo + k * step
        s, n = 0.0, 0
        for (ta, A), (tb, B) in zip(est, est[1:]):
            ga, gb = truth.at(ta + off), truth.at(tb + off)
            if ga and gb:
                s += angle_deg(relative(relative(ga, gb), relative(A, B))[1]) ** 2
                n += 1
        if n:
            rmse = math.sqrt(s / n)
            best = min(best or (rmse, off), (rmse, off))
            print(f'{off * 1000:+10.0f}  {rmse:18.3f}  {n:5d}')
    if best:
        print(f'lowest RPE at {best[1] * 1000:+.0f} ms')

    loops_csv, frames_csv = os.path.join(a.run, 'loops.csv'), os.path.join(a.run, 'frames.csv')
    if not (os.path.exists(loops_csv) and os.path.exists(frames_csv)):
        return
    stamps = {}
    with open(frames_csv) as f:
        for row in csv.reader(l for l in f if not l.startswith('#')):
            stamps[int(row[0])] = float(row[1])
    print(f'\naccepted loops against the truth at {a.offset * 1000:+.0f} ms (interpolated):')
    print('from -> to    error [cm]  error [deg]  turn [deg]  rate at both ends [deg/s]')
    n = wrong = 0
    with open(loops_csv) as f:
        for row in csv.reader(l for l in f if not l.startswith('#')):
            if row[4] != '1':
                continue
            fa, fb = int(row[2]), int(row[3])
            ga, gb = truth.at(stamps[fa] + a.offset), truth.at(stamps[fb] + a.offset)
            if not (ga and gb):
                continue
            measured = ([float(x) for x in row[9:12]], tuple(float(x) for x in row[12:16]))
            G = relative(ga, gb)
            E = relative(G, measured)
            et, er = math.sqrt(sum(x * x for x in E[0])), angle_deg(E[1])
            n += 1
            bad = et > 0.5 or er > 2.0
            wrong += bad
            print(f'{fa:4d} -> {fb:4d}  {100 * et:10.1f}  {er:11.2f}  {angle_deg(G[1]):10.1f}  '
                  f'{truth.rate_deg_s(stamps[fa] + a.offset):6.0f} {truth.rate_deg_s(stamps[fb] + a.offset):6.0f}'
                  f'{"  wrong" if bad else ""}')
    print(f'{wrong} of {n} accepted loops wrong (> 0.5 m or 2 deg)')


if __name__ == '__main__':
    main()
