// The simulator's pacing: the clock is held exactly while a reporting process lags more than max_lag_s, and
// never for ever (a silent process is forgotten, a process holding too long is no longer waited for).
#include "ddsnav/sim/clock_pacer.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

namespace ddsnav::sim {
namespace {

using namespace std::chrono_literals;
constexpr std::int64_t kSecond = 1'000'000'000;

struct PacerTest : ::testing::Test {
  ClockPacer::WallTime wall = std::chrono::steady_clock::time_point{} + 1000s;
  std::int64_t sim = 100 * kSecond;
};

TEST_F(PacerTest, AdvancesWithNobodyReportingAndWhileEveryoneKeepsUp) {
  ClockPacer pacer({.max_lag_s = 0.3});
  EXPECT_TRUE(pacer.mayAdvance(sim, wall));
  pacer.report("perception", sim - kSecond / 10, wall);
  pacer.report("tracker", sim - 3 * kSecond / 10 + 1, wall);
  EXPECT_TRUE(pacer.mayAdvance(sim, wall));
}

TEST_F(PacerTest, HoldsForTheProcessFurthestBehindUntilItCatchesUp) {
  ClockPacer pacer({.max_lag_s = 0.3});
  pacer.report("perception", sim - kSecond / 2, wall);
  pacer.report("planner", sim - kSecond, wall);
  EXPECT_FALSE(pacer.mayAdvance(sim, wall));
  EXPECT_EQ(pacer.holder(), "planner");
  pacer.report("planner", sim, wall + 100ms);
  EXPECT_FALSE(pacer.mayAdvance(sim, wall + 100ms));
  EXPECT_EQ(pacer.holder(), "perception");
  pacer.report("perception", sim - kSecond / 4, wall + 200ms);
  EXPECT_TRUE(pacer.mayAdvance(sim, wall + 200ms));
  EXPECT_NEAR(pacer.heldSeconds().at("planner"), 0.1, 1e-9);
  EXPECT_NEAR(pacer.heldSeconds().at("perception"), 0.1, 1e-9);
  // A reordered older report does not take progress back.
  pacer.report("perception", sim - kSecond, wall + 210ms);
  EXPECT_TRUE(pacer.mayAdvance(sim, wall + 210ms));
}

TEST_F(PacerTest, ForgetsAProcessThatStoppedReporting) {
  ClockPacer pacer({.max_lag_s = 0.3, .silence_s = 1.0});
  pacer.report("mapper", sim - 2 * kSecond, wall);
  EXPECT_FALSE(pacer.mayAdvance(sim, wall + 900ms));
  EXPECT_TRUE(pacer.mayAdvance(sim, wall + 1100ms));
  const auto events = pacer.takeEvents();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, ClockPacer::Event::Forgotten);
  EXPECT_EQ(events[0].name, "mapper");
  EXPECT_TRUE(pacer.takeEvents().empty());
}

TEST_F(PacerTest, StopsWaitingForAProcessThatHoldsTooLongAndWaitsAgainOnceItCaughtUp) {
  ClockPacer pacer({.max_lag_s = 0.3, .max_hold_s = 5.0, .silence_s = 1.0});
  auto t = wall;
  for (int i = 0; i <= 50; ++i, t += 100ms) {  // still reporting, never catching up: 5 s of holding
    pacer.report("stuck", sim - kSecond, t);
    EXPECT_FALSE(pacer.mayAdvance(sim, t)) << i;
  }
  pacer.report("stuck", sim - kSecond, t);
  EXPECT_TRUE(pacer.mayAdvance(sim, t));
  auto events = pacer.takeEvents();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, ClockPacer::Event::LongHold);  // after 1 s
  EXPECT_EQ(events[1].kind, ClockPacer::Event::GaveUp);
  EXPECT_NEAR(events[1].lag_s, 1.0, 1e-9);
  // It catches up: waited for again from then on.
  pacer.report("stuck", sim, t + 100ms);
  EXPECT_TRUE(pacer.mayAdvance(sim, t + 100ms));
  events = pacer.takeEvents();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, ClockPacer::Event::CaughtUp);
  sim += kSecond;
  EXPECT_FALSE(pacer.mayAdvance(sim, t + 200ms));
  EXPECT_EQ(pacer.holder(), "stuck");
}

TEST_F(PacerTest, IgnoresReportsThatAreNoClockTime) {
  ClockPacer pacer({.max_lag_s = 0.3});
  pacer.report("hostile", std::numeric_limits<std::int64_t>::min(), wall);
  pacer.report("hostile", 0, wall);
  pacer.report("hostile", -5, wall);
  EXPECT_TRUE(pacer.mayAdvance(sim, wall));
  EXPECT_TRUE(pacer.mayAdvance(std::numeric_limits<std::int64_t>::max(), wall));
}

TEST(PacerParams, RefuseNonPositiveAndNonFiniteValues) {
  EXPECT_THROW(ClockPacer({.max_lag_s = 0}), std::invalid_argument);
  EXPECT_THROW(ClockPacer({.max_hold_s = -1}), std::invalid_argument);
  EXPECT_THROW(ClockPacer({.silence_s = std::numeric_limits<double>::quiet_NaN()}), std::invalid_argument);
}

}  // namespace
}  // namespace ddsnav::sim
