#!/usr/bin/python3
"""Emulates a sparser LiDAR from KITTI's 64-beam scans by keeping every K-th ring, and writes
the scans plus a pair list for `pcl_mi_compare -list`.

KITTI's HDL-64E .bin files store the points ring by ring, each ring one sweep in azimuth, so
a ring ends where the azimuth wraps from negative to non-negative. K = 2 gives a 32-ring
scan, K = 4 a 16-ring one (about 1.7 deg between rings, close to a VLP-16's 2 deg).

usage: kitti_ring_subset.py KITTI_ROOT K OUT_DIR [--sequences 00,01,02,05,08]
                            [--distance 1,10] [--max-yaw 20] [--poses semantic|gt]
                            [--scale S] [--fov DEG] [--voxel M] [--keep-every N]
                            [--noise SIGMA] [--seed N] [--max-range M]

--scale S multiplies every coordinate and the reference translations by S (e.g. 1000 for
millimetres, 0.1 for a scene the size of a room), to check that an alignment at resolution
S (and simplex steps times S) is the same as at 1 m; --distance stays in metres before scaling.
--fov DEG keeps only the points within DEG/2 of azimuth of straight ahead (+x), as a
forward-looking sensor with that horizontal field of view would see them.
--voxel M keeps the first point of each cube of M metres (before scaling), as a pipeline that
thins its scans with a voxel filter hands them over: about as many points near the sensor as
far from it.
--keep-every N keeps every N-th point of what is left, as a front end that decimates its scans
(e.g. a LIO's point filter) hands them over: sparser everywhere, near and far alike.
--max-range M keeps only the points within M metres of the sensor, as a short-range sensor
(an indoor or low-cost one) would see the scene; KITTI's reach is about 80 m.
--noise SIGMA adds Gaussian noise of SIGMA metres (before scaling) to each coordinate of every
point, as a noisier sensor would measure it; --seed N fixes the draws (default 1).

The list holds every pair i < j of the stored frames whose motion is within --distance and
--max-yaw, with the reference source-to-target transform T_i_j = inv(Tv_i) * Tv_j,
Tv_k = inv(Tr) * P_k * Tr (the same pairs pcl_mi_compare -kitti picks). Then e.g.
    build/apps/pcl_mi_compare -list OUT_DIR/list.txt -methods mi-varz,mi-n
"""
import argparse
import math
import os
import sys

try:
    import numpy as np
except ImportError:
    sys.exit("kitti_ring_subset.py needs numpy: apt-get install python3-numpy (Debian's /usr/bin/python3, "
             "which this script's first line names, has it after scripts/setup_debian.sh)")

from kitti_files import list_row, load_sequence, write_pair_list


def keep_rings(points, every):
    azimuth = np.arctan2(points[:, 1], points[:, 0])
    starts = np.zeros(len(points), dtype=np.int64)
    starts[1:] = (azimuth[:-1] < 0) & (azimuth[1:] >= 0)
    ring = np.cumsum(starts)
    return points[ring % every == 0]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root")
    parser.add_argument("every", type=int)
    parser.add_argument("out")
    parser.add_argument("--sequences", default="00,01,02,05,08")
    parser.add_argument("--distance", default="1,10")
    parser.add_argument("--max-yaw", type=float, default=20.0)
    parser.add_argument("--poses", choices=["semantic", "gt"], default="semantic")
    parser.add_argument("--scale", type=float, default=1.0)
    parser.add_argument("--fov", type=float, default=360.0)
    parser.add_argument("--voxel", type=float, default=0.0)
    parser.add_argument("--keep-every", type=int, default=1)
    parser.add_argument("--noise", type=float, default=0.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--max-range", type=float, default=math.inf)
    args = parser.parse_args()
    if args.every < 1:
        sys.exit("kitti_ring_subset: K must be >= 1")
    if not (args.scale > 0 and math.isfinite(args.scale)):
        sys.exit("kitti_ring_subset: --scale must be positive and finite")
    if not 0 < args.fov <= 360:
        sys.exit("kitti_ring_subset: --fov must be in (0, 360]")
    if args.keep_every < 1:
        sys.exit("kitti_ring_subset: --keep-every must be >= 1")
    if not args.max_range > 0:
        sys.exit("kitti_ring_subset: --max-range must be positive")
    if not (args.noise >= 0 and math.isfinite(args.noise)):
        sys.exit("kitti_ring_subset: --noise must be 0 or more and finite")
    random = np.random.default_rng(args.seed)
    dmin, dmax = (float(v) for v in args.distance.split(","))
    os.makedirs(args.out, exist_ok=True)

    rows = []
    for seq in args.sequences.split(","):
        velodyne, frames, velo = load_sequence(args.root, seq, args.poses, "kitti_ring_subset")
        kept = 0
        for k in frames:
            scan = np.fromfile(os.path.join(velodyne, f"{k:06d}.bin"), dtype=np.float32)
            subset = keep_rings(scan.reshape(-1, 4), args.every)
            if args.fov < 360:
                azimuth = np.degrees(np.arctan2(subset[:, 1], subset[:, 0]))
                subset = subset[np.abs(azimuth) <= args.fov / 2]
            if math.isfinite(args.max_range):
                subset = subset[np.linalg.norm(subset[:, :3], axis=1) <= args.max_range]
            if args.voxel > 0:
                cells = np.floor(subset[:, :3] / args.voxel).astype(np.int64)
                _, first = np.unique(cells, axis=0, return_index=True)
                subset = subset[np.sort(first)]
            subset = subset[::args.keep_every]
            if args.noise > 0:
                subset[:, :3] += random.normal(0.0, args.noise, (len(subset), 3)).astype(np.float32)
            if args.scale != 1.0:
                subset[:, :3] *= np.float32(args.scale)
            subset.tofile(os.path.join(args.out, f"{seq}_{k:06d}.bin"))
            kept += len(subset)
        for a, i in enumerate(frames):
            for j in frames[a + 1:]:
                t = np.linalg.inv(velo[i]) @ velo[j]
                yaw = math.degrees(math.atan2(t[1, 0], t[0, 0]))
                if dmin <= np.linalg.norm(t[:3, 3]) <= dmax and abs(yaw) <= args.max_yaw:
                    t[:3, 3] *= args.scale
                    rows.append(list_row(f"{seq}_{j:06d}.bin", f"{seq}_{i:06d}.bin", t))
        print(f"sequence {seq}: {len(frames)} scans, {kept // max(1, len(frames))} points "
              f"per scan kept (every {args.every}. ring)")
    print(f"{len(rows)} pairs in {write_pair_list(args.out, rows)}")


if __name__ == "__main__":
    main()
