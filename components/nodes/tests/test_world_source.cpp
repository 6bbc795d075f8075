// The world source's decisions without DDS: when the fused world may be planned on before the first map,
// and the map check that keeps the world it builds.
#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"
#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/mapper/occupancy_mapper.hpp>
#include <gtest/gtest.h>

using namespace ddsnav;
using planner::UnknownSpace;

namespace {

TEST(FusedWorldReady, WaitsForTheFirstMapThenGoesOptimisticAfterTheWait) {
  // Nothing before perception has said anything, whatever else is there.
  EXPECT_FALSE(nodes::fusedWorldReady(false, true, UnknownSpace::Optimistic, 100.0, 5.0));
  // Obstacles and a map: ready at once, under both policies.
  EXPECT_TRUE(nodes::fusedWorldReady(true, true, UnknownSpace::Optimistic, 0.0, 5.0));
  EXPECT_TRUE(nodes::fusedWorldReady(true, true, UnknownSpace::Conservative, 0.0, 5.0));
  // Obstacles without a map: the optimistic world waits for the map up to the bound, then plans on the
  // obstacles alone (a sensor that sees nothing makes no map).
  EXPECT_FALSE(nodes::fusedWorldReady(true, false, UnknownSpace::Optimistic, 0.0, 5.0));
  EXPECT_FALSE(nodes::fusedWorldReady(true, false, UnknownSpace::Optimistic, 4.99, 5.0));
  EXPECT_TRUE(nodes::fusedWorldReady(true, false, UnknownSpace::Optimistic, 5.0, 5.0));
  EXPECT_TRUE(nodes::fusedWorldReady(true, false, UnknownSpace::Optimistic, 0.0, 0.0));  // no wait asked for
  // The conservative world has nothing to plan in before the first map, however long it waits.
  EXPECT_FALSE(nodes::fusedWorldReady(true, false, UnknownSpace::Conservative, 1e6, 5.0));
}

TEST(FusedWorldReady, TheWaitForTheFirstMapStartsWithTheClock) {
  // Obstacles before the first clock sample (the component clock reads 0) do not start it: counted from 0, the
  // wait had passed at once.
  EXPECT_EQ(nodes::firstMapWaitStart(std::nullopt, 0), std::nullopt);
  EXPECT_EQ(nodes::firstMapWaitStart(std::nullopt, 7'000'000'000), 7'000'000'000);
  // Once started it stays where it started.
  EXPECT_EQ(nodes::firstMapWaitStart(7'000'000'000, 9'000'000'000), 7'000'000'000);
}

// The mapper's map of a wall at x = 5 (y, z in 1 .. 3) seen from (2, 2, 2).
msg::OccupancyMap wallMessage() {
  mapper::MapperConfig config;
  config.dimensions = 3;
  config.resolution = 0.2;
  mapper::OccupancyMapper mapper(config);
  mapper::Scan scan;
  scan.origin = {2.0f, 2.0f, 2.0f};
  for (int i = 0; i <= 20; ++i)
    for (int k = 0; k <= 20; ++k) scan.points.push_back({5.05f, 1.0f + 0.1f * i, 1.0f + 0.1f * k});
  EXPECT_TRUE(mapper.insert(scan).inserted);
  const auto exported = mapper.exportMap();
  msg::OccupancyMap map;
  map.header().frame_id("map");
  map.resolution(exported.resolution);
  map.octree(exported.octree_binary);
  return map;
}

planner::Scenario box3d() {
  planner::Scenario s;
  s.dimensions = 3;
  s.bounds_min = {0, 0, 0};
  s.bounds_max = {10, 10, 10};
  s.robot_radius = 0.5;
  return s;
}

TEST(BuildOccupancyMap, KeepsTheWorldItChecksWithThePolicyAsked) {
  const auto scenario = box3d();
  const auto optimistic = nodes::buildOccupancyMap(wallMessage(), "map", scenario, {});
  ASSERT_EQ(optimistic.error, "");
  ASSERT_NE(optimistic.world, nullptr);
  EXPECT_FALSE(optimistic.world->isFree({5.0, 2, 2}));  // the wall
  EXPECT_TRUE(optimistic.world->isFree({3.0, 2, 2}));   // observed free
  EXPECT_TRUE(optimistic.world->isFree({8.0, 8, 8}));   // never observed: free
  planner::OctoMapWorldOptions conservative_options;
  conservative_options.unknown_is_occupied = true;
  const auto conservative = nodes::buildOccupancyMap(wallMessage(), "map", scenario, conservative_options);
  ASSERT_NE(conservative.world, nullptr);
  EXPECT_FALSE(conservative.world->isFree({8.0, 8, 8}));  // never observed: occupied
  EXPECT_TRUE(conservative.world->isFree({4.2, 2, 2}));   // observed free (inside the cone of rays)
  // A bad map: the error, and no world.
  auto garbage = wallMessage();
  garbage.octree({1, 2, 3});
  const auto bad = nodes::buildOccupancyMap(garbage, "map", scenario, {});
  EXPECT_NE(bad.error.find("not a binary OctoMap"), std::string::npos) << bad.error;
  EXPECT_EQ(bad.world, nullptr);
  EXPECT_EQ(nodes::checkOccupancyMap(garbage, "map", scenario), bad.error);
}

TEST(ClearFootprint, RemovesExactlyTheEllipsesTheRobotTouchesAndKeepsTheOrder) {
  // The robot (radius 0.5) at the origin. Each ellipse is judged as a world of that ellipse alone would
  // judge it: the robot touches it when its centre is inside it or within the radius of its surface.
  const auto ellipse = [](int id, double x, double y, double a, double b, double yaw) {
    planner::EllipsoidObstacle e;
    e.id = id;
    e.center = planner::Vec3(x, y, 0);
    e.semi_axes = planner::Vec3(a, b, 1);
    e.axes = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return e;
  };
  std::vector<planner::EllipsoidObstacle> obstacles{
      ellipse(10, 0.2, 0.1, 0.3, 0.2, 0.0),     // around the robot's centre
      ellipse(11, 1.2, 0.0, 0.6, 0.1, 0.0),     // its surface 0.6 m away: clear
      ellipse(12, 0.0, 0.9, 1.0, 0.45, 0.3),    // reaches within the radius: touched
      ellipse(13, 30.0, -4.0, 2.0, 1.0, 1.0),   // far
      ellipse(14, -0.95, 0.0, 0.2, 0.5, 0.0),   // its surface 0.75 m away: clear
  };
  std::vector<int> expected;
  const planner::Vec3 far = planner::Vec3::Constant(1e9);
  for (const auto& e : obstacles)
    if (planner::makeEllipsoidWorld(2, -far, far, 0.5, {e})->isFree(planner::Vec3::Zero())) expected.push_back(e.id);
  ASSERT_EQ(expected, (std::vector<int>{11, 13, 14}));
  EXPECT_EQ(nodes::clearFootprint(obstacles, Eigen::Vector3d::Zero(), 0.5, 2), 2u);
  std::vector<int> kept;
  for (const auto& e : obstacles) kept.push_back(e.id);
  EXPECT_EQ(kept, expected);
}

}  // namespace
