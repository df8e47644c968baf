#!/usr/bin/python3
"""How far pcl_mi's verdict and confidence can be trusted, from pcl_mi_compare CSVs (one per
set; the set is named by the file name): per set the share of converged results that miss
the success bound and the share of right results that said converged, then the reliability
diagram of the confidence over all rows (deciles; bins with fewer than 20 rows are marked).
Where the CSVs have MI's refusal column, the right results that did not say converged are
counted per set by kind of reason, as pcl_mi_compare's summary counts them.
With -thresholds, the pooled verdict each other confidence threshold would give: converged
where the search converged, at least 30 inliers, no free direction (contrast >= 0.05) and the
confidence at least the threshold (src/verify/verification.cpp). The CSVs do not record the
second-optimum check, so those figures count a few results as converged that the library
refuses: their wrong shares are upper bounds. Nor do they say which free turns the MI or
the refinement holds, which the library passes and the gate does not, and the gate leaves
out the results the clouds swapped confirm.
With -reference_check ROOT,DEG, the results of a pair list (`pcl_mi_compare -list`) are left
out where the set's own check of its reference, ROOT/SET/pairs_overlap.csv (the
foreign_lidar layout, one row per row of the list), says that a point-to-plane ICP started
at the reference moves it by more than DEG degrees: there the reference itself is uncertain
at the scale of the success bound. How many each set leaves out follows the first table.

Usage: verdict_report.py [-success T,R] [-plot OUT.png] [-thresholds 0.95,0.9,...]
                         [-reference_check ROOT,DEG] A.csv B.csv ...
"""
import csv
import os
import sys

import numpy as np

from fit_confidence import passes_gate

# The kinds of the CSV's refusal column (apps/compare/methods.cpp).
REFUSALS = ("degenerate", "too little shared surface", "a second optimum", "weak evidence",
            "the search capped", "failed")


def consistent_references(rows, root, set_name, max_moves_deg):
    """The rows of a pair list whose reference the set's ICP check moves by at most
    max_moves_deg degrees, and how many were left out; every row where the set has no
    check or the rows are not a pair list's."""
    path = os.path.join(root, set_name, "pairs_overlap.csv")
    if not os.path.exists(path):
        return rows, 0
    with open(path) as f:
        checks = list(csv.DictReader(f))
    kept = [r for r in rows if r["sequence"] != "list" or
            float(checks[int(r["target"]) - 1]["icp_moves_deg"]) <= max_moves_deg]
    return kept, len(rows) - len(kept)


def main(argv):
    args, files, bound, plot, thresholds = argv[1:], [], (0.5, 2.0), None, []
    reference_check = None
    i = 0
    while i < len(args):
        if args[i] == "-reference_check":
            root, degrees = args[i + 1].rsplit(",", 1)
            reference_check, i = (root, float(degrees)), i + 2
        elif args[i] == "-thresholds":
            thresholds, i = [float(x) for x in args[i + 1].split(",")], i + 2
        elif args[i] == "-success":
            bound, i = tuple(float(x) for x in args[i + 1].split(",")), i + 2
        elif args[i] == "-plot":
            plot, i = args[i + 1], i + 2
        else:
            files.append(args[i])
            i += 1
    confidence, success, passes = [], [], []
    print("| set | results | right | converged | wrong among converged | right that said converged |")
    print("|---|---|---|---|---|---|")
    totals = np.zeros(4)
    held_back = []  # per set: right results that did not say converged, by kind of reason
    left_out_lines = []
    for path in files:
        with open(path) as f:
            rows = [r for r in csv.DictReader(f) if r["method"].startswith("mi-")]
        if reference_check:
            name = os.path.splitext(os.path.basename(path))[0]
            rows, left_out = consistent_references(rows, reference_check[0], name,
                                                   reference_check[1])
            left_out_lines.append("%s: %d results left out (ICP from the reference moves "
                                  "more than %g deg)" % (name, left_out, reference_check[1]))
        ok = np.array([float(r["translation_error_m"]) < bound[0] and
                       float(r["rotation_error_deg"]) < bound[1] for r in rows])
        said = np.array([r["converged"] == "1" for r in rows])
        confidence += [float(r["confidence"]) for r in rows]
        passes += [passes_gate(r) for r in rows]
        success += list(ok)
        wrong, found = (said & ~ok).sum(), (said & ok).sum()
        totals += [len(rows), ok.sum(), said.sum(), wrong]
        if rows and "refusal" in rows[0]:
            kinds = [r["refusal"] for r, right, conv in zip(rows, ok, said) if right and not conv]
            held_back.append((path, [kinds.count(k) for k in REFUSALS]))
        print("| %s | %d | %d | %d | %d (%.1f %%) | %.1f %% |" % (
            os.path.splitext(os.path.basename(path))[0], len(rows), ok.sum(), said.sum(), wrong,
            100.0 * wrong / max(said.sum(), 1), 100.0 * found / max(ok.sum(), 1)))
    confidence, success = np.array(confidence), np.array(success)
    print("| all | %d | %d | %d | %d (%.2f %%) | |" % (totals[0], totals[1], totals[2], totals[3],
                                                  100.0 * totals[3] / max(totals[2], 1)))
    if left_out_lines:
        print("\n" + "\n".join(left_out_lines))
    if held_back:
        print("\nRight results that did not say converged, by kind of reason")
        print("| set | " + " | ".join(REFUSALS) + " |")
        print("|---|" + "---|" * len(REFUSALS))
        for path, counts in held_back:
            print("| %s | %s |" % (os.path.splitext(os.path.basename(path))[0],
                                   " | ".join(str(c) for c in counts)))
    print("\nReliability (all rows): confidence decile, rows, mean confidence, observed success")
    print("| confidence | rows | mean confidence | observed success | difference |")
    print("|---|---|---|---|---|")
    centres, observed, counts = [], [], []
    for b in range(10):
        lo, hi = b / 10.0, (b + 1) / 10.0
        m = (confidence >= lo) & ((confidence < hi) if b < 9 else (confidence <= hi))
        if not m.any():
            continue
        c, s = confidence[m].mean(), success[m].mean()
        centres.append(c), observed.append(s), counts.append(m.sum())
        print("| %.1f-%.1f | %d%s | %.3f | %.3f | %+.1f points |" % (
            lo, hi, m.sum(), "" if m.sum() >= 20 else " (< 20)", c, s, 100.0 * (s - c)))
    if thresholds:
        passes = np.array(passes)
        print("\nOther thresholds (all rows; wrong shares are upper bounds, see the usage)")
        print("| confidence at least | converged | wrong among converged | right that said converged |")
        print("|---|---|---|---|")
        for t in thresholds:
            said = passes & (confidence >= t)
            wrong = (said & ~success).sum()
            print("| %.2f | %d | %d (%.2f %%) | %.1f %% |" % (
                t, said.sum(), wrong, 100.0 * wrong / max(said.sum(), 1),
                100.0 * (said & success).sum() / max(success.sum(), 1)))
    if plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 5))
        ax.plot([0, 1], [0, 1], color="grey", lw=1, label="calibrated")
        ax.fill_between([0, 1], [-0.1, 0.9], [0.1, 1.1], color="grey", alpha=0.15,
                        label="+-10 points")
        ax.scatter(centres, observed, s=[10 + 40 * np.log10(n) for n in counts], zorder=3,
                   label="deciles (area: log rows)")
        ax.set_xlim(0, 1), ax.set_ylim(0, 1)
        ax.set_xlabel("mean confidence"), ax.set_ylabel("observed success")
        ax.set_title("pcl_mi confidence, %d results" % len(confidence))
        ax.legend(loc="upper left")
        fig.tight_layout()
        fig.savefig(plot, dpi=100)
        print("\nwrote", plot)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
