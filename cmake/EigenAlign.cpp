// Prints the Eigen alignment this compiler and these flags give fixed-size objects
// (EIGEN_MAX_STATIC_ALIGN_BYTES), for include/pcl_mi/build_config.h.
#include <Eigen/Core>

#include <cstdio>

int
main()
{
  std::printf("%d", EIGEN_MAX_STATIC_ALIGN_BYTES);
  return 0;
}
