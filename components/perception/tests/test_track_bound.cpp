// What perception publishes stays bounded: clusters too large to be an obstacle are structure (the map's),
// tracks of such a surface are dropped from the published set, and at most max_count are published.
#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/obstacle_tracker.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ddsnav::perception {
namespace {

// Points every 0.05 m on a 3-D patch z = f(x, y) over [x0, x1] x [y0, y1].
std::vector<Eigen::Vector3f> slope(float x0, float x1, float y0, float y1) {
  std::vector<Eigen::Vector3f> points;
  for (float x = x0; x <= x1; x += 0.05f)
    for (float y = y0; y <= y1; y += 0.05f) points.emplace_back(x, y, 1.0f + 0.5f * x);
  return points;
}

// A 0.6 m post (a discrete obstacle) at (px, py), its side facing the sensor.
std::vector<Eigen::Vector3f> post(float px, float py) {
  std::vector<Eigen::Vector3f> points;
  for (float y = -0.3f; y <= 0.3f; y += 0.05f)
    for (float z = 0.5f; z <= 1.5f; z += 0.05f) points.emplace_back(px, py + y, z);
  return points;
}

std::vector<Eigen::Vector3f> join(std::vector<Eigen::Vector3f> a, const std::vector<Eigen::Vector3f>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

DetectorParams withStructure(double extent) {
  DetectorParams p;
  p.structure_extent = extent;
  return p;
}

TEST(TrackBound, LargeClustersAreStructureSmallOnesObstacles) {
  ObstacleDetector detector(withStructure(6.0));
  const Eigen::Vector3d sensor(0, 0, 5);
  const auto points = join(slope(10, 20, -5, 5), post(4, -6));
  const auto detections = detector.detect(points, sensor, 3);
  EXPECT_EQ(detector.stats().structure_clusters, 1u);
  EXPECT_GT(detector.structure().size(), 1000u);
  ASSERT_FALSE(detections.empty());
  for (const auto& d : detections) EXPECT_NEAR(d.center.x(), 4.0, 0.5);  // only the post's pieces

  ObstacleDetector everything(withStructure(0.0));  // the default: no structure, the slope is tiled
  const auto tiled = everything.detect(points, sensor, 3);
  EXPECT_TRUE(everything.structure().empty());
  EXPECT_GT(tiled.size(), 20u);
}

TEST(TrackBound, TracksOfASurfaceLaterSeenWholeAreNotPublished) {
  ObstacleDetector detector(withStructure(6.0));
  ObstacleTracker tracker(TrackerParams::matching(detector.params()));
  const Eigen::Vector3d sensor(0, 0, 5);
  // First a glimpse of the slope's corner (small enough to be an obstacle) and the post...
  const auto& first = tracker.update(detector.detect(join(slope(10, 12, -1, 1), post(4, -6)), sensor, 3));
  tracker.markStructure(detector.structure(), 3);
  const std::size_t glimpse_tracks = first.size();
  ASSERT_GE(glimpse_tracks, 2u);
  EXPECT_EQ(tracker.discreteObstacles(sensor, 1000).size(), glimpse_tracks);
  // ...then the whole slope: the glimpse's tracks are structure now, the post's are not.
  tracker.update(detector.detect(join(slope(10, 20, -5, 5), post(4, -6)), sensor, 3));
  EXPECT_GT(tracker.markStructure(detector.structure(), 3), 0u);
  const auto published = tracker.discreteObstacles(sensor, 1000);
  ASSERT_FALSE(published.empty());
  EXPECT_LT(published.size(), glimpse_tracks);
  for (std::size_t i : published) {
    EXPECT_FALSE(tracker.isStructure(i));
    EXPECT_NEAR(tracker.obstacles()[i].center.x(), 4.0, 0.5);
  }
}

TEST(TrackBound, AtMostMaxCountArePublishedNearestFirst) {
  ObstacleDetector detector;  // no structure: every post is an obstacle
  ObstacleTracker tracker(TrackerParams::matching(detector.params()));
  const Eigen::Vector3d sensor(0, 0, 1);
  std::vector<Eigen::Vector3f> posts;
  for (int k = 0; k < 30; ++k) posts = join(posts, post(3.0f + 2.0f * float(k), 0.0f));
  const auto& tracked = tracker.update(detector.detect(posts, sensor, 3));
  ASSERT_GE(tracked.size(), 30u);
  const auto all = tracker.discreteObstacles(sensor, 100000);
  EXPECT_EQ(all.size(), tracked.size());
  const auto near = tracker.discreteObstacles(sensor, 10);
  ASSERT_EQ(near.size(), 10u);
  double farthest_kept = 0.0;
  for (std::size_t i : near) farthest_kept = std::max(farthest_kept, (tracked[i].center - sensor).norm());
  for (std::size_t i : all) {
    if (std::find(near.begin(), near.end(), i) != near.end()) continue;
    EXPECT_GE((tracked[i].center - sensor).norm(), farthest_kept - 1e-9);
  }
  EXPECT_TRUE(std::is_sorted(near.begin(), near.end()));
}

}  // namespace
}  // namespace ddsnav::perception
