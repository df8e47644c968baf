#!/usr/bin/python3
"""Plots pcl_mi_cost_surface output like the paper's cost-function figures.

Usage: pcl_mi_plot_cost_surface.py PREFIX

Reads PREFIX_xy.csv and PREFIX_yaw.csv; writes PREFIX_xy.png (MI over the (tx, ty) grid
around the reference) and PREFIX_yaw.png (MI and GICP's objective versus heading, each
normalised to [0, 1], MI inverted so that both have their optimum at the bottom). Where
PREFIX_line.csv exists (pcl_mi_cost_surface -toward), also PREFIX_line.png: both costs on the
line from the reference to the other pose, on their own axes.
Needs python3-matplotlib and python3-numpy (Debian).
"""
import os
import sys

try:
    import matplotlib
except ImportError:
    sys.exit("pcl_mi_plot_cost_surface.py needs matplotlib: apt-get install python3-matplotlib (Debian's /usr/bin/python3, "
             "which this script's first line names, has it after scripts/setup_debian.sh)")

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
try:
    import numpy as np
except ImportError:
    sys.exit("pcl_mi_plot_cost_surface.py needs numpy: apt-get install python3-numpy (Debian's /usr/bin/python3, "
             "which this script's first line names, has it after scripts/setup_debian.sh)")


def normalise(v):
    v = np.asarray(v, dtype=float)
    finite = np.isfinite(v)
    lo, hi = np.min(v[finite]), np.max(v[finite])
    return (v - lo) / (hi - lo) if hi > lo else np.zeros_like(v)


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 1
    prefix = argv[1]
    try:
        # atleast_1d: a single-row file (-extent 0) reads as a 0-d array.
        xy = np.atleast_1d(np.genfromtxt(prefix + "_xy.csv", delimiter=",", names=True))
        yaw = np.atleast_1d(np.genfromtxt(prefix + "_yaw.csv", delimiter=",", names=True))
    except OSError as e:
        print(f"pcl_mi_plot_cost_surface: {e}", file=sys.stderr)
        return 1
    xs, ys = np.unique(xy["dx_m"]), np.unique(xy["dy_m"])
    grid = np.full((len(ys), len(xs)), np.nan)
    for x, y, mi in zip(xy["dx_m"], xy["dy_m"], xy["mi"]):
        grid[np.searchsorted(ys, y), np.searchsorted(xs, x)] = mi
    fig, ax = plt.subplots(figsize=(6, 5))
    image = ax.pcolormesh(xs, ys, grid, shading="nearest", cmap="viridis")
    fig.colorbar(image, ax=ax, label="mutual information [nats]")
    ax.plot([0], [0], "r+", markersize=14, label="reference")
    ax.set_xlabel("tx offset from reference [m]")
    ax.set_ylabel("ty offset from reference [m]")
    ax.set_title("MI around the reference pose")
    ax.set_aspect("equal")
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(prefix + "_xy.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(yaw["dyaw_deg"], 1.0 - normalise(yaw["mi"]), label="MI (inverted)")
    ax.plot(yaw["dyaw_deg"], normalise(yaw["gicp"]), label="GICP objective")
    ax.axvline(0.0, color="grey", linestyle=":", label="reference")
    ax.set_xlabel("heading offset from reference [deg]")
    ax.set_ylabel("normalised cost")
    ax.set_title("Cost versus heading")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(prefix + "_yaw.png", dpi=120)
    plt.close(fig)
    written = [prefix + "_xy.png", prefix + "_yaw.png"]

    if os.path.exists(prefix + "_line.csv"):
        line = np.genfromtxt(prefix + "_line.csv", delimiter=",", names=True)
        one = line["offset_m"][np.argmin(np.abs(line["s"] - 1.0))]
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(line["offset_m"], line["gicp"], color="C1", label="GICP objective")
        ax.set_xlabel("distance from the reference towards the other pose [m]")
        ax.set_ylabel("GICP objective (lower is better)")
        ax.axvline(0.0, color="grey", linestyle=":")
        ax.axvline(one, color="black", linestyle="--")
        ax.text(0.0, 1.01, "reference", transform=ax.get_xaxis_transform(), ha="center")
        ax.text(one, 1.01, "other pose", transform=ax.get_xaxis_transform(), ha="center")
        mi_axis = ax.twinx()
        mi_axis.plot(line["offset_m"], line["mi"], color="C0", label="MI")
        mi_axis.set_ylabel("mutual information [nats] (higher is better)")
        handles = ax.get_legend_handles_labels()
        mi_handles = mi_axis.get_legend_handles_labels()
        ax.legend(handles[0] + mi_handles[0], handles[1] + mi_handles[1], loc="best")
        ax.set_title("Costs on the line from the reference to the other pose", pad=18)
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(prefix + "_line.png", dpi=120)
        plt.close(fig)
        written.append(prefix + "_line.png")
    print("wrote " + ", ".join(written))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
