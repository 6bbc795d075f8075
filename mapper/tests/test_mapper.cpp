// The fast insertion builds exactly the tree OcTree::insertPointCloud builds.
#include "ddsnav/mapper/occupancy_mapper.hpp"
#include "ddsnav/mapper/synthetic_scan.hpp"
#include "mapper_test_util.hpp"

#include <gtest/gtest.h>

#include <array>
#include <functional>
#include <memory>
#include <octomap/OcTree.h>

#include <cmath>
#include <limits>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace ddsnav::mapper {
namespace {

using testing::compareQueries;
using testing::fullBytes;
using testing::toOctomapCloud;
using testing::toOrigin;

struct Case {
  const char* name;
  MapperConfig config;
  LidarPattern lidar;
  double max_range;
  std::vector<Point3f> poses;
};

// Inserts the same scans with ours and with OcTree::insertPointCloud, then compares everything.
void expectIdentical(const Case& c, bool lazy_reference = false, int expect_walk_threads = 0) {
  const CityBlock city = makeCityBlock(7);
  OccupancyMapper mapper(c.config);
  octomap::OcTree reference(c.config.resolution);
  applySensorModel(reference, c.config);
  std::uint32_t seed = 1;
  for (const Point3f& pose : c.poses) {
    Scan scan = simulateScan(city, c.lidar, pose, seed++);
    scan.max_range = c.max_range;
    const InsertResult r = mapper.insert(scan);
    ASSERT_TRUE(r.inserted) << r.message;
    EXPECT_GT(r.free_cells, 0u);
    EXPECT_GT(r.occupied_cells, 0u);
    if (expect_walk_threads > 0) {
      EXPECT_EQ(r.walk_threads, expect_walk_threads);
    } else if (expect_walk_threads < 0) {
      // Pipelined: each scan is walked either on the background thread (1) or, when the walk is the slower stage,
      // at once on every thread; which one depends on measured times, the tree on neither.
      EXPECT_GE(r.walk_threads, 1);
      EXPECT_LE(r.walk_threads, c.config.threads);
    }
    reference.insertPointCloud(toOctomapCloud(scan, c.config), toOrigin(scan, c.config), c.max_range, lazy_reference,
                               c.config.discretize);
  }
  if (lazy_reference) {
    reference.updateInnerOccupancy();
  } else {
    // Same structure (pruning included) and the same log-odds in every node.
    EXPECT_EQ(fullBytes(mapper.octree()), fullBytes(reference)) << c.name;
    EXPECT_EQ(mapper.octree().memoryUsage(), reference.memoryUsage());
  }
  const bool flat = c.config.dimensions == 2;
  const float z = static_cast<float>(c.config.slab_z);
  const octomap::point3d lo(-25, -25, flat ? z : -1.0f), hi(25, 25, flat ? z : 12.0f);
  const testing::QueryMismatch m = compareQueries(mapper.octree(), reference, lo, hi, 100000, 10000, 42);
  EXPECT_EQ(m.point_mismatches, 0) << c.name;
  EXPECT_EQ(m.ray_mismatches, 0) << c.name;
}

LidarPattern lidar3d(int rings, int columns) {
  LidarPattern l;
  l.rings = rings;
  l.columns = columns;
  l.range_noise = 0.02;
  return l;
}

TEST(MapperIdentical, ThreeDimensionalScansAt02) {
  Case c{"3-D 0.2 m", {}, lidar3d(16, 500), 15.0, {{0, 0, 1.8f}, {3.1f, 0.9f, 1.9f}}};
  c.config.resolution = 0.2;
  c.config.threads = 2;
  expectIdentical(c, false, /*walk_threads=*/2);  // big enough to split the tree walk between 2 threads
}

TEST(MapperIdentical, ThreeDimensionalDenseScanAt01) {
  Case c{"3-D 0.1 m", {}, lidar3d(8, 600), 10.0, {{0.3f, -0.2f, 1.7f}, {0.9f, 0.1f, 1.7f}}};
  expectIdentical(c);
}

TEST(MapperIdentical, SingleThreadDefaultMatchesToo) {
  EXPECT_EQ(MapperConfig{}.threads, 1);
  Case c{"3-D one thread", {}, lidar3d(8, 400), 12.0, {{0, 0, 1.8f}, {-2.0f, 1.0f, 1.8f}}};
  c.config.resolution = 0.15;
  c.config.threads = 1;
  expectIdentical(c, false, /*walk_threads=*/1);
}

TEST(MapperIdentical, DiscretizeMatchesOctoMapDiscretize) {
  Case c{"3-D discretize", {}, lidar3d(16, 400), 15.0, {{0, 0, 1.8f}, {2.0f, 0.5f, 1.8f}}};
  c.config.resolution = 0.2;
  c.config.threads = 2;
  c.config.discretize = true;
  expectIdentical(c);
}

TEST(MapperIdentical, TwoDimensionalSlabWithClampingAndPruning) {
  // Repeated scans from nearby poses drive voxels to the clamping bounds, so the early-abort and the
  // prune/expand paths of the update are all exercised.
  LidarPattern planar;
  planar.rings = 1;
  planar.columns = 480;
  planar.range_noise = 0.01;
  Case c{"2-D slab", {}, planar, 12.0, {}};
  c.config.dimensions = 2;
  c.config.slab_z = 0.5;
  c.config.resolution = 0.05;
  for (int i = 0; i < 8; ++i) c.poses.push_back({0.05f * (i % 4), 0.03f * (i % 3), 0.5f});
  expectIdentical(c);
}

TEST(MapperIdentical, ThreeDimensionalRepeatedScansPruneAndExpand) {
  // Free space near the sensor clamps and prunes into coarse leaves after a few scans; later scans from
  // shifted poses hit those pruned leaves (early abort when clamped, expansion otherwise).
  Case c{"3-D repeated", {}, lidar3d(16, 240), 8.0, {}};
  c.config.resolution = 0.2;
  for (int i = 0; i < 10; ++i) c.poses.push_back({0.1f * (i % 3), 0.07f * (i % 5), 1.8f});
  c.poses.push_back({2.0f, 1.0f, 1.8f});
  c.config.threads = 3;  // three shares of subtrees, each with prune/expand work
  expectIdentical(c, false, /*walk_threads=*/3);
}

// Pipelined insertion: the tree update of scan i runs on a background thread while the keys of scan
// i + 1 are computed; the trees must still be OctoMap's, byte for byte.
TEST(MapperIdentical, PipelinedRepeatedScansPruneAndExpand) {
  Case c{"3-D repeated, pipelined", {}, lidar3d(16, 240), 8.0, {}};
  c.config.resolution = 0.2;
  for (int i = 0; i < 10; ++i) c.poses.push_back({0.1f * (i % 3), 0.07f * (i % 5), 1.8f});
  c.poses.push_back({2.0f, 1.0f, 1.8f});
  c.config.threads = 2;
  c.config.pipeline = true;
  expectIdentical(c, false, /*walk_threads: 1 or all*/ -1);
}

TEST(MapperIdentical, PipelinedDenseScansAt01AndDiscretize) {
  Case c{"3-D 0.1 m, pipelined", {}, lidar3d(16, 900), 12.0, {{0.3f, -0.2f, 1.7f}, {1.9f, 0.6f, 1.7f}, {3.5f, 0.1f, 1.8f}}};
  c.config.threads = 2;
  c.config.pipeline = true;
  expectIdentical(c);
  c.name = "3-D 0.2 m discretize, pipelined";
  c.config.resolution = 0.2;
  c.config.discretize = true;
  expectIdentical(c);
}

TEST(MapperIdentical, PipelinedMapIsCompleteAtEveryRead) {
  // Every read of the map between insertions sees all scans inserted so far, never a half-applied one.
  const CityBlock city = makeCityBlock(4);
  MapperConfig config;
  config.resolution = 0.2;
  config.threads = 2;
  config.pipeline = true;
  OccupancyMapper mapper(config);
  octomap::OcTree reference(config.resolution);
  applySensorModel(reference, config);
  for (std::uint32_t i = 0; i < 5; ++i) {
    Scan scan = simulateScan(city, lidar3d(16, 600), {1.5f * float(i), 0.2f * float(i % 2), 1.8f}, 10 + i);
    scan.max_range = 15.0;
    ASSERT_TRUE(mapper.insert(scan).inserted);
    reference.insertPointCloud(toOctomapCloud(scan, config), toOrigin(scan, config), scan.max_range);
    if (i % 2 == 1) {
      EXPECT_EQ(fullBytes(mapper.octree()), fullBytes(reference)) << "after scan " << i;
    } else {
      std::ostringstream bytes;
      octomap::OcTree max_likelihood(reference);  // writeBinary prunes its tree's maximum likelihood: on a copy
      max_likelihood.writeBinary(bytes);
      const ExportedMap map = mapper.exportMap();
      EXPECT_EQ(std::string(map.octree_binary.begin(), map.octree_binary.end()), bytes.str()) << "after scan " << i;
    }
  }
  EXPECT_EQ(mapper.memoryUsage() - mapper.scratchMemoryUsage(), reference.memoryUsage());
}

TEST(MapperIdentical, AnswersEqualLazyEvalReference) {
  Case c{"3-D vs lazy", {}, lidar3d(16, 500), 15.0, {{0, 0, 1.8f}, {1.0f, 1.0f, 1.8f}}};
  c.config.resolution = 0.2;
  expectIdentical(c, /*lazy_reference=*/true);
}

TEST(MapperIdentical, OctoMapMethodIsTheReference) {
  // The InsertMethod::kOctoMap path calls insertPointCloud itself: both methods give the same tree.
  const CityBlock city = makeCityBlock(3);
  MapperConfig fast_config, ref_config;
  fast_config.resolution = ref_config.resolution = 0.25;
  ref_config.method = InsertMethod::kOctoMap;
  OccupancyMapper fast(fast_config), ref(ref_config);
  Scan scan = simulateScan(city, lidar3d(8, 300), {0, 0, 1.8f});
  ASSERT_TRUE(fast.insert(scan).inserted);
  ASSERT_TRUE(ref.insert(scan).inserted);
  EXPECT_EQ(fullBytes(fast.octree()), fullBytes(ref.octree()));
}

TEST(MapperExport, BinaryBytesAreOctoMapsOwn) {
  MapperConfig config;
  config.resolution = 0.2;
  OccupancyMapper mapper(config);
  std::ostringstream empty_ours, empty_octomap;
  writeOctreeBinary(mapper.octree(), empty_ours);
  mapper.octree().writeBinaryConst(empty_octomap);
  EXPECT_EQ(empty_ours.str(), empty_octomap.str());
  // Three scans from three places: free space seen from more than one leaves neighbours of one class with
  // different probabilities, which the live tree keeps apart and the maximum-likelihood tree merges.
  for (float x : {0.0f, 2.5f, 5.0f})
    ASSERT_TRUE(mapper.insert(simulateScan(makeCityBlock(5), lidar3d(8, 300), {x, 0.5f * x, 1.8f})).inserted);
  std::ostringstream ours, octomap_bytes;
  writeOctreeBinary(mapper.octree(), ours);
  mapper.octree().writeBinaryConst(octomap_bytes);
  EXPECT_GT(ours.str().size(), 1000u);
  EXPECT_EQ(ours.str(), octomap_bytes.str());
  // The export is OctoMap's writeBinary of the same tree: its maximum likelihood, pruned — the live tree unchanged.
  const std::size_t live_nodes = mapper.octree().size();
  const auto exported = mapper.exportMap();
  EXPECT_EQ(mapper.octree().size(), live_nodes);
  octomap::OcTree max_likelihood(mapper.octree());
  std::ostringstream pruned_bytes;
  max_likelihood.writeBinary(pruned_bytes);
  EXPECT_LT(pruned_bytes.str().size(), octomap_bytes.str().size());
  std::printf("3 scans: the whole tree %zu bytes, its maximum likelihood pruned %zu\n", octomap_bytes.str().size(), pruned_bytes.str().size());
  EXPECT_EQ(std::string(exported.octree_binary.begin(), exported.octree_binary.end()), pruned_bytes.str());
  EXPECT_EQ(exported.leaf_count, max_likelihood.getNumLeafNodes());
}

TEST(MapperExport, KeptRegionWalksGiveTheWholeWalksBytes) {
  // The export keeps each region's walk until a voxel in it changes class. Scans that see new ground, scans that
  // only look again (classes settle, leaves clamp, prune and expand) and exports after one scan or after several
  // must all give OctoMap's own maximum-likelihood stream of the live tree, its leaf count and its bounds.
  struct Setup {
    const char* name;
    MapperConfig config;
    LidarPattern lidar;
    int export_every;
  };
  LidarPattern planar;
  planar.rings = 1;
  planar.columns = 480;
  planar.range_noise = 0.01;
  std::vector<Setup> setups;
  setups.push_back({"3-D 0.2 m, pipelined on 2 threads", {}, lidar3d(16, 300), 1});
  setups.back().config.resolution = 0.2;
  setups.back().config.threads = 2;
  setups.back().config.pipeline = true;
  setups.push_back({"3-D 0.1 m, 1 thread, every 3rd scan", {}, lidar3d(8, 300), 3});
  setups.back().config.resolution = 0.1;
  setups.back().config.threads = 1;
  setups.push_back({"2-D 0.05 m", {}, planar, 2});
  setups.back().config.dimensions = 2;
  setups.back().config.slab_z = 0.5;
  setups.back().config.resolution = 0.05;
  const CityBlock city = makeCityBlock(6);
  for (const Setup& setup : setups) {
    OccupancyMapper mapper(setup.config);
    const float z = setup.config.dimensions == 2 ? 0.5f : 1.8f;
    for (int i = 0; i < 14; ++i) {
      // Out along a line, then back over the same ground in small steps.
      const float along = i < 7 ? 2.0f * float(i) : 2.0f * float(13 - i) + 0.1f * float(i % 2);
      Scan scan = simulateScan(city, setup.lidar, {along, 0.3f * float(i % 3), z}, 100 + i);
      scan.max_range = 14.0;
      ASSERT_TRUE(mapper.insert(scan).inserted) << setup.name;
      if ((i + 1) % setup.export_every != 0 && i != 13) continue;
      const ExportedMap map = mapper.exportMap();
      octomap::OcTree max_likelihood(mapper.octree());
      std::ostringstream bytes;
      max_likelihood.writeBinary(bytes);
      ASSERT_EQ(std::string(map.octree_binary.begin(), map.octree_binary.end()), bytes.str()) << setup.name << ", scan " << i;
      EXPECT_EQ(map.leaf_count, max_likelihood.getNumLeafNodes()) << setup.name << ", scan " << i;
      double lo[3], hi[3];
      max_likelihood.getMetricMin(lo[0], lo[1], lo[2]);
      max_likelihood.getMetricMax(hi[0], hi[1], hi[2]);
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(map.bounds_min[a], lo[a], 1e-9) << setup.name << ", scan " << i << ", axis " << a;
        EXPECT_NEAR(map.bounds_max[a], hi[a], 1e-9) << setup.name << ", scan " << i << ", axis " << a;
      }
    }
  }
}

TEST(MapperExport, BinaryRoundTripAndChangedFlag) {
  MapperConfig config;
  config.resolution = 0.2;
  OccupancyMapper mapper(config);
  EXPECT_FALSE(mapper.changedSinceExport());
  const ExportedMap empty = mapper.exportMap();
  EXPECT_EQ(empty.leaf_count, 0u);
  Scan scan = simulateScan(makeCityBlock(5), lidar3d(8, 300), {0, 0, 1.8f});
  ASSERT_TRUE(mapper.insert(scan).inserted);
  EXPECT_TRUE(mapper.changedSinceExport());
  const ExportedMap map = mapper.exportMap();
  EXPECT_FALSE(mapper.changedSinceExport());
  EXPECT_DOUBLE_EQ(map.resolution, 0.2);
  EXPECT_GT(map.leaf_count, 100u);
  for (int i = 0; i < 3; ++i) EXPECT_LT(map.bounds_min[i], map.bounds_max[i]);
  // The export's one walk bounds the leaves as OctoMap's own walk does (pruning merges whole octants: same bounds).
  double lo[3], hi[3];
  mapper.octree().getMetricMin(lo[0], lo[1], lo[2]);
  mapper.octree().getMetricMax(hi[0], hi[1], hi[2]);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(map.bounds_min[i], lo[i], 1e-9) << "axis " << i;
    EXPECT_NEAR(map.bounds_max[i], hi[i], 1e-9) << "axis " << i;
  }

  std::istringstream in(std::string(map.octree_binary.begin(), map.octree_binary.end()));
  octomap::OcTree read(0.1);
  ASSERT_TRUE(read.readBinary(in));
  EXPECT_DOUBLE_EQ(read.getResolution(), 0.2);
  // The binary format keeps occupancy (max likelihood), so compare the occupancy of every leaf.
  std::size_t leaves = 0;
  for (auto it = mapper.octree().begin_leafs(), end = mapper.octree().end_leafs(); it != end; ++it, ++leaves) {
    const octomap::OcTreeNode* n = read.search(it.getKey(), it.getDepth());
    ASSERT_NE(n, nullptr);
    EXPECT_EQ(read.isNodeOccupied(n), mapper.octree().isNodeOccupied(*it));
  }
  EXPECT_GE(leaves, map.leaf_count);  // the live tree's leaves; the map's are those of its maximum likelihood, pruned
  EXPECT_EQ(read.getNumLeafNodes(), map.leaf_count);

  const std::string path = ::testing::TempDir() + "ddsnav_mapper_roundtrip.bt";
  mapper.writeBt(path);
  octomap::OcTree from_file(0.1);
  ASSERT_TRUE(from_file.readBinary(path));
  EXPECT_EQ(from_file.getNumLeafNodes(), read.getNumLeafNodes());
  std::remove(path.c_str());
  EXPECT_THROW(mapper.writeBt("/nonexistent-dir/x.bt"), std::runtime_error);
}

// OctoMap's own stream of the live tree's maximum likelihood, and that stream read back.
std::string exactExport(const OccupancyMapper& mapper) {
  octomap::OcTree max_likelihood(mapper.octree());
  std::ostringstream bytes;
  max_likelihood.writeBinary(bytes);
  return bytes.str();
}
std::unique_ptr<octomap::OcTree> readBack(const std::string& bytes) {
  std::istringstream in(bytes);
  auto tree = std::make_unique<octomap::OcTree>(0.1);
  if (!tree->readBinary(in)) return nullptr;
  return tree;
}

// Scan `i` of a lidar driven down the city block's street, 1.5 m apart, cut at 14 m.
Scan streetScan(const CityBlock& city, int i, unsigned seed) {
  Scan scan = simulateScan(city, lidar3d(16, 300), {1.5f * float(i), 0.2f * float(i % 2), 1.8f}, seed);
  scan.max_range = 14.0;
  return scan;
}

TEST(MapperExport, NewFreeSpaceIsExportedWithinTheDelayAndEveryOtherChangeAtOnce) {
  // free_discovery_delay_exports: a region of open air (no occupied voxel in it or beside it) where never-observed
  // voxels were only observed free keeps its last walk for up to that many exports. Every export still holds every
  // occupied voxel of the live tree and no free voxel the live tree does not have; once the delay has passed with no
  // new scan it is exactly OctoMap's stream again.
  constexpr int kDelay = 2;
  MapperConfig config;
  config.resolution = 0.2;
  config.free_discovery_delay_exports = kDelay;
  OccupancyMapper mapper(config);
  const CityBlock city = makeCityBlock(6);
  int exports_behind = 0;
  for (int i = 0; i < 8; ++i) {
    ASSERT_TRUE(mapper.insert(streetScan(city, i, 300 + i)).inserted);
    const ExportedMap map = mapper.exportMap();
    const std::string bytes(map.octree_binary.begin(), map.octree_binary.end());
    const auto exported = readBack(bytes);
    ASSERT_NE(exported, nullptr) << "scan " << i;
    octomap::OcTree live(mapper.octree());  // its maximum likelihood, pruned: what exactExport writes
    std::ostringstream exact;
    live.writeBinary(exact);
    if (bytes != exact.str()) ++exports_behind;
    for (auto it = live.begin_leafs(), end = live.end_leafs(); it != end; ++it) {
      const octomap::OcTreeNode* in_export = exported->search(it.getCoordinate());
      if (live.isNodeOccupied(*it)) {
        ASSERT_NE(in_export, nullptr) << "scan " << i << ": an occupied voxel at " << it.getCoordinate() << " is missing";
        EXPECT_TRUE(exported->isNodeOccupied(in_export)) << "scan " << i << " at " << it.getCoordinate();
      }
    }
    for (auto it = exported->begin_leafs(), end = exported->end_leafs(); it != end; ++it) {
      if (exported->isNodeOccupied(*it)) continue;
      const octomap::OcTreeNode* in_live = live.search(it.getCoordinate());
      ASSERT_NE(in_live, nullptr) << "scan " << i << ": free in the export, never observed at " << it.getCoordinate();
      EXPECT_FALSE(live.isNodeOccupied(in_live)) << "scan " << i << ": free in the export, occupied at " << it.getCoordinate();
    }
  }
  EXPECT_GT(exports_behind, 0);  // the delay was used: a moving lidar finds free space in regions it had mapped
  // No new scan: within the delay the put-off regions are walked again, and the export is exact.
  EXPECT_TRUE(mapper.changedSinceExport());  // regions are put off
  for (int k = 0; k < kDelay && mapper.changedSinceExport(); ++k) mapper.exportMap();
  EXPECT_FALSE(mapper.changedSinceExport());
  const ExportedMap settled = mapper.exportMap();
  EXPECT_EQ(std::string(settled.octree_binary.begin(), settled.octree_binary.end()), exactExport(mapper));

  // exportMap(complete) is exact at once.
  ASSERT_TRUE(mapper.insert(streetScan(city, 9, 400)).inserted);
  const ExportedMap complete = mapper.exportMap(/*complete=*/true);
  EXPECT_EQ(std::string(complete.octree_binary.begin(), complete.octree_binary.end()), exactExport(mapper));
  EXPECT_FALSE(mapper.changedSinceExport());

  MapperConfig bad = config;
  bad.free_discovery_delay_exports = -1;
  EXPECT_NE(validateConfig(bad).find("free_discovery_delay_exports"), std::string::npos);
}

TEST(MapperExport, FreeSpaceFoundNearTheSensorIsExportedAtOnce) {
  // free_discovery_near_range_m: free space found within it of the scan's origin is never put off. With the range
  // past every ray (14 m), every export is exact despite the delay; with a third of it, some regions are put off.
  const CityBlock city = makeCityBlock(6);
  for (const double near : {100.0, 14.0 / 3.0}) {
    MapperConfig config;
    config.resolution = 0.2;
    config.free_discovery_delay_exports = 3;
    config.free_discovery_near_range_m = near;
    OccupancyMapper mapper(config);
    int exports_behind = 0;
    for (int i = 0; i < 6; ++i) {
      ASSERT_TRUE(mapper.insert(streetScan(city, i, 500 + i)).inserted);
      const ExportedMap map = mapper.exportMap();
      if (std::string(map.octree_binary.begin(), map.octree_binary.end()) != exactExport(mapper)) ++exports_behind;
    }
    if (near > 14.0) EXPECT_EQ(exports_behind, 0);
    else EXPECT_GT(exports_behind, 0);
  }
}

// A 2-D scan down a corridor that opens onto nothing within range: the beams along it return nothing. With
// clear_beam_gaps the space they crossed is free (to max_range, no occupied end); without, it stays unknown. A gap
// wider than max_clear_gap_rad (a blind sector behind the scanner) stays unknown either way.
// A 2-D mapper at 0.1 m, configured further by `configure`, after inserting `scan` (`result`: that insertion's).
std::unique_ptr<OccupancyMapper> mapped2d(const Scan& scan, const std::function<void(MapperConfig&)>& configure, InsertResult& result) {
  MapperConfig config;
  config.dimensions = 2;
  config.resolution = 0.1;
  configure(config);
  auto mapper = std::make_unique<OccupancyMapper>(config);
  result = mapper->insert(scan);
  return mapper;
}

TEST(Mapper, BeamsThatReturnNothingClearTheGapsBetweenReturns) {
  Scan scan;
  scan.origin = {0.0f, 0.0f, 0.0f};
  scan.max_range = 30.0;
  // A 270-degree scanner, 0.5 degrees a beam, walls y = +-1.2 for x in [3, 20] and a wall x = -6 behind; beams
  // within 3.4 degrees of +x pass the corridor's end and return nothing, and so do those toward the blind sector.
  for (int i = -270; i <= 270; ++i) {
    const double a = i * 0.5 * M_PI / 180.0;
    const double c = std::cos(a), sn = std::sin(a);
    double t = std::numeric_limits<double>::infinity();
    if (std::abs(sn) > 1e-9) {
      const double tw = 1.2 / std::abs(sn);
      if (c * tw >= 3.0 && c * tw <= 20.0) t = tw;
    }
    if (c < -1e-9) t = std::min(t, 6.0 / -c);
    if (t <= scan.max_range) scan.points.push_back({static_cast<float>(t * c), static_cast<float>(t * sn), 0.0f});
  }
  InsertResult plain_result, result;
  const auto plain_mapper = mapped2d(scan, [](MapperConfig&) {}, plain_result);
  const auto clearing_mapper = mapped2d(scan, [](MapperConfig& c) { c.clear_beam_gaps = true; }, result);
  const OccupancyMapper &plain = *plain_mapper, &clearing = *clearing_mapper;
  ASSERT_TRUE(plain_result.inserted);
  ASSERT_TRUE(result.inserted);
  MapperConfig config;
  config.dimensions = 2;
  config.resolution = 0.1;
  config.clear_beam_gaps = true;
  EXPECT_GE(result.gap_rays, 10u);  // the corridor's 6.8-degree gap, 0.5 degrees a ray
  EXPECT_LE(result.gap_rays, 16u);  // the blind sector is not filled
  const auto state = [](const octomap::OcTree& tree, double x, double y) {
    const octomap::OcTreeNode* n = tree.search(x, y, 0.0);
    return n == nullptr ? '?' : tree.isNodeOccupied(n) ? '#' : '.';
  };
  for (const double x : {10.0, 19.0, 25.0, 29.0}) {
    EXPECT_EQ(state(plain.octree(), x, 0.05), '?') << x;
    EXPECT_EQ(state(clearing.octree(), x, 0.05), '.') << x;
  }
  EXPECT_EQ(state(clearing.octree(), 31.0, 0.05), '?');       // beyond max_range
  EXPECT_EQ(state(clearing.octree(), -1.0, -3.0), state(plain.octree(), -1.0, -3.0));  // the blind sector
  for (const Point3f& p : scan.points) EXPECT_EQ(state(clearing.octree(), p.x, p.y), '#') << p.x << " " << p.y;  // hits stay hits
  // Returns the sensor could not measure (one, or two in a row, dropped as non-finite) are no gap to clear: a ray
  // there would cross the wall their neighbours hit.
  Scan holed = scan;
  holed.points.erase(holed.points.begin() + 200, holed.points.begin() + 202);
  holed.points.erase(holed.points.begin() + 100);
  OccupancyMapper holed_mapper(config);
  EXPECT_EQ(holed_mapper.insert(holed).gap_rays, result.gap_rays);
  // A bad gap limit is refused.
  config.max_clear_gap_rad = 0.0;
  EXPECT_THROW(OccupancyMapper{config}, std::invalid_argument);
}

// A planar scan from `origin`, a beam every 0.5 degrees, of the segments {x0, y0, x1, y1}; beams that hit none within
// max_range return nothing.
Scan planarScan(const std::vector<std::array<double, 4>>& segments, double ox, double oy, double max_range = 30.0) {
  Scan scan;
  scan.origin = {static_cast<float>(ox), static_cast<float>(oy), 0.0f};
  scan.max_range = max_range;
  for (int i = 0; i < 720; ++i) {
    const double a = i * 0.5 * M_PI / 180.0, c = std::cos(a), sn = std::sin(a);
    double t = std::numeric_limits<double>::infinity();
    for (const auto& [x0, y0, x1, y1] : segments) {
      const double vx = x1 - x0, vy = y1 - y0, across = c * vy - sn * vx;
      if (std::abs(across) < 1e-12) continue;
      const double wx = x0 - ox, wy = y0 - oy;
      const double along = (wx * vy - wy * vx) / across, u = (wx * sn - wy * c) / across;
      if (along > 0.0 && u >= 0.0 && u <= 1.0) t = std::min(t, along);
    }
    if (t <= max_range) scan.points.push_back({static_cast<float>(ox + t * c), static_cast<float>(oy + t * sn), 0.0f});
  }
  return scan;
}

// A return the sensor could not measure is no gap to fill with rays beside it. Down a corridor (faces y = +-0.8 for x in
// [3, 40], open beyond), the beam at 1.5 degrees grazes the upper face at x = 30.55 and its last hit; the beams below
// it pass the corridor's end. With that return dropped (NaN) the gap's first ray runs where it did and on beyond its
// hit, through the inside of the wall: the cells behind the face stay unobserved, as without gap rays.
TEST(Mapper, NoGapRayBesideAReturnTheSensorCouldNotMeasure) {
  const std::vector<std::array<double, 4>> corridor = {{3.0, 0.8, 40.0, 0.8}, {3.0, -0.8, 40.0, -0.8}};
  Scan scan = planarScan(corridor, 0.0, 0.0, 66.0);
  // The beams from 0 degrees up; 0, 0.5 and 1 degree return nothing, so the first return is the 1.5-degree one.
  ASSERT_NEAR(scan.points.front().x, 0.8 / std::tan(1.5 * M_PI / 180.0), 1e-3);
  scan.points.front() = {std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f};
  MapperConfig config;
  config.dimensions = 2;
  config.resolution = 0.1;
  config.clear_beam_gaps = true;
  OccupancyMapper mapper(config);
  const InsertResult result = mapper.insert(scan);
  ASSERT_TRUE(result.inserted);
  EXPECT_EQ(result.dropped_non_finite, 1u);
  for (const auto& [x, y] : {std::pair{31.5, 0.85}, std::pair{33.0, 0.85}, std::pair{36.0, 0.95}})
    EXPECT_EQ(mapper.octree().search(x, y, 0.0), nullptr) << x << " " << y;  // behind the face: never observed
  // The same scan with the return measured: its gap (-1.5 .. 1.5 degrees) is cleared down the corridor's middle.
  OccupancyMapper measured(config);
  const InsertResult whole = measured.insert(planarScan(corridor, 0.0, 0.0, 66.0));
  EXPECT_GE(whole.gap_rays, 5u);
  const octomap::OcTreeNode* beyond = measured.octree().search(50.0, 0.05, 0.0);
  ASSERT_NE(beyond, nullptr);
  EXPECT_FALSE(measured.octree().isNodeOccupied(beyond));
}

// A 3-D lidar (16 rings 2 degrees apart, 512 columns) facing a wall x = 10 with a 3 x 3 m window in it: the beams
// through the window return nothing (open space beyond). With clear_beam_gaps each ring's gap is cleared like a
// planar scan's, so the window is observed free along the rings that cross it; without, it stays unknown. A cloud
// that is not made of rings (random elevations) gets no gap rays.
TEST(Mapper, ThreeDimensionalBeamsThatReturnNothingClearEachRingsGaps) {
  Scan scan;
  scan.origin = {0.0f, 0.0f, 0.0f};
  scan.max_range = 30.0;
  constexpr double kDeg = M_PI / 180.0;
  std::vector<double> ring_elevations;
  for (int r = 0; r < 16; ++r) {
    const double e = (-15.0 + 2.0 * r) * kDeg;
    ring_elevations.push_back(e);
    for (int c = 0; c < 512; ++c) {
      const double a = c * 2.0 * M_PI / 512.0;
      const double dx = std::cos(e) * std::cos(a), dy = std::cos(e) * std::sin(a), dz = std::sin(e);
      if (dx <= 1e-9) continue;
      const double t = 10.0 / dx, y = t * dy, z = t * dz;
      const bool in_wall = std::abs(y) <= 20.0 && std::abs(z) <= 10.0;
      const bool in_window = std::abs(y) < 1.5 && std::abs(z) < 1.5;
      if (in_wall && !in_window && t <= scan.max_range) scan.points.push_back({10.0f, static_cast<float>(y), static_cast<float>(z)});
    }
  }
  MapperConfig config;
  config.dimensions = 3;
  config.resolution = 0.1;
  OccupancyMapper plain(config);
  ASSERT_TRUE(plain.insert(scan).inserted);
  config.clear_beam_gaps = true;
  OccupancyMapper clearing(config);
  const InsertResult result = clearing.insert(scan);
  ASSERT_TRUE(result.inserted);
  // Eight rings cross the window (elevations -7 .. 7 degrees), each over about 17 degrees: 24 rays a ring.
  EXPECT_GE(result.gap_rays, 8u * 20u);
  EXPECT_LE(result.gap_rays, 8u * 26u);
  const auto state = [](const octomap::OcTree& tree, double x, double y, double z) {
    const octomap::OcTreeNode* n = tree.search(x, y, z);
    return n == nullptr ? '?' : tree.isNodeOccupied(n) ? '#' : '.';
  };
  for (const double e : ring_elevations) {
    const double z = 10.05 * std::tan(e);
    if (std::abs(z) >= 1.4) continue;
    for (const double x : {10.05, 15.0}) {  // in the window, and beyond it
      EXPECT_EQ(state(plain.octree(), x, 0.02, x * std::tan(e)), '?') << x << " " << e;
      EXPECT_EQ(state(clearing.octree(), x, 0.02, x * std::tan(e)), '.') << x << " " << e;
    }
  }
  for (const Point3f& p : scan.points) ASSERT_EQ(state(clearing.octree(), p.x, p.y, p.z), '#') << p.y << " " << p.z;  // the wall stays
  EXPECT_EQ(state(clearing.octree(), -5.0, 0.0, 0.0), '?');   // behind the lidar: a blind half, not a gap
  // The same returns at random elevations: no rings, no gaps to speak of.
  Scan scattered = scan;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  for (Point3f& p : scattered.points) p.z += jitter(rng);
  OccupancyMapper scattered_mapper(config);
  EXPECT_EQ(scattered_mapper.insert(scattered).gap_rays, 0u);
}


// The fill yields to space observed free with confidence. A wall along y = 1.2 with a 0.6 m opening (x 16 .. 16.6)
// that the grazing scan from the origin has no beam through, a wall y = 3 behind it: seen three times from below
// the opening first, the opening stays free under the grazing scans; seen once, or not at all, it is filled as the
// face around it is (an opening no beam has looked through is taken for the wall). Both insertion methods agree.
TEST(Mapper, AFaceFillYieldsToAnOpeningBeamsHaveLookedThrough) {
  const std::vector<std::array<double, 4>> world = {{3.0, 1.2, 16.0, 1.2}, {16.6, 1.2, 20.0, 1.2}, {12.0, 3.0, 20.0, 3.0}};
  const Scan grazing = planarScan(world, 0.0, 0.0), through = planarScan(world, 16.3, -0.5);
  std::vector<std::string> trees;  // per method
  for (const InsertMethod method : {InsertMethod::kFast, InsertMethod::kOctoMap}) {
    MapperConfig config;
    config.dimensions = 2;
    config.resolution = 0.1;
    config.fill_surfaces_between_returns = true;
    config.method = method;
    OccupancyMapper looked(config), glimpsed(config), grazed_only(config);
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(looked.insert(through).inserted);
    ASSERT_TRUE(glimpsed.insert(through).inserted);
    for (int k = 0; k < 2; ++k) {
      ASSERT_GT(looked.insert(grazing).surface_fill, 0u);
      ASSERT_GT(glimpsed.insert(grazing).surface_fill, 0u);
      ASSERT_GT(grazed_only.insert(grazing).surface_fill, 0u);
    }
    const auto occupied = [](const OccupancyMapper& m, double x, double y) {
      const octomap::OcTreeNode* n = m.octree().search(x, y, 0.0);
      return n != nullptr && m.octree().isNodeOccupied(n);
    };
    for (const double x : {16.15, 16.25, 16.35, 16.45}) {
      EXPECT_TRUE(occupied(grazed_only, x, 1.25)) << x;  // no beam looked through it: filled, as the wall is
      EXPECT_TRUE(occupied(glimpsed, x, 1.25)) << x;     // one scan's look is not enough
      EXPECT_FALSE(occupied(looked, x, 1.25)) << x;      // three scans' is
    }
    int face = 0, cells = 0;
    for (double x = 11.05; x < 15.5; x += 0.1, ++cells) face += occupied(looked, x, 1.25);  // hits 0.4-0.8 m apart
    EXPECT_EQ(face, cells);
    trees.push_back(fullBytes(looked.octree()));
    trees.push_back(fullBytes(glimpsed.octree()));
  }
  EXPECT_EQ(trees[0], trees[2]);
  EXPECT_EQ(trees[1], trees[3]);
}

// A 2-D scan of a wall along y = 1.2 (x 3 .. 20) seen at a grazing angle, its hits up to 2 m apart, and below the
// x axis a block's face along y = -1.25 (x 2 .. 8.75) with a wall x = 9.25 beyond it: one beam goes through the 0.5 m
// opening between them and hits that wall 5 cm below the face's line. With fill_surfaces_between_returns every cell
// of the wall's face between its hits is occupied; the opening is not closed.
TEST(Mapper, FaceSeenAtAGrazingAngleIsFilledBetweenItsHitsButNotAcrossAnOpening) {
  const Scan scan = planarScan({{3.0, 1.2, 20.0, 1.2}, {2.0, -1.25, 8.75, -1.25}, {9.25, -20.0, 9.25, -1.25}}, 0.0, 0.0);
  InsertResult plain_result, result;
  const auto plain_mapper = mapped2d(scan, [](MapperConfig&) {}, plain_result);
  const auto filling_mapper = mapped2d(scan, [](MapperConfig& c) { c.fill_surfaces_between_returns = true; }, result);
  const OccupancyMapper &plain = *plain_mapper, &filling = *filling_mapper;
  ASSERT_TRUE(plain_result.inserted);
  ASSERT_TRUE(result.inserted);
  EXPECT_GT(result.surface_fill, 0u);
  EXPECT_LE(result.surface_fill, 8 * scan.points.size());
  const auto occupied = [](const octomap::OcTree& tree, double x, double y) {
    const octomap::OcTreeNode* n = tree.search(x, y, 0.0);
    return n != nullptr && tree.isNodeOccupied(n);
  };
  int plain_cells = 0;
  for (double x = 3.25; x < 19.5; x += 0.1) {
    EXPECT_TRUE(occupied(filling.octree(), x, 1.25)) << x;
    plain_cells += occupied(plain.octree(), x, 1.25);
  }
  EXPECT_LT(plain_cells, 80);  // of 163: the hits alone, farther apart than a cell beyond x = 11
  for (const double x : {8.85, 8.95, 9.05, 9.15}) {
    EXPECT_FALSE(occupied(filling.octree(), x, -1.25)) << x;
    EXPECT_FALSE(occupied(filling.octree(), x, -1.29)) << x;
  }
  for (const Point3f& p : scan.points) EXPECT_TRUE(occupied(filling.octree(), p.x, p.y)) << p.x << " " << p.y;
  // A bad length is refused.
  InsertResult unused;
  EXPECT_THROW(mapped2d(scan, [](MapperConfig& c) { c.fill_surfaces_between_returns = true, c.max_surface_fill_m = -1.0; }, unused),
               std::invalid_argument);
}

// A corridor's upper wall y = 0.4 (x 3 .. 20) ends at a convex corner; the corridor turns up past it, and a wall
// x = 22.92 closes its far end. The 1-degree beam passes the corner and hits that far wall exactly on the upper
// wall's line (y = 0.4), so the wall's last hits (2 and 1.5 degrees) and that return are collinear. The fill must
// not run on across the turn (x 20 .. 22.9): the return's own neighbours are on the far wall, not on the line.
TEST(Mapper, FaceFillStopsAtAConvexEndWhoseBeamHitsASurfaceBehindOnItsLine) {
  const double far_x = 0.4 / std::tan(1.0 * M_PI / 180.0);  // 22.92: where the 1-degree beam meets y = 0.4
  const Scan scan = planarScan({{3.0, 0.4, 20.0, 0.4}, {far_x, -5.0, far_x, 5.0}}, 0.0, 0.0, 66.0);
  InsertResult result;
  const auto mapper = mapped2d(scan, [](MapperConfig& c) { c.fill_surfaces_between_returns = true; }, result);
  ASSERT_TRUE(result.inserted);
  EXPECT_GT(result.surface_fill, 0u);
  const auto occupied = [&](double x, double y) {
    const octomap::OcTreeNode* n = mapper->octree().search(x, y, 0.0);
    return n != nullptr && mapper->octree().isNodeOccupied(n);
  };
  for (double x = 20.55; x < far_x - 0.3; x += 0.1) EXPECT_FALSE(occupied(x, 0.45)) << x;  // the turn stays open
  for (double x = 7.65; x < 15.2; x += 0.1) EXPECT_TRUE(occupied(x, 0.45)) << x;   // the face between its hits
}

}  // namespace
}  // namespace ddsnav::mapper
