#!/usr/bin/env bash
# Builds apps/pcl_mi_backend_bench from the engine's sources alone: no PCL, VTK or Boost,
# only a C++17 compiler, Eigen 3 and the OpenCL headers and ICD loader. For timing the
# OpenCL kernels on a GPU machine that has no PCL: build here, copy the binary (and, if that
# machine has no ICD loader, libOpenCL.so.1) across, and run it there next to the data.
#   bash scripts/build_backend_bench.sh [OUTPUT_DIR]   (default build-backend-bench)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-build-backend-bench}
mkdir -p "$out"
cmake -DPRELUDE=kernels/voxel_math.h -DINPUT=kernels/joint_histogram.cl -DOUTPUT="$out/joint_histogram_kernel.cpp" \
      -DSYMBOL=kJointHistogramKernelSource -P cmake/EmbedKernels.cmake
eigen=$(pkg-config --cflags eigen3 2>/dev/null || echo -I/usr/include/eigen3)
flags=(-std=c++17 -O3 -DNDEBUG -DPCL_MI_WITH_OPENCL=1 -Iinclude -Isrc -I. $eigen -pthread)
objs=()
pids=()
for src in src/engine/*.cpp src/search/*.cpp src/refine/*.cpp src/verify/*.cpp src/features/*.cpp src/util/*.cpp \
           src/backend/cpu_backend.cpp \
           src/backend/opencl_*.cpp src/io/kitti.cpp src/io/file_checks.cpp \
           apps/pcl_mi_backend_bench.cpp \
           "$out/joint_histogram_kernel.cpp"; do
  obj="$out/$(basename "${src%.cpp}").o"
  extra=()
  # As in CMakeLists.txt: the OpenCL kernels reproduce the CPU backend's float arithmetic.
  [[ $src == src/backend/cpu_backend.cpp ]] && extra=(-ffp-contract=off)
  "${CXX:-c++}" "${flags[@]}" "${extra[@]}" -c "$src" -o "$obj" &
  pids+=($!)
  objs+=("$obj")
done
for pid in "${pids[@]}"; do wait "$pid"; done # fails the script if any compile failed
"${CXX:-c++}" -pthread "${objs[@]}" -lOpenCL -o "$out/pcl_mi_backend_bench"
echo "built $out/pcl_mi_backend_bench"
