// The tracker forgets evidence the sensor can no longer refresh: a track entirely farther than
// forget_radius from the sensor is dropped, one with a voxel inside is kept, the reference tracker
// drops the same ones, and on a long drive the tracked set stays bounded.
#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/obstacle_tracker.hpp"
#include "ddsnav/perception/reference_tracker.hpp"

#include <gtest/gtest.h>

#include <algorithm>

namespace ddsnav::perception {
namespace {

// A 0.6 m wide, 1 m tall post at (px, py): its face x = px, points every 0.05 m.
std::vector<Eigen::Vector3f> post(float px, float py) {
  std::vector<Eigen::Vector3f> points;
  for (float y = -0.3f; y <= 0.3f; y += 0.05f)
    for (float z = 0.5f; z <= 1.5f; z += 0.05f) points.emplace_back(px, py + y, z);
  return points;
}

std::vector<std::uint64_t> idsOf(const std::vector<ObstacleEllipsoid>& tracks) {
  std::vector<std::uint64_t> ids;
  for (const auto& t : tracks) ids.push_back(t.id);
  return ids;
}

TEST(TrackerForget, TrackBeyondTheRadiusIsDroppedOneInsideIsKept) {
  ObstacleDetector detector;
  TrackerParams params = TrackerParams::matching(detector.params());
  params.forget_radius = 10.0;
  ObstacleTracker tracker(params);
  reference::ReferenceObstacleTracker reference(params);
  const Eigen::Vector3d start(0, 0, 1);
  auto points = post(4, 0);
  const auto far_post = points.size();
  const auto near = post(8, 0);
  points.insert(points.end(), near.begin(), near.end());
  const auto detections = detector.detect(points, start, 3);
  const auto& first = tracker.update(detections, start);
  reference.update(detections, start);
  ASSERT_GE(first.size(), 2u);
  ASSERT_LT(far_post, points.size());
  std::size_t at4 = 0, at8 = 0;
  for (const auto& t : first) (t.center.x() < 6.0 ? at4 : at8)++;
  ASSERT_GT(at4, 0u);
  ASSERT_GT(at8, 0u);
  const std::uint64_t first_last_id = first.back().id;

  // From x = 15 the post at x = 4 is 11 m away (beyond 10 m), the one at x = 8 is 7 m away.
  const Eigen::Vector3d moved(15, 0, 1);
  const auto& second = tracker.update({}, moved);
  reference.update({}, moved);
  EXPECT_EQ(tracker.lastUpdate().forgotten, at4);
  EXPECT_EQ(reference.lastUpdate().forgotten, at4);
  ASSERT_EQ(second.size(), at8);
  for (const auto& t : second) EXPECT_NEAR(t.center.x(), 8.0, 0.5);
  EXPECT_EQ(idsOf(second), idsOf(reference.obstacles()));

  // Without a sensor origin nothing is forgotten; a track just inside the radius stays.
  const Eigen::Vector3d edge(17.9, 0, 1);  // the post's face is 9.9 m away
  tracker.update({}, edge);
  EXPECT_EQ(tracker.lastUpdate().forgotten, 0u);
  EXPECT_EQ(tracker.obstacles().size(), at8);
  tracker.update({});
  EXPECT_EQ(tracker.obstacles().size(), at8);

  // Seen again, the forgotten post is a new track (new id), the kept one is refreshed (same id).
  const auto again = detector.detect(points, start, 3);
  const auto kept_ids = idsOf(tracker.obstacles());
  const auto& back = tracker.update(again, start);
  EXPECT_EQ(tracker.lastUpdate().created, at4);
  for (std::size_t i = 0; i < kept_ids.size(); ++i) EXPECT_EQ(back[i].id, kept_ids[i]);
  for (std::size_t i = kept_ids.size(); i < back.size(); ++i) EXPECT_GT(back[i].id, first_last_id);
}

TEST(TrackerForget, LongDriveStaysBoundedAndMatchesTheReference) {
  DetectorParams detector_params;
  detector_params.max_range = 20.0;  // forget_radius 21.6 m by matching()
  ObstacleDetector detector(detector_params);
  const TrackerParams params = TrackerParams::matching(detector_params);
  EXPECT_DOUBLE_EQ(params.forget_radius, 20.0 + 4.0 * detector_params.cluster_tolerance);
  ObstacleTracker tracker(params);
  reference::ReferenceObstacleTracker reference(params);
  TrackerParams keep_all = params;
  keep_all.forget_radius = std::numeric_limits<double>::infinity();
  ObstacleTracker unbounded(keep_all);

  // 600 m of road with a post every 3 m on either side; the sensor moves 1 m per scan.
  std::size_t most_tracks = 0, most_voxels = 0, forgotten = 0;
  for (int k = 0; k < 600; ++k) {
    const Eigen::Vector3d sensor(k, 0, 1);
    std::vector<Eigen::Vector3f> points;
    for (int p = (k - 25) / 3 * 3; p <= k + 25; p += 3)
      for (float side : {-4.0f, 4.0f}) {
        const auto one = post(static_cast<float>(p), side);
        points.insert(points.end(), one.begin(), one.end());
      }
    const auto detections = detector.detect(points, sensor, 3);
    const auto& tracks = tracker.update(detections, sensor);
    reference.update(detections, sensor);
    unbounded.update(detections);
    forgotten += tracker.lastUpdate().forgotten;
    ASSERT_EQ(idsOf(tracks), idsOf(reference.obstacles())) << "scan " << k;
    std::size_t voxels = 0;
    for (std::size_t i = 0; i < tracks.size(); ++i) {
      const auto evidence = tracker.evidence(i);
      ASSERT_EQ(evidence.size(), reference.obstacles()[i].support.size()) << "scan " << k;
      voxels += evidence.size();
    }
    most_tracks = std::max(most_tracks, tracks.size());
    most_voxels = std::max(most_voxels, voxels);
  }
  // Posts detected within 20 m and kept within 21.6 m: about 2 x (20 + 21.6) / 3 = 28, one track each
  // (measured 28 tracks, 1820 voxels at most); 426 tracks without forgetting.
  EXPECT_GT(forgotten, 0u);
  EXPECT_LE(most_tracks, 60u);
  EXPECT_LE(most_voxels, 60u * 100u);
  EXPECT_GT(unbounded.obstacles().size(), 3 * most_tracks);  // without forgetting it keeps growing
}

}  // namespace
}  // namespace ddsnav::perception
