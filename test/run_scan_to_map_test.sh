#!/usr/bin/env bash
# End-to-end: scripts/kitti_scan_to_map.py on the bundled scans (sequence 00, frames 0 and 9:
# scan 9 against a "map" of scan 0), then pcl_mi_compare -list on what it wrote. Asserts that
# the map is scan 0 in its own frame, that the list's reference is the bundled one, that a
# frame the sequence lacks is refused, that MI-VARZ aligns the scan within 0.1 m / 0.5 deg,
# and that with a kept map the same case gives the same pose, timed as kept or prepared.
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
# One shared map, and MI keeping it between rows: the same case twice, the second against the
# prepared map, gives the same pose as a fresh registration.
"$script" "$data/kitti" "$work/shared" --sequences 00 --sources 9 --shared-map > "$work/shared.txt"
grep -q "(one map)" "$work/shared.txt"
cmp "$work/shared/map_00.bin" "$work/map/map_00_000009.bin"
if "$script" "$data/kitti" "$work/bad" --sequences 00 --sources 0 --shared-map 2> "$work/bad.txt"; then
  echo "a shared map without its first frame was not refused"; exit 1
fi
grep -q "cannot be a source" "$work/bad.txt"
row=$(cat "$work/shared/list.txt")
printf '%s\n%s\n' "$row" "$row" > "$work/shared/list.txt"
"$compare" -list "$work/shared/list.txt" -methods mi-varz -directions forward -reuse_target \
  -csv "$work/reused.csv" | tee "$work/reused.txt"
grep -q "MI stages, median per alignment" "$work/reused.txt"
# The first row prepared the map, the second kept it: one of each in the scan-to-map table.
grep -Eq "^mi-varz +1 +[0-9.]+ +1 +[0-9.]+$" "$work/reused.txt"
/usr/bin/python3 - "$work/map.csv" "$work/reused.csv" <<'PY'
import csv, sys
fresh = list(csv.DictReader(open(sys.argv[1])))
reused = list(csv.DictReader(open(sys.argv[2])))
assert len(fresh) == 1 and len(reused) == 2, (len(fresh), len(reused))
keys = [k for k in fresh[0] if k.startswith("estimate_")]
for r in reused:
    assert all(r[k] == fresh[0][k] for k in keys), "a reused map changed the pose"
print("reused map: the same pose as a fresh registration, twice")
PY
