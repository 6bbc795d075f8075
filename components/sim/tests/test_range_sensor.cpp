#include "ddsnav/sim/range_sensor.hpp"
#include "ddsnav/sim/ray_primitives.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace ddsnav::sim {
namespace {

using planner::Obstacle;
using planner::ObstacleType;

Obstacle sphere(Eigen::Vector3d c, double r) {
  Obstacle o;
  o.type = ObstacleType::Sphere;
  o.center = c;
  o.radius = r;
  return o;
}

planner::Scenario planarWorld() {
  planner::Scenario s;
  s.name = "planar";
  s.dimensions = 2;
  s.bounds_min = {-20, -20, 0};
  s.bounds_max = {20, 20, 0};
  s.obstacles.push_back(sphere({10, 0, 0}, 2.0));
  return s;
}

planner::Scenario cluttered3d() {
  planner::Scenario s;
  s.name = "cluttered";
  s.dimensions = 3;
  s.bounds_min = {-40, -40, 0};
  s.bounds_max = {40, 40, 30};
  Obstacle box;
  box.type = ObstacleType::Box;
  box.center = {8, 3, 2};
  box.size = {2, 4, 4};
  box.yaw = 0.4;
  Obstacle ell;
  ell.type = ObstacleType::Ellipsoid;
  ell.center = {-6, 7, 3};
  ell.semi_axes = {3, 1.5, 2};
  ell.yaw = -0.8;
  Obstacle hill;
  hill.type = ObstacleType::Hill;
  hill.center = {-15, -12, 0};
  hill.height = 8;
  hill.sigma = 5;
  s.obstacles = {box, ell, hill, sphere({2, -9, 1.5}, 1.5), sphere({30, 30, 2}, 1)};
  return s;
}

TEST(RangeSensor, PlanarScannerSeesTheCircle) {
  auto config = RangeSensorConfig::scanner2d(720, 30.0);
  config.walls = false;
  RangeSensor sensor(planarWorld(), config);
  const PointCloud cloud = sensor.scan({{0, 0, 0}, 0.0}, 1.5);
  EXPECT_EQ(cloud.stamp, 1.5);
  // The circle subtends 2 asin(2/10) = 23.07 deg: 46 or 47 beams at 0.5 deg.
  EXPECT_GE(cloud.points.size(), 45u);
  EXPECT_LE(cloud.points.size(), 48u);
  for (const auto& p : cloud.points) {
    EXPECT_NEAR((p.cast<double>() - Eigen::Vector3d(10, 0, 0)).norm(), 2.0, 1e-5);
    EXPECT_EQ(p.z(), 0.0f);
  }
  // Column 360 points along +x (azimuths start at -pi): range 8.
  EXPECT_NEAR(sensor.lastRanges()[360], 8.0, 1e-12);
}

TEST(RangeSensor, PlanarWallsCloseTheWorld) {
  planner::Scenario s = planarWorld();
  s.obstacles.clear();
  RangeSensor sensor(s, RangeSensorConfig::scanner2d(720, 100.0));
  const PointCloud cloud = sensor.scan({{5, 0, 0}, 0.3});
  EXPECT_EQ(cloud.points.size(), 720u);
  for (const auto& p : cloud.points) {
    const bool on_wall = std::abs(std::abs(p.x()) - 20) < 1e-4 || std::abs(std::abs(p.y()) - 20) < 1e-4;
    EXPECT_TRUE(on_wall) << p.transpose();
  }
}

TEST(RangeSensor, BroadPhaseMatchesBruteForce) {
  const planner::Scenario world = cluttered3d();
  RangeSensorConfig config = RangeSensorConfig::lidar3d(16, 360, -25.0, 15.0, 60.0);
  RangeSensor sensor(world, config);
  const Eigen::Vector3d origin(1, 1, 1.8);
  sensor.scan({origin, 2.5});
  const auto& ranges = sensor.lastRanges();
  int hits = 0;
  for (int r = 0; r < config.rings; ++r) {
    for (int c = 0; c < config.columns; ++c) {
      const Ray ray{origin, sensor.beamDirection(r, c)};
      double best = exitBounds(ray, world.bounds_min, world.bounds_max, true, true, false, false);
      for (const auto& o : world.obstacles) best = std::min(best, intersect(ray, o, false, config.max_range));
      if (!(best >= config.min_range && best <= config.max_range)) best = kNoHit;
      const double got = ranges[static_cast<size_t>(r) * config.columns + c];
      ASSERT_EQ(got, best) << "ring " << r << " column " << c;
      hits += best != kNoHit;
    }
  }
  EXPECT_GT(hits, config.rings * config.columns / 2);
}

TEST(RangeSensor, NoiseIsGaussianAndSeeded) {
  auto config = RangeSensorConfig::scanner2d(720, 30.0);
  config.walls = false;
  config.range_noise_sigma = 0.05;
  config.seed = 7;
  RangeSensor a(planarWorld(), config), b(planarWorld(), config);
  const auto ca = a.scan({{0, 0, 0}, 0.0});
  const auto cb = b.scan({{0, 0, 0}, 0.0});
  ASSERT_EQ(ca.points.size(), cb.points.size());
  for (size_t i = 0; i < ca.points.size(); ++i) EXPECT_EQ(ca.points[i], cb.points[i]);

  // Residual along the beam over many scans: mean ~0, std ~sigma.
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int k = 0; k < 40; ++k) {
    const auto cloud = a.scan({{0, 0, 0}, 0.0});
    size_t j = 0;
    for (size_t i = 0; i < a.lastRanges().size(); ++i) {
      if (a.lastRanges()[i] == kNoHit) continue;
      const double measured = cloud.points[j++].cast<double>().norm();
      const double e = measured - a.lastRanges()[i];
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  const double mean = sum / n, stddev = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.005);
  EXPECT_NEAR(stddev, 0.05, 0.005);

  config.seed = 8;
  RangeSensor other(planarWorld(), config);
  const auto co = other.scan({{0, 0, 0}, 0.0});
  bool differs = false;
  for (size_t i = 0; i < co.points.size(); ++i) differs |= co.points[i] != ca.points[i];
  EXPECT_TRUE(differs);
}

TEST(RangeSensor, InvalidFractionProducesNanAndInf) {
  RangeSensorConfig config = RangeSensorConfig::lidar3d(32, 1024);
  config.invalid_fraction = 0.1;
  RangeSensor sensor(cluttered3d(), config);
  const auto cloud = sensor.scan({{0, 0, 1.5}, 0.0});
  int nan = 0, inf = 0;
  for (const auto& p : cloud.points) {
    nan += std::isnan(p.x());
    inf += std::isinf(p.x());
  }
  const double n = static_cast<double>(cloud.points.size());
  EXPECT_GT(n, 10000);
  EXPECT_NEAR((nan + inf) / n, 0.1, 0.01);
  EXPECT_GT(nan, 0);
  EXPECT_GT(inf, 0);
}

TEST(RangeSensor, RejectsBadConfigAndPlanarHill) {
  RangeSensorConfig bad = RangeSensorConfig::lidar3d();
  bad.max_range = -1;
  EXPECT_THROW(RangeSensor(cluttered3d(), bad), std::invalid_argument);
  bad = RangeSensorConfig::lidar3d();
  bad.invalid_fraction = 1.5;
  EXPECT_THROW(RangeSensor(cluttered3d(), bad), std::invalid_argument);
  EXPECT_THROW(RangeSensor(planarWorld(), RangeSensorConfig::lidar3d()), std::invalid_argument);
  planner::Scenario s = planarWorld();
  Obstacle hill;
  hill.type = ObstacleType::Hill;
  hill.height = 3;
  hill.sigma = 2;
  s.obstacles.push_back(hill);
  EXPECT_THROW(RangeSensor(s, RangeSensorConfig::scanner2d()), std::invalid_argument);
}

}  // namespace
}  // namespace ddsnav::sim
