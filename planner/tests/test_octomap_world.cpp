// The OctoMap collision world against OcTree::search and a brute-force scan of every occupied voxel.
#include "ddsnav/planner/collision_world.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>

namespace ddsnav::planner {
namespace {

std::vector<std::uint8_t> toBytes(const octomap::OcTree& tree) {
  std::ostringstream s;
  tree.writeBinaryConst(s);
  const std::string str = s.str();
  return {str.begin(), str.end()};
}

// A map with single voxels, a pruned 8x8x8 occupied block, free space from a few scans and unknown space.
octomap::OcTree makeMap(double resolution, bool flat) {
  octomap::OcTree tree(resolution);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-4.0f, 4.0f), uz(0.0f, 3.0f);
  const float z0 = 0.55f;
  octomap::Pointcloud cloud;
  for (int i = 0; i < 3000; ++i) cloud.push_back(u(rng), u(rng), flat ? z0 : uz(rng));
  tree.insertPointCloud(cloud, octomap::point3d(0.05f, 0.05f, flat ? z0 : 1.5f), 6.0);
  if (!flat) {
    // A solid block aligned to 8 voxels: the tree prunes it into one coarse leaf.
    const double r = resolution;
    for (int x = 0; x < 8; ++x)
      for (int y = 0; y < 8; ++y)
        for (int z = 0; z < 8; ++z)
          tree.setNodeValue((16 + x + 0.5) * r, (8 + y + 0.5) * r, (z + 0.5) * r, tree.getClampingThresMaxLog());
    tree.prune();
  }
  return tree;
}

struct OccupiedCell {
  Vec3 lo, hi;
};

std::vector<OccupiedCell> occupiedCells(const octomap::OcTree& tree, bool flat) {
  std::vector<OccupiedCell> cells;
  const double r = tree.getResolution();
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const int n = 1 << (tree.getTreeDepth() - it.getDepth());
    const octomap::OcTreeKey k = it.getIndexKey();
    for (int x = 0; x < n; ++x)
      for (int y = 0; y < n; ++y)
        for (int z = 0; z < (flat ? 1 : n); ++z) {
          Vec3 lo((int(k[0]) - 32768 + x) * r, (int(k[1]) - 32768 + y) * r, (int(k[2]) - 32768 + z) * r);
          cells.push_back({lo, lo + Vec3::Constant(r)});
        }
  }
  return cells;
}

double distanceToCell(const Vec3& p, const OccupiedCell& c, bool flat) {
  double sum = 0.0;
  for (int i = 0; i < (flat ? 2 : 3); ++i) {
    const double gap = std::max({c.lo[i] - p[i], 0.0, p[i] - c.hi[i]});
    sum += gap * gap;
  }
  return std::sqrt(sum);
}

bool occupiedAt(const octomap::OcTree& tree, const Vec3& p) {
  const octomap::OcTreeNode* n = tree.search(p.x(), p.y(), p.z());
  return n != nullptr && tree.isNodeOccupied(n);
}

TEST(OctoMapWorld, PointQueriesEqualOcTreeSearch) {
  const octomap::OcTree tree = makeMap(0.1, false);
  const auto world = makeOctoMapWorld(3, Vec3(-100, -100, -100), Vec3(100, 100, 100), 0.0, toBytes(tree));
  octomap::OcTree read(0.1);
  std::istringstream in(std::string(reinterpret_cast<const char*>(toBytes(tree).data()), toBytes(tree).size()));
  ASSERT_TRUE(read.readBinary(in));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5.0, 5.0), uz(-0.5, 3.5);
  int mismatches = 0, occupied = 0;
  for (int i = 0; i < 100000; ++i) {
    const Vec3 p(u(rng), u(rng), uz(rng));
    const bool occ = occupiedAt(read, p);
    occupied += occ;
    if (world->isFree(p) == occ) ++mismatches;
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(occupied, 500);  // the test would be empty otherwise
  EXPECT_EQ(world->validityChecks(), 100000u);
}

TEST(OctoMapWorld, RobotRadiusMatchesBruteForce) {
  const octomap::OcTree tree = makeMap(0.1, false);
  const std::vector<OccupiedCell> cells = occupiedCells(tree, false);
  const double radius = 0.35;
  const auto world = makeOctoMapWorld(3, Vec3(-50, -50, -50), Vec3(50, 50, 50), radius, toBytes(tree));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-5.0, 5.0), uz(-0.5, 3.5);
  int mismatches = 0, blocked = 0, clearance_mismatches = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(u(rng), u(rng), uz(rng));
    double nearest = std::numeric_limits<double>::infinity();
    for (const OccupiedCell& c : cells) nearest = std::min(nearest, distanceToCell(p, c, false));
    const bool collides = occupiedAt(tree, p) || nearest <= radius;
    blocked += collides;
    if (world->isFree(p) == collides) ++mismatches;
    if (std::abs(world->clearance(p) - (nearest - radius)) > 1e-12) ++clearance_mismatches;
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(clearance_mismatches, 0);
  EXPECT_GT(blocked, 300);
  EXPECT_LT(blocked, 2900);
}

TEST(OctoMapWorld, ObstaclesNearAreTheOccupiedVoxelsInRangeNearestFirst) {
  const octomap::OcTree tree = makeMap(0.1, false);
  const std::vector<OccupiedCell> cells = occupiedCells(tree, false);
  const auto world = makeOctoMapWorld(3, Vec3(-50, -50, -50), Vec3(50, 50, 50), 0.2, toBytes(tree));
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-4.0, 4.0), uz(0.0, 3.0);
  for (int i = 0; i < 50; ++i) {
    const Vec3 p(u(rng), u(rng), uz(rng));
    const double range = 0.8;
    std::vector<double> expected;
    for (const OccupiedCell& c : cells) {
      const double d = distanceToCell(p, c, false);
      if (d <= range) expected.push_back(d);
    }
    std::sort(expected.begin(), expected.end());
    const std::vector<NearbyObstacle> got = world->obstaclesNear(p, range);
    ASSERT_EQ(got.size(), expected.size());
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_NEAR(got[k].distance, expected[k], 1e-12);
      EXPECT_NEAR((got[k].nearest_point - p).norm(), got[k].distance, 1e-12);
      if (k > 0) {
        EXPECT_NE(got[k].id, got[k - 1].id);
      }
    }
  }
  EXPECT_TRUE(world->obstaclesNear(Vec3(1000, 1000, 1000), 1.0).empty());
}

TEST(OctoMapWorld, UnknownAsOccupiedBlocksUnobservedSpace) {
  const octomap::OcTree tree = makeMap(0.1, false);
  const auto bytes = toBytes(tree);
  const double radius = 0.15;
  const auto optimistic = makeOctoMapWorld(3, Vec3(-50, -50, -50), Vec3(50, 50, 50), radius, bytes);
  const auto cautious = makeOctoMapWorld(3, Vec3(-50, -50, -50), Vec3(50, 50, 50), radius, bytes, {true});
  // Far outside the observed region: free when unknown is free, blocked otherwise.
  EXPECT_TRUE(optimistic->isFree(Vec3(30, 30, 30)));
  EXPECT_FALSE(cautious->isFree(Vec3(30, 30, 30)));
  // Brute force: every voxel whose cube is within the radius must be known free.
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-1.5, 1.5), uz(1.0, 2.0);
  const double r = tree.getResolution();
  int mismatches = 0, free_count = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p(u(rng), u(rng), uz(rng));
    bool collides = false;
    const octomap::OcTreeNode* here = tree.search(p.x(), p.y(), p.z());
    collides = here == nullptr || tree.isNodeOccupied(here);
    for (int dx = -3; dx <= 3 && !collides; ++dx)
      for (int dy = -3; dy <= 3 && !collides; ++dy)
        for (int dz = -3; dz <= 3 && !collides; ++dz) {
          const Vec3 c((std::floor(p.x() / r) + dx + 0.5) * r, (std::floor(p.y() / r) + dy + 0.5) * r,
                       (std::floor(p.z() / r) + dz + 0.5) * r);
          const OccupiedCell cell{c - Vec3::Constant(r / 2), c + Vec3::Constant(r / 2)};
          if (distanceToCell(p, cell, false) > radius) continue;
          const octomap::OcTreeNode* n = tree.search(c.x(), c.y(), c.z());
          if (n == nullptr || tree.isNodeOccupied(n)) collides = true;
        }
    free_count += !collides;
    if (cautious->isFree(p) == collides) ++mismatches;
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(free_count, 100);
}

TEST(OctoMapWorld, TwoDimensionalSlab) {
  const octomap::OcTree tree = makeMap(0.05, true);
  const std::vector<OccupiedCell> cells = occupiedCells(tree, true);
  const double radius = 0.2;
  const auto world = makeOctoMapWorld(2, Vec3(-10, -10, 0), Vec3(10, 10, 0), radius, toBytes(tree));
  EXPECT_EQ(world->dimensions(), 2);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-4.5, 4.5);
  int mismatches = 0, blocked = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(u(rng), u(rng), 0.0);  // z is ignored in 2-D: the slab's column is what counts
    double nearest = std::numeric_limits<double>::infinity();
    for (const OccupiedCell& c : cells) nearest = std::min(nearest, distanceToCell(p, c, true));
    const bool collides = occupiedAt(tree, Vec3(p.x(), p.y(), 0.55)) || nearest <= radius;
    blocked += collides;
    if (world->isFree(p) == collides) ++mismatches;
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(blocked, 100);
  // Bounds: the disc must fit inside.
  EXPECT_FALSE(world->isFree(Vec3(9.9, 0, 0)));
  EXPECT_FALSE(world->isFree(Vec3(std::nan(""), 0, 0)));
}

TEST(OctoMapWorld, SegmentsUseTheSameCheck) {
  octomap::OcTree tree(0.1);
  // A wall at x = 1.0 .. 1.1, y in [-1, 1), z in [0, 1).
  for (int y = -10; y < 10; ++y)
    for (int z = 0; z < 10; ++z) tree.updateNode(octomap::point3d(1.05f, y * 0.1f + 0.05f, z * 0.1f + 0.05f), true);
  const auto world = makeOctoMapWorld(3, Vec3(-5, -5, -5), Vec3(5, 5, 5), 0.1, toBytes(tree));
  EXPECT_FALSE(world->isSegmentFree(Vec3(0, 0, 0.5), Vec3(2, 0, 0.5)));
  EXPECT_TRUE(world->isSegmentFree(Vec3(0, 0, 0.5), Vec3(0, 2, 0.5)));
  EXPECT_TRUE(world->isSegmentFree(Vec3(0, 0, 0.5), Vec3(2, 0, 1.3)) == false);
  EXPECT_TRUE(world->isSegmentFree(Vec3(0, 0, 1.3), Vec3(2, 0, 1.3)));
  EXPECT_NEAR(world->clearance(Vec3(0.5, 0, 0.5)), 0.5 - 0.1, 1e-9);
}

TEST(OctoMapWorld, EmptyMapIsFreeWithInfiniteClearance) {
  octomap::OcTree tree(0.1);
  const auto world = makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, toBytes(tree));
  EXPECT_TRUE(world->isFree(Vec3(0, 0, 0)));
  EXPECT_EQ(world->clearance(Vec3(0, 0, 0)), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(world->obstaclesNear(Vec3(0, 0, 0), 5.0).empty());
}

TEST(OctoMapWorld, BadInputIsRejected) {
  const auto bytes = toBytes(makeMap(0.1, false));
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, {}), std::runtime_error);
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, {1, 2, 3, 4, 5}), std::runtime_error);
  std::vector<std::uint8_t> truncated(bytes.begin(), bytes.begin() + bytes.size() / 2);
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, truncated), std::runtime_error);
  // Another tree type, a node count that does not match the data.
  std::string text(bytes.begin(), bytes.end());
  std::string other = text;
  other.replace(other.find("id OcTree"), 9, "id ColorOcTree");
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, {other.begin(), other.end()}), std::runtime_error);
  std::string wrong_size = text;
  wrong_size.replace(wrong_size.find("size "), 5, "size 1");
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, {wrong_size.begin(), wrong_size.end()}),
               std::runtime_error);
  try {
    makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, {other.begin(), other.end()});
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("ColorOcTree"), std::string::npos) << e.what();
  }
  EXPECT_THROW(makeOctoMapWorld(4, Vec3(-1, -1, -1), Vec3(1, 1, 1), 0.1, bytes), std::invalid_argument);
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(1, -1, -1), Vec3(1, 1, 1), 0.1, bytes), std::invalid_argument);
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), -0.1, bytes), std::invalid_argument);
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-1, -1, -1), Vec3(1, 1, 1), std::nan(""), bytes), std::invalid_argument);
}

// Issue 13 row 3: 63 bytes holding one occupied leaf at depth 2 (2^14 voxels a side, 1.6 km at 0.1 m) that
// covers the bounds' octant. Root: child 7 (the +x+y+z octant, cells 0..32767) an inner node; it: child 0 an
// occupied leaf.
std::vector<std::uint8_t> hostileCoarseLeaf() {
  static const char kBytes[] = "# Octomap OcTree binary file\nid OcTree\nsize 3\nres 0.1\ndata\n\x00\xC0\x02\x00";
  return std::vector<std::uint8_t>(kBytes, kBytes + sizeof kBytes - 1);
}

TEST(OctoMapWorld, CoarseOccupiedLeafIsClippedToTheBounds) {
  const auto bytes = hostileCoarseLeaf();
  ASSERT_EQ(bytes.size(), 63u);
  // 2-D: the leaf's 16384^2 columns would be 2^22 bricks; clipped to the 40 m yard (+ margin), a few thousand.
  const auto flat = makeOctoMapWorld(2, Vec3(0, 0, 0), Vec3(40, 40, 0), 0.4, bytes);
  EXPECT_FALSE(flat->isFree(Vec3(20, 20, 0)));
  EXPECT_DOUBLE_EQ(flat->clearance(Vec3(20, 20, 0)), -0.4);
  // 3-D: 2^36 bricks unclipped; [0, 40]^3 widened by 5.4 m is 57^3 bricks.
  const auto solid = makeOctoMapWorld(3, Vec3(0, 0, 0), Vec3(40, 40, 40), 0.4, bytes);
  EXPECT_FALSE(solid->isFree(Vec3(20, 20, 20)));
  EXPECT_FALSE(solid->isFree(Vec3(39.5, 39.5, 39.5)));
  // Outside the leaf (x < 0) the world is free up to the leaf's face, and clearance measures to it exactly.
  EXPECT_NEAR(solid->clearance(Vec3(-2.0, 20, 20)), 2.0 - 0.4, 1e-9);
  const auto near = solid->obstaclesNear(Vec3(-0.05, 20.05, 20.05), 0.06);
  ASSERT_EQ(near.size(), 1u);
  EXPECT_NEAR(near[0].distance, 0.05, 1e-9);
}

TEST(OctoMapWorld, MapNeedingTooManyBricksIsRefusedNamingTheLimit) {
  const auto bytes = hostileCoarseLeaf();
  // [0, 200]^3 at 0.1 m: 257^3 = 17 M bricks, past the default cap (2^19); refused, not allocated.
  try {
    makeOctoMapWorld(3, Vec3(0, 0, 0), Vec3(200, 200, 200), 0.4, bytes);
    ADD_FAILURE() << "a map needing 17 M bricks was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("more than 524288 bricks"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("OctoMapWorldOptions::max_bricks"), std::string::npos) << e.what();
  }
  OctoMapWorldOptions small;
  small.max_bricks = 100;
  EXPECT_THROW(makeOctoMapWorld(2, Vec3(0, 0, 0), Vec3(40, 40, 0), 0.4, bytes, small), std::runtime_error);
  // Many small leaves in few bricks: the cap counts bricks, not leaves.
  small.max_bricks = 5000;
  EXPECT_NO_THROW(makeOctoMapWorld(3, Vec3(-5, -5, -5), Vec3(5, 5, 5), 0.1, toBytes(makeMap(0.1, false)), small));
  small.max_bricks = 0;
  EXPECT_THROW(makeOctoMapWorld(2, Vec3(0, 0, 0), Vec3(40, 40, 0), 0.4, bytes, small), std::invalid_argument);
}

// Clipping the map to the bounds + margin changes no answer inside the bounds up to the margin.
TEST(OctoMapWorld, ClippingKeepsAnswersInsideTheBounds) {
  const auto bytes = toBytes(makeMap(0.1, false));  // voxels within +-4 m
  const double radius = 0.2;
  OctoMapWorldOptions tight;
  tight.outside_bounds_margin_m = 0.5;
  const auto clipped = makeOctoMapWorld(3, Vec3(-1.5, -1.5, 0), Vec3(1.5, 1.5, 3), radius, bytes, tight);
  const auto whole = makeOctoMapWorld(3, Vec3(-50, -50, -50), Vec3(50, 50, 50), radius, bytes);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.25, 1.25), uz(0.3, 2.7);
  int compared = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(u(rng), u(rng), uz(rng));
    EXPECT_EQ(clipped->isFree(p), whole->isFree(p)) << p.transpose();
    const double c = whole->clearance(p);
    if (c + radius <= 0.5) {
      EXPECT_DOUBLE_EQ(clipped->clearance(p), c) << p.transpose();
      ++compared;
    }
  }
  EXPECT_GT(compared, 1000);
}

}  // namespace
}  // namespace ddsnav::planner

namespace ddsnav::planner {
namespace {

// A roof of occupied voxels at z in [2.0, 2.1) over x, y in [0, 1]; nothing else observed.
octomap::OcTree makeRoof() {
  octomap::OcTree tree(0.1);
  for (double x = 0.05; x < 1.0; x += 0.1)
    for (double y = 0.05; y < 1.0; y += 0.1) tree.updateNode(octomap::point3d(float(x), float(y), 2.05f), true);
  return tree;
}

TEST(OctoMapWorld, SolidBelowSurfaceBlocksWhatLiesUnderTheHighestOccupiedVoxelOfAColumn) {
  const auto bytes = toBytes(makeRoof());
  OctoMapWorldOptions below;
  below.solid_below_surface = true;
  const auto plain = makeOctoMapWorld(3, Vec3(-5, -5, -5), Vec3(5, 5, 5), 0.0, bytes);
  const auto solid = makeOctoMapWorld(3, Vec3(-5, -5, -5), Vec3(5, 5, 5), 0.0, bytes, below);
  const Vec3 under(0.55, 0.45, 1.0), above(0.55, 0.45, 3.0), beside(2.5, 2.5, 1.0);
  // Without the rule the unobserved space under the roof is free (optimistic); with it, solid.
  EXPECT_TRUE(plain->isFree(under));
  EXPECT_FALSE(solid->isFree(under));
  EXPECT_NEAR(solid->clearance(under), -(2.1 - 1.0), 1e-9);  // the depth below the roof's top face
  EXPECT_TRUE(solid->isFree(above));
  EXPECT_NEAR(solid->clearance(above), 3.0 - 2.1, 1e-9);
  EXPECT_TRUE(solid->isFree(beside));  // a column with nothing observed in it
  EXPECT_FALSE(solid->isSegmentFree(Vec3(2.5, 0.5, 1.0), Vec3(-1.5, 0.5, 1.0)));  // under the roof on the way
  EXPECT_TRUE(plain->isSegmentFree(Vec3(2.5, 0.5, 1.0), Vec3(-1.5, 0.5, 1.0)));
  // The robot radius still counts from the roof's voxels above it.
  OctoMapWorldOptions below_radius = below;
  const auto solid_radius = makeOctoMapWorld(3, Vec3(-5, -5, -5), Vec3(5, 5, 5), 0.3, bytes, below_radius);
  EXPECT_FALSE(solid_radius->isFree(Vec3(0.5, 0.5, 2.3)));
  EXPECT_TRUE(solid_radius->isFree(Vec3(0.5, 0.5, 2.5)));
}

// A 3-D world of `tree` in [-6, 6]^3, solid below the surface with a 0.75 m margin (8 columns of 0.1 m, rounded up).
std::unique_ptr<CollisionWorld> marginWorld(const octomap::OcTree& tree) {
  OctoMapWorldOptions options;
  options.solid_below_surface = true;
  options.surface_margin_m = 0.75;
  return makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), options);
}

TEST(OctoMapWorld, SurfaceMarginBlocksBelowTheHighestSurfaceWithinItAsABruteForceScanSays) {
  // Scattered surface voxels at random heights: with surface_margin_m a point is blocked by the depth rule
  // exactly when some occupied voxel whose column lies within the margin (a square window of whole columns)
  // has its top face above the point.
  octomap::OcTree tree(0.1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f), uz(0.0f, 4.0f);
  std::vector<octomap::point3d> hits;
  for (int i = 0; i < 60; ++i) {
    hits.emplace_back(u(rng), u(rng), uz(rng));
    tree.updateNode(hits.back(), true);
  }
  const auto world = marginWorld(tree);
  auto cell = [](double v) { return static_cast<long>(std::floor(v / 0.1)); };
  std::uniform_real_distribution<double> q(-4.5, 4.5), qz(-0.5, 4.5);
  int blocked = 0, checked = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 p(q(rng), q(rng), qz(rng));
    if (tree.search(p.x(), p.y(), p.z()) != nullptr) continue;  // the voxels themselves answer for themselves
    bool below = false;
    for (const auto& h : hits) {
      const double top = (std::floor(h.z() / 0.1) + 1) * 0.1;
      if (std::labs(cell(h.x()) - cell(p.x())) <= 8 && std::labs(cell(h.y()) - cell(p.y())) <= 8 && p.z() < top) below = true;
    }
    ++checked;
    blocked += below;
    ASSERT_EQ(world->isFree(p), !below) << p.transpose();
    if (below) {
      EXPECT_LT(world->clearance(p), 0.0);
    }
  }
  EXPECT_GT(blocked, 1000);  // both answers were exercised
  EXPECT_GT(checked - blocked, 1000);
  OctoMapWorldOptions bad;
  bad.solid_below_surface = true;
  bad.surface_margin_m = -1.0;
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), bad), std::invalid_argument);
  bad.surface_margin_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), bad), std::invalid_argument);
}

// Space observed free is not blocked by the column rule: a point under a top within the margin — a neighbour's, or
// its own column's (a window, the space under an overhang: rays crossed it; a hill's inside is never crossed) — is
// free when its voxel and the robot radius under it (a voxel at least) were observed free or lie between cells
// observed free in their column (the gap between a lidar's rings), and blocked otherwise. A hit with space observed
// free under it (within 1 m) is an underside, no top: its column's top is the next hit under it that is a top.
//
// `wider_cells` > 8: the world is built with a wider surface margin too (wider_surface_margin_m, that many columns),
// which loads the free cells under those wider tops; `through_wider_view`: it is asked through makeWiderMarginView,
// whose rule counts the wider margin's tops and knows those cells. Asked directly it answers as the world built
// without the wider margin (the tracker's), cell for cell.
void checkColumnRuleAgainstABruteForceScan(long wider_cells, bool through_wider_view) {
  octomap::OcTree tree(0.1);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f), uz(0.0f, 4.0f);
  std::vector<octomap::point3d> hits;
  for (int i = 0; i < 60; ++i) {
    hits.emplace_back(u(rng), u(rng), uz(rng));
    tree.updateNode(hits.back(), true);
  }
  // Marks the voxels of the box [lo, hi) free, `step` apart, except the occupied ones (the hits).
  const auto markFree = [&](const octomap::point3d& lo, const octomap::point3d& hi, float z_step) {
    for (float x = lo.x(); x < hi.x(); x += 0.1f)
      for (float y = lo.y(); y < hi.y(); y += 0.1f)
        for (float z = lo.z(); z < hi.z(); z += z_step) {
          const octomap::OcTreeNode* n = tree.search(x, y, z);
          if (n == nullptr || !tree.isNodeOccupied(n)) tree.updateNode(x, y, z, false);
        }
  };
  // Observed free space: random boxes of free voxels.
  for (int b = 0; b < 40; ++b) {
    const octomap::point3d lo(u(rng), u(rng), uz(rng));
    markFree(lo, lo + octomap::point3d(0.8f, 0.8f, 1.5f), 0.1f);
  }
  // Overhangs: observed free space under 15 of the hits. Windows seen by a lidar's rings: under 15 more, layers of
  // free voxels 4 cells apart (unknown between).
  for (int h = 0; h < 30; ++h)
    markFree(hits[h] + octomap::point3d(-0.3f, -0.3f, -1.2f), hits[h] + octomap::point3d(0.3f, 0.3f, -0.15f), h < 15 ? 0.1f : 0.4f);
  const long loaded_cells = through_wider_view ? wider_cells : 8, rule_cells = loaded_cells;
  OctoMapWorldOptions options;
  options.solid_below_surface = true;
  options.surface_margin_m = 0.75;  // 8 columns of 0.1 m, rounded up
  if (wider_cells > 8) options.wider_surface_margin_m = (static_cast<double>(wider_cells) - 0.5) * 0.1;
  const std::shared_ptr<const CollisionWorld> map = makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), options);
  const std::shared_ptr<const CollisionWorld> world = through_wider_view ? makeWiderMarginView(map) : map;
  ASSERT_NE(world, nullptr);
  OctoMapWorldOptions without = options;
  without.wider_surface_margin_m = 0.0;
  const auto plain = makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), without);
  auto cell = [](double v) { return static_cast<long>(std::floor(v / 0.1)); };
  constexpr long kNone = std::numeric_limits<long>::min();
  // The world knows the free cells under each column's widened top (its highest hit within the widest margin).
  const auto widened_top = [&](long x, long y) {
    long top = kNone;
    for (const auto& h : hits)
      if (std::labs(cell(h.x()) - x) <= loaded_cells && std::labs(cell(h.y()) - y) <= loaded_cells) top = std::max(top, cell(h.z()));
    return top;
  };
  const auto state = [&](long x, long y, long z) {  // 'o' occupied, 'f' free (as the world knows it), '?' never observed
    const octomap::OcTreeNode* n = tree.search((x + 0.5) * 0.1, (y + 0.5) * 0.1, (z + 0.5) * 0.1);
    if (n == nullptr) return '?';
    if (tree.isNodeOccupied(n)) return 'o';
    return z <= widened_top(x, y) ? 'f' : '?';
  };
  // The first known cell within 1 m from z, up (step 1) or down (-1), is free.
  const auto free_first = [&](long x, long y, long z, long step) {
    for (long k = 1; k <= 10; ++k) {
      const char st = state(x, y, z + step * k);
      if (st != '?') return st == 'f';
    }
    return false;
  };
  // A column's own top: its highest hit that is no underside.
  std::map<std::pair<long, long>, long> own_top;
  for (const auto& h : hits) {
    const std::pair<long, long> key{cell(h.x()), cell(h.y())};
    if (own_top.count(key) != 0) continue;
    std::vector<long> column;  // the column's hits, highest first
    for (const auto& g : hits)
      if (cell(g.x()) == key.first && cell(g.y()) == key.second) column.push_back(cell(g.z()));
    std::sort(column.rbegin(), column.rend());
    long top = kNone;
    for (const long z : column)
      if (!free_first(key.first, key.second, z, -1)) {
        top = z;
        break;
      }
    own_top[key] = top;
  }
  int undersides = 0;
  for (const auto& h : hits) undersides += own_top[{cell(h.x()), cell(h.y())}] < cell(h.z());
  std::uniform_real_distribution<double> q(-4.5, 4.5), qz(-0.5, 4.5);
  int between_rings = 0;
  int yielded = 0, blocked = 0;
  for (int i = 0; i < 40000; ++i) {
    const Vec3 p(q(rng), q(rng), qz(rng));
    const octomap::OcTreeNode* node = tree.search(p.x(), p.y(), p.z());
    if (node != nullptr && tree.isNodeOccupied(node)) continue;
    const long cx = cell(p.x()), cy = cell(p.y()), cz = cell(p.z());
    bool below = false;  // under an own top within the margin
    for (const auto& [key, top] : own_top)
      if (top != kNone && cz <= top && std::labs(key.first - cx) <= rule_cells && std::labs(key.second - cy) <= rule_cells) below = true;
    // Its voxel and the one under it (the robot radius, at least a voxel) observed free, or never observed with
    // cells observed free first within 1 m above and below it in its column.
    const auto free_or_between_rings = [&](long z) {
      const char st = state(cx, cy, z);
      return st == 'f' || (st == '?' && free_first(cx, cy, z, 1) && free_first(cx, cy, z, -1));
    };
    const bool observed_free = free_or_between_rings(cz) && free_or_between_rings(cz - 1);
    between_rings += below && observed_free && (state(cx, cy, cz) == '?' || state(cx, cy, cz - 1) == '?');
    const bool expect_blocked = below && !observed_free;
    yielded += below && !expect_blocked;
    blocked += expect_blocked;
    ASSERT_EQ(world->isFree(p), !expect_blocked) << p.transpose() << " below " << below << " free " << observed_free;
    if (!through_wider_view) {
      ASSERT_EQ(map->isFree(p), plain->isFree(p)) << p.transpose();
    }
  }
  EXPECT_GE(undersides, 20);  // most of the 30 hits with space observed free under them
  EXPECT_GT(yielded, 200);    // every case was exercised
  EXPECT_GT(between_rings, 50);
  EXPECT_GT(blocked, 1000);
}

TEST(OctoMapWorld, ColumnRuleYieldsToSpaceObservedFreeAsABruteForceScanSays) { checkColumnRuleAgainstABruteForceScan(8, false); }

// The wider margin's view (a 3-D planner's preferred world) follows the same rule with its wider tops, and the map
// built with it follows it with its own margin, knowing the free cells under the wider tops too.
TEST(OctoMapWorld, TheWiderMarginsViewFollowsTheColumnRuleWithItsWiderTops) {
  checkColumnRuleAgainstABruteForceScan(18, true);
  checkColumnRuleAgainstABruteForceScan(18, false);
}

// No view of a world without a wider margin, nor of another kind of world; a view is no copy: it outlives its handle.
TEST(OctoMapWorld, AWiderMarginViewNeedsAWorldBuiltWithTheWiderMargin) {
  octomap::OcTree tree(0.1);
  tree.updateNode(octomap::point3d(0.05f, 0.05f, 2.05f), true);  // one hit 2 m up
  OctoMapWorldOptions options;
  options.solid_below_surface = true;
  options.surface_margin_m = 0.5;
  EXPECT_EQ(makeWiderMarginView(makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), options)), nullptr);
  options.wider_surface_margin_m = 0.3;  // not wider: none
  EXPECT_EQ(makeWiderMarginView(makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), options)), nullptr);
  options.wider_surface_margin_m = 2.0;
  EXPECT_EQ(makeWiderMarginView(makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.0, toBytes(tree), options)), nullptr);
  EXPECT_EQ(makeWiderMarginView(nullptr), nullptr);
  std::shared_ptr<const CollisionWorld> map = makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), options);
  const auto view = makeWiderMarginView(map);
  ASSERT_NE(view, nullptr);
  map.reset();
  // 1.5 m beside the hit, below its top: blocked in the view (2 m), free on the map (0.5 m); above it free in both.
  EXPECT_FALSE(view->isFree(Vec3(1.55, 0.05, 1.0)));
  EXPECT_LT(view->clearance(Vec3(1.55, 0.05, 1.0)), -1.0);
  EXPECT_TRUE(view->isFree(Vec3(1.55, 0.05, 2.5)));
  EXPECT_FALSE(view->isFree(Vec3(0.05, 0.05, 2.05)));  // the hit itself
  EXPECT_TRUE(view->isFree(Vec3(2.55, 0.05, 1.0)));    // beyond the wider margin
  OctoMapWorldOptions bad = options;
  bad.wider_surface_margin_m = -1.0;
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), bad), std::invalid_argument);
  bad.wider_surface_margin_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(makeOctoMapWorld(3, Vec3(-6, -6, -6), Vec3(6, 6, 6), 0.0, toBytes(tree), bad), std::invalid_argument);
}

TEST(OctoMapWorld, SolidBelowSurfaceIsThreeDimensionalOnly) {
  octomap::OcTree tree(0.1);
  tree.updateNode(octomap::point3d(0.55f, 0.55f, 0.05f), true);
  OctoMapWorldOptions below;
  below.solid_below_surface = true;
  const auto flat = makeOctoMapWorld(2, Vec3(-5, -5, 0), Vec3(5, 5, 0), 0.0, toBytes(tree), below);
  EXPECT_FALSE(flat->isFree(Vec3(0.55, 0.55, 0.0)));  // the occupied column itself
  EXPECT_TRUE(flat->isFree(Vec3(1.55, 0.55, 0.0)));
  EXPECT_NEAR(flat->clearance(Vec3(1.55, 0.55, 0.0)), 0.95, 1e-9);  // to the voxel [0.5, 0.6): no depth rule
}


// A planar scan from the origin of a few walls and a disc, every length times `scale`: free cells along the rays,
// occupied cells where they end, the far sides unknown. With unknown_margin_m, exactly the unknown cells within the
// margin (a disc of whole cells) of an occupied cell that borders a non-occupied one are blocked; known cells answer
// for themselves.
void checkUnknownMarginAgainstABruteForceScan(int scale) {
  octomap::OcTree tree(0.1);
  octomap::Pointcloud cloud;
  const int beams = 720 * scale;
  for (int i = 0; i < beams; ++i) {
    const double a = i * 2.0 * M_PI / beams;
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double range = 5.5 * scale;
    if (d.x() > 0.3) range = std::min(range, 2.0 * scale / d.x());             // a wall at x = 2
    const Eigen::Vector2d c(-1.5 * scale, 1.0 * scale);                        // a disc of radius 0.8
    const double rr = 0.8 * scale;
    const double b = d.dot(c), disc = b * b - (c.squaredNorm() - rr * rr);
    if (disc >= 0 && b - std::sqrt(disc) > 0) range = std::min(range, b - std::sqrt(disc));
    cloud.push_back(static_cast<float>(range * d.x()), static_cast<float>(range * d.y()), 0.05f);
  }
  tree.insertPointCloud(cloud, octomap::point3d(0.0f, 0.0f, 0.05f), 5.0 * scale);  // rays longer than 5 m end unknown
  OctoMapWorldOptions options;
  options.unknown_margin_m = 0.45;  // 4 cells (rounded down)
  const double half = 6.0 * scale;
  const auto world = makeOctoMapWorld(2, Vec3(-half, -half, 0), Vec3(half, half, 0), 0.0, toBytes(tree), options);
  const auto plain = makeOctoMapWorld(2, Vec3(-half, -half, 0), Vec3(half, half, 0), 0.0, toBytes(tree), OctoMapWorldOptions{});
  const int kN = 120 * scale, kOff = 60 * scale;  // cells [-kOff, kOff) of 0.1 m per axis
  enum State { Unknown, Free, Occupied };
  std::vector<State> state(static_cast<std::size_t>(kN) * kN, Unknown);
  auto at = [&](int x, int y) -> State {
    return x < 0 || y < 0 || x >= kN || y >= kN ? Unknown : state[static_cast<std::size_t>(y * kN + x)];
  };
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x)
      if (const auto* n = tree.search((x - kOff + 0.5) * 0.1, (y - kOff + 0.5) * 0.1, 0.05))
        state[static_cast<std::size_t>(y * kN + x)] = tree.isNodeOccupied(n) ? Occupied : Free;
  std::vector<std::pair<int, int>> faces;
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x)
      if (at(x, y) == Occupied && (at(x + 1, y) != Occupied || at(x - 1, y) != Occupied || at(x, y + 1) != Occupied || at(x, y - 1) != Occupied))
        faces.emplace_back(x, y);
  // A hole between beams (observed free within 2 cells on both sides along a row, a column or a diagonal) is
  // no unseen space beyond a surface (UnknownMarginLeavesHolesBetweenBeamsFree).
  auto betweenBeams = [&](int x, int y) {
    for (const auto& [ux, uy] : {std::pair{1, 0}, std::pair{0, 1}, std::pair{1, 1}, std::pair{1, -1}}) {
      const bool ahead = at(x + ux, y + uy) == Free || at(x + 2 * ux, y + 2 * uy) == Free;
      const bool behind = at(x - ux, y - uy) == Free || at(x - 2 * ux, y - 2 * uy) == Free;
      if (ahead && behind) return true;
    }
    return false;
  };
  int newly_blocked = 0, unknown_free = 0;
  for (int y = 2; y < kN - 2; ++y)
    for (int x = 2; x < kN - 2; ++x) {
      const Vec3 p((x - kOff + 0.5) * 0.1, (y - kOff + 0.5) * 0.1, 0.0);
      bool expected = at(x, y) == Occupied;
      if (at(x, y) == Unknown && !betweenBeams(x, y))
        for (const auto& [fx, fy] : faces)
          if ((fx - x) * (fx - x) + (fy - y) * (fy - y) <= 16) expected = true;
      ASSERT_EQ(world->isFree(p), !expected) << p.transpose();
      newly_blocked += expected && plain->isFree(p);
      unknown_free += at(x, y) == Unknown && !expected;
    }
  EXPECT_GT(newly_blocked, 300 * scale);  // both answers were exercised among the unknown cells
  EXPECT_GT(unknown_free, 300 * scale);
  // Known free space next to a surface stays free: the cell in front of the wall, on the ray from the origin.
  EXPECT_TRUE(world->isFree(Vec3(2.0 * scale - 0.15, 0.05, 0.0)));
}

TEST(OctoMapWorld, UnknownMarginBlocksUnseenCellsNearSeenSurfacesAsABruteForceScanSays) {
  checkUnknownMarginAgainstABruteForceScan(1);
  // 3-D worlds ignore it; bad values are refused.
  octomap::OcTree tree(0.1);
  tree.updateNode(octomap::point3d(1.0f, 1.0f, 0.05f), true);
  OctoMapWorldOptions bad;
  bad.unknown_margin_m = -0.1;
  EXPECT_THROW(makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.0, toBytes(tree), bad), std::invalid_argument);
  bad.unknown_margin_m = std::numeric_limits<double>::infinity();
  EXPECT_THROW(makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.0, toBytes(tree), bad), std::invalid_argument);
}

// Four times larger: 480 cells a side, several of the margin's 256-cell tiles.
TEST(OctoMapWorld, UnknownMarginMatchesABruteForceScanOverSeveralTiles) { checkUnknownMarginAgainstABruteForceScan(4); }

// The margin is computed in tiles of 256 cells that start 4 cells (the margin) before the first occupied brick: a
// wall whose end lies two cells before a tile's edge blocks the unseen cells past its end in the next tile, whose
// only faces lie in its halo.
TEST(OctoMapWorld, UnknownMarginReachesAcrossATileEdgeFromAWallEnd) {
  octomap::OcTree tree(0.1);
  for (int x = 0; x <= 250; ++x) {
    tree.updateNode(octomap::point3d((x + 0.5f) * 0.1f, 0.05f, 0.05f), true);  // the wall, y cell 0
    for (int y = 1; y <= 10; ++y) tree.updateNode(octomap::point3d((x + 0.5f) * 0.1f, (0.5f - y) * 0.1f, 0.05f), false);
  }
  OctoMapWorldOptions options;
  options.unknown_margin_m = 0.45;  // 4 cells
  const auto world = makeOctoMapWorld(2, Vec3(-5, -5, 0), Vec3(30, 5, 0), 0.0, toBytes(tree), options);
  auto cell = [](int x, int y) { return Vec3((x + 0.5) * 0.1, (y + 0.5) * 0.1, 0.0); };
  // The tile edge is at x cell 252 (-4 + 256). Past the end (250, 0): blocked within 4 cells, free beyond.
  for (int x = 251; x <= 254; ++x) EXPECT_FALSE(world->isFree(cell(x, 0))) << x;
  EXPECT_TRUE(world->isFree(cell(255, 0)));
  EXPECT_FALSE(world->isFree(cell(252, 2)));  // 2^2 + 2^2 <= 16
  EXPECT_FALSE(world->isFree(cell(253, 2)));  // 3^2 + 2^2 <= 16
  EXPECT_TRUE(world->isFree(cell(254, 2)));   // 4^2 + 2^2 > 16
  EXPECT_TRUE(world->isFree(cell(252, 4)));   // 2^2 + 4^2 > 16 from the end, the nearest face
  EXPECT_FALSE(world->isFree(cell(240, 4)));  // above the wall: 4 cells from (240, 0)
  EXPECT_TRUE(world->isFree(cell(240, 5)));
}


// A planar scan from the origin of two boxes, hits only (a ray that hits nothing leaves no free cells): a long wall
// whose face is x = 3 (y from -2 to 4), and in front of it a short wall along y = 0.5 .. 0.7 from x = 1 to the long
// one, which hides the face from y = 0.5 to y = 2.1 (rays of slope 0.5 to 0.7 end on the short wall's end face).
struct ScanBox {
  Eigen::Vector2d lo, hi;
};
octomap::OcTree boxesScan(const std::vector<ScanBox>& boxes, int beams, double range);
octomap::OcTree occludedWallScan(int beams = 1440) { return boxesScan({{{3.0, -2.0}, {3.3, 4.0}}, {{1.0, 0.5}, {3.0, 0.7}}}, beams, 6.0); }

// A planar scan from the origin (`beams` evenly spaced, hits within `range` only) of axis-aligned boxes.
octomap::OcTree boxesScan(const std::vector<ScanBox>& boxes, int beams, double range) {
  octomap::OcTree tree(0.1);
  octomap::Pointcloud cloud;
  for (int i = 0; i < beams; ++i) {
    const double a = i * 2.0 * M_PI / beams;
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double best = std::numeric_limits<double>::infinity();
    for (const ScanBox& b : boxes) {  // slab test
      double t0 = 0.0, t1 = range;
      for (int k = 0; k < 2; ++k) {
        if (std::abs(d[k]) < 1e-12) {
          if (b.lo[k] > 0.0 || b.hi[k] < 0.0) t0 = t1 + 1;
          continue;
        }
        double ta = b.lo[k] / d[k], tb = b.hi[k] / d[k];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta), t1 = std::min(t1, tb);
      }
      if (t0 <= t1) best = std::min(best, t0);
    }
    if (std::isfinite(best)) cloud.push_back(static_cast<float>((best + 1e-3) * d.x()), static_cast<float>((best + 1e-3) * d.y()), 0.05f);
  }
  tree.insertPointCloud(cloud, octomap::point3d(0.0f, 0.0f, 0.05f));
  return tree;
}

// The unknown margin is for unseen space beyond a surface, not for the holes a fan of beams leaves between its
// rays: a never-observed cell with observed free space on both sides of it (within 2 cells, along a row, a column
// or a diagonal) stays free; one with unobserved space on a side is blocked.
// nearestPerBrick is obstaclesNear's list with only the first entry of each brick kept (what the fused world used to
// compute from it), 2-D with the unknown margin's cells and 3-D.
TEST(OctoMapWorld, NearestPerBrickIsTheFirstOfEachBrickInObstaclesNear) {
  const octomap::OcTree tree = occludedWallScan();
  OctoMapWorldOptions with_margin;
  with_margin.unknown_margin_m = 0.45;
  for (int dims : {2, 3}) {
    const auto world = makeOctoMapWorld(dims, Vec3(-6, -6, -1), Vec3(6, 6, 1), 0.3, toBytes(tree), dims == 2 ? with_margin : OctoMapWorldOptions{});
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-5.0, 5.0);
    std::size_t compared = 0;
    for (int i = 0; i < 300; ++i) {
      const Vec3 p(u(rng), u(rng), dims == 3 ? 0.05 : 0.0);
      const double range = 0.5 + std::abs(u(rng));
      std::vector<NearbyObstacle> expected;
      std::set<int> bricks;
      for (const auto& o : world->obstaclesNear(p, range))
        if (bricks.insert(o.id / 512).second) expected.push_back(o);
      const auto got = world->nearestPerBrick(p, range);
      ASSERT_EQ(got.size(), expected.size()) << p.transpose();
      for (std::size_t k = 0; k < got.size(); ++k) {
        EXPECT_EQ(got[k].id, expected[k].id);
        EXPECT_EQ(got[k].distance, expected[k].distance);
        EXPECT_EQ(got[k].nearest_point, expected[k].nearest_point);
      }
      compared += got.size();
    }
    EXPECT_GT(compared, 300u) << dims;
  }
}

TEST(OctoMapWorld, UnknownMarginLeavesHolesBetweenBeamsFree) {
  octomap::OcTree tree(0.1);
  for (double x = 0.05; x < 2.0; x += 0.1) tree.updateNode(x, 0.05, 0.05, true);  // a wall's face along y = 0
  // Free rows at y = 0.25 and 0.45 (beams), the row between them (y = 0.35) never observed; nothing above 0.5.
  for (double x = 0.05; x < 2.0; x += 0.1) {
    tree.updateNode(x, 0.25, 0.05, false);
    tree.updateNode(x, 0.45, 0.05, false);
  }
  OctoMapWorldOptions options;
  options.unknown_margin_m = 0.8;
  const auto world = makeOctoMapWorld(2, Vec3(-3, -3, 0), Vec3(3, 3, 0), 0.0, toBytes(tree), options);
  EXPECT_TRUE(world->isFree(Vec3(1.0, 0.35, 0)));   // the hole between the two rows
  EXPECT_TRUE(world->isFree(Vec3(1.0, 0.25, 0)));   // observed free
  EXPECT_FALSE(world->isFree(Vec3(1.0, 0.65, 0)));  // unobserved beyond the last row, within the margin
  EXPECT_FALSE(world->isFree(Vec3(1.0, 0.15, 0)));  // unobserved, between the face and the first row (one side)
  EXPECT_FALSE(world->isFree(Vec3(2.3, 0.05, 0)));  // beyond the face's end
}

TEST(OctoMapWorld, ASeenSurfaceGoesOnWhereSomethingInFrontHidesIt) {
  const octomap::OcTree tree = occludedWallScan();
  OctoMapWorldOptions knows_unobserved;
  knows_unobserved.unknown_margin_m = 0.05;  // below one cell: no margin, but the free leaves are loaded
  const std::shared_ptr<const CollisionWorld> map =
      makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.2, toBytes(tree), knows_unobserved);
  const auto continued = occludedSurfaceContinuation(*map, Vec3::Zero(), 5.0);
  EXPECT_DOUBLE_EQ(continued.cell_size, 0.1);
  // The hidden stretch of the face (its cells are x in [3.0, 3.1)), and nothing else: not the long wall's ends in
  // plain sight (nothing behind them was hit, so the cells beyond are unknown too), not the short wall.
  ASSERT_FALSE(continued.cells.empty());
  int hidden_stretch = 0;
  for (const Vec3& c : continued.cells) {
    EXPECT_NEAR(c.x(), 3.05, 1e-9) << c.transpose();
    EXPECT_GT(c.y(), 0.5) << c.transpose();
    EXPECT_LT(c.y(), 2.2) << c.transpose();
    hidden_stretch += c.y() > 0.75 && c.y() < 2.0;
  }
  EXPECT_GE(hidden_stretch, 12);  // 0.75 .. 2.0 m: 12 or 13 cells
  // A robot of radius 0.2 there: free on the plain map (unknown space is free), blocked with the continuation.
  const auto with = makeBlockedCellsWorld(map, continued.cells, continued.cell_size);
  const Vec3 behind(3.1, 1.3, 0.0);
  EXPECT_TRUE(map->isFree(behind));
  EXPECT_FALSE(with->isFree(behind));
  EXPECT_TRUE(with->isFree(Vec3(2.5, 3.0, 0.0)));  // in front of the seen face
  EXPECT_LT(with->clearance(behind), 0.0);
  // Only a map that loaded its unobserved cells can tell; other worlds give nothing.
  const auto plain = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.2, toBytes(tree), OctoMapWorldOptions{});
  EXPECT_TRUE(occludedSurfaceContinuation(*plain, Vec3::Zero(), 5.0).cells.empty());
  EXPECT_TRUE(occludedSurfaceContinuation(*map, Vec3::Zero(), 0.0).cells.empty());
  EXPECT_THROW(occludedSurfaceContinuation(*map, Vec3::Zero(), -1.0), std::invalid_argument);
  EXPECT_THROW(occludedSurfaceContinuation(*map, Vec3::Zero(), std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  // From above the short wall the stretch is in plain sight: not continued. The long wall's lower end, a true end,
  // is out of sight behind the short wall from there, and it is continued while the cells beyond it were never
  // observed (this scan's beams past it hit nothing in range); once they were (the mapper's rays through gaps of
  // beams that returned nothing clear them: MapperConfig::clear_beam_gaps), nothing is continued.
  for (const Vec3& c : occludedSurfaceContinuation(*map, Vec3(2.0, 1.3, 0.0), 5.0).cells) EXPECT_LT(c.y(), -2.0) << c.transpose();
  octomap::OcTree seen_beyond = tree;
  for (double y = -2.05; y > -4.0; y -= 0.1)
    for (const double x : {2.95, 3.05, 3.15, 3.25}) seen_beyond.updateNode(x, y, 0.05, false);
  const std::shared_ptr<const CollisionWorld> seen_map =
      makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.2, toBytes(seen_beyond), knows_unobserved);
  for (const Vec3& c : occludedSurfaceContinuation(*seen_map, Vec3(2.0, 1.3, 0.0), 5.0).cells) ADD_FAILURE() << c.transpose();
}

// Where the seen surfaces end is found once per world and reused from every viewpoint: a world asked (or prepared)
// before gives each viewpoint the continuation a world built afresh gives it.
TEST(OctoMapWorld, AContinuationFromAWorldAskedBeforeIsTheFreshWorldsOne) {
  const octomap::OcTree tree = occludedWallScan();
  OctoMapWorldOptions knows_unobserved;
  knows_unobserved.unknown_margin_m = 0.05;
  const auto build = [&] { return makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.2, toBytes(tree), knows_unobserved); };
  const auto reused = build();
  prepareSurfaceContinuation(*reused);
  int continued = 0;
  for (const Vec3& viewpoint : {Vec3(0, 0, 0), Vec3(2.0, 1.3, 0.0), Vec3(-3.0, 2.0, 0.0), Vec3(0, 0, 0)}) {
    const auto fresh = occludedSurfaceContinuation(*build(), viewpoint, 5.0).cells;
    const auto again = occludedSurfaceContinuation(*reused, viewpoint, 5.0).cells;
    ASSERT_EQ(again.size(), fresh.size()) << viewpoint.transpose();
    for (std::size_t i = 0; i < fresh.size(); ++i) EXPECT_EQ(again[i], fresh[i]) << viewpoint.transpose();
    continued += static_cast<int>(fresh.size());
  }
  EXPECT_GT(continued, 0);
  // Any other world: nothing to prepare.
  prepareSurfaceContinuation(*makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.2, toBytes(tree), OctoMapWorldOptions{}));
}

// A face whose hits near its end fall in two rows (a grazed face's do when its line is at a cell boundary) has an
// axis a degree or more off; walked along, it leaves the face's row for the row in front, observed free, within metres.
// The face y in [0, 0.1), x in [0, 3); its last 0.2 m also hit in the row above; that row and the next observed free
// beyond, a wall at y = 1.5 (x 2.5 .. 6) hiding the face's continuation from the viewpoint (1.5, 3). The
// continuation must go on in the face's row (moving across at most two cells) well beyond where the tilt meets the
// free row.
TEST(OctoMapWorld, AContinuationFollowsTheFaceWhenItsTiltedAxisMeetsSpaceObservedFree) {
  octomap::OcTree tree(0.1);
  for (double x = 0.05; x < 3.0; x += 0.1) tree.updateNode(x, 0.05, 0.05, true);
  for (const double x : {2.85, 2.95}) tree.updateNode(x, 0.15, 0.05, true);
  for (double x = 0.05; x < 2.8; x += 0.1) tree.updateNode(x, 0.15, 0.05, false);
  for (double x = 3.05; x < 9.0; x += 0.1)
    for (const double y : {0.15, 0.25}) tree.updateNode(x, y, 0.05, false);
  for (double x = 2.55; x < 6.0; x += 0.1) tree.updateNode(x, 1.55, 0.05, true);
  OctoMapWorldOptions knows_unobserved;
  knows_unobserved.unknown_margin_m = 0.05;  // below one cell: no margin, but the free leaves are loaded
  const auto map = makeOctoMapWorld(2, Vec3(-10, -10, 0), Vec3(20, 20, 0), 0.2, toBytes(tree), knows_unobserved);
  double farthest_in_row = 0.0;
  for (const Vec3& c : occludedSurfaceContinuation(*map, Vec3(1.5, 3.0, 0.0), 5.0).cells) {
    EXPECT_FALSE(c.y() > 0.1 && c.y() < 0.3 && c.x() > 3.0) << "on space observed free: " << c.transpose();
    if (c.y() > -0.25 && c.y() < 0.1) farthest_in_row = std::max(farthest_in_row, c.x());
  }
  EXPECT_GT(farthest_in_row, 6.0);  // without moving across: stops near x = 4, where the tilted axis meets y = 0.1
}

// The same walls seen by a coarse scanner (4 degrees between beams): the face is sampled every 0.2 m or so, not
// in every cell, and rays from the hidden stretch slip between the short wall's samples. The stretch is
// continued all the same (a scanner's view of a wall 38 m away, bugtrap_0.6, was not continued at all).
TEST(OctoMapWorld, ASparselySampledSurfaceGoesOnWhereSomethingInFrontHidesIt) {
  const octomap::OcTree tree = occludedWallScan(90);
  OctoMapWorldOptions knows_unobserved;
  knows_unobserved.unknown_margin_m = 0.05;
  const std::shared_ptr<const CollisionWorld> map =
      makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.2, toBytes(tree), knows_unobserved);
  const auto continued = occludedSurfaceContinuation(*map, Vec3::Zero(), 5.0);
  int hidden_stretch = 0;
  for (const Vec3& c : continued.cells) {
    EXPECT_GT(c.x(), 2.9) << c.transpose();  // the face or a cell in front of it (sparse samples tilt the axis)
    EXPECT_LT(c.x(), 3.15) << c.transpose();
    EXPECT_GT(c.y(), 0.5) << c.transpose();
    EXPECT_LT(c.y(), 2.3) << c.transpose();
    hidden_stretch += c.y() > 0.9 && c.y() < 1.8;
  }
  EXPECT_GE(hidden_stretch, 9);
  const auto with = makeBlockedCellsWorld(map, continued.cells, continued.cell_size);
  EXPECT_TRUE(map->isFree(Vec3(3.1, 1.3, 0.0)));
  EXPECT_FALSE(with->isFree(Vec3(3.1, 1.3, 0.0)));
}

// A block whose faces no hit of the scan is left on (x 1.0 .. 3.9, y 0.4 .. 0.8), as a scanner leaves a face it
// hit every few metres at a grazing angle between the hits, in front of a wall's face at x = 4, seen above y = 3.2.
// No ray from the face below that to the viewpoint meets a hit, but each crosses a metre and more of never-observed
// space (the block) beyond its first metre: the face is continued down behind the block (bugtrap_0.6: the neck's
// wall, hit every 2.5-7 m, hid the box's side wall behind it, and no ray to that wall met one of the hits).
TEST(OctoMapWorld, ASurfaceHiddenBehindAFaceMissedByTheRaysGoesOn) {
  octomap::OcTree tree = boxesScan({{{4.0, -2.0}, {4.3, 8.0}}, {{1.0, 0.4}, {3.9, 0.8}}}, 1440, 8.0);
  // The block's hits taken away (observed free instead: OctoMap's deleteNode asserts on pruned trees); its inside
  // stays never observed.
  const float free = tree.getClampingThresMinLog();
  for (double x = 1.05; x < 3.9; x += 0.1) tree.setNodeValue(octomap::point3d(float(x), 0.45f, 0.05f), free);
  for (double y = 0.55; y < 0.8; y += 0.1) tree.setNodeValue(octomap::point3d(1.05f, float(y), 0.05f), free);
  OctoMapWorldOptions knows_unobserved;
  knows_unobserved.unknown_margin_m = 0.05;
  const std::shared_ptr<const CollisionWorld> map =
      makeOctoMapWorld(2, Vec3(-8, -8, 0), Vec3(8, 8, 0), 0.2, toBytes(tree), knows_unobserved);
  int behind_the_block = 0;
  for (const Vec3& c : occludedSurfaceContinuation(*map, Vec3::Zero(), 5.0).cells)
    behind_the_block += std::abs(c.x() - 4.05) < 1e-9 && c.y() > 1.0 && c.y() < 3.1;
  EXPECT_GE(behind_the_block, 18);  // 20 cells
}

// A doorway 1 m wide at x = 3 between two walls, a wall behind it at x = 5.5 (so the rays through the doorway
// clear it), and an ellipse fitted to the upper wall's end face that reaches 0.4 m down into the doorway (an ellipse
// cannot hug the corner of a face and the first samples of the side face beside it).
TEST(ClipToObservedSpace, AnEllipseOfAMappedSurfaceLosesWhatTheScannerSawFree) {
  const octomap::OcTree tree =
      boxesScan({{{3.0, 0.5}, {5.0, 2.0}}, {{3.0, -2.0}, {5.0, -0.5}}, {{5.5, -3.0}, {5.8, 3.0}}}, 1440, 8.0);
  OctoMapWorldOptions options;
  options.keep_observed_free = true;
  const std::shared_ptr<const CollisionWorld> map = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, toBytes(tree), options);
  EllipsoidObstacle end_face;
  end_face.center = Vec3(3.05, 1.0, 0.0);
  end_face.semi_axes = Vec3(0.9, 0.15, 0.0);
  end_face.axes.col(0) = Vec3(0, 1, 0);
  end_face.axes.col(1) = Vec3(-1, 0, 0);
  EllipsoidObstacle in_the_open = end_face;  // nothing mapped there: an obstacle the map does not hold
  in_the_open.center = Vec3(1.5, -1.0, 0.0);
  EllipsoidObstacle off_its_arc = end_face;  // centre on the face, but both points half its semi-axis out (+-0.45 m along x) off it
  off_its_arc.center = Vec3(3.0, 1.2, 0.0);
  off_its_arc.axes.col(0) = Vec3(1, 0, 0);
  off_its_arc.axes.col(1) = Vec3(0, 1, 0);

  const auto clipped = clipToObservedSpace(*map, {end_face, in_the_open, off_its_arc});
  ASSERT_EQ(clipped.clipped.size(), 3u);
  EXPECT_TRUE(clipped.clipped[0]);
  EXPECT_FALSE(clipped.clipped[1]);
  EXPECT_FALSE(clipped.clipped[2]);
  EXPECT_DOUBLE_EQ(clipped.cell_size, 0.1);
  ASSERT_FALSE(clipped.cells.empty());
  // Every cell is the ellipse's (within it grown by half a cell diagonal) and none was observed free but those
  // bordering the wall's cells: the doorway below y = 0.4 keeps none, the wall's unseen inside keeps them all.
  int inside_the_wall = 0;
  for (const Vec3& c : clipped.cells) {
    const double u = (c.y() - 1.0) / (0.9 + 0.0708), v = (c.x() - 3.05) / (0.15 + 0.0708);
    EXPECT_LE(u * u + v * v, 1.0) << c.transpose();
    EXPECT_GT(c.y(), 0.4) << c.transpose();
    inside_the_wall += c.x() > 3.1 && c.y() > 0.65 && c.y() < 1.85;
  }
  EXPECT_GE(inside_the_wall, 11);  // x in [3.1, 3.2), y from 0.7 to 1.8
  // A robot of radius 0.3 in the doorway: blocked by the whole ellipse, free once it is clipped.
  const Vec3 doorway(3.0, 0.05, 0.0);
  const auto whole = makeEllipsoidWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, {end_face});
  EXPECT_FALSE(whole->isFree(doorway));
  EXPECT_TRUE(map->isFree(doorway));
  EXPECT_TRUE(makeBlockedCellsWorld(map, clipped.cells, clipped.cell_size)->isFree(doorway));
  // A map that did not keep its free cells, a 3-D map or another world clips nothing.
  const auto plain = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, toBytes(tree), OctoMapWorldOptions{});
  EXPECT_EQ(clipToObservedSpace(*plain, {end_face}).clipped, std::vector<bool>{false});
  EXPECT_EQ(clipToObservedSpace(*whole, {end_face}).clipped, std::vector<bool>{false});
  const auto volume = makeOctoMapWorld(3, Vec3(-6, -6, -1), Vec3(6, 6, 1), 0.3, toBytes(tree), options);
  EXPECT_EQ(clipToObservedSpace(*volume, {end_face}).clipped, std::vector<bool>{false});
  // Hostile shapes stay whole: not finite, degenerate, or wider than the cell cap.
  EllipsoidObstacle bad = end_face;
  bad.semi_axes = Vec3(std::nan(""), 0.1, 0.0);
  EllipsoidObstacle flat = end_face;
  flat.semi_axes = Vec3(0.9, 0.0, 0.0);
  EllipsoidObstacle huge = end_face;
  huge.semi_axes = Vec3(50.0, 50.0, 0.0);
  EXPECT_EQ(clipToObservedSpace(*map, {bad, flat, huge}).clipped, (std::vector<bool>{false, false, false}));
}

// The doorway above, with one cell past the upper wall's corner that no ray crossed (beams fan out: a hole between two
// of them) while the cells beside it were crossed: a gap between beams, clipped with the space around it. Kept, such a
// cell 0.45 m into bugtrap_0.4's 1.6 m neck mouth, one past each wall's corner, closed the mouth for the 1 m robot
// (read from a recorded map; docs/world-model.md, "Ellipses of mapped surfaces"). A never-observed cell with no
// observed free space on both sides of it (the wall's unseen inside) is still kept.
TEST(ClipToObservedSpace, ACellBetweenBeamsPastTheCornerIsClippedWithTheSpaceAroundIt) {
  octomap::OcTree tree = boxesScan({{{3.0, 0.5}, {5.0, 2.0}}, {{3.0, -2.0}, {5.0, -0.5}}, {{5.5, -3.0}, {5.8, 3.0}}}, 1440, 8.0);
  const octomap::point3d hole(3.15f, 0.25f, 0.05f);
  tree.deleteNode(hole);  // its return value says whether the root went too, not whether the node did
  ASSERT_EQ(tree.search(hole), nullptr);
  for (const float dx : {-0.1f, 0.1f}) {
    const auto* beside = tree.search(octomap::point3d(hole.x() + dx, hole.y(), hole.z()));
    ASSERT_NE(beside, nullptr);
    ASSERT_FALSE(tree.isNodeOccupied(beside));
  }
  OctoMapWorldOptions options;
  options.keep_observed_free = true;
  const std::shared_ptr<const CollisionWorld> map = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, toBytes(tree), options);
  EllipsoidObstacle end_face;
  end_face.center = Vec3(3.05, 1.0, 0.0);
  end_face.semi_axes = Vec3(0.9, 0.25, 0.0);  // wide enough to hold the hole's cell
  end_face.axes.col(0) = Vec3(0, 1, 0);
  end_face.axes.col(1) = Vec3(-1, 0, 0);
  const auto clipped = clipToObservedSpace(*map, {end_face});
  ASSERT_EQ(clipped.clipped, std::vector<bool>{true});
  int inside_the_wall = 0;
  for (const Vec3& c : clipped.cells) {
    EXPECT_FALSE(std::abs(c.x() - 3.15) < 1e-6 && std::abs(c.y() - 0.25) < 1e-6) << "the hole between beams was kept";
    EXPECT_GT(c.y(), 0.4) << c.transpose();
    inside_the_wall += c.x() > 3.1 && c.y() > 0.65;
  }
  EXPECT_GE(inside_the_wall, 11);
  // A robot of radius 0.3 in the doorway, 0.28 m from the hole's cell (0.42 m from the lower wall): free.
  EXPECT_TRUE(makeBlockedCellsWorld(map, clipped.cells, clipped.cell_size)->isFree(Vec3(3.15, -0.08, 0.0)));
}

// A wall's face at x = 3 a stretch of which (y 0.3 .. 1.4) the map lost to grazing rays (a cell hit once and crossed three times
// beside the surface reads free again), with an ellipse fitted to the face. The map still holds the face above and
// below: between those hits the ellipse keeps its whole width, so the face it bounds stays blocked (a
// gart_cluttered_2d run drove 0.2 m into a flank whose cells were clipped that way). Past the face's ends, where
// the rays to a wall behind it crossed, it is clipped.
TEST(ClipToObservedSpace, AFaceTheMapLostToGrazingRaysStaysBlockedBetweenItsHits) {
  octomap::OcTree tree = boxesScan({{{3.0, -2.0}, {5.0, 2.0}}, {{5.5, -5.0}, {5.8, 5.0}}}, 1440, 8.0);
  const float free = tree.getClampingThresMinLog();
  for (double y = 0.35; y < 1.4; y += 0.1) tree.setNodeValue(octomap::point3d(3.05f, float(y), 0.05f), free);
  OctoMapWorldOptions options;
  options.keep_observed_free = true;
  const std::shared_ptr<const CollisionWorld> map = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, toBytes(tree), options);
  EllipsoidObstacle face;
  face.center = Vec3(3.05, 0.0, 0.0);
  face.semi_axes = Vec3(2.6, 0.3, 0.0);  // reaches 0.6 m past the face's ends, where the rays crossed
  face.axes.col(0) = Vec3(0, 1, 0);
  face.axes.col(1) = Vec3(-1, 0, 0);
  const auto clipped = clipToObservedSpace(*map, {face});
  ASSERT_EQ(clipped.clipped, std::vector<bool>{true});
  const Vec3 against_the_face(2.75, 0.9, 0.0);  // 0.05 m into the face for a robot of radius 0.3
  EXPECT_TRUE(map->isFree(against_the_face));    // the map alone lost it
  EXPECT_FALSE(makeBlockedCellsWorld(map, clipped.cells, clipped.cell_size)->isFree(against_the_face));
  for (const Vec3& c : clipped.cells) EXPECT_LT(std::abs(c.y()), 2.1) << c.transpose();  // nothing kept past the face's ends
}

TEST(BlockedCellsWorld, FreeAndClearanceAsABruteForceScanSays) {
  const octomap::OcTree tree = occludedWallScan();
  const std::shared_ptr<const CollisionWorld> map = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, toBytes(tree));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::vector<Vec3> cells;
  for (int i = 0; i < 60; ++i) cells.emplace_back(std::floor(u(rng) * 10) / 10 + 0.05, std::floor(u(rng) * 10) / 10 + 0.05, 0.0);
  const auto world = makeBlockedCellsWorld(map, cells, 0.1);
  for (int i = 0; i < 4000; ++i) {
    const Vec3 p(u(rng), u(rng), 0.0);
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vec3& c : cells) {
      const double dx = std::max(std::abs(p.x() - c.x()) - 0.05, 0.0), dy = std::max(std::abs(p.y() - c.y()) - 0.05, 0.0);
      nearest = std::min(nearest, std::hypot(dx, dy));
    }
    ASSERT_EQ(world->isFree(p), map->isFree(p) && nearest > 0.3) << p.transpose();
    ASSERT_NEAR(world->clearance(p), std::min(map->clearance(p), nearest - 0.3), 1e-9) << p.transpose();
  }
  // Each bucket's nearest square is listed among the obstacles near a point, nearest first, with ids of its own.
  const auto near = world->obstaclesNear(Vec3(0, 0, 0), 3.0);
  EXPECT_TRUE(std::is_sorted(near.begin(), near.end(), [](const auto& a, const auto& b) { return a.distance < b.distance; }));
  EXPECT_TRUE(std::any_of(near.begin(), near.end(), [](const auto& o) { return o.id < 0; }));
  EXPECT_THROW(makeBlockedCellsWorld(nullptr, cells, 0.1), std::invalid_argument);
  EXPECT_THROW(makeBlockedCellsWorld(map, cells, 0.0), std::invalid_argument);
  EXPECT_THROW(makeBlockedCellsWorld(map, {Vec3(std::nan(""), 0, 0)}, 0.1), std::invalid_argument);
}

// robotInObservedFreeSpace: a scan from the origin of a wall at x = 3 and a small block at (1.0..1.5, 0.5..0.7) whose
// shadow (bearings 18-35 degrees beyond it) the scanner never saw. The plain map, optimistic, has the shadow free.
TEST(OctoMapWorld, ObservedFreeSpaceIsWhereRaysCrossedAndTheShadowIsNot) {
  const octomap::OcTree tree = boxesScan({{{3.0, -2.0}, {5.0, 2.0}}, {{1.0, 0.5}, {1.5, 0.7}}}, 1440, 8.0);
  OctoMapWorldOptions options;
  options.keep_observed_free = true;
  const auto map = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, toBytes(tree), options);
  const Vec3 open(1.5, -0.3, 0), before_the_wall(2.55, -0.5, 0), in_the_shadow(2.3, 1.15, 0);  // open: rays to the wall cross it
  EXPECT_EQ(robotInObservedFreeSpace(*map, open), std::optional<bool>(true));
  EXPECT_EQ(robotInObservedFreeSpace(*map, before_the_wall), std::optional<bool>(true));  // 0.15 m from the face
  EXPECT_TRUE(map->isFree(in_the_shadow));
  EXPECT_EQ(robotInObservedFreeSpace(*map, in_the_shadow), std::optional<bool>(false));
  EXPECT_EQ(robotInObservedFreeSpace(*map, Vec3(2.8, -0.5, 0)), std::optional<bool>(false));  // over the face's hits
  // Beside the wall's end, where the beams hit nothing within the scan's range: a beam without a return clears no
  // cell (why the tracker also asks the newest scan, tracker::ScanFreeSpace).
  EXPECT_EQ(robotInObservedFreeSpace(*map, Vec3(1.5, -1.6, 0)), std::optional<bool>(false));
  // A world that cannot tell: no free cells kept, a 3-D map, another kind of world, a point that is not finite.
  const auto plain = makeOctoMapWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, toBytes(tree), OctoMapWorldOptions{});
  EXPECT_EQ(robotInObservedFreeSpace(*plain, open), std::nullopt);
  const auto volume = makeOctoMapWorld(3, Vec3(-6, -6, -1), Vec3(6, 6, 1), 0.3, toBytes(tree), options);
  EXPECT_EQ(robotInObservedFreeSpace(*volume, open), std::nullopt);
  const auto ellipses = makeEllipsoidWorld(2, Vec3(-6, -6, 0), Vec3(6, 6, 0), 0.3, {});
  EXPECT_EQ(robotInObservedFreeSpace(*ellipses, open), std::nullopt);
  EXPECT_EQ(robotInObservedFreeSpace(*map, Vec3(std::nan(""), 0, 0)), std::nullopt);
}

}  // namespace
}  // namespace ddsnav::planner
