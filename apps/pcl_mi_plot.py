#!/usr/bin/python3
"""Plots pcl_mi_compare results like the paper's figures.

Usage: pcl_mi_plot.py RESULTS.csv OUTPUT_PREFIX

Writes OUTPUT_PREFIX_translation.png and OUTPUT_PREFIX_rotation.png: boxplots of the final
translation (rotation) error per method, grouped by 1 m (2 deg) bins of the initial error.
Where the CSV has the signed error columns (pcl_mi_compare writes them), also
OUTPUT_PREFIX_bias.png: the signed error along, left of and above the reference motion of
every successful row (< 0.5 m and < 2 deg) against the distance between the scans, with the
per-metre means of each direction; a bias that grows with the distance shows as a slope.
Needs python3-matplotlib (Debian).
"""
import csv
import math
import sys

try:
    import matplotlib
except ImportError:
    sys.exit("pcl_mi_plot.py needs matplotlib: apt-get install python3-matplotlib (Debian's /usr/bin/python3, "
             "which this script's first line names, has it after scripts/setup_debian.sh)")

matplotlib.use("Agg")  # files only; works without a display
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402
from matplotlib.transforms import blended_transform_factory  # noqa: E402


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


SUCCESS_M, SUCCESS_DEG = 0.5, 2.0  # pcl_mi_compare's default -success bound


SMALL_BIN = 5  # fewer rows than this are drawn as points: a box of two says nothing


def succeeded(row):
    return (float(row["translation_error_m"]) < SUCCESS_M
            and float(row["rotation_error_deg"]) < SUCCESS_DEG)


def boxplot(rows, initial_key, final_key, bin_width, unit, title, path):
    """Final against initial error per method and bin: a box per (bin, method), or its
    points when the bin is small, with the rows and success rate above each, and the
    success bound as a line. Linear scale when every error is small, else symlog with
    plain-number ticks."""
    methods = list(dict.fromkeys(r["method"] for r in rows))
    bins = sorted({int(float(r[initial_key]) // bin_width) for r in rows})
    fig, ax = plt.subplots(figsize=(min(14.0, max(7.0, 1.4 * len(bins) + 3.5)), 4.8))
    width = 0.8 / max(1, len(methods))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    bound = SUCCESS_M if unit == "m" else SUCCESS_DEG
    largest = max(float(r[final_key]) for r in rows)
    linthresh = 0.1 if unit == "m" else 0.5
    annotate = blended_transform_factory(ax.transData, ax.transAxes)
    for m_index, method in enumerate(methods):
        colour = colours[m_index % len(colours)]
        for b_index, b in enumerate(bins):
            group = [r for r in rows
                     if r["method"] == method and int(float(r[initial_key]) // bin_width) == b]
            if not group:
                continue
            values = [float(r[final_key]) for r in group]
            x = b_index + (m_index - (len(methods) - 1) / 2) * width
            if len(values) < SMALL_BIN:
                ax.scatter([x] * len(values), values, color=colour, s=14, zorder=3)
            else:
                parts = ax.boxplot([values], positions=[x], widths=width * 0.9,
                                   patch_artist=True, manage_ticks=False, showfliers=True,
                                   medianprops={"color": "black"})
                parts["boxes"][0].set_facecolor(colour)
                parts["boxes"][0].set_alpha(0.7)
            rate = 100.0 * sum(succeeded(r) for r in group) / len(group)
            ax.text(x, 1.01, f"{rate:.0f}%", transform=annotate, ha="center", va="bottom",
                    fontsize=6)
        ax.plot([], [], color=colour, linewidth=8, label=method)
    ax.axhline(bound, color="grey", linestyle="--", linewidth=0.8,
               label=f"success bound ({bound:g} {unit})")
    ax.set_xticks(range(len(bins)))
    counts = [max(sum(1 for r in rows if r["method"] == m
                      and int(float(r[initial_key]) // bin_width) == b) for m in methods)
              for b in bins]
    ax.set_xticklabels([f"{b * bin_width:g}-{(b + 1) * bin_width:g}\nn={n}"
                        for b, n in zip(bins, counts)])
    ax.set_xlabel(f"initial error [{unit}] (n: alignments per method; above: success rate)")
    ax.set_ylabel(f"final error [{unit}]")
    if largest > 2 * max(linthresh, bound):
        ax.set_yscale("symlog", linthresh=linthresh)
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.set_ylim(bottom=0)
    ax.set_title(title, pad=22)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


BIAS_COLUMNS = (("along_error_m", "along the reference motion (+ = beyond it)"),
                ("left_error_m", "left of the reference motion"),
                ("up_error_m", "above the reference motion"))


def bias_plot(rows, path):
    """Signed error components of the successful rows against the reference distance."""
    rows = [r for r in rows if succeeded(r) and not math.isnan(float(r["along_error_m"]))]
    if not rows:
        return False
    methods = list(dict.fromkeys(r["method"] for r in rows))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, axes = plt.subplots(1, 3, figsize=(13.0, 4.2), sharey=True)
    for ax, (column, label) in zip(axes, BIAS_COLUMNS):
        for m_index, method in enumerate(methods):
            colour = colours[m_index % len(colours)]
            # Directions apart: a disagreement about the later scan's height changes sign
            # with the direction (see pcl_mi_compare's bias table), along and left do not.
            for direction, style, marker in (("forward", "-", "o"), ("backward", "--", "s")):
                points = [(float(r["true_translation_m"]), float(r[column])) for r in rows
                          if r["method"] == method and r["direction"] == direction]
                if not points:
                    continue
                ax.scatter([d for d, _ in points], [e for _, e in points], s=6, alpha=0.3,
                           color=colour, marker=marker)
                by_metre = {}
                for d, e in points:
                    by_metre.setdefault(int(d), []).append(e)
                metres = sorted(by_metre)
                ax.plot([m + 0.5 for m in metres],
                        [sum(by_metre[m]) / len(by_metre[m]) for m in metres],
                        linestyle=style, marker=marker, color=colour,
                        label=f"{method} {direction}")
        ax.axhline(0.0, color="black", linewidth=0.8)
        ax.set_xlabel("distance between the scans (reference) [m]")
        ax.set_title(label, fontsize="medium")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("signed translation error [m]")
    # Below the panels, where it covers no data.
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(4, len(labels)), fontsize="small")
    fig.suptitle("Signed error of the successful alignments (dots) and its mean per metre")
    fig.tight_layout(rect=(0, 0.08 + 0.04 * ((len(labels) - 1) // 4), 1, 1))
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 1
    try:
        rows = read_rows(argv[1])
    except OSError as e:
        print(f"pcl_mi_plot: {e}", file=sys.stderr)
        return 1
    if not rows or "translation_error_m" not in rows[0]:
        print(f"pcl_mi_plot: '{argv[1]}' holds no pcl_mi_compare rows", file=sys.stderr)
        return 1
    rows = [r for r in rows if not math.isnan(float(r["translation_error_m"]))]
    prefix = argv[2]
    boxplot(rows, "initial_translation_m", "translation_error_m", 1.0, "m",
            "Final translation error vs initial error", prefix + "_translation.png")
    boxplot(rows, "initial_rotation_deg", "rotation_error_deg", 2.0, "deg",
            "Final rotation error vs initial error", prefix + "_rotation.png")
    written = [prefix + "_translation.png", prefix + "_rotation.png"]
    if "along_error_m" in rows[0] and bias_plot(rows, prefix + "_bias.png"):
        written.append(prefix + "_bias.png")
    print("wrote " + ", ".join(written))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
