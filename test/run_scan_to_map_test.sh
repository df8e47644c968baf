#!/usr/bin/env bash
# End-to-end: scripts/kitti_scan_to_map.py on the bundled scans (sequence 00, frames 0 and 9:
# scan 9 against a "map" of scan 0), then pcl_mi_compare -list on what it wrote. Asserts that
# the map is scan 0 in its own frame, that the list's reference is the bundled one, that a
# frame the sequence lacks is refused, and that MI-VARZ aligns the scan within 0.1 m / 0.5 deg.
# Usage: run_scan_to_map_test.sh SCRIPT COMPARE_BINARY DATA_DIR WORK_DIR
set -euo pipefail
script=$1 compare=$2 data=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
"$script" "$data/kitti" "$work/map" --sequences 00 --sources 9 | tee "$work/log.txt"
/usr/bin/python3 - "$data/kitti" "$work/map" <<'PY'
import sys
import numpy as np
kitti, out = sys.argv[1], sys.argv[2]
scan0 = np.fromfile(f"{kitti}/sequences/00/velodyne/000000.bin", dtype=np.float32).reshape(-1, 4)
built = np.fromfile(f"{out}/map_00_000009.bin", dtype=np.float32).reshape(-1, 4)
assert built.shape == scan0.shape and np.allclose(built, scan0, atol=1e-4)
row = open(f"{out}/list.txt").read().split()
assert row[:2] == ["00_000009.bin", "map_00_000009.bin"], row[:2]
reference = np.loadtxt(f"{kitti}/reference_00_000009_to_000000.txt")[:3, :]
assert np.allclose(np.array(row[2:14], float).reshape(3, 4), reference, atol=1e-6)
print("map = scan 0, reference = the bundled one")
PY
if "$script" "$data/kitti" "$work/bad" --sequences 00 --sources 5 2> "$work/bad.txt"; then
  echo "a missing frame was not refused"; exit 1
fi
grep -q "has no stored frame 5" "$work/bad.txt"
"$compare" -list "$work/map/list.txt" -methods mi-varz -directions forward -csv "$work/map.csv"
awk -F, 'NR > 1 { n++; if ($10 >= 0.1 || $11 >= 0.5) { print "out of bound: " $0; bad++ } }
         END { if (n != 1 || bad) exit 1; print n " alignment within 0.1 m / 0.5 deg" }' "$work/map.csv"
