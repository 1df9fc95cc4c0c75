#!/usr/bin/env python3
"""Makes a KITTI odometry folder with sweeps missing, to test tracking recovery.

    scripts/drop_sweeps.py SRC DST --drop 150:15 330:15 520:15 [--hide-gaps]

SRC holds velodyne/NNNNNN.bin, times.txt, calib.txt and (optionally) poses.txt. DST gets
velodyne/ as symbolic links to SRC's sweeps (renumbered from 0, no copies), calib.txt, and the
lines of times.txt and poses.txt of the sweeps kept. `--drop FIRST:COUNT` removes COUNT sweeps
from index FIRST (of SRC). With --hide-gaps the time stamps are rewritten as if nothing was lost
(the mean interval of SRC): the constant-velocity guess then falls short by the lost motion, a
sudden jump; without it the stamps show the gap.
"""
import argparse
import os
import sys


def fail(msg):
    sys.exit("drop_sweeps.py: " + msg)


def read_lines(path, what):
    try:
        with open(path) as f:
            return [l.rstrip("\n") for l in f if l.strip()]
    except OSError as e:
        fail("cannot read the %s '%s': %s" % (what, path, e.strerror))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("src", help="KITTI sequence folder (velodyne/, times.txt, calib.txt)")
    ap.add_argument("dst", help="output folder (created; must not hold a velodyne/ folder yet)")
    ap.add_argument("--drop", nargs="+", required=True, metavar="FIRST:COUNT",
                    help="sweeps to remove: COUNT sweeps from index FIRST")
    ap.add_argument("--hide-gaps", action="store_true",
                    help="rewrite the time stamps at SRC's mean interval (a jump, not a gap)")
    a = ap.parse_args()

    velo = os.path.join(a.src, "velodyne")
    if not os.path.isdir(velo):
        fail("'%s' has no velodyne/ folder" % a.src)
    n = len([f for f in os.listdir(velo) if f.endswith(".bin")])
    times = read_lines(os.path.join(a.src, "times.txt"), "time stamps")
    if len(times) != n:
        fail("%s: %d lines for %d sweeps" % (os.path.join(a.src, "times.txt"), len(times), n))
    poses_path = os.path.join(a.src, "poses.txt")
    poses = read_lines(poses_path, "poses") if os.path.exists(poses_path) else None
    if poses is not None and len(poses) != n:
        fail("%s: %d lines for %d sweeps" % (poses_path, len(poses), n))

    drop = set()
    for spec in a.drop:
        try:
            first, count = (int(v) for v in spec.split(":"))
        except ValueError:
            fail("--drop '%s': expected FIRST:COUNT, two integers" % spec)
        if first < 0 or count < 1 or first + count > n:
            fail("--drop '%s': outside the %d sweeps of '%s'" % (spec, n, a.src))
        drop.update(range(first, first + count))
    keep = [i for i in range(n) if i not in drop]

    out_velo = os.path.join(a.dst, "velodyne")
    if os.path.exists(out_velo):
        fail("'%s' exists already (choose a new output folder)" % out_velo)
    os.makedirs(out_velo)
    for j, i in enumerate(keep):
        os.symlink(os.path.abspath(os.path.join(velo, "%06d.bin" % i)),
                   os.path.join(out_velo, "%06d.bin" % j))
    stamps = [float(t) for t in times]
    if a.hide_gaps:
        dt = (stamps[-1] - stamps[0]) / max(1, n - 1)
        new_times = ["%.7f" % (stamps[0] + j * dt) for j in range(len(keep))]
    else:
        new_times = [times[i] for i in keep]

    def write(name, lines):
        path = os.path.join(a.dst, name)
        with open(path + ".tmp", "w") as f:
            f.write("\n".join(lines) + "\n")
        os.replace(path + ".tmp", path)

    write("times.txt", new_times)
    if poses is not None:
        write("poses.txt", [poses[i] for i in keep])
    write("calib.txt", read_lines(os.path.join(a.src, "calib.txt"), "calibration"))
    print("%s: %d of %d sweeps (%d removed%s)" % (a.dst, len(keep), n, len(drop),
                                                  ", time stamps without gaps" if a.hide_gaps else ""))


if __name__ == "__main__":
    main()
