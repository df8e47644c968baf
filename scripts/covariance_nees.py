#!/usr/bin/python3
"""Checks pcl_mi's covariance against exact errors: each real scan is split into two disjoint
halves (alternate points), one half is moved by a known random transform, the halves are
aligned with the defaults from the identity guess, and the normalised squared error
e^T inv(Sigma) e of every converged result is printed (its mean is 6 for a consistent
6-DoF covariance). e is the left increment [t, rotation vector] that carries the result onto
the known transform, the order and frame of getCovariance(). With -noise SIGMA, Gaussian
noise of SIGMA (m) is added to every coordinate before the split. With -split random, each
point goes to either half by a coin toss instead of alternately, which rules out the
scanner's order of points as a cause of a too-small covariance. With -keep_every N, only every
N-th point of each scan is kept before the split, as a sparser sensor or a front end's
decimation would leave it.

Usage: covariance_nees.py BUILD_DIR SCAN.bin... [-pairs_per_scan K] [-seed S] [-noise SIGMA]
                          [-split alternate|random] [-keep_every N]
"""
import sys

import numpy as np


def rotation_vector(r):
    angle = np.arccos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))
    if angle < 1e-12:
        return np.zeros(3)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / (2.0 * np.sin(angle))
    return angle * axis


def rotation(axis, angle):
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def main(argv):
    args, scans, k, seed, noise, split, keep = argv[2:], [], 2, 1, 0.0, "alternate", 1
    i = 0
    while i < len(args):
        if args[i] == "-pairs_per_scan":
            k, i = int(args[i + 1]), i + 2
        elif args[i] == "-seed":
            seed, i = int(args[i + 1]), i + 2
        elif args[i] == "-noise":
            noise, i = float(args[i + 1]), i + 2
        elif args[i] == "-keep_every":
            keep, i = int(args[i + 1]), i + 2
            if keep < 1:
                sys.exit("covariance_nees.py: -keep_every takes a count of 1 or more, not %d" % keep)
        elif args[i] == "-split":
            split, i = args[i + 1], i + 2
            if split not in ("alternate", "random"):
                sys.exit("covariance_nees.py: -split takes alternate or random, not '%s'" % split)
        else:
            scans.append(args[i])
            i += 1
    sys.path.insert(0, argv[1] + "/python")
    import pcl_mi

    rng = np.random.default_rng(seed)
    nees, normalised, errors, rows = [], [], [], 0
    for path in scans:
        points = np.fromfile(path, dtype=np.float32).reshape(-1, 4)[:, :3].astype(np.float64)
        points = points[np.isfinite(points).all(1) & (np.abs(points).sum(1) > 0)][::keep]
        if noise > 0:
            points = points + rng.normal(scale=noise, size=points.shape)
        if split == "random":
            heads = rng.random(len(points)) < 0.5
            target, half = points[heads], points[~heads]
        else:
            target, half = points[0::2], points[1::2]
        for _ in range(k):
            # A known motion: 0.2-1 m horizontally, up to 5 deg about a random axis.
            truth = np.eye(4)
            truth[:3, :3] = rotation(rng.normal(size=3), np.radians(rng.uniform(-5, 5)))
            direction = rng.uniform(0, 2 * np.pi)
            truth[:3, 3] = rng.uniform(0.2, 1.0) * np.array([np.cos(direction), np.sin(direction), 0])
            # source = truth^-1 applied to the half, so truth maps it back onto the target.
            inverse = np.linalg.inv(truth)
            source = half @ inverse[:3, :3].T + inverse[:3, 3]
            reg = pcl_mi.Registration()
            reg.set_target(target)
            result = reg.align(source, np.eye(4))
            rows += 1
            if not result.converged:
                continue
            d = truth @ np.linalg.inv(result.transformation)
            e = np.concatenate([d[:3, 3], rotation_vector(d[:3, :3])])
            sigma = np.asarray(result.covariance)
            nees.append(float(e @ np.linalg.solve(sigma, e)))
            normalised.append(e / np.sqrt(np.diag(sigma)))
            errors.append(e)
    nees = np.array(nees)
    print("pairs %d, converged %d" % (rows, len(nees)))
    if len(nees):
        print("NEES mean %.2f, median %.2f (6 and 5.35 when consistent), 90 %% %.2f" %
              (nees.mean(), np.median(nees), np.percentile(nees, 90)))
        # Which parameters the covariance is too small (> 1) or too large (< 1) for.
        rms = np.sqrt((np.array(normalised) ** 2).mean(0))
        print("RMS of error / standard deviation, [tx ty tz roll pitch yaw]: " +
              " ".join("%.2f" % x for x in rms))
        to_cm_deg = np.array([100.0] * 3 + [np.degrees(1.0)] * 3)
        rms = np.sqrt((np.array(errors) ** 2).mean(0)) * to_cm_deg
        print("RMS error [cm cm cm deg deg deg]: " + " ".join("%.3f" % x for x in rms))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
