#!/usr/bin/python3
"""Aligns synthetic scans of a corridor that nothing but its surfaces could align, and counts
the results that say converged: there should be none.

Each scan is what a sensor sees of a corridor 4 m wide and 3 m high along x, out to RANGE
metres either way (25), with samples of its own (uniform on the floor and the two walls, as
dense as a 120 m corridor of 40000 samples a surface, 1 cm noise); with --walls-only, its
floor left out, as scans whose ground was removed leave it. The sensors
stand SHIFT metres apart along it (1.5 and 3 by default). Each scan ends where its sensor's
range does, so both look the same wherever they were taken: no pose is right but the one
the sensors had, and nothing in the scans says which that was. A result that says converged
is therefore at best right by chance; the script counts those more than 0.5 m off.

Usage: PYTHONPATH=build/python corridor_verdicts.py [--walls-only] [FIRST_SEED LAST_SEED
       [SHIFT ...]]   (seeds FIRST_SEED..LAST_SEED-1, default 2 32; pcl_mi's defaults)
"""
import sys

import numpy as np

import pcl_mi

LENGTH = 60.0  # half the length of the corridor the scans are cut from
RANGE = 25.0
SAMPLES_PER_SURFACE = 40000


def corridor_scan(rng, sensor_x, floor):
    """The corridor as a sensor at (sensor_x, 0, 0) sees it, in the sensor's frame."""
    def surface(lo, hi):
        lo, hi = np.array(lo), np.array(hi)
        points = lo + (hi - lo) * rng.random((SAMPLES_PER_SURFACE, 3))
        return points + rng.normal(0.0, 0.01, (SAMPLES_PER_SURFACE, 3))
    surfaces = [surface([-LENGTH, -2, 0], [LENGTH, 2, 0])] if floor else []
    corridor = np.vstack(surfaces + [surface([-LENGTH, -2, 0], [LENGTH, -2, 3]),
                                     surface([-LENGTH, 2, 0], [LENGTH, 2, 3])])
    seen = corridor[np.abs(corridor[:, 0] - sensor_x) < RANGE].copy()
    seen[:, 0] -= sensor_x
    return seen


def main(argv):
    floor = "--walls-only" not in argv
    argv = [a for a in argv if a != "--walls-only"]
    if len(argv) == 2:
        print(__doc__)
        return 1
    first, last = (int(argv[1]), int(argv[2])) if len(argv) >= 3 else (2, 32)
    shifts = [float(s) for s in argv[3:]] or [1.5, 3.0]
    alignments = converged = wrong = 0
    for seed in range(first, last):
        for shift in shifts:
            rng = np.random.default_rng(seed)
            target = corridor_scan(rng, 0.0, floor)
            source = corridor_scan(rng, shift, floor)
            reg = pcl_mi.Registration()
            reg.set_target(target)
            result = reg.align(source)
            alignments += 1
            if result.converged:
                error = np.linalg.norm(result.transformation[:3, 3] - [shift, 0.0, 0.0])
                converged += 1
                wrong += error > 0.5
                print(f"seed {seed}, {shift} m apart: converged {error:.2f} m off "
                      f"(confidence {result.confidence:.3f})")
    print(f"{alignments} alignments: {converged} said converged, {wrong} of them more than "
          f"0.5 m off")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
