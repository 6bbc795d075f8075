// Latencies of a mission recording, on hand-made receipts.
#include "ddsnav/nodes/mission_latency.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace ddsnav;

namespace {

constexpr std::uint64_t kMs = 1'000'000;

TEST(MissionLatency, StatsAreMedianAndNearestRankP99) {
  std::vector<double> values;
  for (int i = 1; i <= 200; ++i) values.push_back(i);
  const auto s = nodes::latencyStats(values);
  EXPECT_EQ(s.count, 200u);
  EXPECT_DOUBLE_EQ(s.median_ms, 100.5);
  EXPECT_DOUBLE_EQ(s.p99_ms, 198.0);
  EXPECT_DOUBLE_EQ(s.max_ms, 200.0);
  EXPECT_TRUE(std::isnan(nodes::latencyStats({}).median_ms));
  EXPECT_DOUBLE_EQ(nodes::latencyStats({7.0}).p99_ms, 7.0);
}

TEST(MissionLatency, EffectsAreTiedToTheirCausesByKey) {
  nodes::MissionRecording r;
  // Clouds stamped 100, 200, 300 received at 10, 20, 30 ms; obstacles of 100 and 300 at 15 and 42 ms, a
  // duplicate of 100 later (not a new effect), and one of a cloud never recorded (skipped).
  r.clouds = {{10 * kMs, 100}, {20 * kMs, 200}, {30 * kMs, 300}};
  r.obstacles = {{15 * kMs, 100}, {42 * kMs, 300}, {90 * kMs, 100}, {95 * kMs, 999}};
  r.maps = {{1020 * kMs, 300}};
  // Request 1 (first plan), 2 and 3 (replans); paths 1 and 2 answer; trajectory 2 at 150 ms, 3 never.
  r.requests = {{5 * kMs, 1}, {100 * kMs, 2}, {200 * kMs, 3}};
  r.paths = {{50 * kMs, 1}, {120 * kMs, 2}};
  r.trajectories = {{60 * kMs, 1}, {150 * kMs, 2}};
  const auto l = nodes::missionLatencies(r);
  EXPECT_EQ(l.cloud_to_obstacles.count, 2u);
  EXPECT_DOUBLE_EQ(l.cloud_to_obstacles.median_ms, 8.5);  // 5 and 12 ms
  EXPECT_DOUBLE_EQ(l.cloud_to_obstacles.max_ms, 12.0);
  EXPECT_EQ(l.cloud_to_map.count, 1u);
  EXPECT_DOUBLE_EQ(l.cloud_to_map.median_ms, 990.0);
  EXPECT_EQ(l.request_to_path.count, 2u);
  EXPECT_DOUBLE_EQ(l.request_to_path.max_ms, 45.0);
  // The replan of request 2: newest obstacles before 100 ms arrived at 95 ms; its trajectory at 150 ms.
  ASSERT_EQ(l.obstacles_to_trajectory.count, 1u);
  EXPECT_DOUBLE_EQ(l.obstacles_to_trajectory.median_ms, 55.0);
  // ... split: 5 ms to the request, 20 ms to its path, 30 ms of smoothing.
  EXPECT_DOUBLE_EQ(l.replan_obstacles_to_request.median_ms, 5.0);
  EXPECT_DOUBLE_EQ(l.replan_request_to_path.median_ms, 20.0);
  EXPECT_DOUBLE_EQ(l.replan_path_to_trajectory.median_ms, 30.0);
  // ... and on its own, with no map before it (the only one came at 1020 ms).
  ASSERT_EQ(l.replans.size(), 1u);
  EXPECT_EQ(l.replans[0].request_id, 2);
  EXPECT_DOUBLE_EQ(l.replans[0].obstacles_to_trajectory_ms, 55.0);
  EXPECT_DOUBLE_EQ(l.replans[0].obstacles_to_request_ms, 5.0);
  EXPECT_TRUE(std::isnan(l.replans[0].map_to_request_ms));
  EXPECT_TRUE(l.replans[0].answered_by_own_trajectory);
}

TEST(MissionLatency, EachReplanSaysHowLongAfterTheNewestMapItWasAsked) {
  nodes::MissionRecording r;
  r.obstacles = {{10 * kMs, 1}, {110 * kMs, 2}};
  r.maps = {{150 * kMs, 1}, {400 * kMs, 2}};
  r.requests = {{5 * kMs, 1}, {230 * kMs, 2}};  // the replan 80 ms after a map, 120 ms after the newest obstacles
  r.trajectories = {{20 * kMs, 1}, {260 * kMs, 2}};
  const auto l = nodes::missionLatencies(r);
  ASSERT_EQ(l.replans.size(), 1u);
  EXPECT_DOUBLE_EQ(l.replans[0].obstacles_to_request_ms, 120.0);
  EXPECT_DOUBLE_EQ(l.replans[0].map_to_request_ms, 80.0);
  EXPECT_DOUBLE_EQ(l.replans[0].obstacles_to_trajectory_ms, 150.0);
}

TEST(MissionLatency, OnlyReplansForABlockedTrajectoryAnswerAChange) {
  nodes::MissionRecording r;
  r.obstacles = {{90 * kMs, 1}, {190 * kMs, 2}};
  r.requests = {{5 * kMs, 1}, {100 * kMs, 2}, {200 * kMs, 3}};
  r.paths = {{50 * kMs, 1}, {120 * kMs, 2}, {230 * kMs, 3}};
  r.trajectories = {{60 * kMs, 1}, {150 * kMs, 2}, {260 * kMs, 3}};
  // Request 2 retried a failed plan; request 3 answered a blocked trajectory.
  r.request_reasons = {{1, "first plan"}, {2, "retrying"}, {3, "trajectory_blocked: sample at t=3 s ..."}};
  const auto l = nodes::missionLatencies(r);
  ASSERT_EQ(l.obstacles_to_trajectory.count, 1u);
  EXPECT_DOUBLE_EQ(l.obstacles_to_trajectory.median_ms, 70.0);
}

TEST(MissionLatency, AReplanWhosePlanCouldNotBeFlownCountsUntilALaterPlansTrajectory) {
  nodes::MissionRecording r;
  r.obstacles = {{90 * kMs, 1}, {490 * kMs, 2}};
  // Request 2 (blocked) got a path but no trajectory (it could not be smoothed); request 3 retried it and was answered
  // at 420 ms. Request 4 (blocked) was answered by its own trajectory.
  r.requests = {{5 * kMs, 1}, {100 * kMs, 2}, {400 * kMs, 3}, {500 * kMs, 4}};
  r.paths = {{50 * kMs, 1}, {120 * kMs, 2}, {410 * kMs, 3}, {530 * kMs, 4}};
  r.trajectories = {{60 * kMs, 1}, {420 * kMs, 3}, {550 * kMs, 4}};
  r.request_reasons = {{1, "start"}, {2, "trajectory_blocked: ..."}, {3, "retrying"}, {4, "trajectory_blocked: ..."}};
  const auto l = nodes::missionLatencies(r);
  ASSERT_EQ(l.obstacles_to_trajectory.count, 2u);
  EXPECT_DOUBLE_EQ(l.obstacles_to_trajectory.max_ms, 330.0);  // 90 -> 420 ms
  EXPECT_DOUBLE_EQ(l.obstacles_to_trajectory.median_ms, 195.0);  // with 490 -> 550 ms
  EXPECT_EQ(l.replans_answered_later, 1u);
  // The parts only over request 4's own answer: 10, 30 and 20 ms.
  ASSERT_EQ(l.replan_request_to_path.count, 1u);
  EXPECT_DOUBLE_EQ(l.replan_obstacles_to_request.median_ms, 10.0);
  EXPECT_DOUBLE_EQ(l.replan_request_to_path.median_ms, 30.0);
  EXPECT_DOUBLE_EQ(l.replan_path_to_trajectory.median_ms, 20.0);
}

}  // namespace
