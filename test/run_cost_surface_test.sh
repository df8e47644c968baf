#!/usr/bin/env bash
# pcl_mi_cost_surface on a bundled pair (coarse grid), then its plot script. Asserts that the
# MI over the (tx, ty) grid and over the heading sweep peaks at the reference, and that both
# PNGs are written.
# Usage: run_cost_surface_test.sh BINARY PLOT_SCRIPT DATA_DIR WORK_DIR
set -euo pipefail
binary=$1 plot=$2 data=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
"$binary" "$data/kitti/sequences/02/velodyne/000006.bin" \
  "$data/kitti/sequences/02/velodyne/000000.bin" "$data/kitti/reference_02_000006_to_000000.txt" \
  -o "$work/cs" -extent 3 -step 1 -yaw_extent 6 -yaw_step 2
test "$(tail -n +2 "$work/cs_xy.csv" | wc -l)" -eq 49
test "$(tail -n +2 "$work/cs_yaw.csv" | wc -l)" -eq 7
# The grid's and the sweep's maximum MI lie at the reference (offset 0).
awk -F, 'NR > 1 && $3 > best { best = $3; at = $1 "," $2 } END { if (at != "0,0") { print "xy peak at " at; exit 1 } }' "$work/cs_xy.csv"
awk -F, 'NR > 1 && $2 > best { best = $2; at = $1 } END { if (at != "0") { print "yaw peak at " at; exit 1 } }' "$work/cs_yaw.csv"
/usr/bin/python3 "$plot" "$work/cs"
test -s "$work/cs_xy.png" && test -s "$work/cs_yaw.png"
