# Finds PCL the way Debian 12 needs it. Used by the build and, installed, by
# pcl_miConfig.cmake, so that consumers get the same workaround.
#
# Debian's VTK 9.1 config refers to MPI::MPI_C, so the C language must be enabled and MPI's
# C component found before find_package(PCL), or CMake stops with
# "VTK::mpi ... MPI::MPI_C ... target was not found".
get_property(_pcl_mi_languages GLOBAL PROPERTY ENABLED_LANGUAGES)
if(NOT "C" IN_LIST _pcl_mi_languages)
  enable_language(C)
endif()
find_package(MPI QUIET COMPONENTS C)
# PCL's components are imported targets (pcl_common, ...) carrying their include
# directories and dependencies, so linking them is all a consumer needs.
set(PCL_MI_PCL_COMPONENTS common io kdtree search registration)
find_package(PCL 1.10 REQUIRED COMPONENTS ${PCL_MI_PCL_COMPONENTS})
