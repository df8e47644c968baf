#!/usr/bin/python3
"""Checks that two pcl_mi_compare CSVs hold the same poses, bit for bit.

    scripts/compare_poses.py [--every-column] BEFORE.csv AFTER.csv

Rows are matched by (sequence, target, source, direction, method); for each the estimated
pose, the evaluation count and the converged flag must be equal as written, and with
--every-column every column but the time (`seconds`): the verdict, confidence, covariance
and evidence too. Prints the number of rows compared and every difference; exits 1 when any
row differs or is missing. Used to show that a change which should not alter results (a
refactoring) did not.
"""
import csv
import sys

KEY = ("sequence", "target", "source", "direction", "method")


def rows(path):
    with open(path, newline="") as f:
        table = {}
        for row in csv.DictReader(f):
            table[tuple(row[k] for k in KEY)] = row
        return table


def main():
    args = sys.argv[1:]
    every_column = "--every-column" in args
    paths = [a for a in args if a != "--every-column"]
    if len(paths) != 2 or len(args) - len(paths) > 1:
        sys.exit(__doc__)
    before, after = rows(paths[0]), rows(paths[1])
    if not before:
        sys.exit(f"{paths[0]}: no rows")
    columns = list(next(iter(before.values())))
    if every_column:
        checked = [c for c in columns if c != "seconds"]
    else:
        checked = [c for c in columns if c.startswith("estimate_")]
        checked += ["evaluations", "converged"]
    differ = 0
    for key in sorted(set(before) | set(after)):
        if key not in before or key not in after:
            print("only in", paths[0] if key in before else paths[1], ":", key)
            differ += 1
            continue
        changed = [c for c in checked if before[key].get(c) != after[key].get(c)]
        if changed:
            print("differs:", key, ", ".join(changed))
            differ += 1
    print(f"{len(before)} rows compared, {differ} differ")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
