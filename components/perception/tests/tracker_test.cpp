#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/obstacle_tracker.hpp"
#include "ddsnav/sim/range_sensor.hpp"

#include <gtest/gtest.h>

#include <map>
#include <numbers>

namespace ddsnav::perception {
namespace {

ObstacleEllipsoid detection(Eigen::Vector3d centre, Eigen::Matrix3d covariance, std::size_t points, int dims = 3) {
  ObstacleEllipsoid e;
  e.dimensions = dims;
  e.center = centre;
  e.covariance = covariance;
  e.point_count = points;
  e.probability = 0.99;
  updateShapeFromCovariance(e);
  return e;
}

TEST(Tracker, SameObstacleKeepsItsIdAndFarOneGetsANewId) {
  ObstacleTracker tracker;
  const Eigen::Matrix3d cov = Eigen::Vector3d(0.5, 0.2, 0.3).asDiagonal();
  std::vector<ObstacleEllipsoid> scan1 = {detection({5, 0, 1}, cov, 100), detection({-5, 3, 1}, cov, 80)};
  const auto& after1 = tracker.update(scan1);
  ASSERT_EQ(after1.size(), 2u);
  EXPECT_EQ(after1[0].id, 1u);
  EXPECT_EQ(after1[1].id, 2u);

  // Slightly moved (noise), listed in the other order, plus a new obstacle.
  std::vector<ObstacleEllipsoid> scan2 = {detection({-5.1, 3.05, 1}, cov, 80), detection({5.05, 0.1, 1}, cov, 100),
                                          detection({20, 20, 1}, cov, 30)};
  const auto& after2 = tracker.update(scan2);
  ASSERT_EQ(after2.size(), 3u);
  EXPECT_EQ(tracker.lastUpdate().fused, 2u);
  EXPECT_EQ(tracker.lastUpdate().created, 1u);
  EXPECT_NEAR(after2[0].center.x(), 5.025, 1e-9);  // equal weights, equal covariances: the mean
  EXPECT_NEAR(after2[1].center.y(), 3.025, 1e-9);
  EXPECT_EQ(after2[2].id, 3u);
}

TEST(Tracker, FusionGrowsTheEllipsoidWhenNewFacesAppear) {
  // First the left half of a 10 m wall, then the right half: one track whose extent covers both.
  ObstacleTracker tracker;
  const double var = 5.0 * 5.0 / 12.0;  // 5 m segment, uniform
  const Eigen::Matrix3d cov = Eigen::Vector3d(var, 0.01, 0.5).asDiagonal();
  tracker.update(std::vector{detection({-2.5, 10, 1}, cov, 200)});
  const auto& fused = tracker.update(std::vector{detection({2.5, 10, 1}, cov, 200)});
  ASSERT_EQ(fused.size(), 1u);
  EXPECT_NEAR(fused[0].center.x(), 0.0, 1e-9);
  EXPECT_NEAR(fused[0].covariance(0, 0), 10.0 * 10.0 / 12.0, 1e-9);  // a uniform 10 m segment
  EXPECT_GT(fused[0].semi_axes.x(), 5.0);
  EXPECT_EQ(fused[0].point_count, 400u);
}

TEST(Tracker, IgnoresBadDetectionsAndMixedDimensions) {
  ObstacleTracker tracker;
  const Eigen::Matrix3d cov = Eigen::Matrix3d::Identity() * 0.2;
  auto bad = detection({1, 1, 0}, cov, 10);
  bad.center.x() = std::nan("");
  tracker.update(std::vector{bad, detection({1, 1, 0}, cov, 10, 2)});
  ASSERT_EQ(tracker.obstacles().size(), 1u);
  tracker.update(std::vector{detection({1, 1, 0}, cov, 10, 3)});
  EXPECT_EQ(tracker.obstacles().size(), 2u);  // a 3-D detection never fuses into a 2-D track
}

TEST(Tracker, SimulatedDriveKeepsOneStableTrackPerObstacle) {
  // A 2-D scanner drives past four obstacles; the tracked set must end with exactly one track per
  // obstacle, each id bound to the same obstacle the whole time, centres near the true ones.
  planner::Scenario world;
  world.name = "drive";
  world.dimensions = 2;
  world.bounds_min = {-50, -50, 0};
  world.bounds_max = {50, 50, 0};
  auto circle = [](double x, double y, double r) {
    planner::Obstacle o;
    o.type = planner::ObstacleType::Sphere;
    o.center = {x, y, 0};
    o.radius = r;
    return o;
  };
  world.obstacles = {circle(0, 6, 1.0), circle(10, -6, 1.5), circle(20, 7, 1.0), circle(30, -5, 2.0)};
  auto config = sim::RangeSensorConfig::scanner2d(720, 15);
  config.walls = false;
  config.range_noise_sigma = 0.02;
  sim::RangeSensor sensor(world, config);
  DetectorParams params;
  params.range_noise_sigma = 0.02;
  params.beam_spacing = 2 * std::numbers::pi / 720;
  ObstacleDetector detector(params);
  ObstacleTracker tracker;
  std::map<std::uint64_t, int> owner;  // track id -> obstacle index
  for (double x = -10; x <= 40; x += 1.0) {
    const auto cloud = sensor.scan({{x, 0, 0}, 0.0});
    for (const auto& t : tracker.update(detector.detect(cloud.points, cloud.origin))) {
      int nearest = 0;
      for (int k = 1; k < 4; ++k)
        if ((world.obstacles[k].center - t.center).norm() < (world.obstacles[nearest].center - t.center).norm())
          nearest = k;
      auto [it, inserted] = owner.emplace(t.id, nearest);
      EXPECT_EQ(it->second, nearest) << "track " << t.id << " switched obstacle at x = " << x;
    }
  }
  ASSERT_EQ(tracker.obstacles().size(), 4u);
  for (const auto& t : tracker.obstacles()) {
    const auto& truth = world.obstacles[owner[t.id]];
    // The drive saw the side of each circle that faces the road, from both ends: the fused ellipse
    // holds that whole half circle (sampled here at 5 deg).
    const double facing = truth.center.y() > 0 ? -1.0 : 1.0;
    for (double a = 0; a <= std::numbers::pi + 1e-9; a += std::numbers::pi / 36) {
      const Eigen::Vector3d p = truth.center + truth.radius * Eigen::Vector3d(std::cos(a), facing * std::sin(a), 0);
      EXPECT_TRUE(t.contains(p)) << "track " << t.id << " misses " << p.transpose();
    }
    EXPECT_GT(t.point_count, 100u);
  }
}

}  // namespace
}  // namespace ddsnav::perception
