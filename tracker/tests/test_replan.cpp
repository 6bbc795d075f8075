// The replan decision: hysteresis (consecutive checks or an overlap margin), the horizon, the start
// predicted along the trajectory by the expected planning time, and the mission flying on meanwhile.
#include "ddsnav/tracker/mission.hpp"
#include "ddsnav/tracker/replan.hpp"
#include "ddsnav/tracker/smoother.hpp"
#include "test_worlds.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <numbers>
#include <stdexcept>

namespace ddsnav::tracker {
namespace {

using testing::pathOf;
using testing::scenario2d;

struct Straight {
  planner::Scenario sc = scenario2d(60, 0.3, "");
  std::unique_ptr<planner::CollisionWorld> world = planner::makeScenarioWorld(sc);
  Trajectory trajectory = smoothPath(pathOf({{1, 5, 0}, {55, 5, 0}}), *world, *sc.vehicle);
};

// A check result as TrajectoryTracker::checkReplan gives it for a sample `ahead` s away overlapping by `overlap` m.
ReplanDecision blocked(double ahead, double overlap) {
  ReplanDecision d;
  d.needed = true;
  d.reason = ReplanReason::TrajectoryBlocked;
  d.message = "sample blocked";
  d.time_ahead = ahead;
  d.penetration = overlap;
  return d;
}

TEST(ReplanGate, AGrazingBlockNeedsConsecutiveChecks) {
  Straight s;
  ReplanPolicy policy;
  policy.confirm_checks = 2;  // block_margin 0.2 m as by default
  ReplanGate gate(policy);
  EXPECT_EQ(gate.check(blocked(20, 0.05), s.trajectory, 0).action, ReplanAction::Continue);
  EXPECT_EQ(gate.check({}, s.trajectory, 0.1).action, ReplanAction::Continue);  // it went away: start over
  EXPECT_EQ(gate.check(blocked(20, 0.05), s.trajectory, 0.2).action, ReplanAction::Continue);
  const auto v = gate.check(blocked(20, 0.05), s.trajectory, 0.3);
  EXPECT_EQ(v.action, ReplanAction::ReplanAhead);
  EXPECT_NE(v.reason.find("trajectory_blocked"), std::string::npos);
  EXPECT_NE(v.reason.find("2 consecutive checks"), std::string::npos);
}

// A grazing block the vehicle must stop for (1 s ahead: less than the 0.3 s planning + 1.5 s margin) is confirmed
// by near_confirm_checks (2), not confirm_checks (5): waiting half a second at speed eats the stopping distance.
TEST(ReplanGate, AGrazingBlockTooNearToPlanAheadOfNeedsFewerChecks) {
  Straight s;
  ReplanGate gate;
  EXPECT_EQ(gate.check(blocked(1.0, 0.05), s.trajectory, 0).action, ReplanAction::Continue);
  const auto v = gate.check(blocked(0.9, 0.05), s.trajectory, 0.1);
  EXPECT_EQ(v.action, ReplanAction::StopAndReplan);
  EXPECT_NE(v.reason.find("2 consecutive checks"), std::string::npos);
  // Never more than the far blocks need; a far grazing block still needs all five.
  ReplanPolicy one;
  one.confirm_checks = 1;
  EXPECT_EQ(ReplanGate(one).check(blocked(1.0, 0.05), s.trajectory, 0).action, ReplanAction::StopAndReplan);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(gate.check(blocked(20, 0.05), s.trajectory, 0.2).action, ReplanAction::Continue);
  EXPECT_EQ(gate.check(blocked(20, 0.05), s.trajectory, 0.2).action, ReplanAction::ReplanAhead);
  ReplanPolicy bad;
  bad.near_confirm_checks = 0;
  EXPECT_THROW(ReplanGate{bad}, std::invalid_argument);
}

TEST(ReplanGate, ADeepOverlapIsConfirmedAtOnce) {
  Straight s;
  ReplanGate gate;
  const auto v = gate.check(blocked(20, 0.5), s.trajectory, 0);
  EXPECT_EQ(v.action, ReplanAction::ReplanAhead);
  EXPECT_NE(v.reason.find("overlap beyond the margin"), std::string::npos);
}

TEST(ReplanGate, StartIsPredictedByTheExpectedPlanningTime) {
  Straight s;
  ReplanPolicy policy;
  policy.planning_time_s = 0.5;
  ReplanGate gate(policy);
  EXPECT_DOUBLE_EQ(gate.expectedPlanningTime(), 0.5);
  auto v = gate.check(blocked(20, 1.0), s.trajectory, 3.0);
  ASSERT_EQ(v.action, ReplanAction::ReplanAhead);
  EXPECT_NEAR(v.start.time, 3.5, 0.06);
  EXPECT_NEAR((v.start.position - s.trajectory.at(3.5).position).norm(), 0.0, 1e-9);
  // Slow plans move the prediction: 1.25 x the second longest of the recent ones (the longest while there is one).
  gate.planReady(2.0);
  EXPECT_DOUBLE_EQ(gate.expectedPlanningTime(), 2.5);
  gate.planReady(0.4);
  EXPECT_DOUBLE_EQ(gate.expectedPlanningTime(), 0.5);  // one slow plan is an outlier
  gate.planReady(2.0);
  EXPECT_DOUBLE_EQ(gate.expectedPlanningTime(), 2.5);  // two are the rule
  v = gate.check(blocked(20, 1.0), s.trajectory, 3.0);
  ASSERT_EQ(v.action, ReplanAction::ReplanAhead);
  EXPECT_NEAR(v.start.time, 5.5, 0.06);
}

TEST(ReplanGate, ABlockTooCloseStopsTheVehicle) {
  Straight s;
  ReplanGate gate;  // 0.3 s planning + 1.5 s margin
  EXPECT_EQ(gate.check(blocked(1.0, 1.0), s.trajectory, 0).action, ReplanAction::StopAndReplan);
  ReplanDecision deviation;
  deviation.needed = true;
  deviation.reason = ReplanReason::Deviation;
  deviation.message = "cross-track error 1.2 m";
  const auto v = gate.check(deviation, s.trajectory, 0);
  EXPECT_EQ(v.action, ReplanAction::StopAndReplan);
  EXPECT_EQ(v.reason.rfind("deviation: ", 0), 0u);
}

TEST(ReplanGate, OnlyTheHorizonIsChecked) {
  // An obstacle 12 s ahead on the trajectory: outside a 5 s horizon nothing is blocked, inside 20 s it is.
  Straight s;
  const auto block = planner::makeScenarioWorld(scenario2d(60, 0.3, "  - {type: sphere, center: [13, 5], radius: 1}\n"));
  const double t_block = [&] {
    for (const auto& sample : s.trajectory.samples)
      if (!block->isFree(sample.position)) return sample.time;
    return -1.0;
  }();
  ASSERT_GT(t_block, 5.5);
  TrackerConfig near_config;
  near_config.replan_horizon = 5.0;
  TrajectoryTracker near(s.trajectory, *s.sc.vehicle, near_config);
  EXPECT_FALSE(near.checkReplan(*block).needed);
  TrackerConfig far_config;
  far_config.replan_horizon = 20.0;
  TrajectoryTracker far(s.trajectory, *s.sc.vehicle, far_config);
  const auto d = far.checkReplan(*block);
  ASSERT_TRUE(d.needed);
  EXPECT_NEAR(d.time_ahead, t_block, 1e-9);
  EXPECT_GT(d.penetration, 0.5);  // the sample is inside the 1 m sphere
  ReplanGate gate;
  EXPECT_EQ(gate.check(d, s.trajectory, 0).action, ReplanAction::ReplanAhead);
  // The caller's planning time widens a short horizon (never narrows one): a slow plan needs the block
  // seen earlier.
  EXPECT_TRUE(near.checkReplan(*block, t_block + 1.0).needed);
  EXPECT_FALSE(near.checkReplan(*block, 2.0).needed);
  EXPECT_TRUE(far.checkReplan(*block, 2.0).needed);
}

TEST(ReplanGate, ADistanceHorizonReachesAsFarAsTheSensor) {
  // The same obstacle, 12 s ahead: a 5 s horizon alone misses it; with a distance horizon that reaches past
  // it along the trajectory (the sensor's range) it is found, and one that stops short of it adds nothing.
  Straight s;
  const auto block = planner::makeScenarioWorld(scenario2d(60, 0.3, "  - {type: sphere, center: [13, 5], radius: 1}\n"));
  double arc_block = -1.0;
  for (const auto& sample : s.trajectory.samples)
    if (!block->isFree(sample.position)) {
      arc_block = sample.arc_length;
      break;
    }
  ASSERT_GT(arc_block, 0.0);
  TrackerConfig config;
  config.replan_horizon = 5.0;
  ASSERT_LT(s.trajectory.at(5.0).arc_length, arc_block);  // the time horizon alone stops short
  config.replan_horizon_distance = arc_block + 1.0;
  const auto seen = TrajectoryTracker(s.trajectory, *s.sc.vehicle, config).checkReplan(*block);
  ASSERT_TRUE(seen.needed);
  EXPECT_EQ(seen.reason, ReplanReason::TrajectoryBlocked);
  EXPECT_GT(seen.time_ahead, 5.0);
  config.replan_horizon_distance = arc_block - 1.0;
  EXPECT_FALSE(TrajectoryTracker(s.trajectory, *s.sc.vehicle, config).checkReplan(*block).needed);
  config.replan_horizon_distance = -1.0;
  EXPECT_THROW(TrajectoryTracker(s.trajectory, *s.sc.vehicle, config), std::invalid_argument);
}

TEST(ReplanGate, RefusesBadPolicies) {
  ReplanPolicy p;
  p.confirm_checks = 0;
  EXPECT_THROW(ReplanGate{p}, std::invalid_argument);
  p = {};
  p.stop_margin_s = -1;
  EXPECT_THROW(ReplanGate{p}, std::invalid_argument);
}

TEST(Mission, KeepsDrivingWhileAReplanAheadIsPlanned) {
  MissionConfig config;
  config.goal = {50, 5, 0};
  config.goal_radius = 1.0;
  Mission mission(config);
  VehicleState here;
  here.position = {1, 5, 0};
  auto d = mission.update(0, here, true, std::nullopt);
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  PlanAnswer answer{d.request_id, true, "", true, Vec3(50, 5, 0)};
  ASSERT_EQ(mission.update(1'000'000, here, true, answer).action, MissionAction::SmoothPath);
  ASSERT_EQ(mission.pathSmoothed(2'000'000, here, true).action, MissionAction::Drive);
  VehicleState ahead = here;
  ahead.position = {4, 5, 0};
  d = mission.replanAhead(3'000'000, ahead, "trajectory_blocked: test");
  ASSERT_EQ(d.action, MissionAction::RequestPlan);
  EXPECT_EQ(d.reason, "trajectory_blocked: test");
  EXPECT_EQ(d.from.position, ahead.position);
  EXPECT_TRUE(mission.awaitingPlan());
  // Until the answer comes, the vehicle drives on.
  EXPECT_EQ(mission.update(4'000'000, here, true, std::nullopt).action, MissionAction::Drive);
  PlanAnswer second{d.request_id, true, "", true, Vec3(50, 5, 0)};
  EXPECT_EQ(mission.update(5'000'000, here, true, second).action, MissionAction::SmoothPath);
  EXPECT_FALSE(mission.awaitingPlan());
  // Held (the block came too close): no driving until the plan is there.
  d = mission.replanAhead(6'000'000, ahead, "trajectory_blocked: again");
  mission.hold();
  EXPECT_EQ(mission.update(7'000'000, here, true, std::nullopt).action, MissionAction::Wait);
}


// A vehicle at rest asks from a heading the planner's tree can grow along: its own while the way ahead is free;
// stopped facing the end wall of a corridor that turns left, the least turn that opens up (left, up the
// corridor), not the longest free way (back); touching the wall, free space counts from where it leaves it.
TEST(RestStartHeading, KeepsAFreeHeadingAndTurnsOutOfACornerTheShortWay) {
  // Corridor 2 m wide along y in [14, 16] from x = 11 to 60, turning up (x in [11, 13]) at its left end.
  const auto sc = scenario2d(60, 0.5,
                             "  - {type: box, min: [0, 0], max: [11, 60]}\n"
                             "  - {type: box, min: [11, 0], max: [60, 14]}\n"
                             "  - {type: box, min: [13, 16], max: [60, 60]}\n");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const double pi = std::numbers::pi;
  EXPECT_DOUBLE_EQ(restStartHeading(*world, Vec3(40, 15, 0), pi, 2.0), pi);  // along the corridor: kept
  EXPECT_DOUBLE_EQ(restStartHeading(*world, Vec3(40, 15, 0), 0.0, 2.0), 0.0);
  // At the corner, facing the end wall (0.2 m ahead): up the corridor, a quarter turn.
  EXPECT_NEAR(restStartHeading(*world, Vec3(11.7, 15, 0), pi, 2.0), pi / 2, 1e-9);
  // 0.1 m inside the wall: up the corridor and out of the wall (straight up stays in it).
  const double out_of_wall = restStartHeading(*world, Vec3(11.4, 15, 0), pi, 2.0);
  EXPECT_GT(out_of_wall, pi / 4);
  EXPECT_LT(out_of_wall, pi / 2);
  // Facing down into the floor at the corner: up, the way out (a half turn), or back along the corridor (a
  // quarter turn): the least turn wins.
  EXPECT_NEAR(std::abs(restStartHeading(*world, Vec3(11.7, 15, 0), -pi / 2, 2.0)), 0.0, 1e-9);
}

// The room asked for grows with each failed plan: a heading with a few metres free ahead that the planner's tree
// could not grow from is given up for one with more room (a pocket below a wall, short of another).
TEST(RestStartHeading, AsksForMoreRoomAfterEachFailedPlan) {
  EXPECT_DOUBLE_EQ(restStartRoom(0.5, 0), 2.0);
  EXPECT_DOUBLE_EQ(restStartRoom(0.5, 1), 4.0);
  EXPECT_DOUBLE_EQ(restStartRoom(0.5, 2), 8.0);
  EXPECT_DOUBLE_EQ(restStartRoom(0.5, 9), 16.0);  // at most 8 times
  EXPECT_DOUBLE_EQ(restStartRoom(0.1, 0), 1.0);   // at least a metre
  EXPECT_DOUBLE_EQ(restStartRoom(std::numeric_limits<double>::quiet_NaN(), -3), 1.0);
  // A pocket: a wall 1.5 m above the vehicle (y = 53.2) and one 3.4 m ahead (x = 78); heading 20 deg, 2.9 m of
  // room for the robot.
  const auto sc = scenario2d(110, 0.5,
                             "  - {type: box, min: [56, 53.2], max: [78, 54.2]}\n"
                             "  - {type: box, min: [78, 32], max: [80, 54.2]}\n");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const double heading = 20.0 * std::numbers::pi / 180.0;
  const Vec3 at(74.6, 51.7, 0);
  EXPECT_DOUBLE_EQ(restStartHeading(*world, at, heading, restStartRoom(0.5, 0)), heading);
  const double after_one = restStartHeading(*world, at, heading, restStartRoom(0.5, 1));
  EXPECT_NE(after_one, heading);
  // 4 m free along it: away from both walls.
  const Vec3 dir(std::cos(after_one), std::sin(after_one), 0);
  for (double t = 0; t <= 4.0; t += 0.25) EXPECT_TRUE(world->isFree(at + t * dir)) << t;
}

// A vehicle at rest 0.6 m above a 28-degree flank, facing up it (a random world, seed 62): nothing is free level ahead,
// but climbing is, so it keeps its heading in 3-D; it used to turn round and fly away downhill first. Buried a little
// deeper than its radius (as a map's widened terrain does), free space counts from where the climb leaves it.
TEST(RestStartHeading, InThreeDimensionsAHeadingUpAFlankIsKeptWhereTheVehicleCanClimb) {
  const auto sc = ddsnav::planner::parseScenario(
      "name: flank\ndimensions: 3\nbounds: {min: [0, 0, 0], max: [60, 60, 25]}\nrobot_radius: 0.3\n"
      "start: [4.8, 6.0, 4.39]\ngoal: [55, 54, 12]\ngoal_radius: 2\n"
      "vehicle: {model: unicycle, v_max: 5.0, omega_max: 0.7, vz_max: 2.0, dt: 1.0}\n"
      "obstacles:\n  - {type: hill, center: [12.3, 21.4], height: 13.0, sigma: 10.9}\n",
      "flank");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const double uphill = 44.0 * std::numbers::pi / 180.0;
  const Vec3 at(4.8, 6.0, 4.39);
  ASSERT_TRUE(world->isFree(at));
  const Vec3 level(std::cos(uphill), std::sin(uphill), 0.0);
  EXPECT_FALSE(world->isFree(at + 1.2 * level));  // level ahead: into the flank
  EXPECT_DOUBLE_EQ(restStartHeading(*world, at, uphill, 1.2), uphill);
  // 0.5 m lower the robot is inside the flank: within its radius nothing leaves it, within radius + 1 m climbing does.
  const Vec3 buried = at - Vec3(0, 0, 0.5);
  ASSERT_FALSE(world->isFree(buried));
  EXPECT_NE(restStartHeading(*world, buried, uphill, 1.2), uphill);
  EXPECT_DOUBLE_EQ(restStartHeading(*world, buried, uphill, 1.2, 1.3), uphill);
}

// Shorter routes are asked for at most every every_s of mission time, less often after each ask that brings none,
// and never where no route could save min_gain of the time left (seconds throughout).
TEST(ImprovementGate, AsksOnlyWhereARouteCouldBeShorterAndBacksOffWhenNoneIs) {
  ImprovementPolicy policy;
  policy.every_s = 4.0;
  policy.min_gain = 0.1;
  policy.max_backoff = 4;
  policy.wall_duty = 0.25;
  ImprovementGate gate(policy);
  // 100 s left, 95 s at the least: no route can save 10 s.
  EXPECT_FALSE(gate.due(0.0, 0.0, 100.0, 95.0));
  EXPECT_TRUE(gate.due(0.0, 0.0, 100.0, 80.0));
  EXPECT_TRUE(gate.worthTaking(100.0, 89.0));
  EXPECT_FALSE(gate.worthTaking(100.0, 91.0));
  // Near the goal a switch must still save a second (min_saving_s): 10 % of 8 s is not worth asking for, nor taking.
  EXPECT_FALSE(gate.due(0.0, 0.0, 8.0, 1.0));
  EXPECT_FALSE(gate.worthTaking(8.0, 7.1));
  EXPECT_TRUE(gate.worthTaking(8.0, 6.9));
  gate.asked(0.0, 0.0);
  EXPECT_FALSE(gate.due(3.9, 3.9, 100.0, 50.0));
  EXPECT_TRUE(gate.due(4.0, 4.0, 100.0, 50.0));
  gate.answered(false, 0.3);  // nothing shorter: the interval doubles
  EXPECT_DOUBLE_EQ(gate.interval(), 8.0);
  EXPECT_FALSE(gate.due(7.9, 7.9, 100.0, 50.0));
  EXPECT_TRUE(gate.due(8.0, 8.0, 100.0, 50.0));
  gate.asked(8.0, 8.0);
  gate.answered(false, 8.3);
  gate.answered(false, 8.3);
  EXPECT_DOUBLE_EQ(gate.interval(), 16.0);  // capped at every_s x max_backoff
  gate.answered(true, 0.3);
  EXPECT_DOUBLE_EQ(gate.interval(), 4.0);
  // A new trajectory from a replan restarts the interval from its time.
  gate.newTrajectory(20.0);
  EXPECT_FALSE(gate.due(23.0, 23.0, 100.0, 50.0));
  EXPECT_TRUE(gate.due(24.0, 24.0, 100.0, 50.0));
}

// A vehicle meant to fly that stands still for stall_s fires once; moving, turning in place, or not being meant to fly
// (a stop, a plan awaited) starts the stretch over.
TEST(StallWatch, FiresOnlyAfterStandingStillForItsWholeTimeWhileMeantToFly) {
  StallPolicy policy;
  policy.stall_s = 6.0;
  StallWatch watch(policy);
  const Vec3 here(10, 5, 0);
  double t = 0.0;
  auto standFor = [&](double seconds, const Vec3& p, double heading, bool meant) {
    int fired = 0;
    for (const double end = t + seconds; t < end - 1e-9; t += 0.05) fired += watch.update(t, p, heading, meant);
    return fired;
  };
  EXPECT_EQ(standFor(5.9, here, 0.0, true), 0);
  EXPECT_EQ(standFor(0.2, here, 0.0, true), 1);  // 6 s in all
  EXPECT_EQ(standFor(5.8, here, 0.0, true), 0);  // watched afresh after it fired
  // Creeping within the radius (0.15 m over 5 s) is standing still; leaving it is moving.
  StallWatch creeping(policy);
  int fired = 0;
  for (int i = 0; i <= 140; ++i) fired += creeping.update(0.05 * i, here + Vec3(0.15 * i / 140.0, 0, 0), 0.0, true);
  EXPECT_EQ(fired, 1);
  StallWatch moving(policy);
  fired = 0;
  for (int i = 0; i <= 400; ++i) fired += moving.update(0.05 * i, here + Vec3(0.05 * i, 0, 0), 0.0, true);  // 1 m/s
  EXPECT_EQ(fired, 0);
  // Turning in place at 0.15 rad/s (an AUV's limit) is moving: 0.35 rad every 2.3 s.
  StallWatch turning(policy);
  fired = 0;
  for (int i = 0; i <= 400; ++i) fired += turning.update(0.05 * i, here, 0.0075 * i, true);
  EXPECT_EQ(fired, 0);
  // Not meant to fly for a step (braking to a stop, a required plan awaited): the stretch starts over.
  StallWatch interrupted(policy);
  fired = 0;
  for (int i = 0; i <= 400; ++i) fired += interrupted.update(0.05 * i, here, 0.0, i % 100 != 99);
  EXPECT_EQ(fired, 0);
  policy.stall_s = 0.0;  // off
  StallWatch off(policy);
  fired = 0;
  for (int i = 0; i <= 400; ++i) fired += off.update(0.05 * i, here, 0.0, true);
  EXPECT_EQ(fired, 0);
  policy.radius_m = 0.0;
  EXPECT_THROW(StallWatch{policy}, std::invalid_argument);
}

// On a sped-up clock the asks are bounded in wall time too: an ask that took 0.5 s of wall time is followed by
// another after 2 s of wall time at the least (wall_duty 0.25), however much mission time passed.
TEST(ImprovementGate, TheAsksWallTimeStaysUnderItsShare) {
  ImprovementPolicy policy;
  policy.every_s = 1.0;
  ImprovementGate gate(policy);
  gate.asked(0.0, 100.0);
  gate.answered(true, 100.5);
  EXPECT_FALSE(gate.due(10.0, 101.9, 100.0, 50.0));
  EXPECT_TRUE(gate.due(10.0, 102.0, 100.0, 50.0));
  policy.every_s = 0.0;  // off
  EXPECT_FALSE(ImprovementGate(policy).due(1e6, 1e6, 100.0, 1.0));
  policy.min_gain = 1.0;
  EXPECT_THROW(ImprovementGate{policy}, std::invalid_argument);
}

}  // namespace
}  // namespace ddsnav::tracker
