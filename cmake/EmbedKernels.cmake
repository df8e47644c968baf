# Script mode (cmake -P): embeds an OpenCL source file into a C++ file as a string.
#   -DINPUT=kernels/joint_histogram.cl -DOUTPUT=.../kernels.cpp -DSYMBOL=kJointHistogramKernelSource
file(READ "${INPUT}" content)
file(WRITE "${OUTPUT}.tmp"
  "// Generated from ${INPUT} by cmake/EmbedKernels.cmake; do not edit.\n"
  "namespace pcl_mi {\nnamespace backend {\n"
  "extern const char* const ${SYMBOL};\n"
  "const char* const ${SYMBOL} = R\"pcl_mi_kernel(${content})pcl_mi_kernel\";\n"
  "} // namespace backend\n} // namespace pcl_mi\n")
# Only touch the output when it changed, so an unchanged kernel triggers no rebuild.
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUTPUT}.tmp" "${OUTPUT}")
file(REMOVE "${OUTPUT}.tmp")
