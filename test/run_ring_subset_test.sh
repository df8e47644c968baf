#!/usr/bin/env bash
# End-to-end: scripts/kitti_ring_subset.py on the bundled scans (every 2nd ring, a 32-ring
# sensor), then pcl_mi_compare -list on what it wrote. Asserts that about half the points
# are kept, that the list holds the two bundled pairs with their reference poses, and that
# MI-VARZ aligns all four alignments within 0.15 m / 0.5 deg.
# Usage: run_ring_subset_test.sh SCRIPT COMPARE_BINARY DATA_DIR WORK_DIR
set -euo pipefail
script=$1 compare=$2 data=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
/usr/bin/python3 "$script" "$data/kitti" 2 "$work/rings" --sequences 00,02 | tee "$work/log.txt"
full=$(stat -c %s "$data/kitti/sequences/00/velodyne/000000.bin")
half=$(stat -c %s "$work/rings/00_000000.bin")
awk -v f="$full" -v h="$half" 'BEGIN { r = h / f; print "kept fraction " r; exit !(r > 0.4 && r < 0.6) }'
test "$(wc -l < "$work/rings/list.txt")" -eq 2
grep -q "^00_000009.bin 00_000000.bin " "$work/rings/list.txt"
"$compare" -list "$work/rings/list.txt" -methods mi-varz -csv "$work/rings.csv"
awk -F, 'NR > 1 { n++; if ($10 >= 0.15 || $11 >= 0.5) { print "out of bound: " $0; bad++ } }
         END { if (n != 4 || bad) exit 1; print n " alignments within 0.15 m / 0.5 deg" }' "$work/rings.csv"
# K = 1 keeps every point: the scans are byte-identical to the originals.
/usr/bin/python3 "$script" "$data/kitti" 1 "$work/all" --sequences 00 > /dev/null
cmp "$work/all/00_000009.bin" "$data/kitti/sequences/00/velodyne/000009.bin"
