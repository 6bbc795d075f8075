#include "ddsnav/nodes/world_tier.hpp"

#include <gtest/gtest.h>

namespace ddsnav::nodes {
namespace {

TEST(WorldTier, ATenthOfTheBudgetUpTo100MsCutByEightPerFailureDownTo50Ms) {
  WorldTier tier;
  EXPECT_DOUBLE_EQ(tier.share(5.0), 0.1);  // a tenth would be 0.5 s
  EXPECT_DOUBLE_EQ(tier.share(0.8), 0.08);
  tier.failed();
  EXPECT_DOUBLE_EQ(tier.share(5.0), 0.05);  // 0.0125 without the floor
  tier.failed();
  EXPECT_DOUBLE_EQ(tier.share(5.0), 0.05);
  for (int i = 0; i < 100; ++i) tier.failed();
  EXPECT_DOUBLE_EQ(tier.share(5.0), 0.05);
  EXPECT_DOUBLE_EQ(tier.share(0.3), 0.03);  // never more than a tenth of what is left
}

TEST(WorldTier, FastSolvesBoundTheShare) {
  WorldTier tier;
  tier.solved(0.004);
  EXPECT_DOUBLE_EQ(tier.share(5.0), 0.02);  // 3 x 4 ms is below the 20 ms minimum
  tier.solved(0.056);
  tier.solved(0.010);
  EXPECT_NEAR(tier.share(5.0), 0.03, 1e-12);  // 3 x the 10 ms median
  tier.failed();
  tier.failed();
  EXPECT_NEAR(tier.share(5.0), 0.03, 1e-12);  // the halving stops at that bound too
  EXPECT_EQ(tier.failuresInARow(), 2);
  tier.solved(0.03);
  EXPECT_EQ(tier.failuresInARow(), 0);
  EXPECT_NEAR(tier.share(0.2), 0.02, 1e-12);  // never more than a tenth of what is left
}

TEST(WorldTier, SlowSolvesKeepTheirRoom) {
  WorldTier tier;
  for (double s : {0.11, 0.125, 0.09}) tier.solved(s);
  EXPECT_NEAR(tier.share(5.0), 0.33, 1e-12);  // 3 x the 110 ms median
  tier.failed();
  EXPECT_NEAR(tier.share(5.0), 0.1, 1e-12);
  for (int i = 0; i < 10; ++i) tier.failed();
  EXPECT_DOUBLE_EQ(tier.share(5.0), 0.1);  // down to 0.1 s when 3 x the median is more
}

}  // namespace
}  // namespace ddsnav::nodes
