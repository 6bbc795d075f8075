// The k-d tree index against brute force, in 2-D and 3-D, while points are being added.
#include "ddsnav/planner/nearest.hpp"
#include "ddsnav/planner/tree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace ddsnav::planner {
namespace {

class NearestVsBruteForce : public ::testing::TestWithParam<int> {};

TEST_P(NearestVsBruteForce, NearestKNearestAndRadiusAgree) {
  const int dims = GetParam();
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-50, 50);
  NearestIndex index(dims);
  std::vector<Vec3> points;
  std::vector<int> got;
  for (int n = 0; n < 3000; ++n) {
    const Vec3 p(u(rng), u(rng), dims == 3 ? u(rng) : 0.0);
    EXPECT_EQ(index.add(p), n);
    points.push_back(p);
    if (n % 97 != 0) continue;
    for (int q = 0; q < 20; ++q) {
      const Vec3 query(u(rng), u(rng), dims == 3 ? u(rng) : 0.0);
      std::vector<std::pair<double, int>> all;
      for (std::size_t i = 0; i < points.size(); ++i) all.emplace_back((points[i] - query).norm(), static_cast<int>(i));
      std::sort(all.begin(), all.end());
      EXPECT_DOUBLE_EQ((index.point(index.nearest(query)) - query).norm(), all[0].first);
      index.kNearest(query, 5, got);
      ASSERT_EQ(got.size(), std::min<std::size_t>(5, points.size()));
      for (std::size_t k = 0; k < got.size(); ++k) EXPECT_DOUBLE_EQ((points[got[k]] - query).norm(), all[k].first);
      index.withinRadius(query, 12.0, got);
      std::size_t inside = 0;
      while (inside < all.size() && all[inside].first < 12.0) ++inside;
      ASSERT_EQ(got.size(), inside);
      for (std::size_t k = 0; k < got.size(); ++k) EXPECT_EQ(got[k], all[k].second);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Dimensions, NearestVsBruteForce, ::testing::Values(2, 3));

TEST(Nearest, EmptyIndex) {
  NearestIndex index(2);
  EXPECT_EQ(index.nearest(Vec3::Zero()), -1);
  std::vector<int> out{1, 2};
  index.kNearest(Vec3::Zero(), 3, out);
  EXPECT_TRUE(out.empty());
  EXPECT_THROW(NearestIndex(4), std::invalid_argument);
}

TEST(SearchTree, ReparentMovesSubtreeCostsAndHeading) {
  SearchTree tree(2);
  const int root = tree.add(State{Vec3(0, 0, 0), 0.0}, -1, 0.0);
  const int a = tree.add(State{Vec3(0, 4, 0), 1.5708}, root, 4.0);
  const int b = tree.add(State{Vec3(3, 4, 0), 0.0}, a, 7.0);
  const int c = tree.add(State{Vec3(6, 4, 0), 0.0}, b, 10.0);
  const int d = tree.add(State{Vec3(3, 0, 0), 0.0}, root, 3.0);
  tree.reparent(b, d, 6.5);  // a cheaper cost-to-come: every descendant follows
  EXPECT_DOUBLE_EQ(tree.node(b).cost, 6.5);
  EXPECT_DOUBLE_EQ(tree.node(c).cost, 9.5);
  EXPECT_EQ(tree.node(b).parent, d);
  EXPECT_TRUE(tree.node(a).children.empty());
  EXPECT_NEAR(tree.node(b).state.heading, 1.5707963267948966, 1e-12);  // edge d -> b points along +y
  const auto path = tree.pathTo(c);
  ASSERT_EQ(path.size(), 4u);
  EXPECT_EQ(path[1].position, Vec3(3, 0, 0));
  EXPECT_EQ(tree.edges().size(), 4u);
}

TEST(Metrics, CoverageMatchesItsDefinition) {
  // One node in the corner of a 64 x 64 world: delta = 1 (4096 grid points). Every grid point except
  // the node's own is >= 1 away, so c(G) = (4095 * 1 + 0) / 4096 on the 64 x 64 grid of spacing 1
  // (65 x 65 points including both edges, of which one sits on the node).
  Scenario s;
  s.dimensions = 2;
  s.bounds_max = Vec3(64, 64, 0);
  const auto world = makeScenarioWorld(s);
  SearchTree tree(2);
  tree.add(State{Vec3(0, 0, 0), 0.0}, -1, 0.0);
  EXPECT_NEAR(treeCoverage(tree, *world, 1), (65.0 * 65.0 - 1.0) / (65.0 * 65.0), 1e-12);
  // A second node at a grid point removes one more full term.
  tree.add(State{Vec3(10, 10, 0), 0.0}, 0, 14.0);
  EXPECT_NEAR(treeCoverage(tree, *world, 2), (65.0 * 65.0 - 2.0) / (65.0 * 65.0), 1e-12);
  EXPECT_NEAR(treeGrowth(tree, *world), 1.0 / (65.0 * 65.0), 1e-12);
}

}  // namespace
}  // namespace ddsnav::planner
