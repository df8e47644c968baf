#!/usr/bin/python3
"""Pairs for a sensor that stood still: each KITTI-style .bin scan split into its even and
odd points, the odd half to be aligned onto the even half, whose true transform is the
identity. Both halves keep the scan's own pattern (a spinning LiDAR's rings), as two scans
taken from one place would. Writes the halves and a pair list for `pcl_mi_compare -list`.

usage: standstill_pairs.py OUT_DIR SCAN.bin [SCAN.bin ...]
e.g.   standstill_pairs.py /tmp/still data/kitti/sequences/*/velodyne/*.bin
       build/apps/pcl_mi_compare -list /tmp/still/list.txt -methods mi-varz
"""
import os
import sys

try:
    import numpy as np
except ImportError:
    sys.exit("standstill_pairs.py needs numpy: apt-get install python3-numpy (Debian's "
             "/usr/bin/python3, which this script's first line names, has it after "
             "scripts/setup_debian.sh)")

from kitti_files import list_row, write_pair_list


def main(argv):
    if len(argv) < 3 or argv[1] in ("-h", "--help"):
        sys.exit(__doc__)
    out_dir = argv[1]
    os.makedirs(out_dir, exist_ok=True)
    rows = []
    for index, path in enumerate(argv[2:]):
        points = np.fromfile(path, dtype=np.float32)
        if points.size == 0 or points.size % 4:
            sys.exit(f"{path}: not a KITTI-style .bin scan (float32 x y z intensity)")
        points = points.reshape(-1, 4)
        # Numbered in the order given: scans of several sets often share a file name.
        stem = f"{index:04d}_{os.path.splitext(os.path.basename(path))[0]}"
        halves = []
        for parity in (0, 1):
            name = f"{stem}_{'even' if parity == 0 else 'odd'}.bin"
            points[parity::2].tofile(os.path.join(out_dir, name))
            halves.append(name)
        rows.append(list_row(halves[1], halves[0], np.eye(4)))
    print(write_pair_list(out_dir, rows))


if __name__ == "__main__":
    main(sys.argv)
