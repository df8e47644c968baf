#!/usr/bin/python3
"""Would an overlap limited to what both sensors see rank the reference above pcl_mi's failed
results? A numpy model of MI-VARZ, not the library: for each failed row of a pcl_mi_compare
CSV, the MI of the reference pose and of the result, once over the intersection of the
bounding boxes (the library's overlap) and once over its voxels that lie inside both clouds'
azimuth ranges (1st to 99th percentile about each cloud's origin). Prints how often each
overlap scores the reference higher.

usage: covisible_mi_check.py LIST CSV RESOLUTION [--every N]

LIST is the set's list.txt (`SOURCE TARGET` + the 3x4 reference, paths relative to it), CSV
the `pcl_mi_compare -list LIST -csv CSV` output, RESOLUTION the voxel size it used. The model
bins z-variance into 16 bins up to the target's 90th percentile, as the library does by
default, but voxelises the raw points, not the library's samples.
"""
import argparse
import collections
import csv
import os

import numpy as np

BINS = 16


def load(path):
    return np.fromfile(path, dtype=np.float32).reshape(-1, 4)[:, :3].astype(np.float64)


def variance_z(points, origin, resolution):
    """Voxel key -> variance of the in-voxel height (voxel units), and the voxel indices."""
    index = np.floor((points - origin) / resolution).astype(np.int64)
    z = (points[:, 2] - origin[2]) / resolution - index[:, 2]
    keys = index[:, 0] * 1000003 + index[:, 1] * 1009 + index[:, 2]
    unique, inverse, count = np.unique(keys, return_inverse=True, return_counts=True)
    mean = np.bincount(inverse, z) / count
    variance = np.maximum(np.bincount(inverse, z * z) / count - mean ** 2, 0.0)
    return dict(zip(unique, variance)), index


def azimuth_range(points):
    a = np.arctan2(points[:, 1], points[:, 0])
    return np.percentile(a, 1), np.percentile(a, 99)


def entropy(p):
    p = p[p > 0]
    return -(p * np.log(p)).sum()


def mutual_information(target, source, pose, resolution, covisible):
    moved = source @ pose[:3, :3].T + pose[:3, 3]
    origin = target.min(0)
    target_values, target_index = variance_z(target, origin, resolution)
    source_values, source_index = variance_z(moved, origin, resolution)
    top = np.quantile(list(target_values.values()), 0.9) + 1e-12
    lo = np.maximum(target_index.min(0), source_index.min(0))
    hi = np.minimum(target_index.max(0), source_index.max(0))
    if (lo > hi).any():
        return 0.0
    grid = np.stack(np.meshgrid(*[np.arange(lo[a], hi[a] + 1) for a in range(3)],
                                indexing="ij"), -1).reshape(-1, 3)
    if covisible:
        centres = grid * resolution + origin + 0.5 * resolution
        in_source = (centres - pose[:3, 3]) @ pose[:3, :3]
        keep = np.ones(len(grid), dtype=bool)
        for cloud, seen in ((target, centres), (source, in_source)):
            a0, a1 = azimuth_range(cloud)
            a = np.arctan2(seen[:, 1], seen[:, 0])
            keep &= (a >= a0) & (a <= a1)
        grid = grid[keep]
    keys = grid[:, 0] * 1000003 + grid[:, 1] * 1009 + grid[:, 2]

    def bins(values):
        v = np.array([values.get(k, -1.0) for k in keys])
        return np.where(v < 0, 0, 1 + np.minimum(BINS - 1, np.floor(BINS * v / top)).astype(int))

    joint = np.zeros((BINS + 1, BINS + 1))
    np.add.at(joint, (bins(target_values), bins(source_values)), 1)
    joint /= joint.sum()
    return entropy(joint.sum(1)) + entropy(joint.sum(0)) - entropy(joint.ravel())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("list")
    parser.add_argument("csv")
    parser.add_argument("resolution", type=float)
    parser.add_argument("--every", type=int, default=1, help="every N-th row of the CSV")
    args = parser.parse_args()
    root = os.path.dirname(args.list)
    pairs = [line.split() for line in open(args.list) if line.strip()]
    counts = collections.Counter()
    for i, row in enumerate(csv.DictReader(open(args.csv))):
        if i % args.every or (float(row["translation_error_m"]) < 0.5 and
                              float(row["rotation_error_deg"]) < 2.0):
            continue
        pair = pairs[int(row["source"]) - 1]
        reference = np.eye(4)
        reference[:3, :] = np.array([float(v) for v in pair[2:14]]).reshape(3, 4)
        source, target = pair[0], pair[1]
        if row["direction"] != "forward":
            source, target, reference = target, source, np.linalg.inv(reference)
        result = np.eye(4)
        result[:3, :] = np.array([float(row["estimate_%d%d" % (r, c)])
                                  for r in range(3) for c in range(4)]).reshape(3, 4)
        t, s = load(os.path.join(root, target)), load(os.path.join(root, source))
        for name, covisible in (("boxes", False), ("covisible", True)):
            counts[name] += (mutual_information(t, s, reference, args.resolution, covisible) >
                             mutual_information(t, s, result, args.resolution, covisible))
        counts["failed"] += 1
    print("failed results: %d; the reference scores higher over the boxes' intersection in %d, "
          "over the co-visible voxels in %d" % (counts["failed"], counts["boxes"],
                                                counts["covisible"]))


if __name__ == "__main__":
    main()
