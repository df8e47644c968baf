"""Readers of KITTI's calib.txt and pose files, shared by the scripts that derive
evaluation data from the KITTI odometry layout."""
import sys

import numpy as np


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
