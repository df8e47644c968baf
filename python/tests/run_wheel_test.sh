#!/usr/bin/env bash
# Builds the wheel from a build tree, unpacks it as pip would into an empty folder, and
# aligns the bundled pair with the system python and nothing else on the path.
# Usage: run_wheel_test.sh SOURCE_DIR BUILD_DIR WORK_DIR PYTHON
set -euo pipefail
source_dir=$1 build_dir=$2 work=$3 python=$4
rm -rf "$work" && mkdir -p "$work/site"
bash "$source_dir/scripts/build_wheel.sh" "$build_dir" "$work/dist" "$python"
wheel=$(ls "$work"/dist/pcl_mi-*.whl)
(cd "$work/site" && "$python" -m zipfile -e "$wheel" .)
cd "$source_dir"
env -u LD_LIBRARY_PATH PYTHONPATH="$work/site" "$python" - <<'PY'
import numpy as np
import pcl_mi

def scan(frame):
    path = f"data/kitti/sequences/00/velodyne/{frame:06d}.bin"
    return np.fromfile(path, dtype=np.float32).reshape(-1, 4)

result = pcl_mi.align(scan(9), scan(0))
assert result.converged, result
assert "/site/" in pcl_mi.__file__, pcl_mi.__file__
print("wheel module", pcl_mi.__file__, result)
PY
