/*
 * Explicit instantiation of pcl::MutualInformationRegistration for the common point
 * types, so users of these types do not compile the template bodies again.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#define PCL_MI_NO_PRECOMPILE
#include <pcl_mi/mutual_information_registration.h>
#undef PCL_MI_NO_PRECOMPILE

#include <pcl_mi/build_config.h>

#include <pcl/point_types.h>

static_assert(EIGEN_MAX_STATIC_ALIGN_BYTES == PCL_MI_EIGEN_MAX_STATIC_ALIGN_BYTES,
              "build_config.h must describe the flags the library is compiled with");

template class pcl::MutualInformationRegistration<pcl::PointXYZ>;
template class pcl::MutualInformationRegistration<pcl::PointXYZI>;
