// The simulator on the scenarios shipped in configs/scenarios.
#include "ddsnav/sim/range_sensor.hpp"
#include "ddsnav/sim/ray_primitives.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ddsnav::sim {
namespace {

const std::string kScenarios = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/";

TEST(ShippedScenarios, TerrainScanLandsOnHillsFloorOrWalls) {
  const auto world = planner::loadScenario(kScenarios + "gart_terrain_3d.yaml");
  auto config = RangeSensorConfig::lidar3d(16, 360, -30, 10, 80);
  RangeSensor sensor(world, config);
  const Eigen::Vector3d origin = world.start;
  const auto cloud = sensor.scan({origin, 0.8});
  ASSERT_GT(cloud.points.size(), 3000u);
  int on_hill = 0;
  for (const auto& pf : cloud.points) {
    const Eigen::Vector3d p = pf.cast<double>();
    double terrain = 0.0;  // highest hill surface below p
    for (const auto& o : world.obstacles) {
      const double d2 = std::pow(p.x() - o.center.x(), 2) + std::pow(p.y() - o.center.y(), 2);
      terrain = std::max(terrain, o.height * std::exp(-d2 / (2 * o.sigma * o.sigma)));
    }
    const bool on_wall = std::abs(p.x()) < 1e-6 || std::abs(p.x() - 110) < 1e-6 || std::abs(p.y()) < 1e-6 ||
                         std::abs(p.y() - 110) < 1e-6;
    const bool on_terrain = std::abs(p.z() - terrain) < 1e-3;
    on_hill += on_terrain && p.z() > 0.01;
    EXPECT_TRUE(on_wall || on_terrain) << p.transpose() << " terrain " << terrain;
  }
  EXPECT_GT(on_hill, 1000);

  // Broad phase (angular cones, culling) gives exactly the brute-force answer on hills.
  for (int r = 0; r < config.rings; ++r) {
    for (int c = 0; c < config.columns; ++c) {
      const Ray ray{origin, sensor.beamDirection(r, c)};
      double best = exitBounds(ray, world.bounds_min, world.bounds_max, true, true, false, false);
      for (const auto& o : world.obstacles) best = std::min(best, intersect(ray, o, false, config.max_range));
      if (!(best >= config.min_range && best <= config.max_range)) best = kNoHit;
      ASSERT_EQ(sensor.lastRanges()[static_cast<size_t>(r) * config.columns + c], best);
    }
  }
}

TEST(ShippedScenarios, PlanarScenarioScans) {
  const auto world = planner::loadScenario(kScenarios + "demo_2d.yaml");
  ASSERT_EQ(world.dimensions, 2);
  RangeSensor sensor(world, RangeSensorConfig::scanner2d(720, 200.0));
  const auto cloud = sensor.scan({world.start, 0.0});
  EXPECT_EQ(cloud.points.size(), 720u);  // walls close the world
  for (const auto& p : cloud.points) EXPECT_EQ(p.z(), 0.0f);
}

}  // namespace
}  // namespace ddsnav::sim
