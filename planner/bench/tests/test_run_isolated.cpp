// runIsolated: a result crosses the process boundary intact; a run past its deadline is killed and one that
// crashes is reported, both as unsolved runs with a note, and the caller goes on.
#include "bench_run.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <thread>

namespace ddsnav::bench {
namespace {

RunRecord identity() {
  RunRecord r;
  r.scenario = "s";
  r.planner = "p";
  r.seed = 7;
  return r;
}

TEST(RunIsolated, ReturnsTheChildsRecord) {
  const RunRecord r = runIsolated(
      [] {
        RunRecord x = identity();
        x.solved = x.valid = x.kinodynamic = true;
        x.time_to_first_s = 0.125;
        x.iterations = 4962;
        x.cost = 38.25;
        x.invalid_reason = "quoted \"note\", with a comma";
        return x;
      },
      1.0, identity());
  EXPECT_TRUE(r.solved && r.valid && r.kinodynamic);
  EXPECT_EQ(r.seed, 7u);
  EXPECT_DOUBLE_EQ(r.time_to_first_s, 0.125);
  EXPECT_EQ(r.iterations, 4962);
  EXPECT_DOUBLE_EQ(r.cost, 38.25);
  EXPECT_EQ(r.invalid_reason, "quoted \"note\", with a comma");
}

TEST(RunIsolated, KillsARunThatIgnoresItsTimeLimit) {
  const auto start = std::chrono::steady_clock::now();
  const RunRecord r = runIsolated(
      [] {
        for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
        return identity();
      },
      0.1, identity(), /*slack_s=*/0.3);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_FALSE(r.solved);
  EXPECT_EQ(r.planner, "p");
  EXPECT_NE(r.invalid_reason.find("did not stop within 0.5 s of its 0.1 s time limit: killed"), std::string::npos)
      << r.invalid_reason;
  EXPECT_LT(waited, 5.0);
}

TEST(RunIsolated, ReportsACrashAndAnException) {
  const RunRecord crashed = runIsolated(
      []() -> RunRecord {
        std::abort();
      },
      1.0, identity());
  EXPECT_FALSE(crashed.solved);
  EXPECT_NE(crashed.invalid_reason.find("crashed: signal 6"), std::string::npos) << crashed.invalid_reason;

  const RunRecord threw = runIsolated([]() -> RunRecord { throw std::invalid_argument("no vehicle block"); }, 1.0,
                                      identity());
  EXPECT_FALSE(threw.solved);
  EXPECT_EQ(threw.invalid_reason, "no vehicle block");
  EXPECT_EQ(threw.scenario, "s");
}

}  // namespace
}  // namespace ddsnav::bench
