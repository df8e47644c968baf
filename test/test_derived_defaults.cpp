/*
 * The defaults derived from the data: the resolution from the target's extent, translation
 * steps in voxels, and the coarsening of a derived grid that would not fit.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/derived_defaults.h"
#include "test_data.h"

#include <pcl_mi/registration_core.h>

#include <gtest/gtest.h>

#include <random>

namespace {

using pcl_mi::PointList;
using pcl_mi::core::deriveResolution;

/** The walls, floor and ceiling of an empty box room, sampled at random. */
PointList
room(double length, double width, double height, int points_per_face = 4000)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float l = static_cast<float>(length), w = static_cast<float>(width),
              h = static_cast<float>(height);
  PointList points;
  for (int i = 0; i < points_per_face; ++i) {
    const float a = u(rng), b = u(rng);
    // Sensor at the centre, 1 m above the floor, as a handheld or tripod scan.
    const float x = (a - 0.5f) * l, y = (b - 0.5f) * w, z = b * h - 1.0f;
    points.emplace_back(x, y, -1.0f);             // floor
    points.emplace_back(x, y, h - 1.0f);          // ceiling
    points.emplace_back(-0.5f * l, y, z);         // end walls
    points.emplace_back(0.5f * l, y, z);
    points.emplace_back(x, -0.5f * w, a * h - 1); // side walls
    points.emplace_back(x, 0.5f * w, a * h - 1);
  }
  return points;
}

TEST(DerivedDefaults, StreetScansKeepOneMetre)
{
  for (const auto& [sequence, frame] : {std::make_pair("00", 0), std::make_pair("00", 9),
                                        std::make_pair("02", 0), std::make_pair("02", 6)}) {
    SCOPED_TRACE(testing::Message() << sequence << ":" << frame);
    EXPECT_EQ(deriveResolution(test_data::pointList(*test_data::loadScan(sequence, frame))), 1.0);
  }
}

TEST(DerivedDefaults, ARoomGetsSubMetreVoxels)
{
  // PCL's room_scan room: about 9 x 5.5 x 3 m.
  const double resolution = deriveResolution(room(9.0, 5.5, 3.0));
  EXPECT_EQ(resolution, 0.25);
  // A smaller room, a shack of 4 x 3 m, gets finer voxels still.
  EXPECT_EQ(deriveResolution(room(4.0, 3.0, 2.5)), 0.125);
}

TEST(DerivedDefaults, FollowsTheUnitsAndIgnoresFarOutliers)
{
  const PointList metres = room(9.0, 5.5, 3.0);
  PointList millimetres;
  for (const auto& p : metres)
    millimetres.push_back(1024.0f * p);
  EXPECT_EQ(deriveResolution(millimetres), 1024.0 * deriveResolution(metres));

  PointList with_outliers = metres;
  with_outliers.emplace_back(1e6f, 0.0f, 0.0f);
  with_outliers.emplace_back(0.0f, -3e5f, 10.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  with_outliers.emplace_back(nan, 0.0f, 0.0f);
  with_outliers.emplace_back(0.0f, 0.0f, 0.0f);
  EXPECT_EQ(deriveResolution(with_outliers), deriveResolution(metres));
}

TEST(DerivedDefaults, NothingToDeriveFrom)
{
  EXPECT_EQ(deriveResolution({}), 0.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(deriveResolution(PointList{{nan, 0, 0}, {0, 0, 0}}), 0.0);
  EXPECT_EQ(deriveResolution(PointList{{1, 2, 3}, {1, 2, 3}, {1, 2, 3}}), 0.0);
  // Points on a line take their length: 64 m / 32 = 2 m.
  PointList line;
  for (int i = 0; i <= 640; ++i)
    line.emplace_back(0.1f * static_cast<float>(i) / 0.9f, 0.0f, 0.0f);
  EXPECT_EQ(deriveResolution(line), 2.0);
}

TEST(DerivedDefaults, StepsInVoxelsFollowTheResolution)
{
  pcl_mi::Parameters requested; // default: resolution 0, steps -16, -16, -4 voxels
  const pcl_mi::Parameters resolved = pcl_mi::core::resolveParameters(requested, 0.25);
  EXPECT_EQ(resolved.grid.resolution, 0.25);
  EXPECT_EQ(resolved.search.simplex_steps[0], 4.0);
  EXPECT_EQ(resolved.search.simplex_steps[1], 4.0);
  EXPECT_EQ(resolved.search.simplex_steps[2], 1.0);
  EXPECT_EQ(resolved.search.simplex_steps.tail<3>(), requested.search.simplex_steps.tail<3>());
  EXPECT_EQ(resolved.effectiveTranslationTolerance(), 0.005 * 0.25);
  EXPECT_EQ(resolved.effectiveRefinementResolution(), 0.7 * 0.25);

  // What is set explicitly wins: a resolution, a step in the clouds' units, a pinned step.
  requested.grid.resolution = 0.5;
  requested.search.simplex_steps[0] = 3.0;
  requested.search.simplex_steps[2] = 0.0;
  const pcl_mi::Parameters set = pcl_mi::core::resolveParameters(requested, 0.25);
  EXPECT_EQ(set.grid.resolution, 0.5);
  EXPECT_EQ(set.search.simplex_steps[0], 3.0);
  EXPECT_EQ(set.search.simplex_steps[1], 8.0);
  EXPECT_EQ(set.search.simplex_steps[2], 0.0);
  EXPECT_TRUE(pcl_mi::Parameters::paper().search.simplex_steps.head<3>().minCoeff() > 0.0);
  EXPECT_EQ(pcl_mi::Parameters::paper().grid.resolution, 1.0);
}

TEST(DerivedDefaults, CoarsensWhereTheDerivedGridWouldNotFit)
{
  // A room whose stray returns chain out 2 km along x and y, each within the outlier gap of
  // the next: they stay, and at the room's 0.25 m the grid would need ~8000 x 8000 x 13
  // voxels. The engine coarsens its own choice instead of refusing the alignment.
  PointList target = room(9.0, 5.5, 3.0);
  for (int i = 1; i <= 200; ++i) {
    target.emplace_back(10.0f * static_cast<float>(i), 0.0f, 0.0f);
    target.emplace_back(0.0f, 10.0f * static_cast<float>(i), 0.0f);
  }
  pcl_mi::RegistrationCore core;
  core.setTarget(target);
  EXPECT_EQ(core.effectiveParameters().grid.resolution, 0.25);
  core.setSource(room(9.0, 5.5, 3.0));
  const pcl_mi::AlignmentResult result = core.align(Eigen::Matrix4d::Identity());
  EXPECT_EQ(result.error, "");
  EXPECT_GE(core.effectiveParameters().grid.resolution, 1.0);

  // A resolution the user set is the user's: it is refused with the reason.
  pcl_mi::Parameters p;
  p.grid.resolution = 0.25;
  ASSERT_EQ(core.setParameters(p), "");
  EXPECT_NE(core.align(Eigen::Matrix4d::Identity()).error.find("resolution"), std::string::npos);
}

} // namespace
