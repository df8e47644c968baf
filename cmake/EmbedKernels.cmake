# Script mode (cmake -P): embeds an OpenCL source file, with a prelude before it, into a
# C++ file as one string.
#   -DPRELUDE=kernels/voxel_math.h -DINPUT=kernels/joint_histogram.cl
#   -DOUTPUT=.../kernels.cpp -DSYMBOL=kJointHistogramKernelSource
# The prelude is the per-voxel arithmetic the CPU backend shares, so the kernels need no
# #include and the program builds from one string.
file(READ "${PRELUDE}" prelude)
file(READ "${INPUT}" kernels)
set(content "${prelude}\n${kernels}")
file(WRITE "${OUTPUT}.tmp"
  "// Generated from ${PRELUDE} and ${INPUT} by cmake/EmbedKernels.cmake; do not edit.\n"
  "namespace pcl_mi {\nnamespace backend {\n"
  "extern const char* const ${SYMBOL};\n"
  "const char* const ${SYMBOL} = R\"pcl_mi_kernel(${content})pcl_mi_kernel\";\n"
  "} // namespace backend\n} // namespace pcl_mi\n")
# Only touch the output when it changed, so an unchanged kernel triggers no rebuild.
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUTPUT}.tmp" "${OUTPUT}")
file(REMOVE "${OUTPUT}.tmp")
