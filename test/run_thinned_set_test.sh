#!/usr/bin/env bash
# End-to-end: scripts/thinned_set.py on a list of the bundled KITTI pair of sequence 00, then
# pcl_mi_compare -list on what it wrote. Asserts that every 3rd point is kept, in order and
# unchanged, that the list is copied as it was, that MI-VARZ aligns both directions within
# 0.15 m / 0.5 deg, the same scaled by 1024 with -units_per_metre (converged), and that a scan
# named outside the list's folder is refused.
# Usage: run_thinned_set_test.sh SCRIPT COMPARE_BINARY DATA_DIR WORK_DIR
set -euo pipefail
script=$1 compare=$2 data=$3 work=$4
rm -rf "$work" && mkdir -p "$work/in/scans"
velodyne="$data/kitti/sequences/00/velodyne"
cp "$velodyne/000000.bin" "$velodyne/000009.bin" "$work/in/scans/"
# The bundled reference of scan 9 onto scan 0, its first three rows as the list's 12 numbers.
printf 'scans/000009.bin scans/000000.bin %s\n' \
  "$(head -n 3 "$data/kitti/reference_00_000009_to_000000.txt" | tr '\n' ' ')" > "$work/in/list.txt"
"$script" "$work/in/list.txt" "$work/out" --keep-every 3
cmp "$work/in/list.txt" "$work/out/list.txt"
/usr/bin/python3 - "$work/in/scans" "$work/out/scans" <<'PY'
import sys
import numpy as np
for name in ("000000.bin", "000009.bin"):
    full = np.fromfile(f"{sys.argv[1]}/{name}", np.float32).reshape(-1, 4)
    kept = np.fromfile(f"{sys.argv[2]}/{name}", np.float32).reshape(-1, 4)
    assert np.array_equal(kept, full[::3]), name
    print(f"{name}: {len(kept)} of {len(full)} points, every 3rd")
PY
"$compare" -list "$work/out/list.txt" -methods mi-varz -csv "$work/out.csv" > /dev/null
awk -F, 'NR > 1 { n++; if ($10 >= 0.15 || $11 >= 0.5) { print "out of bound: " $0; bad++ } }
         END { if (n != 2 || bad) exit 1; print n " alignments within 0.15 m / 0.5 deg" }' "$work/out.csv"
# Scaled by 1024 (millimetre-like units): the points and the references' translations, and
# MI-VARZ told the units aligns both directions within the same bound, scaled.
"$script" "$work/in/list.txt" "$work/scaled" --scale 1024
/usr/bin/python3 - "$work/in" "$work/scaled" <<'PY'
import sys
import numpy as np
for name in ("scans/000000.bin", "scans/000009.bin"):
    full = np.fromfile(f"{sys.argv[1]}/{name}", np.float32).reshape(-1, 4)
    scaled = np.fromfile(f"{sys.argv[2]}/{name}", np.float32).reshape(-1, 4)
    assert np.array_equal(scaled[:, :3], full[:, :3] * 1024) and np.array_equal(scaled[:, 3], full[:, 3]), name
before = [float(v) for v in open(f"{sys.argv[1]}/list.txt").read().split()[2:]]
after = [float(v) for v in open(f"{sys.argv[2]}/list.txt").read().split()[2:]]
assert all(abs(a - (b * 1024 if k in (3, 7, 11) else b)) <= 1e-9 * max(1, abs(a)) for k, (a, b) in enumerate(zip(after, before)))
print("scaled by 1024: points and translations")
PY
"$compare" -list "$work/scaled/list.txt" -methods mi-varz -units_per_metre 1024 -success 512,2 \
  -csv "$work/scaled.csv" > /dev/null
awk -F, 'NR > 1 { n++; if ($10 >= 0.15 * 1024 || $11 >= 0.5 || $13 != 1) { print "out of bound or refused: " $0; bad++ } }
         END { if (n != 2 || bad) exit 1; print n " alignments within 0.15 m / 0.5 deg at 1024 units a metre, converged" }' "$work/scaled.csv"
printf '%s %s\n' "$work/in/scans/000009.bin" "scans/000000.bin" > "$work/outside.txt"
if "$script" "$work/outside.txt" "$work/outside" --keep-every 2 2> "$work/outside.err"; then
  echo "a scan outside the list's folder was not refused"; exit 1
fi
grep -q "lies outside the list's folder" "$work/outside.err"
echo "thinned_set.py: ok"
