#!/usr/bin/env bash
# Installs the built project into a scratch prefix, configures and builds the consumer
# project against it, and runs it on the bundled KITTI pair.
# Usage: run_consumer_test.sh BUILD_DIR SOURCE_DIR WORK_DIR
set -euo pipefail
build_dir=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
cmake --install "$build_dir" --prefix "$work_dir/install" > "$work_dir.install.log" 2>&1 ||
  { cat "$work_dir.install.log"; exit 1; }
data="$source_dir/data/kitti"
# Once with the library's own flags, once with -march=native (common in PCL users' builds):
# Eigen then aligns fixed-size members differently, and the header must notice and compile
# the templates in the consumer instead of using the precompiled, differently laid out ones.
for flags in "" "-march=native"; do
  dir="$work_dir/build${flags:+-native}"
  cmake -S "$source_dir/test/consumer" -B "$dir" -DCMAKE_PREFIX_PATH="$work_dir/install" \
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="$flags" > "$dir.configure.log" 2>&1 ||
    { cat "$dir.configure.log"; exit 1; }
  cmake --build "$dir"
  echo "consumer built with CXXFLAGS='$flags':"
  "$dir/consumer" "$data/sequences/00/velodyne/000009.bin" \
    "$data/sequences/00/velodyne/000000.bin" "$data/reference_00_000009_to_000000.txt"
done
# The installed app runs from its prefix without LD_LIBRARY_PATH (RPATH relative to itself).
if [ -x "$work_dir/install/bin/pcl_mi_align" ]; then
  env -u LD_LIBRARY_PATH "$work_dir/install/bin/pcl_mi_align" -h > "$work_dir.app_help.log"
  echo "installed pcl_mi_align -h: exit 0"
fi
# The installed Python module imports with the system python3 from the prefix alone.
module=$(find "$work_dir/install" -name 'pcl_mi.cpython-*.so' | head -n 1)
if [ -n "$module" ]; then
  env -u LD_LIBRARY_PATH PYTHONPATH="$(dirname "$module")" /usr/bin/python3 -c \
    "import pcl_mi; print('installed Python module:', pcl_mi.__version__, pcl_mi.__file__)"
fi
