/*
 * pcl_mi: what the point-to-plane terms of the evidence at a pose say about the pose: their
 * information with turns weighed at the samples' radius, and the covariance and information
 * matrix the verdict reports from it.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"
#include "verify/pose_evidence.h"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace pcl_mi {
namespace core {

/** \brief The radius at which the verdict weighs turns against shifts for \a source: the
 * samples' root mean square distance from the source's local origin, at least one voxel
 * (\a resolution). */
double
rotationRadius(const SourceSamples& source, double resolution);

/** \brief The point-to-plane information of \a at (gathered with the point-to-plane terms)
 * in [delta, omega], rotations scaled by \a radius so that a unit turn moves a point at that
 * radius by one unit of length, decomposed. */
Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>
scaledInformation(const PoseEvidence& at, double radius);

/** \brief planeCovariance() of \a at from \a solver, scaledInformation(at, radius)'s
 * decomposition. */
Eigen::Matrix<double, 6, 6>
covarianceFrom(const PoseEvidence& at,
               const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>& solver,
               double radius,
               const Eigen::Vector3d& target_centroid,
               const Eigen::Matrix3d& target_axes);

/** \brief The covariance the verdict reports for the evidence \a at (gathered with the
 * point-to-plane terms) of the samples \a source on a grid of voxel size \a resolution:
 * sigma^2 H^-1 plus the outer product of the Gauss-Newton step to the point-to-plane optimum,
 * as a left increment [delta, omega] about the input frame's origin (\a target_centroid and
 * \a target_axes place the target local frame in the input frame: input = centroid + axes *
 * local). Zero where the evidence holds 6 inliers or fewer, or leaves a direction without
 * information. */
Eigen::Matrix<double, 6, 6>
planeCovariance(const PoseEvidence& at,
                const SourceSamples& source,
                double resolution,
                const Eigen::Vector3d& target_centroid,
                const Eigen::Matrix3d& target_axes);

/** \brief The point-to-plane information of \a at over its residuals' variance, as
 * planeCovariance() gives the covariance: a left increment [delta, omega] about the input
 * frame's origin. Finite along a direction the surfaces leave free; zero with 6 inliers or
 * fewer. */
Eigen::Matrix<double, 6, 6>
informationFrom(const PoseEvidence& at,
                const Eigen::Vector3d& target_centroid,
                const Eigen::Matrix3d& target_axes);

} // namespace core
} // namespace pcl_mi
