#!/usr/bin/python3
"""Writes a thinned copy of a pair list, as a sparser sensor or a front end's decimation would
hand its scans over: every scan the list names keeps every N-th point, in the order stored,
and the list itself is copied unchanged (the references do not depend on the points kept).

usage: thinned_set.py LIST OUT_DIR --keep-every N

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
    parser.add_argument("--keep-every", type=int, required=True, help="keep every N-th point")
    args = parser.parse_args()
    if args.keep_every < 1:
        sys.exit("thinned_set.py: --keep-every must be at least 1")
    base = os.path.dirname(os.path.abspath(args.list))
    scans = set()
    with open(args.list) as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            if len(fields) < 2:
                sys.exit("thinned_set.py: %s:%d: expected SOURCE TARGET [reference]"
                         % (args.list, number))
            scans.update(fields[:2])
    for name in sorted(scans):
        if not name.endswith(".bin"):
            sys.exit("thinned_set.py: %s is not a .bin scan" % name)
        # OUT_DIR mirrors the names: one outside the list's folder would be written over.
        if os.path.isabs(name) or os.path.normpath(name).startswith(".."):
            sys.exit("thinned_set.py: %s lies outside the list's folder" % name)
        points = np.fromfile(os.path.join(base, name), np.float32).reshape(-1, 4)
        target = os.path.join(args.out, name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        points[::args.keep_every].tofile(target)
    os.makedirs(args.out, exist_ok=True)
    shutil.copy(args.list, os.path.join(args.out, "list.txt"))
    print("%d scans thinned to 1 point in %d, in %s" % (len(scans), args.keep_every, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
