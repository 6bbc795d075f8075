// Bad scans and bad parameters: a clear message, the scan skipped or cleaned, never a crash.
#include "ddsnav/mapper/occupancy_mapper.hpp"
#include "ddsnav/mapper/synthetic_scan.hpp"
#include "mapper_test_util.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <limits>

namespace ddsnav::mapper {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

MapperConfig coarse() {
  MapperConfig c;
  c.resolution = 0.2;
  return c;
}

TEST(MapperBadInput, NonFinitePointsAreDroppedAndTheRestMatchesOctoMap) {
  LidarPattern lidar;
  lidar.rings = 8;
  lidar.columns = 400;
  lidar.invalid_fraction = 0.2;
  Scan scan = simulateScan(makeCityBlock(2), lidar, {0, 0, 1.8f});
  scan.points.push_back({kNaN, 0, 0});
  scan.points.push_back({0, -kInf, 0});
  OccupancyMapper mapper(coarse());
  const InsertResult r = mapper.insert(scan);
  ASSERT_TRUE(r.inserted);
  EXPECT_GT(r.dropped_non_finite, 2u);
  EXPECT_NE(r.message.find("non-finite"), std::string::npos);
  EXPECT_EQ(r.points_used + r.dropped_non_finite, scan.points.size());

  octomap::OcTree reference(0.2);
  applySensorModel(reference, coarse());
  reference.insertPointCloud(testing::toOctomapCloud(scan, coarse()), testing::toOrigin(scan, coarse()), 20.0);
  EXPECT_EQ(testing::fullBytes(mapper.octree()), testing::fullBytes(reference));
}

TEST(MapperBadInput, EmptyScanChangesNothing) {
  OccupancyMapper mapper(coarse());
  Scan scan;
  const InsertResult r = mapper.insert(scan);
  EXPECT_TRUE(r.inserted);
  EXPECT_NE(r.message.find("no points"), std::string::npos);
  EXPECT_EQ(mapper.octree().size(), 0u);
  EXPECT_FALSE(mapper.changedSinceExport());
  Scan all_bad;
  all_bad.points = {{kNaN, kNaN, kNaN}, {kInf, 0, 0}};
  EXPECT_TRUE(mapper.insert(all_bad).inserted);
  EXPECT_EQ(mapper.octree().size(), 0u);
}

TEST(MapperBadInput, BadOriginOrRangeSkipsTheScan) {
  OccupancyMapper mapper(coarse());
  Scan scan;
  scan.points = {{1, 1, 1}, {2, 2, 2}};
  // 1e12 and -3e38 overflow OctoMap's int key arithmetic (coordToKeyChecked casts before it checks: undefined
  // behaviour, found by UBSan through the bad-input pipeline test): refused before OctoMap sees them.
  for (const Point3f origin : {Point3f{kNaN, 0, 0}, Point3f{0, kInf, 0}, Point3f{1e6f, 0, 0}, Point3f{0, 0, -7000.0f},
                               Point3f{1e12f, 0, 0}, Point3f{0, -3e38f, 0}}) {
    scan.origin = origin;
    const InsertResult r = mapper.insert(scan);
    EXPECT_FALSE(r.inserted);
    EXPECT_NE(r.message.find("origin"), std::string::npos) << r.message;
  }
  scan.origin = {0, 0, 0};
  for (double range : {-1.0, 0.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e9}) {
    scan.max_range = range;
    const InsertResult r = mapper.insert(scan);
    EXPECT_FALSE(r.inserted) << range;
    EXPECT_NE(r.message.find("max_range"), std::string::npos) << r.message;
  }
  EXPECT_EQ(mapper.octree().size(), 0u);
  EXPECT_FALSE(mapper.changedSinceExport());
}

TEST(MapperBadInput, PointsFarOutsideTheMapAreHandledLikeOctoMap) {
  // End points beyond the key range: the ray is clipped to max_range, so space is still cleared.
  Scan scan;
  scan.origin = {0, 0, 0};
  scan.points = {{1e7f, 0, 0}, {0, -1e7f, 3}, {2, 2, 0}};
  scan.max_range = 10.0;
  OccupancyMapper mapper(coarse());
  ASSERT_TRUE(mapper.insert(scan).inserted);
  octomap::OcTree reference(0.2);
  applySensorModel(reference, coarse());
  reference.insertPointCloud(testing::toOctomapCloud(scan, coarse()), {0, 0, 0}, 10.0);
  EXPECT_EQ(testing::fullBytes(mapper.octree()), testing::fullBytes(reference));
}

TEST(MapperBadInput, MillionsOfPoints) {
  MapperConfig config = coarse();
  config.max_points = 3'000'000;
  OccupancyMapper mapper(config);
  Scan scan;
  scan.origin = {0, 0, 0};
  scan.max_range = 5.0;
  // Short rays so the test stays fast; the point count is what is being tested.
  scan.points.resize(2'500'000);
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    scan.points[i] = {float(i % 17) * 0.1f - 0.8f, float(i % 13) * 0.1f - 0.6f, float(i % 7) * 0.1f + 0.3f};
  }
  const InsertResult r = mapper.insert(scan);
  EXPECT_TRUE(r.inserted) << r.message;
  EXPECT_EQ(r.points_used, scan.points.size());
  EXPECT_GT(r.occupied_cells, 0u);

  scan.points.resize(3'000'001);
  const InsertResult too_many = mapper.insert(scan);
  EXPECT_FALSE(too_many.inserted);
  EXPECT_NE(too_many.message.find("max_points"), std::string::npos);
}

TEST(MapperBadInput, BadParametersNameTheParameter) {
  auto expectError = [](MapperConfig c, const std::string& name) {
    const std::string error = validateConfig(c);
    EXPECT_NE(error.find("'" + name + "'"), std::string::npos) << error;
    EXPECT_THROW(OccupancyMapper{c}, std::invalid_argument);
  };
  MapperConfig c;
  EXPECT_EQ(validateConfig(c), "");
  c.resolution = -0.1;
  expectError(c, "resolution");
  c = {};
  c.resolution = std::numeric_limits<double>::quiet_NaN();
  expectError(c, "resolution");
  c = {};
  c.dimensions = 4;
  expectError(c, "dimensions");
  c = {};
  c.prob_hit = 0.3;
  expectError(c, "prob_hit");
  c = {};
  c.prob_miss = 0.6;
  expectError(c, "prob_miss");
  c = {};
  c.clamping_min = 0.99;
  expectError(c, "clamping_min");
  c = {};
  c.threads = 0;
  expectError(c, "threads");
}

}  // namespace
}  // namespace ddsnav::mapper
