#!/usr/bin/python3
"""Which pose do the scans prefer, the reference or the estimate?

Usage: reference_check.py COST_SURFACE_BINARY KITTI_ROOT|LIST RESULTS.csv METHOD [MIN_M [MAX_M]]
                          [-wrong_converged]

For every row of a pcl_mi_compare CSV with the given method whose true motion lies in
[MIN_M, MAX_M] m (default: all), runs `pcl_mi_cost_surface SOURCE TARGET REFERENCE -toward
ESTIMATE` and reads GICP's objective (plane-regularised covariances, k = 20, 5 m
correspondences, as PCL's GICP; lower is better) on the line from the reference (s = 0) to
the estimate (s = 1), 0.5 beyond either end. Prints per row the objective at both poses and
where on the line it is lowest, then how many rows prefer the estimate. The scans of a KITTI
run (`pcl_mi_compare -kitti`) are found under KITTI_ROOT; those of a pair list's run
(`pcl_mi_compare -list LIST`) in LIST, by the row's line number. With -wrong_converged, only
the rows that said converged and miss the success bound (0.5 m, 2 deg) are checked.

A reference that is less accurate than the alignment shows as rows whose objective is lower
at the estimate, with the line's minimum near s = 1: the estimate's error then measures the
reference as much as the method.
"""
import csv
import os
import subprocess
import sys
import tempfile


def write_matrix(path, row, kind):
    rows = [[row[f"{kind}_{i}{j}"] for j in range(4)] for i in range(3)]
    with open(path, "w") as f:
        f.write("\n".join(" ".join(r) for r in rows) + "\n0 0 0 1\n")


def scan_paths(root, list_lines, row):
    """Source and target scans of a CSV row: from the pair list ROOT, read as list_lines
    (line = the row's 'source', the list's first scan the source of a forward row), or under
    a KITTI root (list_lines None)."""
    if list_lines is not None:
        words = list_lines[int(row["source"]) - 1].replace(",", " ").split()
        folder = os.path.dirname(root)
        first, second = (w if w.startswith("/") else os.path.join(folder, w) for w in words[:2])
        return (first, second) if row["direction"] == "forward" else (second, first)
    velodyne = os.path.join(root, "sequences", row["sequence"], "velodyne")
    return (os.path.join(velodyne, "%06d.bin" % int(row["source"])),
            os.path.join(velodyne, "%06d.bin" % int(row["target"])))


def wrong_converged(row):
    return row["converged"] == "1" and not (float(row["translation_error_m"]) < 0.5 and
                                            float(row["rotation_error_deg"]) < 2.0)


def main(argv):
    only_wrong = "-wrong_converged" in argv
    argv = [a for a in argv if a != "-wrong_converged"]
    if len(argv) not in (5, 6, 7):
        print(__doc__.strip(), file=sys.stderr)
        return 1
    binary, root, results, method = argv[1:5]
    low = float(argv[5]) if len(argv) > 5 else 0.0
    high = float(argv[6]) if len(argv) > 6 else float("inf")
    rows = [r for r in csv.DictReader(open(results))
            if r["method"] == method and low <= float(r["true_translation_m"]) <= high and
            (not only_wrong or wrong_converged(r))]
    if not rows and only_wrong:
        print(f"no {method} row with motion in [{low}, {high}] m said converged and missed the"
              " bound")
        return 0
    if not rows:
        print(f"reference_check: no {method} rows with motion in [{low}, {high}] m in {results}",
              file=sys.stderr)
        return 1
    print(f"{'pair':>12} {'dir':>8} {'error m':>8} {'GICP obj. ref':>13} {'at estimate':>11}"
          f" {'lowest at s':>11}")
    prefer = 0
    lowest_s = []
    list_lines = open(root).read().splitlines() if os.path.isfile(root) else None
    with tempfile.TemporaryDirectory() as work:
        for r in rows:
            source, target = scan_paths(root, list_lines, r)
            reference, estimate = (os.path.join(work, f"{k}.txt") for k in ("ref", "est"))
            write_matrix(reference, r, "reference")
            write_matrix(estimate, r, "estimate")
            prefix = os.path.join(work, "line")
            subprocess.run([binary, source, target, reference, "-toward", estimate, "-extent", "0",
                            "-yaw_extent", "0", "-o", prefix], check=True,
                           stdout=subprocess.DEVNULL)
            line = list(csv.DictReader(open(prefix + "_line.csv")))
            cost = {round(float(x["s"]), 2): float(x["gicp"]) for x in line}
            best = min(cost, key=cost.get)
            lowest_s.append(best)
            prefer += cost[1.0] < cost[0.0]
            pair = f"{r['sequence']}:{r['target']}-{r['source']}"
            print(f"{pair:>12} {r['direction']:>8}"
                  f" {float(r['translation_error_m']):8.3f} {cost[0.0]:13.4f} {cost[1.0]:11.4f}"
                  f" {best:11.2f}", flush=True)
    lowest_s.sort()
    print(f"{prefer} of {len(rows)} rows: GICP's objective is lower at the estimate than at the"
          f" reference; median s of its minimum on the line {lowest_s[len(lowest_s) // 2]:.2f}"
          " (0 = reference, 1 = estimate)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
