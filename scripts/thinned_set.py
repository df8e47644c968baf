#!/usr/bin/python3
"""Writes a thinned or rescaled copy of a pair list, as a sparser sensor or a front end's
decimation would hand its scans over: every scan the list names keeps every N-th point, in
the order stored, and the list itself is copied unchanged (the references do not depend on
the points kept). With --scale S, every coordinate and the references' translations are
multiplied by S, as clouds in other units would be (S = 1000: millimetres).

usage: thinned_set.py LIST OUT_DIR [--keep-every N] [--scale S]

LIST is a `pcl_mi_compare -list` file whose scans are KITTI-style .bin files (float32 x y z
intensity), named relative to the list and within its folder. OUT_DIR gets the thinned scans under the same
relative names and list.txt, for `pcl_mi_compare -list OUT_DIR/list.txt`.
"""
import argparse
import os
import shutil
import sys

try:
    import numpy as np
except ImportError:
    sys.exit("thinned_set.py needs numpy: apt-get install python3-numpy")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("list")
    parser.add_argument("out")
    parser.add_argument("--keep-every", type=int, default=1, help="keep every N-th point")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="multiply the coordinates and the references' translations")
    args = parser.parse_args()
    if args.keep_every < 1:
        sys.exit("thinned_set.py: --keep-every must be at least 1")
    if not (args.scale > 0.0 and np.isfinite(args.scale)):
        sys.exit("thinned_set.py: --scale must be positive and finite")
    base = os.path.dirname(os.path.abspath(args.list))
    scans = set()
    lines = []
    with open(args.list) as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                lines.append(line)
                continue
            if len(fields) < 2:
                sys.exit("thinned_set.py: %s:%d: expected SOURCE TARGET [reference]"
                         % (args.list, number))
            scans.update(fields[:2])
            if args.scale != 1.0 and len(fields) >= 14:
                # The reference's 3x4 rows: the translations are its 4th, 8th and 12th numbers.
                for k in (5, 9, 13):
                    fields[k] = repr(float(fields[k]) * args.scale)
                line = " ".join(fields) + "\n"
            lines.append(line)
    for name in sorted(scans):
        if not name.endswith(".bin"):
            sys.exit("thinned_set.py: %s is not a .bin scan" % name)
        # OUT_DIR mirrors the names: one outside the list's folder would be written over.
        if os.path.isabs(name) or os.path.normpath(name).startswith(".."):
            sys.exit("thinned_set.py: %s lies outside the list's folder" % name)
        points = np.fromfile(os.path.join(base, name), np.float32).reshape(-1, 4)
        target = os.path.join(args.out, name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        kept = points[::args.keep_every]
        kept[:, :3] *= np.float32(args.scale)
        kept.tofile(target)
    os.makedirs(args.out, exist_ok=True)
    if args.scale == 1.0:
        shutil.copy(args.list, os.path.join(args.out, "list.txt"))
    else:
        with open(os.path.join(args.out, "list.txt"), "w") as f:
            f.writelines(lines)
    print("%d scans, 1 point in %d kept, coordinates times %g, in %s"
          % (len(scans), args.keep_every, args.scale, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
