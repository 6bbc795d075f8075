// The k-d tree index against brute force, in 2-D and 3-D, while points are being added.
#include "ddsnav/planner/nearest.hpp"
#include "ddsnav/planner/tree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

namespace ddsnav::planner {
namespace {

// Squared distance summed axis by axis in the same order as the index, so exact ties stay exact ties.
double distance2(const Vec3& a, const Vec3& b, int dims) {
  double s = 0.0;
  for (int d = 0; d < dims; ++d) {
    const double t = a[d] - b[d];
    s += t * t;
  }
  return s;
}

// Every stored point as (squared distance, index), sorted: the order the index promises.
std::vector<std::pair<double, int>> byDistance(const std::vector<Vec3>& points, const Vec3& q, int dims) {
  std::vector<std::pair<double, int>> all;
  for (std::size_t i = 0; i < points.size(); ++i) all.emplace_back(distance2(points[i], q, dims), static_cast<int>(i));
  std::sort(all.begin(), all.end());
  return all;
}

// Checks nearest, kNearest for several k and withinRadius for several r against brute force.
void expectMatchesBruteForce(const NearestIndex& index, const std::vector<Vec3>& points, const Vec3& q,
                             const std::vector<double>& radii) {
  const int dims = index.dimensions();
  const auto all = byDistance(points, q, dims);
  ASSERT_EQ(index.size(), points.size());
  ASSERT_FALSE(all.empty());
  EXPECT_EQ(index.nearest(q), all[0].second) << "query " << q.transpose();
  std::vector<int> got;
  for (const std::size_t k : {std::size_t{1}, std::size_t{5}, std::size_t{10}, points.size() + 3}) {
    index.kNearest(q, k, got);
    const std::size_t expected = std::min(k, points.size());
    ASSERT_EQ(got.size(), expected);
    for (std::size_t i = 0; i < expected; ++i) {
      ASSERT_EQ(got[i], all[i].second) << "k " << k << " rank " << i << " query " << q.transpose();
    }
  }
  for (const double r : radii) {
    index.withinRadius(q, r, got);
    std::size_t inside = 0;
    while (inside < all.size() && all[inside].first < r * r) ++inside;
    ASSERT_EQ(got.size(), inside) << "r " << r << " query " << q.transpose();
    for (std::size_t i = 0; i < inside; ++i) ASSERT_EQ(got[i], all[i].second) << "r " << r << " rank " << i;
  }
}

class NearestVsBruteForce : public ::testing::TestWithParam<int> {};

TEST_P(NearestVsBruteForce, RandomPointsWhileAdding) {
  const int dims = GetParam();
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-50, 50);
  NearestIndex index(dims);
  std::vector<Vec3> points;
  for (int n = 0; n < 3000; ++n) {
    const Vec3 p(u(rng), u(rng), dims == 3 ? u(rng) : 0.0);
    ASSERT_EQ(index.add(p), n);
    points.push_back(p);
    if (n % 97 != 0 && n > 40) continue;  // every size while the root is a single leaf, then now and then
    for (int q = 0; q < 10; ++q) {
      const Vec3 query(u(rng), u(rng), dims == 3 ? u(rng) : 0.0);
      expectMatchesBruteForce(index, points, query, {0.5, 12.0, 40.0});
      if (HasFatalFailure()) return;
    }
  }
  // A query at a stored point finds that point first (distance 0).
  for (int i = 0; i < 3000; i += 311) EXPECT_EQ(index.nearest(points[static_cast<std::size_t>(i)]), i);
}

TEST_P(NearestVsBruteForce, GridWithDuplicatesAndExactTies) {
  // Integer grid points, each stored three times in shuffled order: queries at grid points and half-way
  // points see many exactly equal distances, so the (distance, index) order is really exercised, and
  // r = 1 must exclude the neighbours exactly 1 away (strict radius).
  const int dims = GetParam();
  const int side = dims == 3 ? 7 : 16;
  std::vector<Vec3> cells;
  for (int x = 0; x < side; ++x)
    for (int y = 0; y < side; ++y)
      for (int z = 0; z < (dims == 3 ? side : 1); ++z) cells.emplace_back(x, y, z);
  std::vector<Vec3> order;
  for (int copy = 0; copy < 3; ++copy) order.insert(order.end(), cells.begin(), cells.end());
  std::mt19937_64 rng(7);
  std::shuffle(order.begin(), order.end(), rng);
  NearestIndex index(dims);
  std::vector<Vec3> points;
  for (const Vec3& p : order) {
    index.add(p);
    points.push_back(p);
  }
  std::uniform_int_distribution<int> cell(0, side - 1);
  for (int q = 0; q < 60; ++q) {
    Vec3 query(cell(rng), cell(rng), dims == 3 ? cell(rng) : 0);
    if (q % 2 == 1) query += dims == 3 ? Vec3(0.5, 0.5, 0.5) : Vec3(0.5, 0.5, 0.0);
    expectMatchesBruteForce(index, points, query, {1.0, 1.5, std::sqrt(2.0) / 2.0, 3.0});
    if (HasFatalFailure()) return;
  }
}

TEST_P(NearestVsBruteForce, ManyIdenticalPoints) {
  // 200 copies of one point cannot be split along any axis: the leaf must still hold them all, and a few
  // distinct points added afterwards must still be found.
  const int dims = GetParam();
  NearestIndex index(dims);
  std::vector<Vec3> points;
  const Vec3 same(1, 2, dims == 3 ? 3 : 0);
  for (int i = 0; i < 200; ++i) {
    index.add(same);
    points.push_back(same);
  }
  for (int i = 0; i < 40; ++i) {
    const Vec3 p(1 + 0.25 * i, 2 - 0.1 * i, dims == 3 ? 3 + 0.05 * i : 0);
    index.add(p);
    points.push_back(p);
    index.add(same);
    points.push_back(same);
  }
  for (const Vec3& q : {same, Vec3(5, 0, 0), Vec3(1.3, 1.9, dims == 3 ? 3.0 : 0.0), Vec3(-4, 8, 1)}) {
    const Vec3 query(q.x(), q.y(), dims == 3 ? q.z() : 0.0);
    expectMatchesBruteForce(index, points, query, {1e-9, 0.5, 3.0, 100.0});
    if (HasFatalFailure()) return;
  }
}

// Insertion orders like a planner's: each point next to the last ones, the tree growing outward.
enum class Growth { kLine, kSpiral, kRandomWalk };

std::vector<Vec3> correlatedPoints(Growth growth, int dims, int n) {
  std::vector<Vec3> points;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> step(0.0, 0.3);
  Vec3 walk = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    switch (growth) {
      case Growth::kLine:
        points.emplace_back(0.01 * i, 0.5 * 0.01 * i, dims == 3 ? -0.01 * i : 0.0);
        break;
      case Growth::kSpiral: {
        const double angle = 0.05 * i, radius = 0.002 * i;
        points.emplace_back(radius * std::cos(angle), radius * std::sin(angle), dims == 3 ? 0.001 * i : 0.0);
        break;
      }
      case Growth::kRandomWalk:
        walk += Vec3(step(rng), step(rng), dims == 3 ? step(rng) : 0.0);
        points.push_back(walk);
        break;
    }
  }
  return points;
}

class NearestCorrelatedOrder : public ::testing::TestWithParam<std::tuple<int, Growth>> {};

TEST_P(NearestCorrelatedOrder, ExactWhenPointsArriveInOrder) {
  const auto [dims, growth] = GetParam();
  const int n = 20000;
  const auto all_points = correlatedPoints(growth, dims, n);
  NearestIndex index(dims);
  std::vector<Vec3> points;
  std::mt19937_64 rng(11);
  for (int i = 0; i < n; ++i) {
    index.add(all_points[static_cast<std::size_t>(i)]);
    points.push_back(all_points[static_cast<std::size_t>(i)]);
    if (i % 1999 != 0) continue;
    // Queries near the growing front and at a random older point.
    const Vec3 front = points.back() + Vec3(0.05, -0.02, dims == 3 ? 0.03 : 0.0);
    std::uniform_int_distribution<std::size_t> pick(0, points.size() - 1);
    for (const Vec3& q : {front, points[pick(rng)], Vec3(points[pick(rng)] + Vec3(0.004, 0.003, 0.0))}) {
      expectMatchesBruteForce(index, points, q, {0.02, 0.3});
      if (HasFatalFailure()) return;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Orders, NearestCorrelatedOrder,
                         ::testing::Combine(::testing::Values(2, 3),
                                            ::testing::Values(Growth::kLine, Growth::kSpiral, Growth::kRandomWalk)));

INSTANTIATE_TEST_SUITE_P(Dimensions, NearestVsBruteForce, ::testing::Values(2, 3));

TEST(Nearest, EmptyIndexAndDegenerateArguments) {
  NearestIndex index(2);
  EXPECT_TRUE(index.empty());
  EXPECT_EQ(index.nearest(Vec3::Zero()), -1);
  std::vector<int> out{1, 2};
  index.kNearest(Vec3::Zero(), 3, out);
  EXPECT_TRUE(out.empty());
  out = {1, 2};
  index.withinRadius(Vec3::Zero(), 10.0, out);
  EXPECT_TRUE(out.empty());
  EXPECT_THROW(NearestIndex(4), std::invalid_argument);
  EXPECT_THROW(NearestIndex(1), std::invalid_argument);

  index.add(Vec3(1, 1, 0));
  out = {7};
  index.kNearest(Vec3::Zero(), 0, out);
  EXPECT_TRUE(out.empty());
  index.withinRadius(Vec3::Zero(), 0.0, out);
  EXPECT_TRUE(out.empty());
  index.withinRadius(Vec3::Zero(), -1.0, out);
  EXPECT_TRUE(out.empty());
  index.withinRadius(Vec3(-2, -3, 0), 5.0, out);  // exactly 5 away (3-4-5): strict, so excluded
  EXPECT_TRUE(out.empty());
  index.withinRadius(Vec3::Zero(), 1.5, out);
  EXPECT_EQ(out, std::vector<int>{0});
}

TEST(Nearest, TwoDimensionalIndexIgnoresZ) {
  NearestIndex index(2);
  index.add(Vec3(0, 0, 100));
  index.add(Vec3(3, 0, 0));
  EXPECT_EQ(index.point(0), Vec3(0, 0, 0));
  EXPECT_EQ(index.nearest(Vec3(1, 0, -50)), 0);
  EXPECT_EQ(index.size(), 2u);
  EXPECT_EQ(index.dimensions(), 2);
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
