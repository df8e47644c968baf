#!/usr/bin/python3
"""Writes a tilted copy of a pair list, for sensors carried or mounted tilted: each row's
source scan is turned about its sensor (the origin of its frame) by a random roll and pitch
(each uniform in +-TILT deg) and yaw (uniform in +-YAW deg), and the row's reference
follows, so the rows' pairs are those of the list, seen by a tilted sensor. With --both,
each row's target is turned too, by its own random roll and pitch (no yaw), as a sensor
carried by hand tilts for every scan. With --mounted ROLL,PITCH, every scan of every row is
turned by that one roll and pitch instead, as a sensor mounted tilted on its vehicle sees
the same places: the pairs' up directions agree and both lie off the sensor's z.

usage: tilted_set.py LIST OUT_DIR [--tilt 30] [--yaw 90] [--seed 1] [--stride 1] [--both]
                      [--repeat 1] [--mounted ROLL,PITCH]

LIST is a `pcl_mi_compare -list` file whose scans are KITTI-style .bin files (float32 x y
z intensity). OUT_DIR gets scans/ (the turned sources, and links to the targets) and
list.txt for `pcl_mi_compare -list OUT_DIR/list.txt`, which runs every row both ways, so
either cloud of a pair is the tilted one. The reference becomes Q * T * R^-1 for a reference
T, a turn R of the source and a turn Q of the target (the identity without --both).
"""
import argparse
import os
import sys

try:
    import numpy as np
except ImportError:
    sys.exit("tilted_set.py needs numpy: apt-get install python3-numpy")


def rotation(roll, pitch, yaw):
    """R = Rz(yaw) Ry(pitch) Rx(roll), angles in degrees."""
    r, p, y = np.radians([roll, pitch, yaw])
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return rz @ ry @ rx


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("list")
    parser.add_argument("out")
    parser.add_argument("--tilt", type=float, default=30.0, help="largest |roll|, |pitch| (deg)")
    parser.add_argument("--yaw", type=float, default=90.0, help="largest |yaw| (deg)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--stride", type=int, default=1, help="every STRIDE-th row only")
    parser.add_argument("--both", action="store_true", help="turn each row's target too")
    parser.add_argument("--repeat", type=int, default=1,
                        help="each row REPEAT times, each with its own turns (a set of one pair)")
    parser.add_argument("--mounted", help="ROLL,PITCH (deg): turn every scan by this one tilt")
    args = parser.parse_args()
    mounted = None
    if args.mounted:
        roll, pitch = (float(v) for v in args.mounted.split(","))
        mounted = rotation(roll, pitch, 0.0)
    rng = np.random.default_rng(args.seed)
    base = os.path.dirname(os.path.abspath(args.list))
    os.makedirs(os.path.join(args.out, "scans"), exist_ok=True)
    rows = []
    with open(args.list) as f:
        lines = [line.split() for line in f if line.strip() for _ in range(args.repeat)]
    def turned_copy(path, turn, name):
        scan = np.fromfile(os.path.join(base, path), dtype=np.float32).reshape(-1, 4)
        turned = scan.copy()
        turned[:, :3] = (scan[:, :3].astype(np.float64) @ turn.T).astype(np.float32)
        turned.tofile(os.path.join(args.out, name))

    for k, fields in enumerate(lines):
        turn = rotation(rng.uniform(-args.tilt, args.tilt), rng.uniform(-args.tilt, args.tilt),
                        rng.uniform(-args.yaw, args.yaw))
        target_turn = np.eye(3)
        if mounted is not None:
            turn = target_turn = mounted
        elif args.both:
            target_turn = rotation(rng.uniform(-args.tilt, args.tilt),
                                   rng.uniform(-args.tilt, args.tilt), 0.0)
        if k % args.stride:
            continue
        source, target = fields[0], fields[1]
        numbers = np.array([float(v) for v in fields[2:]])
        reference = np.eye(4)
        reference[:3] = numbers[:12].reshape(3, 4)
        name = "scans/source_%05d.bin" % k
        turned_copy(source, turn, name)
        if args.both or mounted is not None:
            target_name = "scans/target_%05d.bin" % k
            turned_copy(target, target_turn, target_name)
        else:
            target_name = "scans/" + os.path.basename(target)
            link = os.path.join(args.out, target_name)
            if not os.path.lexists(link):
                os.symlink(os.path.join(base, target), link)
        inverse = np.eye(4)
        inverse[:3, :3] = turn.T
        target_side = np.eye(4)
        target_side[:3, :3] = target_turn
        moved = target_side @ reference @ inverse
        rows.append(" ".join([name, target_name] + ["%.9f" % v for v in moved[:3].ravel()]))
    with open(os.path.join(args.out, "list.txt"), "w") as f:
        f.write("\n".join(rows) + "\n")
    print("%d rows in %s" % (len(rows), os.path.join(args.out, "list.txt")))


if __name__ == "__main__":
    main()
