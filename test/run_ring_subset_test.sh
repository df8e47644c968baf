#!/usr/bin/env bash
# End-to-end: scripts/kitti_ring_subset.py on the bundled scans (every 2nd ring, a 32-ring
# sensor), then pcl_mi_compare -list on what it wrote. Asserts that about half the points
# are kept, that the list holds the two bundled pairs with their reference poses, and that
# MI-VARZ aligns all four alignments within 0.15 m / 0.5 deg, that --scale scales the
# points and the reference translations only, that --fov cuts to the field of view, and
# that --noise adds noise of the deviation asked, reproducibly, that --keep-every keeps
# every N-th point, and that --max-range keeps the points within that range.
# Usage: run_ring_subset_test.sh SCRIPT COMPARE_BINARY DATA_DIR WORK_DIR
set -euo pipefail
script=$1 compare=$2 data=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
"$script" "$data/kitti" 2 "$work/rings" --sequences 00,02 | tee "$work/log.txt"
full=$(stat -c %s "$data/kitti/sequences/00/velodyne/000000.bin")
half=$(stat -c %s "$work/rings/00_000000.bin")
awk -v f="$full" -v h="$half" 'BEGIN { r = h / f; print "kept fraction " r; exit !(r > 0.4 && r < 0.6) }'
test "$(wc -l < "$work/rings/list.txt")" -eq 2
grep -q "^00_000009.bin 00_000000.bin " "$work/rings/list.txt"
"$compare" -list "$work/rings/list.txt" -methods mi-varz -csv "$work/rings.csv"
awk -F, 'NR > 1 { n++; if ($10 >= 0.15 || $11 >= 0.5) { print "out of bound: " $0; bad++ } }
         END { if (n != 4 || bad) exit 1; print n " alignments within 0.15 m / 0.5 deg" }' "$work/rings.csv"
# K = 1 keeps every point: the scans are byte-identical to the originals.
"$script" "$data/kitti" 1 "$work/all" --sequences 00 > /dev/null
cmp "$work/all/00_000009.bin" "$data/kitti/sequences/00/velodyne/000009.bin"
# --scale multiplies the coordinates and the reference translations, nothing else.
"$script" "$data/kitti" 1 "$work/mm" --sequences 00 --scale 1000 > /dev/null
/usr/bin/python3 - "$work/all" "$work/mm" <<'PY'
import sys
import numpy as np
metres, mm = sys.argv[1], sys.argv[2]
a = np.fromfile(f"{metres}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
b = np.fromfile(f"{mm}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
assert np.allclose(b[:, :3], 1000 * a[:, :3], rtol=1e-6) and np.array_equal(b[:, 3], a[:, 3])
ra = np.array(open(f"{metres}/list.txt").read().split()[2:14], float).reshape(3, 4)
rb = np.array(open(f"{mm}/list.txt").read().split()[2:14], float).reshape(3, 4)
assert np.allclose(rb[:, :3], ra[:, :3]) and np.allclose(rb[:, 3], 1000 * ra[:, 3])
print("--scale 1000: points and reference translations x1000, rotations unchanged")
PY
# --fov keeps the points within half the angle of straight ahead, and all of those.
"$script" "$data/kitti" 1 "$work/fov" --sequences 00 --fov 70 > /dev/null
/usr/bin/python3 - "$work/all" "$work/fov" <<'PY'
import sys
import numpy as np
full = np.fromfile(f"{sys.argv[1]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
cut = np.fromfile(f"{sys.argv[2]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
inside = np.abs(np.degrees(np.arctan2(full[:, 1], full[:, 0]))) <= 35
assert np.array_equal(cut, full[inside]) and 0.1 < len(cut) / len(full) < 0.3
print(f"--fov 70: {len(cut)} of {len(full)} points kept, all within +-35 deg")
PY
# --noise adds zero-mean Gaussian noise of that deviation to the coordinates only, the same
# for the same --seed.
"$script" "$data/kitti" 1 "$work/noise" --sequences 00 --noise 0.1 --seed 3 > /dev/null
"$script" "$data/kitti" 1 "$work/noise_again" --sequences 00 --noise 0.1 --seed 3 > /dev/null
cmp "$work/noise/00_000009.bin" "$work/noise_again/00_000009.bin"
/usr/bin/python3 - "$work/all" "$work/noise" <<'PY'
import sys
import numpy as np
clean = np.fromfile(f"{sys.argv[1]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
noisy = np.fromfile(f"{sys.argv[2]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
d = (noisy[:, :3] - clean[:, :3]).astype(np.float64)
assert len(noisy) == len(clean) and np.array_equal(noisy[:, 3], clean[:, 3])
assert abs(d.std() - 0.1) < 0.002 and abs(d.mean()) < 0.002, (d.std(), d.mean())
print(f"--noise 0.1: deviation {d.std():.4f} m, mean {d.mean():+.5f} m, intensities unchanged")
PY
# --keep-every N keeps points 0, N, 2N, ... of the scan, unchanged.
"$script" "$data/kitti" 1 "$work/every" --sequences 00 --keep-every 9 > /dev/null
/usr/bin/python3 - "$work/all" "$work/every" <<'PY'
import sys
import numpy as np
full = np.fromfile(f"{sys.argv[1]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
kept = np.fromfile(f"{sys.argv[2]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
assert np.array_equal(kept, full[::9]), (len(kept), len(full))
print(f"--keep-every 9: {len(kept)} of {len(full)} points kept, every 9th")
PY
# --max-range M keeps the points within M metres of the sensor, and all of those.
"$script" "$data/kitti" 1 "$work/near" --sequences 00 --max-range 20 > /dev/null
/usr/bin/python3 - "$work/all" "$work/near" <<'PY'
import sys
import numpy as np
full = np.fromfile(f"{sys.argv[1]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
near = np.fromfile(f"{sys.argv[2]}/00_000009.bin", dtype=np.float32).reshape(-1, 4)
inside = np.linalg.norm(full[:, :3], axis=1) <= 20
assert np.array_equal(near, full[inside]) and 0.3 < len(near) / len(full) < 0.95, len(near)
print(f"--max-range 20: {len(near)} of {len(full)} points kept, all within 20 m")
PY
