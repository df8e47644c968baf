#!/usr/bin/python3
"""Writes scan-to-map cases from KITTI: each scan of a sequence against a map of the
sequence's other stored scans, and a pair list for `pcl_mi_compare -list ... -directions
forward`.

usage: kitti_scan_to_map.py KITTI_ROOT OUT_DIR [--sequences 00,01,02,05,08]
                            [--sources 1-9] [--poses semantic|gt] [--shared-map]

The map of source scan k holds every other stored scan j != k, moved into the frame of the
first stored scan with the reference poses (Tv_j = inv(Tr) * P_j * Tr); the list row is
`SOURCE MAP` + the reference source-to-map transform inv(Tv_first) * Tv_k, so the identity
guess is off by scan k's motion from the first scan. The map is built with the same poses
that score the result, so the errors measure agreement with them. Each map of ten KITTI
scans is about 17 MB.

With --shared-map, each sequence gets one map, of its stored scans that are not sources
(always including the first), and every source scan is aligned against it: the list's rows
of a sequence share their target, as in a localisation loop that sets the map once
(`pcl_mi_compare -list OUT/list.txt -directions forward -reuse_target`).
"""
import argparse
import os
import sys

try:
    import numpy as np
except ImportError:
    sys.exit("kitti_scan_to_map.py needs numpy: apt-get install python3-numpy (Debian's /usr/bin/python3, "
             "which this script's first line names, has it after scripts/setup_debian.sh)")

from kitti_files import list_row, load_sequence, write_pair_list


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root")
    parser.add_argument("out")
    parser.add_argument("--sequences", default="00,01,02,05,08")
    parser.add_argument("--sources", default="1-9",
                        help="source frames, e.g. 1-9 or 3,5 (the first stored scan is the "
                             "map's frame)")
    parser.add_argument("--poses", choices=["semantic", "gt"], default="semantic")
    parser.add_argument("--shared-map", action="store_true",
                        help="one map per sequence of the scans that are not sources")
    args = parser.parse_args()
    if "-" in args.sources:
        first, last = (int(v) for v in args.sources.split("-"))
        sources = list(range(first, last + 1))
    else:
        sources = [int(v) for v in args.sources.split(",")]
    os.makedirs(args.out, exist_ok=True)

    rows = []
    for seq in args.sequences.split(","):
        velodyne, frames, velo = load_sequence(args.root, seq, args.poses, "kitti_scan_to_map")
        origin = np.linalg.inv(velo[frames[0]])
        scans = {k: np.fromfile(os.path.join(velodyne, f"{k:06d}.bin"),
                                dtype=np.float32).reshape(-1, 4) for k in frames}
        for k in sources:
            if k not in scans:
                sys.exit(f"kitti_scan_to_map: sequence {seq} has no stored frame {k}")
        if args.shared_map and frames[0] in sources:
            sys.exit(f"kitti_scan_to_map: with --shared-map the first stored frame "
                     f"({frames[0]}) is the map's frame and cannot be a source")

        def write_map(name, left_out):
            parts = []
            for j in frames:
                if j in left_out:
                    continue
                t = origin @ velo[j]
                moved = scans[j].copy()
                moved[:, :3] = (scans[j][:, :3].astype(np.float64) @ t[:3, :3].T
                                + t[:3, 3]).astype(np.float32)
                parts.append(moved)
            if not parts:
                sys.exit(f"kitti_scan_to_map: sequence {seq} leaves no scan for its map")
            np.concatenate(parts).tofile(os.path.join(args.out, name))
            return len(parts)

        if args.shared_map:
            map_name = f"map_{seq}.bin"
            map_scans = write_map(map_name, set(sources))
        for k in sources:
            if not args.shared_map:
                map_name = f"map_{seq}_{k:06d}.bin"
                map_scans = write_map(map_name, {k})
            scan_name = f"{seq}_{k:06d}.bin"
            scans[k].tofile(os.path.join(args.out, scan_name))
            rows.append(list_row(scan_name, map_name, origin @ velo[k]))
        print(f"sequence {seq}: {len(sources)} scans, each against a map of "
              f"{map_scans} scans" + (" (one map)" if args.shared_map else ""))
    print(f"{len(rows)} cases in {write_pair_list(args.out, rows)}")


if __name__ == "__main__":
    main()
