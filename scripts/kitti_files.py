"""Readers of KITTI's calib.txt and pose files, and the writer of pcl_mi_compare's -list
file, shared by the scripts that derive evaluation data from the KITTI odometry layout."""
import os
import sys

try:
    import numpy as np
except ImportError:
    sys.exit("this KITTI script needs numpy: apt-get install python3-numpy (Debian's /usr/bin/python3, "
             "which this script's first line names, has it after scripts/setup_debian.sh)")


def read_tr(path):
    """The 4x4 velodyne-to-camera transform of calib.txt's Tr: line."""
    for line in open(path):
        if line.startswith("Tr:"):
            tr = np.eye(4)
            tr[:3, :] = np.array([float(v) for v in line.split()[1:13]]).reshape(3, 4)
            return tr
    sys.exit(f"no Tr: line in {path}")


def read_poses(path):
    """Every pose of a KITTI / SemanticKITTI pose file as a 4x4 matrix."""
    poses = []
    for line in open(path):
        if line.strip():
            p = np.eye(4)
            p[:3, :] = np.array([float(v) for v in line.split()[:12]]).reshape(3, 4)
            poses.append(p)
    return poses


def load_sequence(root, seq, poses_kind, program):
    """The velodyne directory of sequence \a seq, its stored frame numbers (sorted), and the
    velodyne-frame pose Tv_k = inv(Tr) * P_k * Tr of each, from the SemanticKITTI poses
    ("semantic": sequences/SS/poses.txt) or KITTI's ground truth ("gt": poses/SS.txt)."""
    seq_dir = os.path.join(root, "sequences", seq)
    velodyne = os.path.join(seq_dir, "velodyne")
    if not os.path.isdir(velodyne):
        sys.exit(f"{program}: no {velodyne}")
    frames = sorted(int(f[:-4]) for f in os.listdir(velodyne) if f.endswith(".bin"))
    tr = read_tr(os.path.join(seq_dir, "calib.txt"))
    pose_file = (os.path.join(seq_dir, "poses.txt") if poses_kind == "semantic"
                 else os.path.join(root, "poses", seq + ".txt"))
    poses = read_poses(pose_file)
    velo = {k: np.linalg.inv(tr) @ poses[k] @ tr for k in frames}
    return velodyne, frames, velo


def list_row(source, target, transform):
    """One pcl_mi_compare -list row: SOURCE TARGET and the top three rows of the 4x4
    source-to-target \a transform, row-major."""
    numbers = " ".join(f"{v:.9g}" for v in transform[:3, :].reshape(-1))
    return f"{source} {target} {numbers}"


def write_pair_list(out_dir, rows):
    """Writes \a rows (from list_row) to OUT_DIR/list.txt and returns its path."""
    path = os.path.join(out_dir, "list.txt")
    with open(path, "w") as out:
        out.write("\n".join(rows) + "\n")
    return path
