#!/usr/bin/env bash
# Main job on the bundled sample: installs dependencies, builds the apps, aligns a real
# KITTI pair (sequence 00, scan 9 onto scan 0, 6.7 m apart) from the identity guess, prints
# the recovered transform and its error against the reference pose, and writes the clouds
# for pcl_viewer into build/demo/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup_debian.sh"
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release > "$root/build.configure.log" 2>&1 ||
  { cat "$root/build.configure.log"; exit 1; }
cmake --build "$root/build" --target pcl_mi_align -j "$(nproc)"
mkdir -p "$root/build/demo"
data="$root/data/kitti"
"$root/build/apps/pcl_mi_align" \
  "$data/sequences/00/velodyne/000009.bin" "$data/sequences/00/velodyne/000000.bin" \
  -reference "$data/reference_00_000009_to_000000.txt" \
  -aligned "$root/build/demo/aligned.pcd" -merged "$root/build/demo/merged.pcd"
echo "Look at it: pcl_viewer $root/build/demo/merged.pcd   (grey: target, red: aligned source)"
