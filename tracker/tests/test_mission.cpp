#include "ddsnav/tracker/mission.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <optional>

using namespace ddsnav::tracker;

namespace {

constexpr std::int64_t kSecond = 1'000'000'000;

MissionConfig config() {
  MissionConfig c;
  c.goal = {10, 0, 0};
  c.goal_radius = 1.0;
  c.max_plan_attempts = 3;
  c.plan_retry_delay_s = 1.0;
  c.time_budget_s = 0.5;  // answer timeout 2 * 0.5 + 2 = 3 s
  c.replan_check_period_s = 0.5;
  c.wait_for_world = true;
  return c;
}

VehicleState at(double x, double y = 0.0) {
  VehicleState s;
  s.position = {x, y, 0};
  return s;
}

// A solved answer is an exact path ending at the goal of config() unless `end` says otherwise.
std::optional<PlanAnswer> answer(std::uint32_t id, bool solved, std::string failure = "", Vec3 end = {10, 0, 0},
                                 bool exact = true) {
  PlanAnswer a;
  a.request_id = id;
  a.solved = solved;
  a.failure = std::move(failure);
  if (solved) {
    a.exact = exact;
    a.path_end = end;
  }
  return a;
}

// Starts a mission and returns it with its first request (id 1) sent at t = 0.
Mission started(const MissionConfig& c = config()) {
  Mission m(c);
  const auto d = m.update(0, at(0), true, std::nullopt);
  EXPECT_EQ(d.action, MissionAction::RequestPlan);
  return m;
}

// A status that is neither at the end of the trajectory nor reports the controller's goal.
TrackingStatus midway() {
  TrackingStatus s;
  s.progress = 0.5;
  return s;
}

}  // namespace

TEST(Mission, FirstRequestWaitsForTheVehicleAndTheWorld) {
  Mission m(config());
  EXPECT_EQ(m.update(0, std::nullopt, true, std::nullopt).action, MissionAction::Wait);
  EXPECT_EQ(m.update(1, at(2, 3), false, std::nullopt).action, MissionAction::Wait);  // no world yet
  EXPECT_EQ(m.requestId(), 0u);
  const auto d = m.update(2, at(2, 3), true, std::nullopt);
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  EXPECT_EQ(d.request_id, 1u);
  EXPECT_EQ(d.reason, "start");
  EXPECT_EQ(d.from.position, (Vec3{2, 3, 0}));
  EXPECT_EQ(m.attempts(), 1);
  // Then it waits for the answer.
  EXPECT_EQ(m.update(3, at(2, 3), true, std::nullopt).action, MissionAction::Wait);
}

TEST(Mission, FirstRequestWithoutWaitingForTheWorld) {
  auto c = config();
  c.wait_for_world = false;
  Mission m(c);
  EXPECT_EQ(m.update(0, at(0), false, std::nullopt).action, MissionAction::RequestPlan);
}

TEST(Mission, FailedPlanIsRetriedAfterTheDelayAndCounted) {
  Mission m = started();
  auto d = m.update(kSecond / 10, at(0), true, answer(1, false, "no perception/obstacles received yet"));
  EXPECT_EQ(d.action, MissionAction::Wait);
  EXPECT_EQ(d.warning, "plan 1 failed: no perception/obstacles received yet");  // the planner's reason, passed on
  // Not before the delay (1 s after the failure) ...
  EXPECT_EQ(m.update(kSecond, at(0), true, std::nullopt).action, MissionAction::Wait);
  // ... then from the current state, as request 2 and attempt 2.
  d = m.update(kSecond / 10 + kSecond, at(1), true, std::nullopt);
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  EXPECT_EQ(d.request_id, 2u);
  EXPECT_EQ(d.reason, "retrying");
  EXPECT_EQ(d.from.position.x(), 1.0);
  EXPECT_EQ(m.attempts(), 2);
}

TEST(Mission, AnswersToOtherRequestsAreIgnored) {
  Mission m = started();
  EXPECT_EQ(m.update(kSecond, at(0), true, answer(7, false)).action, MissionAction::Wait);
  EXPECT_EQ(m.update(2 * kSecond, at(0), true, answer(7, true)).action, MissionAction::Wait);
  EXPECT_EQ(m.attempts(), 1);
  EXPECT_EQ(m.update(2 * kSecond, at(0), true, answer(1, true)).action, MissionAction::SmoothPath);
}

TEST(Mission, UnansweredRequestIsRepeatedAfterItsTimeoutAndCounted) {
  Mission m = started();
  EXPECT_DOUBLE_EQ(m.config().answerTimeoutS(), 3.0);
  EXPECT_EQ(m.update(3 * kSecond, at(0), true, std::nullopt).action, MissionAction::Wait);  // not more than 3 s yet
  const auto d = m.update(3 * kSecond + 1000, at(0), true, std::nullopt);
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  EXPECT_EQ(d.request_id, 2u);
  EXPECT_EQ(d.reason, "no answer");
  EXPECT_EQ(d.warning, "plan 1: no answer from the planner");
  EXPECT_EQ(m.attempts(), 2);
}

// On a sped-up clock the planner's wall-time budget lasts longer in mission seconds: the answer timeout
// grows with the clock's speed (at speed 4 a 3 s wall timeout is 12 simulated seconds).
TEST(Mission, AnswerTimeoutFollowsTheClockSpeed) {
  Mission m = started();
  m.setClockSpeed(4.0);
  EXPECT_DOUBLE_EQ(m.config().answerTimeoutS(), 12.0);
  EXPECT_EQ(m.update(11 * kSecond, at(0), true, std::nullopt).action, MissionAction::Wait);
  EXPECT_EQ(m.update(12 * kSecond + 1000, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
  m.setClockSpeed(std::nan(""));  // ignored
  m.setClockSpeed(0.0);           // ignored
  EXPECT_DOUBLE_EQ(m.config().answerTimeoutS(), 12.0);
}

TEST(Mission, GivesUpAfterMaxAttemptsWithoutAnswers) {
  Mission m = started();  // attempt 1 at t = 0
  std::int64_t t = 0;
  for (int attempt = 2; attempt <= 3; ++attempt) {
    t += 3 * kSecond + 1;
    ASSERT_EQ(m.update(t, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
    EXPECT_EQ(m.attempts(), attempt);
  }
  t += 3 * kSecond + 1;
  const auto d = m.update(t, at(0), true, std::nullopt);
  ASSERT_EQ(d.action, MissionAction::Failed);
  EXPECT_EQ(d.reason, "no answer from the planner (planning/path) after 3 attempts");
  EXPECT_EQ(d.warning, "plan 3: no answer from the planner");
  // It stays failed.
  EXPECT_EQ(m.update(t + kSecond, at(0), true, answer(3, true)).action, MissionAction::Failed);
}

TEST(Mission, GivesUpAfterMaxFailedPlans) {
  Mission m = started();
  std::int64_t t = 0;
  for (std::uint32_t id = 1; id < 3; ++id) {
    ASSERT_EQ(m.update(t, at(0), true, answer(id, false)).action, MissionAction::Wait);
    t += kSecond;
    ASSERT_EQ(m.update(t, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
  }
  const auto d = m.update(t, at(0), true, answer(3, false));
  ASSERT_EQ(d.action, MissionAction::Failed);
  EXPECT_EQ(d.reason, "no plan after 3 attempts");
  EXPECT_EQ(d.warning, "plan 3 failed");
}

TEST(Mission, UnsmoothablePathsAreRetriedAndEndTheMissionAfterMaxAttempts) {
  Mission m = started();
  std::int64_t t = 0;
  for (std::uint32_t id = 1; id <= 3; ++id) {
    ASSERT_EQ(m.update(t, at(0), true, answer(id, true)).action, MissionAction::SmoothPath);
    const auto d = m.pathSmoothed(t, at(0), false);
    if (id == 3) {
      ASSERT_EQ(d.action, MissionAction::Failed);
      EXPECT_EQ(d.reason, "no drivable trajectory after 3 attempts");
      break;
    }
    ASSERT_EQ(d.action, MissionAction::Wait);
    t += kSecond;
    ASSERT_EQ(m.update(t, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
  }
  EXPECT_FALSE(m.driving());
}

// Plan 1 refused (the retry due at once), its retry refused too (due after plan_retry_delay_s, 1 s), plan 3 flown.
void refusedTwiceThenFlown(Mission& m, bool retry_at_once) {
  ASSERT_EQ(m.update(0, at(0), true, answer(1, true)).action, MissionAction::SmoothPath);
  ASSERT_EQ(m.pathSmoothed(0, at(0), false, retry_at_once).action, MissionAction::Wait);
  EXPECT_TRUE(m.retryDue(1));  // what a tracker braking to its rest point asks before it calls update()
  const auto again = m.update(1, at(0), true, std::nullopt);
  ASSERT_EQ(again.action, MissionAction::RequestPlan);
  EXPECT_EQ(again.reason, "retrying");
  ASSERT_EQ(m.update(2, at(0), true, answer(2, true)).action, MissionAction::SmoothPath);
  ASSERT_EQ(m.pathSmoothed(2, at(0), false, retry_at_once).action, MissionAction::Wait);
  EXPECT_FALSE(m.retryDue(kSecond / 2));
  EXPECT_TRUE(m.retryDue(kSecond + 2));
  EXPECT_EQ(m.update(kSecond / 2, at(0), true, std::nullopt).action, MissionAction::Wait);
  ASSERT_EQ(m.update(kSecond + 2, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
  ASSERT_EQ(m.update(kSecond + 3, at(0), true, answer(3, true)).action, MissionAction::SmoothPath);
  ASSERT_EQ(m.pathSmoothed(kSecond + 3, at(0), true).action, MissionAction::Drive);
  ASSERT_EQ(m.replan(2 * kSecond, at(0), "trajectory_blocked").action, MissionAction::RequestPlan);
  ASSERT_EQ(m.update(2 * kSecond, at(0), true, answer(4, true)).action, MissionAction::SmoothPath);
  ASSERT_EQ(m.pathSmoothed(2 * kSecond, at(0), false).action, MissionAction::Wait);
}

// A refused path (a collision on the tracker's newer world) is asked again at once the first time; a second refusal in
// a row waits the retry delay; a drivable trajectory starts the count again.
TEST(Mission, TheFirstRefusedPathInARowIsAskedAgainAtOnce) {
  Mission m = started();
  ASSERT_NO_FATAL_FAILURE(refusedTwiceThenFlown(m, /*retry_at_once=*/false));
  EXPECT_EQ(m.update(2 * kSecond + 1, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
}

// With a refused-retry delay (the component's 0.2 s, for the planner to build the tracker's newer map), a path refused
// for the vehicle's speed at its start is still asked again at once; a second refusal in a row waits plan_retry_delay_s.
TEST(Mission, APathRefusedForTheVehiclesSpeedIsAskedAgainWithoutTheMapsDelay) {
  MissionConfig c = config();
  c.refused_retry_delay_s = 0.2;
  Mission m = started(c);
  ASSERT_NO_FATAL_FAILURE(refusedTwiceThenFlown(m, /*retry_at_once=*/true));
  // The last refusal, which no speed explains (a collision on the tracker's newer map), waits the delay.
  EXPECT_FALSE(m.retryDue(2 * kSecond + kSecond / 10));
  EXPECT_TRUE(m.retryDue(2 * kSecond + kSecond / 5 + 1));
}

TEST(Mission, DrivableTrajectoryResetsTheAttempts) {
  Mission m = started();
  ASSERT_EQ(m.update(0, at(0), true, answer(1, false)).action, MissionAction::Wait);
  ASSERT_EQ(m.update(kSecond, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
  EXPECT_EQ(m.attempts(), 2);
  ASSERT_EQ(m.update(kSecond, at(0), true, answer(2, true)).action, MissionAction::SmoothPath);
  EXPECT_EQ(m.pathSmoothed(kSecond, at(0), true).action, MissionAction::Drive);
  EXPECT_EQ(m.attempts(), 0);
  EXPECT_TRUE(m.driving());
  // While driving, no answer timeout applies.
  EXPECT_EQ(m.update(100 * kSecond, at(0), true, std::nullopt).action, MissionAction::Drive);
}

// A replan asked while a failed attempt waits for its retry supersedes the retry: once its trajectory is
// adopted, the stale retry must not ask again (gart_cluttered_2d, 2026-12-03: a stop-and-replan's trajectory was
// dropped for a "retrying" request 50 ms after it was ready, three times in one mission).
TEST(Mission, ANewRequestSupersedesAPendingRetry) {
  Mission m = started();
  ASSERT_EQ(m.update(0, at(0), true, answer(1, true)).action, MissionAction::SmoothPath);
  ASSERT_EQ(m.pathSmoothed(0, at(0), false).action, MissionAction::Wait);  // retry due at 1 s
  const auto replan = m.replan(kSecond / 2, at(0), "rest_start");
  ASSERT_EQ(replan.action, MissionAction::RequestPlan);
  ASSERT_EQ(replan.request_id, 2u);
  ASSERT_EQ(m.update(2 * kSecond, at(0), true, answer(2, true)).action, MissionAction::SmoothPath);
  EXPECT_EQ(m.pathSmoothed(2 * kSecond, at(0), true).action, MissionAction::Drive);
  EXPECT_FALSE(m.awaitingPlan());
  EXPECT_EQ(m.update(3 * kSecond, at(0), true, std::nullopt).action, MissionAction::Drive);
}

TEST(Mission, GoalRegionEndsTheMission) {
  Mission m = started();
  m.update(0, at(0), true, answer(1, true));
  ASSERT_EQ(m.pathSmoothed(0, at(0), true).action, MissionAction::Drive);
  auto near_end = midway();
  near_end.progress = 0.97;
  // Inside the goal region but not near the end of the trajectory, or near the end but outside: go on.
  auto before_end = midway();
  before_end.progress = 0.94;
  EXPECT_NE(m.tracked(0, at(9.5), before_end, 0.05).action, MissionAction::Finished);
  EXPECT_NE(m.tracked(0, at(8.5), near_end, 0.05).action, MissionAction::Finished);
  EXPECT_FALSE(m.finished());
  EXPECT_EQ(m.tracked(0, at(9.5), near_end, 0.05).action, MissionAction::Finished);
  EXPECT_TRUE(m.finished());
  // Finished stays finished, whatever arrives.
  EXPECT_EQ(m.update(kSecond, at(9.5), true, answer(1, false)).action, MissionAction::Finished);
}

// Issue 13 row 5: the end of the trajectory is not the goal. The controller finished 5 m short of the goal
// region: no success, a new request from where the vehicle is; after max_plan_attempts such ends, failure.
TEST(Mission, TrajectoryEndOutsideTheGoalRegionIsNoSuccess) {
  Mission m = started();
  m.update(0, at(0), true, answer(1, true));
  m.pathSmoothed(0, at(0), true);
  auto done = midway();
  done.goal_reached = true;
  done.progress = 1.0;
  auto d = m.tracked(kSecond, at(5), done, 0.05);
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  EXPECT_FALSE(m.finished());
  EXPECT_FALSE(m.driving());
  EXPECT_EQ(d.request_id, 2u);
  EXPECT_EQ(d.from.position, (Vec3{5, 0, 0}));
  EXPECT_EQ(d.warning, "trajectory 1 ended but the vehicle is 5.00 m from the goal, outside the 1.00 m goal region");
  for (std::uint32_t id = 2; id <= 3; ++id) {
    ASSERT_EQ(m.update(2 * kSecond, at(5), true, answer(id, true)).action, MissionAction::SmoothPath);
    ASSERT_EQ(m.pathSmoothed(2 * kSecond, at(5), true).action, MissionAction::Drive);
    d = m.tracked(3 * kSecond, at(5), done, 0.05);
  }
  ASSERT_EQ(d.action, MissionAction::Failed);
  EXPECT_EQ(d.reason, "goal not reached: 3 trajectories ended outside the goal region; last: the vehicle is 5.00 m from the goal, outside the 1.00 m goal region");
  EXPECT_FALSE(m.finished());
  EXPECT_EQ(m.update(4 * kSecond, at(5), true, std::nullopt).action, MissionAction::Failed);
}

// Issue 13 row 5: a "solved" path that ends short of the goal (or is marked inexact) is a failed attempt.
TEST(Mission, SolvedPathThatStopsShortOfTheGoalIsAFailedAttempt) {
  Mission m = started();
  auto d = m.update(0, at(0), true, answer(1, true, "", {-28, 0, 0}));
  EXPECT_EQ(d.action, MissionAction::Wait);
  EXPECT_EQ(d.warning, "plan 1 is solved but does not reach the goal region: it ends 38.00 m from the goal (goal radius 1.00 m)");
  ASSERT_EQ(m.update(kSecond, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
  d = m.update(kSecond, at(0), true, answer(2, true, "", {10, 0.5, 0}, /*exact=*/false));
  EXPECT_EQ(d.action, MissionAction::Wait);
  EXPECT_EQ(d.warning, "plan 2 is solved but does not reach the goal region: the planner marks it approximate (exact = false)");
  ASSERT_EQ(m.update(2 * kSecond, at(0), true, std::nullopt).action, MissionAction::RequestPlan);
  PlanAnswer empty;
  empty.request_id = 3;
  empty.solved = true;
  empty.exact = true;
  d = m.update(2 * kSecond, at(0), true, empty);
  ASSERT_EQ(d.action, MissionAction::Failed);
  EXPECT_EQ(d.reason, "no plan to the goal region after 3 attempts");
  EXPECT_EQ(d.warning, "plan 3 is solved but does not reach the goal region: it has no states");
  EXPECT_FALSE(m.driving());
}

TEST(Mission, GoalCheckUsesTheTruePosition) {
  EXPECT_TRUE(checkGoal({10, 0, 0}, 1.0, Vec3{9.5, 0.5, 0}).reached);
  const auto far = checkGoal({10, 0, 0}, 1.5, Vec3{-28, 0, 0});
  EXPECT_FALSE(far.reached);
  EXPECT_DOUBLE_EQ(far.distance, 38.0);
  EXPECT_EQ(far.why, "the vehicle is 38.00 m from the goal, outside the 1.50 m goal region");
  const auto none = checkGoal({10, 0, 0}, 1.5, std::nullopt);
  EXPECT_FALSE(none.reached);
  EXPECT_EQ(none.why, "no vehicle position was received");
  EXPECT_FALSE(checkGoal({10, 0, 0}, 1.5, Vec3{std::nan(""), 0, 0}).reached);
}

TEST(Mission, PeriodicReplanCheckAndReplan) {
  Mission m = started();
  m.update(0, at(0), true, answer(1, true));
  ASSERT_EQ(m.pathSmoothed(0, at(0), true).action, MissionAction::Drive);
  // Control period 0.1 s, check period 0.5 s: the 5th step checks (0.1 * 5 may round below 0.5: at most a 6th).
  int steps = 0;
  MissionAction a = MissionAction::Drive;
  while (a == MissionAction::Drive && steps < 20) {
    a = m.tracked(0, at(1), midway(), 0.1).action;
    ++steps;
  }
  EXPECT_EQ(a, MissionAction::CheckReplan);
  EXPECT_GE(steps, 5);
  EXPECT_LE(steps, 6);
  // The check found a reason: a new request from the current state, driving stops until it is answered.
  const auto d = m.replan(3 * kSecond, at(2, 1), "cross-track error 1.2 m > 1 m");
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  EXPECT_EQ(d.request_id, 2u);
  EXPECT_EQ(d.reason, "cross-track error 1.2 m > 1 m");
  EXPECT_EQ(d.from.position, (Vec3{2, 1, 0}));
  EXPECT_FALSE(m.driving());
  EXPECT_EQ(m.attempts(), 1);
  EXPECT_EQ(m.update(3 * kSecond + 1, at(2, 1), true, std::nullopt).action, MissionAction::Wait);
  // The counter restarted: the next check is a full period later.
  m.update(4 * kSecond, at(2, 1), true, answer(2, true));
  ASSERT_EQ(m.pathSmoothed(4 * kSecond, at(2, 1), true).action, MissionAction::Drive);
  EXPECT_EQ(m.tracked(0, at(2, 1), midway(), 0.1).action, MissionAction::Drive);
}

// A shorter route asked while the vehicle flies on (improveAhead) is optional: its failure, in every form, changes
// nothing — no attempt counted, no retry, the vehicle drives on — and a required replan supersedes it.
TEST(Mission, AnOptionalPlanThatFailsChangesNothing) {
  Mission m = started();
  m.update(0, at(0), true, answer(1, true));
  ASSERT_EQ(m.pathSmoothed(0, at(0), true).action, MissionAction::Drive);
  // Unsolved.
  auto d = m.improveAhead(kSecond, at(2), "shorter_route");
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  EXPECT_EQ(d.request_id, 2u);
  EXPECT_EQ(m.attempts(), 0);
  EXPECT_TRUE(m.improving());
  EXPECT_TRUE(m.awaitingPlan());
  EXPECT_FALSE(m.awaitingRequiredPlan());
  d = m.update(kSecond, at(2), true, answer(2, false, "no path within the budget"));
  EXPECT_EQ(d.action, MissionAction::Drive);
  EXPECT_TRUE(d.warning.empty());
  EXPECT_NE(d.note.find("no path within the budget"), std::string::npos) << d.note;
  EXPECT_FALSE(m.awaitingPlan());
  EXPECT_EQ(m.update(10 * kSecond, at(3), true, std::nullopt).action, MissionAction::Drive);  // no retry comes
  // Solved, but not to the goal region.
  ASSERT_EQ(m.improveAhead(11 * kSecond, at(3), "shorter_route").request_id, 3u);
  EXPECT_EQ(m.update(11 * kSecond, at(3), true, answer(3, true, "", {5, 0, 0})).action, MissionAction::Drive);
  EXPECT_FALSE(m.awaitingPlan());
  // Solved, but its trajectory not taken (not shorter, or not smoothable).
  ASSERT_EQ(m.improveAhead(12 * kSecond, at(3), "shorter_route").request_id, 4u);
  ASSERT_EQ(m.update(12 * kSecond, at(3), true, answer(4, true)).action, MissionAction::SmoothPath);
  EXPECT_EQ(m.pathSmoothed(12 * kSecond, at(3), false).action, MissionAction::Drive);
  EXPECT_FALSE(m.awaitingPlan());
  EXPECT_EQ(m.update(20 * kSecond, at(3), true, std::nullopt).action, MissionAction::Drive);
  // Lost: dropped after the answer timeout (3 s), not asked again.
  ASSERT_EQ(m.improveAhead(21 * kSecond, at(3), "shorter_route").request_id, 5u);
  EXPECT_EQ(m.update(25 * kSecond, at(3), true, std::nullopt).action, MissionAction::Drive);
  EXPECT_FALSE(m.awaitingPlan());
  EXPECT_EQ(m.attempts(), 0);
  // A required replan supersedes a pending optional one; the optional one's late answer is ignored.
  ASSERT_EQ(m.improveAhead(26 * kSecond, at(3), "shorter_route").request_id, 6u);
  const auto replan = m.replanAhead(26 * kSecond, at(4), "trajectory_blocked");
  ASSERT_EQ(replan.request_id, 7u);
  EXPECT_FALSE(m.improving());
  EXPECT_TRUE(m.awaitingRequiredPlan());
  EXPECT_EQ(m.attempts(), 1);
  EXPECT_EQ(m.update(26 * kSecond, at(4), true, answer(6, true)).action, MissionAction::Drive);
  // Its failure is an attempt as ever: retried after the delay.
  EXPECT_EQ(m.update(26 * kSecond, at(4), true, answer(7, false)).action, MissionAction::Wait);
  EXPECT_EQ(m.update(27 * kSecond + 1, at(4), true, std::nullopt).action, MissionAction::RequestPlan);
}

TEST(Mission, AnOptionalPlanTakenIsFlownLikeAnyOther) {
  Mission m = started();
  m.update(0, at(0), true, answer(1, true));
  ASSERT_EQ(m.pathSmoothed(0, at(0), true).action, MissionAction::Drive);
  // Not while stopped, nor while another request is awaited.
  Mission idle = started();
  EXPECT_EQ(idle.improveAhead(0, at(0), "shorter_route").action, MissionAction::Drive);
  EXPECT_EQ(idle.requestId(), 1u);
  ASSERT_EQ(m.improveAhead(kSecond, at(1), "shorter_route").action, MissionAction::RequestPlan);
  EXPECT_EQ(m.improveAhead(kSecond, at(1), "shorter_route").action, MissionAction::Drive);  // one at a time
  EXPECT_EQ(m.requestId(), 2u);
  ASSERT_EQ(m.update(kSecond, at(1), true, answer(2, true)).action, MissionAction::SmoothPath);
  EXPECT_EQ(m.pathSmoothed(kSecond, at(1), true).action, MissionAction::Drive);
  EXPECT_FALSE(m.improving());
  EXPECT_FALSE(m.awaitingPlan());
}

TEST(Mission, RejectsABadConfig) {
  auto c = config();
  c.max_plan_attempts = 0;
  EXPECT_THROW(Mission{c}, std::invalid_argument);
  c = config();
  c.replan_check_period_s = 0;
  EXPECT_THROW(Mission{c}, std::invalid_argument);
}
