# Script mode (cmake -P): embeds OpenCL sources into a C++ file as one string, in order.
#   -DINPUTS="kernels/voxel_math.h;kernels/joint_histogram.cl" -DOUTPUT=.../kernels.cpp
#   -DSYMBOL=kJointHistogramKernelSource
# The shared per-voxel arithmetic (voxel_math.h) goes first, so the kernels need no
# #include and the program builds from one string.
set(content "")
foreach(input IN LISTS INPUTS)
  file(READ "${input}" text)
  string(APPEND content "${text}\n")
endforeach()
file(WRITE "${OUTPUT}.tmp"
  "// Generated from ${INPUTS} by cmake/EmbedKernels.cmake; do not edit.\n"
  "namespace pcl_mi {\nnamespace backend {\n"
  "extern const char* const ${SYMBOL};\n"
  "const char* const ${SYMBOL} = R\"pcl_mi_kernel(${content})pcl_mi_kernel\";\n"
  "} // namespace backend\n} // namespace pcl_mi\n")
# Only touch the output when it changed, so an unchanged kernel triggers no rebuild.
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUTPUT}.tmp" "${OUTPUT}")
file(REMOVE "${OUTPUT}.tmp")
