#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/obstacle_tracker.hpp"
#include "ddsnav/sim/range_sensor.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <numbers>

namespace ddsnav::perception {
namespace {

// A detection as the detector makes it: the ellipse fitted to voxel centroids, carrying them.
ObstacleEllipsoid detectionOf(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& sensor, int dims = 2) {
  std::vector<SupportPoint> support;
  for (const auto& p : points) support.push_back({p, (p - sensor).normalized()});
  ObstacleEllipsoid e = fitEllipsoid(support, dims, EllipsoidFitParams{0.99, 0.02, 0.1, true});
  e.support = std::move(support);
  return e;
}

// Voxel centroids along a straight segment, every 0.1 m, jittered by `jitter` across it.
std::vector<Eigen::Vector3f> segment(Eigen::Vector3f a, Eigen::Vector3f b, float jitter = 0.0f) {
  std::vector<Eigen::Vector3f> points;
  const int n = static_cast<int>(std::ceil((b - a).norm() / 0.1f));
  const Eigen::Vector3f normal = Eigen::Vector3f(-(b - a).y(), (b - a).x(), 0).normalized();
  for (int i = 0; i <= n; ++i) points.push_back(a + (b - a) * (float(i) / n) + normal * (i % 2 ? jitter : -jitter));
  return points;
}

TEST(Tracker, SameSurfaceKeepsItsIdAndAFarOneGetsANewId) {
  ObstacleTracker tracker;
  const Eigen::Vector3f sensor(0, 0, 0);
  const auto& after1 = tracker.update(std::vector{detectionOf(segment({5, -0.5, 0}, {5, 0.5, 0}), sensor),
                                                  detectionOf(segment({-5, 3, 0}, {-5, 4, 0}), sensor)});
  ASSERT_EQ(after1.size(), 2u);
  EXPECT_EQ(after1[0].id, 1u);
  EXPECT_EQ(after1[1].id, 2u);
  EXPECT_EQ(tracker.lastUpdate().created, 2u);

  // The same surfaces with noise, in the other order, plus a new obstacle.
  const auto& after2 = tracker.update(std::vector{detectionOf(segment({-5.02, 3.05, 0}, {-5.02, 4.05, 0}, 0.02f), sensor),
                                                  detectionOf(segment({5.03, -0.45, 0}, {5.03, 0.45, 0}, 0.02f), sensor),
                                                  detectionOf(segment({20, 20, 0}, {20.5, 20, 0}), sensor)});
  ASSERT_EQ(after2.size(), 3u);
  EXPECT_EQ(tracker.lastUpdate().fused, 2u);
  EXPECT_EQ(tracker.lastUpdate().created, 1u);
  EXPECT_NEAR(after2[0].center.x(), 5.015, 0.03);  // refitted from the voxels of both scans
  EXPECT_NEAR(after2[1].center.y(), 3.525, 0.06);  // the union of both views, 3 .. 4.05
  EXPECT_EQ(after2[2].id, 3u);
  EXPECT_LT(after2[0].semi_axes.y(), 0.2);      // the noise does not fatten the surface
}

TEST(Tracker, OverlappingEllipsesOfDifferentSurfacesAreNotMerged) {
  // A post 0.42 m beyond the end of a 1.4 m wall piece lies inside the piece's ellipsoid (3-D: its
  // chi-square semi-axis is 0.97 x its length; a 2-D ellipse is shortened to its points and would not
  // reach it), and the combined-extent gate of the old tracker accepted it; its voxels are farther than
  // the association distance from the wall's, so it is another surface and gets its own track.
  ObstacleTracker tracker;
  const Eigen::Vector3f sensor(0, -4, 0);
  const auto& first = tracker.update(std::vector{detectionOf(segment({-0.7, 0, 0}, {0.7, 0, 0}), sensor, 3)});
  ASSERT_EQ(first.size(), 1u);
  const std::size_t first_voxels = first[0].support.size();
  const auto post = detectionOf(segment({1.12, 0, 0}, {1.18, 0, 0}), sensor, 3);
  ASSERT_TRUE(first[0].contains(post.center));
  const auto& after = tracker.update(std::vector{post});
  EXPECT_EQ(after.size(), 2u);
  EXPECT_EQ(tracker.lastUpdate().created, 1u);
  EXPECT_EQ(after[0].support.size(), first_voxels);  // the wall piece is unchanged
}

TEST(Tracker, AWallSeenPieceByPieceStaysAChainOfBoundedTracks) {
  // A 12 m wall revealed 0.5 m at a time (as a drive along it does): the tracks never exceed
  // max_segment_length, hold every voxel once, and their ellipses stay near the wall.
  ObstacleTracker tracker;
  const Eigen::Vector3f sensor(0, -3, 0);
  for (float end = 0.5f; end <= 12.0f; end += 0.5f) tracker.update(std::vector{detectionOf(segment({0, 0, 0}, {end, 0, 0}, 0.01f), sensor)});
  const auto& tracks = tracker.obstacles();
  EXPECT_GE(tracks.size(), 6u);
  EXPECT_LE(tracks.size(), 20u);
  std::size_t voxels = 0;
  for (const auto& t : tracks) {
    float lo = 1e9f, hi = -1e9f;
    for (const auto& sp : t.support) lo = std::min(lo, sp.position.x()), hi = std::max(hi, sp.position.x());
    EXPECT_LE(hi - lo, tracker.params().max_segment_length + 1e-4) << "track " << t.id;
    EXPECT_LT(std::abs(t.center.y()), 0.05);
    EXPECT_LT(t.semi_axes.y(), 0.2);
    EXPECT_GT(t.center.x() + t.semi_axes.x(), 0.0);
    EXPECT_LT(t.center.x() - t.semi_axes.x(), 12.0);
    voxels += t.support.size();
  }
  // Each voxel cell the detections touched is in exactly one track.
  std::set<std::pair<int, int>> cells;
  for (const auto& p : segment({0, 0, 0}, {12, 0, 0}, 0.01f))
    cells.emplace(static_cast<int>(std::floor(p.x() / 0.1)), static_cast<int>(std::floor(p.y() / 0.1)));
  std::set<std::pair<int, int>> owned;
  for (const auto& t : tracks)
    for (const auto& sp : t.support)
      EXPECT_TRUE(owned.emplace(static_cast<int>(std::floor(sp.position.x() / 0.1)),
                                static_cast<int>(std::floor(sp.position.y() / 0.1))).second);
  EXPECT_EQ(voxels, owned.size());
  EXPECT_GE(owned.size(), cells.size());
}

// A wall face seen only in glimpses (a doorway's side, the far part of a face at a grazing angle): every scan's
// cluster is short, so the detector never calls it structure; the chain of its tracks does once it spans more than
// the extent, and only then.
TEST(TrackerStructure, AChainOfGlimpsesLongerThanTheExtentIsStructure) {
  ObstacleTracker tracker;
  const Eigen::Vector3f sensor(-2, 0, 0);
  for (float y = 0.0f; y < 12.0f; y += 1.0f) {
    tracker.update(std::vector{detectionOf(segment({0, y, 0}, {0, y + 0.9f, 0}, 0.01f), sensor)});  // 0.1 m apart
    const bool longer = y + 0.9f > 10.0f;
    const std::size_t marked = tracker.markStructureChains(10.0);
    if (!longer) {
      EXPECT_EQ(marked, 0u) << "at y = " << y;
      EXPECT_EQ(tracker.discreteObstacles(sensor.cast<double>(), 1000).size(), tracker.obstacles().size());
    }
  }
  EXPECT_GE(tracker.obstacles().size(), 8u);
  EXPECT_TRUE(tracker.discreteObstacles(sensor.cast<double>(), 1000).empty());
  // A later glimpse of the face belongs to the structure at once; an obstacle 1 m off the face stays one.
  tracker.update(std::vector{detectionOf(segment({0, 12.0f, 0}, {0, 12.5f, 0}), sensor), detectionOf(segment({-1.0f, 5, 0}, {-1.0f, 5.3f, 0}), sensor)});
  tracker.markStructureChains(10.0);
  const auto left = tracker.discreteObstacles(sensor.cast<double>(), 1000);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_NEAR(tracker.obstacles()[left[0]].center.x(), -1.0, 0.05);
}

TEST(TrackerStructure, AGlimpseWhereStructureWasSeenIsStructure) {
  ObstacleTracker tracker;
  const Eigen::Vector3f sensor(-2, 0, 0);
  // A scan showed the wall x = 0, y in [0, 10] as one long cluster (structure: it never reaches the tracker).
  const auto wall = segment({0, 0, 0}, {0, 10, 0});
  EXPECT_EQ(tracker.markStructure(wall, 2), 0u);  // no track yet
  // Later glimpses: one of its end (a corner's leg) and a post 2 m away.
  tracker.update(std::vector{detectionOf(segment({0.1f, 10.0f, 0}, {0.4f, 10.0f, 0}), sensor), detectionOf(segment({-2.0f, 4, 0}, {-2.0f, 4.2f, 0}), sensor)});
  EXPECT_EQ(tracker.markStructureChains(10.0), 1u);
  const auto left = tracker.discreteObstacles(sensor.cast<double>(), 1000);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_NEAR(tracker.obstacles()[left[0]].center.x(), -2.0, 0.05);
  // Chains off: nothing changes.
  ObstacleTracker other;
  other.update(std::vector{detectionOf(segment({0, 0, 0}, {0, 0.9f, 0}), sensor)});
  EXPECT_EQ(other.markStructureChains(0.0), 0u);
}

TEST(Tracker, IgnoresBadDetectionsAndMixedDimensions) {
  ObstacleTracker tracker;
  const Eigen::Vector3f sensor(0, 0, 0);
  auto bad = detectionOf(segment({1, 1, 0}, {1, 2, 0}), sensor);
  bad.support.clear();  // no evidence: nothing to associate on
  auto nan = detectionOf(segment({3, 1, 0}, {3, 2, 0}), sensor);
  for (auto& sp : nan.support) sp.position.x() = std::nanf("");
  tracker.update(std::vector{bad, nan, detectionOf(segment({1, 1, 0}, {1, 2, 0}), sensor)});
  ASSERT_EQ(tracker.obstacles().size(), 1u);
  EXPECT_EQ(tracker.lastUpdate().ignored, 2u);
  auto lifted = segment({1, 1, 1}, {1, 2, 1});
  tracker.update(std::vector{detectionOf(lifted, sensor, 3)});
  EXPECT_EQ(tracker.obstacles().size(), 2u);  // a 3-D detection never joins a 2-D track
  TrackerParams params;
  params.max_segment_length = 0.1;
  EXPECT_THROW(ObstacleTracker{params}, std::invalid_argument);
}

TEST(Tracker, SimulatedDriveKeepsEveryTrackOnOneObstacle) {
  // A 2-D scanner drives past four obstacles; every track id stays bound to the obstacle it
  // started on, and each obstacle is a few tracks (pieces of at most max_segment_length).
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
  ObstacleTracker tracker(TrackerParams::matching(params));
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
  std::map<int, int> tracks_per_obstacle;
  for (const auto& [id, k] : owner) ++tracks_per_obstacle[k];
  ASSERT_EQ(tracks_per_obstacle.size(), 4u);
  for (const auto& [k, count] : tracks_per_obstacle) EXPECT_LE(count, 16) << "obstacle " << k;
  for (int k = 0; k < 4; ++k) {
    const auto& truth = world.obstacles[k];
    // The drive saw the side of each circle that faces the road, from both ends: the tracks of
    // that circle together hold that whole half circle (sampled here at 5 deg).
    const double facing = truth.center.y() > 0 ? -1.0 : 1.0;
    for (double a = 0; a <= std::numbers::pi + 1e-9; a += std::numbers::pi / 36) {
      const Eigen::Vector3d p = truth.center + truth.radius * Eigen::Vector3d(std::cos(a), facing * std::sin(a), 0);
      bool held = false;
      for (const auto& t : tracker.obstacles()) held |= owner[t.id] == k && t.contains(p);
      EXPECT_TRUE(held) << "obstacle " << k << " misses " << p.transpose();
    }
  }
}

}  // namespace
}  // namespace ddsnav::perception
