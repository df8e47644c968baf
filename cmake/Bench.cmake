# `cmake --build build --target bench`: where pcl_mi's time goes and how it compares, in one
# run. A benchmark, not a test: the figures depend on the machine and its load, so PCL's
# methods are given as ratios to MI measured in the same run (docs/benchmarks.md, "Speed").
#  1. pcl_mi_stage_bench (with the tests): each stage on the bundled KITTI pair, and a
#     scan against a target that is set once.
#  2. MI-VARZ, MI-N, PCL GICP and PCL NDT on the bundled pairs, identity guess and 5 m /
#     10 deg off, with MI's median per stage; then MI on OpenCL (PoCL without a GPU).
#  3. With the shared KITTI data (PCL_MI_SHARED_DATA): MI-VARZ on every pair, shuffled;
#     GICP and NDT beside it on every 8th pair; and scan to map, each sequence's odd scans
#     against one map of its even scans that MI prepares once (the time per scan is the
#     "kept target" median, without the alignments that prepared a map).
set(PCL_MI_SHARED_DATA ${PROJECT_SOURCE_DIR}/../shared/data CACHE PATH
    "Shared evaluation data (kitti_odometry, foreign_lidar) for the bench target")
set(_bundled -kitti ${PROJECT_SOURCE_DIR}/data/kitti -sequences 00,02 -pairs 00:0:9,02:0:6)
set(_bench_commands)
if(TARGET pcl_mi_stage_bench)
  list(APPEND _bench_commands COMMAND $<TARGET_FILE:pcl_mi_stage_bench>)
endif()
list(APPEND _bench_commands
  COMMAND pcl_mi_compare ${_bundled} -methods mi-varz,mi-n,gicp,ndt -repeat 3
  COMMAND pcl_mi_compare ${_bundled} -methods mi-varz,mi-n,gicp,ndt -repeat 3 -perturb 5,10
  # The first repeat pays the OpenCL start-up, the median does not.
  COMMAND pcl_mi_compare ${_bundled} -methods mi-varz,mi-n -repeat 3 -backend opencl)
set(_kitti ${PCL_MI_SHARED_DATA}/kitti_odometry)
if(EXISTS ${_kitti}/sequences)
  set(_map ${CMAKE_BINARY_DIR}/bench_scan_to_map)
  list(APPEND _bench_commands
    COMMAND pcl_mi_compare -kitti ${_kitti} -methods mi-varz -shuffle 1
    COMMAND pcl_mi_compare -kitti ${_kitti} -methods mi-varz,gicp,ndt -stride 8 -shuffle 1
    COMMAND /usr/bin/python3 ${PROJECT_SOURCE_DIR}/scripts/kitti_scan_to_map.py ${_kitti} ${_map}
            --sources 1,3,5,7,9 --shared-map
    COMMAND pcl_mi_compare -list ${_map}/list.txt -directions forward -methods mi-varz
            -reuse_target)
else()
  message(STATUS "pcl_mi: bench runs on the bundled pairs only (no ${_kitti})")
endif()
add_custom_target(bench ${_bench_commands}
  DEPENDS pcl_mi_compare
  USES_TERMINAL
  COMMENT "pcl_mi benchmark")
if(TARGET pcl_mi_stage_bench)
  add_dependencies(bench pcl_mi_stage_bench)
endif()
