/*
 * pcl_mi: a cloud's up direction, read from its horizontal surfaces (ground, floor,
 * ceiling), for sensors that are carried tilted.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"

#include <Eigen/Core>

#include <optional>

namespace pcl_mi {
namespace core {

/** \brief The normal shared by the most planar cells of \a cells (a makeSourceSamples()
 * summary with covariances; at most 8192 of them, evenly spread, are looked at) among the
 * normals within 75 degrees of the frame's +z, refined
 * as the principal direction of those within 10 degrees of it; pointing to +z. Nothing
 * where fewer than 20 planar cells lie in that cone.
 *
 * A scan's largest family of parallel planes within that cone is its ground, or its floor
 * and ceiling, for a sensor tilted by up to about 70 degrees. Each wall orientation is a
 * family of its own, which a tilt of more than 15 degrees brings into the cone, but the
 * normal counts once per cell, so surfaces weigh by their area, not by how densely the
 * sensor sampled them, and the ground outweighs each. The cells' normals are found on up to
 * \a threads threads, with the same result on any number. */
std::optional<Eigen::Vector3d>
estimateUpDirection(const SourceSamples& cells, int threads = 1);

} // namespace core
} // namespace pcl_mi
