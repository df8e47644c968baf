#!/usr/bin/python3
"""Checks that two pcl_mi_compare CSVs hold the same poses, bit for bit.

    scripts/compare_poses.py BEFORE.csv AFTER.csv

Rows are matched by (sequence, target, source, direction, method); for each the estimated
pose, the evaluation count and the converged flag must be equal as written. Prints the
number of rows compared and every difference; exits 1 when any row differs or is missing.
Used to show that a change which should not alter results (a refactoring) did not.
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
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    before, after = rows(sys.argv[1]), rows(sys.argv[2])
    checked = [c for c in next(iter(before.values())) if c.startswith("estimate_")]
    checked += ["evaluations", "converged"]
    differ = 0
    for key in sorted(set(before) | set(after)):
        if key not in before or key not in after:
            print("only in", sys.argv[1] if key in before else sys.argv[2], ":", key)
            differ += 1
            continue
        changed = [c for c in checked if before[key][c] != after[key][c]]
        if changed:
            print("differs:", key, ", ".join(changed))
            differ += 1
    print(f"{len(before)} rows compared, {differ} differ")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
