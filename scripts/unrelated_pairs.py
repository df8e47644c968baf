#!/usr/bin/python3
"""Writes a pcl_mi_compare list of pairs that show two different places: KITTI scans of
different sequences (frames 0, 3, 6 and 9 of each pair of sequences) and scans of different
foreign_lidar sets with the same sensor class (the two Livox sets; the two car sets),
20 pairs each. No transform aligns them, so the reference is a 1 km shift that no result
comes near, and every result is wrong: the check is that none says converged and that
the confidence stays low.

Usage: unrelated_pairs.py SHARED_DATA_DIR OUT_DIR
then:  build/apps/pcl_mi_compare -list OUT_DIR/list.txt -methods mi-varz -csv unrelated.csv
The list's scans are symbolic links in OUT_DIR/scans.
"""
import glob
import itertools
import os
import sys

UNREACHABLE = "1 0 0 1000 0 1 0 0 0 0 1 0"
KITTI_SEQUENCES = ["00", "01", "02", "05", "08"]
FOREIGN_PAIRS = [("livox_avia_hku1", "livox_avia_quickshack"),
                 ("seosan01_ouster128", "mulran_riverside02_os1")]
FOREIGN_PAIRS_PER_SET = 20


def main(argv):
    if len(argv) != 3:
        print(__doc__)
        return 1
    data, out = argv[1], argv[2]
    os.makedirs(os.path.join(out, "scans"), exist_ok=True)

    def link(path, name):
        relative = os.path.join("scans", name)
        target = os.path.join(out, relative)
        if not os.path.lexists(target):
            os.symlink(os.path.abspath(path), target)
        return relative

    rows = []
    kitti = os.path.join(data, "kitti_odometry", "sequences")
    for a, b in itertools.combinations(KITTI_SEQUENCES, 2):
        scans_a = sorted(glob.glob(os.path.join(kitti, a, "velodyne", "*.bin")))
        scans_b = sorted(glob.glob(os.path.join(kitti, b, "velodyne", "*.bin")))
        for k in range(0, min(len(scans_a), len(scans_b)), 3):
            rows.append((link(scans_a[k], "kitti%s_%d.bin" % (a, k)),
                         link(scans_b[k], "kitti%s_%d.bin" % (b, k))))
    for a, b in FOREIGN_PAIRS:
        scans_a = sorted(glob.glob(os.path.join(data, "foreign_lidar", a, "scans", "*.bin")))
        scans_b = sorted(glob.glob(os.path.join(data, "foreign_lidar", b, "scans", "*.bin")))
        for k in range(FOREIGN_PAIRS_PER_SET):
            i = k * len(scans_a) // FOREIGN_PAIRS_PER_SET
            j = k * len(scans_b) // FOREIGN_PAIRS_PER_SET
            rows.append((link(scans_a[i], "%s_%d.bin" % (a, i)),
                         link(scans_b[j], "%s_%d.bin" % (b, j))))
    with open(os.path.join(out, "list.txt"), "w") as f:
        for source, target in rows:
            f.write("%s %s %s\n" % (source, target, UNREACHABLE))
    print("%d pairs in %s" % (len(rows), os.path.join(out, "list.txt")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
