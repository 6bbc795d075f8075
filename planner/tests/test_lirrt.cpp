// Li-RRT: liveness bookkeeping on hand-computed trees, the control set, and whole runs.
#include "ddsnav/planner/lirrt.hpp"
#include "ddsnav/planner/tree.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

namespace ddsnav::planner {
namespace {

// A small tree, built node by node; every value below is worked out by hand from eq. 6,
//   LnLi = ln Se - (m_h + d + d_s / n_t).
TEST(LirrtLiveness, HandComputedTree) {
  LivenessBook book;
  // Node 0 (root), Se = 1, no neighbours: LnLi = 0.
  EXPECT_EQ(book.add(-1, 1.0, {}), 0);
  EXPECT_DOUBLE_EQ(book.lnLi(0), 0.0);
  EXPECT_EQ(book.mostAlive(), 0);

  // Node 1 under 0, Se = 0.5, neighbour {0}.
  //   node 1: m_h = 1                 -> ln 0.5 - 1        = -1.6931
  //   node 0: d = 1, m_h = 1          -> 0 - (1 + 1)       = -2
  EXPECT_EQ(book.add(0, 0.5, {0}), 1);
  EXPECT_EQ(book.neighbourCollisions(1), 1);
  EXPECT_EQ(book.degree(0), 1);
  EXPECT_EQ(book.neighbourCollisions(0), 1);
  EXPECT_NEAR(book.lnLi(1), std::log(0.5) - 1.0, 1e-12);
  EXPECT_NEAR(book.lnLi(0), -2.0, 1e-12);
  EXPECT_EQ(book.mostAlive(), 1);

  // Node 2 under 1, Se = 1, no neighbours; n_t = 3.
  //   node 2: 0
  //   node 1: d = 1                   -> ln 0.5 - (1 + 1)  = -2.6931
  //   node 0: d_s = 1 (a grandchild)  -> -(1 + 1 + 1/3)    = -2.3333
  EXPECT_EQ(book.add(1, 1.0, {}), 2);
  EXPECT_EQ(book.offspring(0), 1);
  EXPECT_EQ(book.offspring(1), 0);  // node 2 is a child of 1, counted in d, not in d_s
  EXPECT_NEAR(book.lnLi(2), 0.0, 1e-12);
  EXPECT_NEAR(book.lnLi(1), std::log(0.5) - 2.0, 1e-12);
  EXPECT_NEAR(book.lnLi(0), -(2.0 + 1.0 / 3.0), 1e-12);
  EXPECT_EQ(book.mostAlive(), 2);

  // Node 3 under 2, Se = 0.25, neighbour {2}; n_t = 4.
  //   node 3: m_h = 1                 -> ln 0.25 - 1             = -2.3863
  //   node 2: d = 1, m_h = 1          -> -(1 + 1)                = -2
  //   node 1: d = 1, d_s = 1          -> ln 0.5 - (1 + 1 + 1/4)  = -2.9431
  //   node 0: d = 1, m_h = 1, d_s = 2 -> -(1 + 1 + 2/4)          = -2.5
  EXPECT_EQ(book.add(2, 0.25, {2}), 3);
  EXPECT_NEAR(book.lnLi(3), std::log(0.25) - 1.0, 1e-12);
  EXPECT_NEAR(book.lnLi(2), -2.0, 1e-12);
  EXPECT_NEAR(book.lnLi(1), std::log(0.5) - 2.25, 1e-12);
  EXPECT_NEAR(book.lnLi(0), -2.5, 1e-12);
  EXPECT_EQ(book.offspring(0), 2);
  EXPECT_EQ(book.offspring(1), 1);
  EXPECT_EQ(book.mostAlive(), 2);

  // Node 4 under 0 is dead (Se = 0): -inf, never the most alive; the root pays d = 2; n_t = 5 changes
  // every offspring term: node 0 -> -(1 + 2 + 2/5) = -3.4, node 1 -> ln 0.5 - (2 + 1/5) = -2.8931.
  EXPECT_EQ(book.add(0, 0.0, {}), 4);
  EXPECT_TRUE(book.dead(4));
  EXPECT_EQ(book.lnLi(4), -std::numeric_limits<double>::infinity());
  EXPECT_NEAR(book.lnLi(0), -3.4, 1e-12);
  EXPECT_NEAR(book.lnLi(1), std::log(0.5) - 2.2, 1e-12);
  EXPECT_EQ(book.mostAlive(), 2);
}

TEST(LirrtLiveness, AllDeadMeansNothingToExpand) {
  LivenessBook book;
  book.add(-1, 0.0, {});
  EXPECT_EQ(book.mostAlive(), -1);
  EXPECT_THROW(book.add(0, 1.5, {}), std::invalid_argument);
  EXPECT_THROW(book.add(7, 1.0, {}), std::invalid_argument);
}

// The offspring term makes a heap keyed by the bound ln Se - m_h - d disagree with eq. 6: the lazy
// evaluation must still return the exact argmax. Node 1 has the larger bound (0) but 3 grandchildren:
// LnLi(1) = -(1 + 2/6) = -1.333 < LnLi(5) = ln 0.3 = -1.204.
TEST(LirrtLiveness, OffspringTermOverridesBound) {
  LivenessBook book;
  book.add(-1, 0.05, {});  // 0: ln 0.05 - ... very low
  book.add(0, 1.0, {});    // 1
  book.add(1, 1.0, {});    // 2 (child of 1): d(1) = 1
  book.add(2, 0.01, {});   // 3
  book.add(2, 0.01, {});   // 4  -> d_s(1) = 2
  book.add(0, 0.3, {});    // 5
  // n_t = 6: node 1: d = 1, d_s = 2 -> -(1 + 2/6) = -1.3333; node 5: ln 0.3 = -1.2040; node 2: -(2) = -2.
  EXPECT_NEAR(book.lnLi(1), -(1.0 + 2.0 / 6.0), 1e-12);
  EXPECT_NEAR(book.lnLi(5), std::log(0.3), 1e-12);
  EXPECT_EQ(book.mostAlive(), 5);
}

// Random trees: mostAlive() equals a brute-force argmax of lnLi() after every insertion (exercises the
// stale entries and the heap compaction).
TEST(LirrtLiveness, MatchesBruteForceArgmax) {
  std::mt19937 rng(7);
  LivenessBook book;
  book.add(-1, 1.0, {});
  for (int i = 1; i < 400; ++i) {
    const int parent = static_cast<int>(rng() % static_cast<unsigned>(i));
    const double se = (rng() % 5) / 4.0;  // 0, 0.25, ..., 1
    std::vector<int> near;
    for (int k = 0; k < static_cast<int>(rng() % 4); ++k) near.push_back(static_cast<int>(rng() % static_cast<unsigned>(i)));
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    book.add(parent, se, near);
    int expected = -1;
    for (int n = 0; n < book.size(); ++n) {
      if (book.dead(n)) continue;
      if (expected < 0 || book.lnLi(n) > book.lnLi(expected)) expected = n;
    }
    ASSERT_EQ(book.mostAlive(), expected) << "after inserting node " << i;
  }
}

TEST(LirrtControls, SetCoversTurnsAndSpeeds) {
  VehicleLimits limits;
  limits.v_max = 2.0;
  limits.omega_max = 0.15;
  limits.vz_max = 1.0;
  limits.dt = 10.0;
  const ForwardRegion r2 = forwardRegion(limits, 2);
  const auto u2 = lirrtControlSet(r2, LirrtOptions{});
  ASSERT_EQ(u2.size(), 20u);  // 4 lengths x 5 turns
  EXPECT_DOUBLE_EQ(u2.front().length, 2.5);  // reach 20 / 2^3
  EXPECT_DOUBLE_EQ(u2.front().turn, -1.5);
  EXPECT_DOUBLE_EQ(u2[2].turn, 0.0);
  EXPECT_DOUBLE_EQ(u2[5].length, 5.0);
  EXPECT_DOUBLE_EQ(u2[10].length, 10.0);
  EXPECT_DOUBLE_EQ(u2.back().turn, 1.5);
  EXPECT_DOUBLE_EQ(u2.back().length, 20.0);
  const auto u3 = lirrtControlSet(forwardRegion(limits, 3), LirrtOptions{});
  ASSERT_EQ(u3.size(), 60u);  // x 3 climbs
  EXPECT_DOUBLE_EQ(u3.front().climb, -10.0);
  EXPECT_DOUBLE_EQ(u3[1].climb, 0.0);
}

}  // namespace
}  // namespace ddsnav::planner
