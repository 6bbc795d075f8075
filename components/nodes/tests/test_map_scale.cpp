// The mapper's default resolution and range: 0.1 m on the yard-scale worlds, coarser and longer at sea
// scale, and always bounded in voxels per beam.
#include "ddsnav/nodes/map_scale.hpp"

#include <ddsnav/sim/sensor_choice.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <tuple>

namespace ddsnav::nodes {
namespace {

const std::string kScenarios = DDSNAV_SOURCE_DIR "/configs/scenarios/";

MapScale shipped(const std::string& file) {
  const auto scenario = planner::loadScenario(kScenarios + file);
  return mapScaleFor(scenario, sim::defaultMaxRange(scenario));
}

TEST(MapScale, ThreeDimensionalWorldsMapTheWholeLidarRange) {
  // gart_terrain_3d: robot radius 0.5 m, 65.9 m lidar -> 0.22 m voxels, 300 of them per beam.
  const auto scenario = planner::loadScenario(kScenarios + "gart_terrain_3d.yaml");
  const auto scale = shipped("gart_terrain_3d.yaml");
  EXPECT_NEAR(scale.resolution, sim::defaultMaxRange(scenario) / 300.0, 1e-12);
  EXPECT_NEAR(scale.max_range, sim::defaultMaxRange(scenario), 1e-9);
  // Never coarser than half the robot radius: a long-range lidar on a small robot maps part of its range.
  planner::Scenario small = scenario;
  small.robot_radius = 0.3;
  EXPECT_DOUBLE_EQ(mapScaleFor(small, 200.0).resolution, 0.15);
  EXPECT_DOUBLE_EQ(mapScaleFor(small, 200.0).max_range, 45.0);
}

TEST(MapScale, YardScale2dWorldsMapTheWholeScannerRange) {
  for (const char* file : {"demo_2d.yaml", "gart_cluttered_2d.yaml", "stunnel_1.0.yaml", "bugtrap_1.0.yaml"}) {
    const auto scenario = planner::loadScenario(kScenarios + file);
    const auto scale = shipped(file);
    EXPECT_DOUBLE_EQ(scale.resolution, 0.1) << file;
    // Up to 1 000 voxels per beam in 2-D: the scanner's whole range (bugtrap_1.0: 65.9 m, no longer 30 m).
    EXPECT_DOUBLE_EQ(scale.max_range, std::min(100.0, sim::defaultMaxRange(scenario))) << file;
  }
  EXPECT_GT(shipped("bugtrap_1.0.yaml").max_range, 60.0);
}

TEST(MapScale, SeaScaleFollowsTheRobotAndTheSonar) {
  // auv_coastal: robot radius 2 m, 200 m sonar -> 0.4 m voxels, 500 of them per beam.
  const auto coast = shipped("auv_coastal.yaml");
  EXPECT_DOUBLE_EQ(coast.resolution, 0.4);
  EXPECT_DOUBLE_EQ(coast.max_range, 200.0);
  // variant_sea_800: the same robot, an 80 m sonar: the whole sonar range is mapped.
  const auto bay = shipped("variants/sea_800.yaml");
  EXPECT_DOUBLE_EQ(bay.resolution, 0.4);
  EXPECT_DOUBLE_EQ(bay.max_range, 80.0);
}

TEST(MapScale, BoundedForAnyInput) {
  planner::Scenario s;
  s.robot_radius = 0.02;
  EXPECT_DOUBLE_EQ(mapScaleFor(s, 5.0).resolution, 0.1);  // never finer than 0.1 m
  EXPECT_DOUBLE_EQ(mapScaleFor(s, 5.0).max_range, 5.0);   // never beyond the sensor
  s.robot_radius = 50.0;
  const auto huge = mapScaleFor(s, 1e4);
  EXPECT_DOUBLE_EQ(huge.resolution, 10.0);
  EXPECT_DOUBLE_EQ(huge.max_range, s.dimensions == 3 ? 3000.0 : 1e4);
  EXPECT_DOUBLE_EQ(mapScaleFor(s, 0.0).max_range, 30.0);  // no sensor range: the former default
}

// The world model's lengths follow the robot radius below the papers' 0.5 m robot and stop at their values there.
TEST(MapScale, LengthsFollowTheRobotUpToThePapersValues) {
  planner::Scenario s;
  for (const auto& [radius, extent, margin, continuation] :
       {std::tuple{0.1, 2.5, 0.2, 3.0}, std::tuple{0.4, 10.0, 0.8, 12.0}, std::tuple{0.5, 10.0, 1.0, 15.0}, std::tuple{2.0, 10.0, 1.0, 15.0}}) {
    s.robot_radius = radius;
    EXPECT_DOUBLE_EQ(defaultStructureExtent(s), extent) << radius;
    EXPECT_DOUBLE_EQ(defaultUnknownMargin(s), margin) << radius;
    EXPECT_DOUBLE_EQ(defaultHiddenContinuation(s), continuation) << radius;
  }
}

}  // namespace
}  // namespace ddsnav::nodes
