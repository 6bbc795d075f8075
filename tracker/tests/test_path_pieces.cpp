// A long path smoothed a piece at a time: where it is split, and the path that continues a trajectory.

#include "ddsnav/planner/tree.hpp"
#include "ddsnav/tracker/path_pieces.hpp"
#include "ddsnav/tracker/smoother.hpp"
#include "test_worlds.hpp"

#include <gtest/gtest.h>

using namespace ddsnav;
using namespace ddsnav::tracker;
using ddsnav::tracker::testing::pathOf;
using ddsnav::tracker::testing::scenario2d;

namespace {

TEST(SplitPath, CutsAtTheGivenArcLengthOnTheEdgeThatReachesIt) {
  const auto path = pathOf({{0, 0, 0}, {100, 0, 0}, {100, 100, 0}, {0, 100, 0}});  // 300 m
  const PathPieces pieces = splitPath(path, 150.0);
  ASSERT_EQ(pieces.piece.size(), 3u);
  EXPECT_NEAR(planner::pathLength(pieces.piece), 150.0, 1e-9);
  EXPECT_TRUE(pieces.piece.back().position.isApprox(Vec3(100, 50, 0)));
  ASSERT_EQ(pieces.rest.size(), 3u);
  EXPECT_EQ(pieces.rest.front().position, pieces.piece.back().position);
  EXPECT_NEAR(planner::pathLength(pieces.rest), 150.0, 1e-9);
  EXPECT_EQ(pieces.rest.back().position, path.back().position);
}

TEST(SplitPath, ACutAtAStateStartsTheRestThereWithoutACopy) {
  const auto path = pathOf({{0, 0, 0}, {100, 0, 0}, {100, 100, 0}, {0, 100, 0}});
  const PathPieces pieces = splitPath(path, 100.0);
  ASSERT_EQ(pieces.piece.size(), 2u);
  ASSERT_EQ(pieces.rest.size(), 3u);
  EXPECT_EQ(pieces.rest[0].position, Vec3(100, 0, 0));
  EXPECT_EQ(pieces.rest[1].position, Vec3(100, 100, 0));
}

TEST(SplitPath, AShortPathOrNoPieceLengthIsTheWholePath) {
  const auto path = pathOf({{0, 0, 0}, {100, 0, 0}, {100, 100, 0}, {0, 100, 0}});
  for (const double piece_length : {200.0, 1000.0, 0.0, -1.0}) {
    const PathPieces pieces = splitPath(path, piece_length);
    EXPECT_EQ(pieces.piece.size(), path.size()) << piece_length;
    EXPECT_TRUE(pieces.rest.empty()) << piece_length;
  }
}

// The continuation of a trajectory from a time on it: the trajectory's own positions first (spaced), then the
// rest of the planner's path; smoothed from that sample's speed and heading, it begins where the vehicle will be.
TEST(ContinuationPath, FollowsTheTrajectoryFromTheSwitchThenTheRest) {
  const auto sc = scenario2d(400, 0.3, "  - {type: box, min: [140, 10], max: [160, 30]}\n", 2.0, 0.5);
  const auto world = planner::makeScenarioWorld(sc);
  const auto path = pathOf({{5, 5, 0}, {100, 5, 0}, {140, 60, 0}, {300, 60, 0}, {300, 300, 0}});
  const PathPieces pieces = splitPath(path, 150.0);
  ASSERT_FALSE(pieces.rest.empty());
  const Trajectory first = smoothPath(pieces.piece, *world, *sc.vehicle);
  EXPECT_NEAR(first.samples.back().position.x(), pieces.piece.back().position.x(), 1e-6);

  const double switch_time = 0.5 * first.duration();
  const TrajectorySample at_switch = first.at(switch_time);
  const auto continuation = continuationPath(first, switch_time, pieces.rest, 1.0);
  EXPECT_TRUE(continuation.front().position.isApprox(at_switch.position));
  for (std::size_t i = 1; i + 1 < continuation.size() && continuation[i].position != pieces.rest.front().position; ++i)
    EXPECT_GE((continuation[i].position - continuation[i - 1].position).norm(), 1.0 - 1e-9) << i;
  EXPECT_EQ(continuation.back().position, path.back().position);
  EXPECT_EQ(std::count_if(continuation.begin(), continuation.end(),
                          [&](const planner::State& s) { return s.position == pieces.rest.front().position; }),
            1);

  SmootherConfig moving;
  moving.initial_heading = at_switch.heading;
  moving.initial_speed = at_switch.speed;
  const Trajectory next = smoothPath(continuation, *world, *sc.vehicle, moving);
  EXPECT_TRUE(next.samples.front().position.isApprox(at_switch.position, 1e-9));
  EXPECT_NEAR(next.samples.front().speed, at_switch.speed, 1e-6);
  EXPECT_NEAR(next.samples.back().position.y(), 300.0, 1e-6);
  EXPECT_EQ(next.report.samples_in_collision, 0u);
}

}  // namespace
