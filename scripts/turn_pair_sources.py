#!/usr/bin/env python3
"""Turns every source cloud of an obm-bench pair folder, to start a method elsewhere.

    scripts/turn_pair_sources.py SRC DST --axis x|y|z --deg A

SRC is a folder of `obm-bench --write-pairs` (pair_NNNN_src.ply / pair_NNNN_tgt.ply, binary
little-endian float x y z, and gt.txt). DST gets the same pairs with each source turned by A
degrees about the given axis of its own frame (about the origin), p' = R·p, and gt.txt
rewritten so the pairs stay exact: T' = T·R⁻¹. The targets are copied unchanged. Scoring DST
with `obm-bench --pairs DST` then runs every method from a start turned by R, which is how
several starts per pair can be compared from outside the tool (docs/benchmarks.md).
"""
import argparse
import math
import os
import struct
import sys


def fail(msg):
    sys.exit("turn_pair_sources.py: " + msg)


def read_ply(path):
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        fail("cannot read '%s': %s" % (path, e.strerror))
    end = data.find(b"end_header\n")
    if end < 0:
        fail("'%s' has no PLY header" % path)
    head = data[: end + len(b"end_header\n")]
    text = head.decode("ascii", "replace")
    if "binary_little_endian" not in text:
        fail("'%s' is not a binary little-endian PLY (as obm-bench --write-pairs writes)" % path)
    props = [l.split()[-1] for l in text.splitlines() if l.startswith("property")]
    if props[:3] != ["x", "y", "z"] or any("float" not in l for l in text.splitlines()
                                           if l.startswith("property")):
        fail("'%s': expected float x y z properties first, found %s" % (path, props))
    return head, data[len(head):], len(props)


def rotation(axis, deg):
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    R[i][i], R[i][j], R[j][i], R[j][j] = c, -s, s, c
    return R


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--axis", choices=["x", "y", "z"], required=True)
    ap.add_argument("--deg", type=float, required=True)
    args = ap.parse_args()
    R = rotation(args.axis, args.deg)
    gt_path = os.path.join(args.src, "gt.txt")
    try:
        with open(gt_path) as f:
            lines = [l for l in f if l.strip()]
    except OSError as e:
        fail("cannot read '%s': %s" % (gt_path, e.strerror))
    os.makedirs(args.dst, exist_ok=True)
    out_gt = []
    for n, line in enumerate(lines, 1):
        f = line.split()
        if len(f) != 13:
            fail("%s:%d: expected an id and 12 numbers, found %d fields" % (gt_path, n, len(f)))
        try:
            T = [float(x) for x in f[1:]]
        except ValueError:
            fail("%s:%d: a field is not a number" % (gt_path, n))
        M = [T[0:4], T[4:8], T[8:12]]
        # T' = T·R⁻¹: the rotation block times Rᵀ; R turns about 0, so t is unchanged.
        Mp = [[sum(M[r][k] * R[c][k] for k in range(3)) for c in range(3)] + [M[r][3]]
              for r in range(3)]
        out_gt.append(f[0] + " " + " ".join(repr(x) for row in Mp for x in row))
        for kind in ("src", "tgt"):
            name = "pair_%s_%s.ply" % (f[0], kind)
            head, body, nprop = read_ply(os.path.join(args.src, name))
            if kind == "src":
                stride = 4 * nprop
                if len(body) % stride:
                    fail("'%s': the body is not a whole number of vertices" % name)
                out = bytearray(body)
                for v in range(len(body) // stride):
                    p = struct.unpack_from("<3f", body, v * stride)
                    q = [sum(R[r][k] * p[k] for k in range(3)) for r in range(3)]
                    struct.pack_into("<3f", out, v * stride, *q)
                body = bytes(out)
            tmp = os.path.join(args.dst, name + ".tmp")
            with open(tmp, "wb") as g:
                g.write(head + body)
            os.replace(tmp, os.path.join(args.dst, name))
    tmp = os.path.join(args.dst, "gt.txt.tmp")
    with open(tmp, "w") as g:
        g.write("\n".join(out_gt) + "\n")
    os.replace(tmp, os.path.join(args.dst, "gt.txt"))
    print("%d pairs turned by %g deg about %s into %s"
          % (len(lines), args.deg, args.axis, args.dst))


if __name__ == "__main__":
    main()
