#!/usr/bin/env bash
# pcl_mi_cost_surface on a bundled pair (coarse grid), then its plot script. Asserts that the
# MI over the (tx, ty) grid and over the heading sweep peaks at the reference, that on the line
# from the reference to a pose 2 m off (-toward) both costs prefer the reference, and that the
# PNGs are written.
# Usage: run_cost_surface_test.sh BINARY PLOT_SCRIPT DATA_DIR WORK_DIR
set -euo pipefail
binary=$1 plot=$2 data=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
# The reference with 2 m added to its x translation (4th number of the first row).
awk 'NR == 1 { $4 += 2 } { print }' "$data/kitti/reference_02_000006_to_000000.txt" > "$work/off.txt"
"$binary" "$data/kitti/sequences/02/velodyne/000006.bin" \
  "$data/kitti/sequences/02/velodyne/000000.bin" "$data/kitti/reference_02_000006_to_000000.txt" \
  -o "$work/cs" -extent 3 -step 1 -yaw_extent 6 -yaw_step 2 -toward "$work/off.txt"
test "$(tail -n +2 "$work/cs_xy.csv" | wc -l)" -eq 49
test "$(tail -n +2 "$work/cs_yaw.csv" | wc -l)" -eq 7
# The grid's and the sweep's maximum MI lie at the reference (offset 0).
awk -F, 'NR > 1 && $3 > best { best = $3; at = $1 "," $2 } END { if (at != "0,0") { print "xy peak at " at; exit 1 } }' "$work/cs_xy.csv"
awk -F, 'NR > 1 && $2 > best { best = $2; at = $1 } END { if (at != "0") { print "yaw peak at " at; exit 1 } }' "$work/cs_yaw.csv"
# The line runs from s = -0.5 to 1.5 in 41 steps, 2 m per unit of s; GICP's objective is
# lowest within 0.3 m of the reference and MI is higher there than at the other pose.
test "$(tail -n +2 "$work/cs_line.csv" | wc -l)" -eq 41
awk -F, 'NR > 1 && $1 == 1 && ($2 < 1.99 || $2 > 2.01) { print "offset at s = 1: " $2; exit 1 }' "$work/cs_line.csv"
awk -F, 'NR == 2 || (NR > 2 && $4 < low) { low = $4; at = $2 }
         $1 == 0 { mi0 = $3 } $1 == 1 { mi1 = $3 }
         END { if (at < -0.3 || at > 0.3) { print "GICP minimum at " at " m"; exit 1 }
               if (!(mi0 > mi1)) { print "MI " mi0 " at the reference, " mi1 " 2 m off"; exit 1 } }' \
  "$work/cs_line.csv"
"$plot" "$work/cs"
test -s "$work/cs_xy.png" && test -s "$work/cs_yaw.png" && test -s "$work/cs_line.png"
