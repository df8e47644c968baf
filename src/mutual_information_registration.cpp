/*
 * Explicit instantiation of pcl::MutualInformationRegistration for the common point
 * types, so users of these types do not compile the template bodies again.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#define PCL_MI_NO_PRECOMPILE
#include <pcl_mi/mutual_information_registration.h>
#undef PCL_MI_NO_PRECOMPILE

#include <pcl/point_types.h>

template class pcl::MutualInformationRegistration<pcl::PointXYZ>;
template class pcl::MutualInformationRegistration<pcl::PointXYZI>;
