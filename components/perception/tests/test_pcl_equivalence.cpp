// The stock PCL pipeline is the oracle: same voxels, same clusters, same clustered points.
#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/pcl_reference.hpp"
#include "ddsnav/sim/city_block.hpp"
#include "ddsnav/sim/range_sensor.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <random>

namespace ddsnav::perception {
namespace {

// Pairs each PCL voxel with ours within 1e-4 m (float sums in another order may differ in the last
// bits); returns pcl index -> our index, -1 when unmatched.
std::vector<int> matchVoxels(const std::vector<Eigen::Vector3f>& pcl, const std::vector<Eigen::Vector3f>& ours) {
  std::multimap<long, int> by_x;  // our voxels bucketed by x in millimetres
  for (size_t i = 0; i < ours.size(); ++i) by_x.emplace(std::lround(ours[i].x() * 1000), static_cast<int>(i));
  std::vector<int> map(pcl.size(), -1);
  std::vector<bool> used(ours.size(), false);
  for (size_t k = 0; k < pcl.size(); ++k) {
    const long key = std::lround(pcl[k].x() * 1000);
    for (auto it = by_x.lower_bound(key - 1); it != by_x.end() && it->first <= key + 1; ++it) {
      if (!used[it->second] && (pcl[k] - ours[it->second]).norm() < 1e-4f) {
        map[k] = it->second;
        used[it->second] = true;
        break;
      }
    }
  }
  return map;
}

void expectSameClusters(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin, int dims,
                        const DetectorParams& params) {
  ObstacleDetector detector(params);
  detector.detect(points, origin, dims);
  PclReferencePipeline reference(params);
  reference.setInput(points);
  reference.run(dims);

  EXPECT_EQ(detector.stats().voxels, reference.voxelCountBeforeGround());
  ASSERT_EQ(detector.voxels().size(), reference.voxels().size());
  const auto map = matchVoxels(reference.voxels(), detector.voxels());
  ASSERT_EQ(std::count(map.begin(), map.end(), -1), 0) << "voxel centroids differ";

  const Clusters& ours = detector.clusters();
  ASSERT_EQ(ours.size(), reference.clusters().size());
  std::vector<int> our_label(detector.voxels().size(), -1);
  for (size_t c = 0; c < ours.size(); ++c)
    for (int i : ours[c]) our_label[i] = static_cast<int>(c);
  size_t clustered = 0;
  for (const auto& cluster : reference.clusters()) {
    ASSERT_FALSE(cluster.empty());
    const int label = our_label[map[cluster[0]]];
    ASSERT_GE(label, 0) << "a PCL cluster's point is unclustered here";
    EXPECT_EQ(ours[label].size(), cluster.size());
    for (int i : cluster) EXPECT_EQ(our_label[map[i]], label);
    clustered += cluster.size();
  }
  EXPECT_EQ(detector.stats().clustered_points, clustered);
  EXPECT_GT(ours.size(), 0u);
}

TEST(PclEquivalence, CityBlockLidarScans) {
  const auto world = sim::makeCityBlock(3);
  auto config = sim::RangeSensorConfig::lidar3d(16, 1800, -15, 15, 100);
  config.range_noise_sigma = 0.02;
  config.invalid_fraction = 0.01;
  sim::RangeSensor sensor(world, config);
  DetectorParams params;
  params.min_cluster_size = 1;  // PCL's defaults
  params.max_cluster_size = 1u << 30;
  for (double x : {-20.0, 5.0}) {
    const auto cloud = sensor.scan({{x, 1.0, 1.8}, 0.2});
    expectSameClusters(cloud.points, cloud.origin, 3, params);
  }
}

TEST(PclEquivalence, ClusterSizeLimitsDropLikePcl) {
  const auto world = sim::makeCityBlock(4);
  auto config = sim::RangeSensorConfig::lidar3d(16, 900, -15, 15, 60);
  config.range_noise_sigma = 0.03;
  sim::RangeSensor sensor(world, config);
  DetectorParams params;
  params.min_cluster_size = 12;
  params.max_cluster_size = 400;
  params.cluster_tolerance = 0.3;
  params.voxel_size = 0.15;
  const auto cloud = sensor.scan({{10, -1, 1.8}, 1.0});
  expectSameClusters(cloud.points, cloud.origin, 3, params);
}

TEST(PclEquivalence, RandomBlobsIncludingNearTolerancePairs) {
  // Dense random points: many pairs near the tolerance, where a cell shortcut would show.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 6.f);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 4000; ++i) points.emplace_back(u(rng), u(rng), 0.5f * u(rng));
  DetectorParams params;
  params.min_cluster_size = 1;
  params.remove_ground = false;
  params.voxel_size = 0.05;
  expectSameClusters(points, Eigen::Vector3d(3, 3, 1), 3, params);
}

TEST(PclEquivalence, PlanarScan) {
  planner::Scenario world = sim::makeCityBlock(2);
  world.dimensions = 2;
  for (auto& o : world.obstacles) o.center.z() = 0;
  sim::RangeSensor sensor(world, sim::RangeSensorConfig::scanner2d(2000, 60));
  const auto cloud = sensor.scan({{0, 0, 0}, 0.0});
  DetectorParams params;
  params.min_cluster_size = 1;
  expectSameClusters(cloud.points, cloud.origin, 2, params);
}

}  // namespace
}  // namespace ddsnav::perception
