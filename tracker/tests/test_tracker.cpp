#include "ddsnav/tracker/closed_loop.hpp"
#include "ddsnav/tracker/scan_free_space.hpp"
#include "ddsnav/tracker/smoother.hpp"
#include "ddsnav/tracker/tracker.hpp"

#include "test_worlds.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <cstdio>

using namespace ddsnav::tracker;
using ddsnav::planner::Vec3;
using ddsnav::tracker::testing::pathOf;
using ddsnav::tracker::testing::scenario2d;

namespace {

ClosedLoopConfig loopConfig(const ddsnav::planner::VehicleLimits& limits, VehicleNoise noise = VehicleNoise::nominal()) {
  ClosedLoopConfig c;
  c.vehicle.limits = limits;
  c.vehicle.noise = noise;
  return c;
}

}  // namespace

// A trajectory along x sampled every 0.1 m over `length` metres: speed and curvature by arc length.
static Trajectory sampledAlong(double length, const std::function<double(double)>& speed, const std::function<double(double)>& curvature) {
  Trajectory t;
  for (double s = 0.0; s <= length + 1e-9; s += 0.1) {
    TrajectorySample sample;
    sample.arc_length = s;
    sample.position = Vec3(s, 0.0, 0.0);
    sample.speed = speed(s);
    sample.curvature = curvature(s);
    t.samples.push_back(sample);
  }
  return t;
}

// stunnel_0.5 at real time, 2026-12-06: a vehicle at 4.29 m/s, a trajectory starting at 1.6 m/s 0.9 m before a
// 0.181 1/m curve (omega_max 0.628 rad/s, max_decel 2 m/s^2). Braking, the vehicle reaches the curve at 3.85 m/s and
// needs 0.70 rad/s: it cannot take over. It can where the curve comes after it is down to the trajectory's speed, where
// the curve is gentle, and where the start is at most the slack slower; not where the trajectory stops first.
TEST(TakeOver, AVehicleArrivingFasterCannotTakeOverBeforeACurveItCannotTurn) {
  const double omega = 0.628, decel = 2.0;
  const auto slowThenSpeedUp = [](double s) { return std::min(4.0, 1.6 + 0.5 * s); };
  const auto curveAfter = [](double at, double kappa) { return [=](double s) { return s >= at ? kappa : 0.0; }; };
  EXPECT_TRUE(cannotTakeOver(sampledAlong(10, slowThenSpeedUp, curveAfter(0.9, 0.181)), 4.29, decel, omega));
  EXPECT_FALSE(cannotTakeOver(sampledAlong(10, slowThenSpeedUp, curveAfter(4.0, 0.181)), 4.29, decel, omega));
  EXPECT_FALSE(cannotTakeOver(sampledAlong(10, slowThenSpeedUp, curveAfter(0.0, 0.05)), 4.29, decel, omega));
  const auto constant = [](double v) { return [=](double) { return v; }; };
  EXPECT_FALSE(cannotTakeOver(sampledAlong(10, constant(3.9), curveAfter(0.5, 0.181)), 4.29, decel, omega));  // within the slack
  // At rest: not under a moving vehicle; under one that hardly moves it is flown.
  EXPECT_TRUE(cannotTakeOver(sampledAlong(10, constant(0.0), curveAfter(20, 0.0)), 4.29, decel, omega));
  EXPECT_FALSE(cannotTakeOver(sampledAlong(10, constant(0.0), curveAfter(20, 0.0)), 0.4, decel, omega));
  // A stop 1 m on, before the vehicle (3 m/s, braking) is down to the trajectory's 1 m/s.
  EXPECT_TRUE(cannotTakeOver(sampledAlong(3, [](double s) { return s < 1.0 ? 1.0 : 0.0; }, curveAfter(20, 0.0)), 3.0, decel, omega));
  EXPECT_FALSE(cannotTakeOver(Trajectory{}, 4.29, decel, omega));
}

// terrain_ridge_3d at speed 4, 2026-12-06: a replan's trajectory started at 0.56 m/s climbing at 0.79 (vz 0.44 m/s)
// under a vehicle at 3.8 m/s that climbs at 2 m/s at most. At 3.8 m/s that slope needs 3 m/s: the vehicle flew under
// the trajectory, 0.72 m off it. Braking, it is down to 2.5 m/s (the steepest it can fly that slope at) only after
// 2 m; a slope it can fly at its speed, or a climb that starts after it has slowed enough, takes over.
TEST(TakeOver, AVehicleArrivingFasterCannotTakeOverBeforeAClimbTooSteepForItsSpeed) {
  const double omega = 0.6, decel = 2.0, vz_max = 2.0;
  const auto slowThenSpeedUp = [](double s) { return std::min(4.0, 0.56 + 0.5 * s); };
  const auto straight = [](double) { return 0.0; };
  const auto climbing = [&](double slope, double from) {
    Trajectory t = sampledAlong(10, slowThenSpeedUp, straight);
    for (auto& sample : t.samples)
      if (sample.arc_length >= from) sample.vz = slope * sample.speed;
    return t;
  };
  EXPECT_TRUE(cannotTakeOver(climbing(0.79, 0.0), 3.8, decel, omega, kFlownThroughSpeed, kAtRestSpeed, kStartSpeedSlack, vz_max));
  EXPECT_FALSE(cannotTakeOver(climbing(0.79, 0.0), 3.8, decel, omega));  // without a vertical limit: as before
  EXPECT_FALSE(cannotTakeOver(climbing(0.5, 0.0), 3.8, decel, omega, kFlownThroughSpeed, kAtRestSpeed, kStartSpeedSlack, vz_max));
  EXPECT_FALSE(cannotTakeOver(climbing(0.79, 2.5), 3.8, decel, omega, kFlownThroughSpeed, kAtRestSpeed, kStartSpeedSlack, vz_max));
  EXPECT_TRUE(cannotTakeOver(climbing(-0.79, 0.0), 3.8, decel, omega, kFlownThroughSpeed, kAtRestSpeed, kStartSpeedSlack, vz_max));
  // The refusal names what the vehicle would meet, where.
  const std::string why = takeOverRefusal(climbing(0.79, 0.0), 3.8, decel, omega, kFlownThroughSpeed, kAtRestSpeed, kStartSpeedSlack, vz_max);
  EXPECT_NE(why.find("slope of 0.79 0.0 m on at 3.8 m/s"), std::string::npos) << why;
  EXPECT_EQ(takeOverRefusal(climbing(0.5, 0.0), 3.8, decel, omega, kFlownThroughSpeed, kAtRestSpeed, kStartSpeedSlack, vz_max), "");
}

TEST(Tracker, StatusOnAStraightTrajectory) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  auto traj = smoothPath(pathOf({{1, 5, 0}, {15, 5, 0}}), *world, *sc.vehicle);
  TrajectoryTracker tracker(traj, *sc.vehicle);
  // A vehicle 0.3 m to the left of the path, behind the reference, facing along it.
  VehicleState s;
  s.position = {1.0, 5.3, 0};
  for (int i = 0; i < 20; ++i) tracker.update(s, 0.05);  // it does not move: the reference waits max_lead ahead
  const auto& st = tracker.status();
  EXPECT_NEAR(st.cross_track_error, 0.3, 1e-9);
  EXPECT_LT(st.along_track_error, 0.0);
  EXPECT_GE(st.along_track_error, -0.5 - 0.05);  // reference held within max_lead (plus one step)
  EXPECT_NEAR(st.max_cross_track_error, 0.3, 1e-9);
  EXPECT_NEAR(st.progress, 0.0, 1e-9);
  EXPECT_FALSE(st.goal_reached);
  // Right of the path: negative.
  s.position = {1.0, 4.8, 0};
  tracker.update(s, 0.05);
  EXPECT_NEAR(tracker.status().cross_track_error, -0.2, 1e-9);
  // Commands turn the vehicle back towards the path (right, negative omega) and move it forward.
  s.position = {1.0, 5.3, 0};
  const auto cmd = tracker.update(s, 0.05);
  EXPECT_LT(cmd.omega, 0.0);
  EXPECT_GT(cmd.v, 0.0);
  EXPECT_LE(cmd.v, sc.vehicle->v_max);
}

TEST(Tracker, ReplanOnDeviationAndOnNewObstacle) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  auto traj = smoothPath(pathOf({{1, 5, 0}, {15, 5, 0}}), *world, *sc.vehicle);
  TrackerConfig cfg;
  cfg.replan_deviation = 0.8;
  TrajectoryTracker tracker(traj, *sc.vehicle, cfg);
  VehicleState s;
  s.position = {1.0, 5.0, 0};
  tracker.update(s, 0.05);
  EXPECT_FALSE(tracker.checkReplan(*world).needed);

  // An obstacle appears across the trajectory.
  auto blocked = ddsnav::planner::makeScenarioWorld(scenario2d(20, 0.3, "  - {type: sphere, center: [10, 5.5], radius: 1}\n"));
  const auto d = tracker.checkReplan(*blocked);
  EXPECT_TRUE(d.needed);
  EXPECT_EQ(d.reason, ReplanReason::TrajectoryBlocked);
  EXPECT_NEAR(d.blocked_at.y(), 5.0, 1e-9);
  EXPECT_NE(d.message.find("no longer collision free"), std::string::npos);

  s.position = {1.0, 6.0, 0};
  tracker.update(s, 0.05);
  const auto dev = tracker.checkReplan(*world);
  EXPECT_TRUE(dev.needed);
  EXPECT_EQ(dev.reason, ReplanReason::Deviation);
}

TEST(Tracker, RejectsBadInput) {
  Trajectory empty;
  ddsnav::planner::VehicleLimits l;
  l.v_max = 1;
  l.omega_max = 1;
  EXPECT_THROW(TrajectoryTracker(empty, l), std::invalid_argument);
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  auto traj = smoothPath(pathOf({{1, 5, 0}, {15, 5, 0}}), *world, *sc.vehicle);
  TrajectoryTracker tracker(traj, l);
  VehicleState s;
  s.position = {NAN, 0, 0};
  EXPECT_THROW(tracker.update(s, 0.05), std::invalid_argument);
  EXPECT_THROW(tracker.update(VehicleState{}, -1.0), std::invalid_argument);
}

TEST(ClosedLoop, HandMadeWorldReachesGoalWithSmallError) {
  auto sc = scenario2d(30, 0.3,
                       "  - {type: box, min: [8, 0], max: [10, 18]}\n"
                       "  - {type: sphere, center: [20, 12], radius: 3}\n",
                       2.0, 0.628);
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig scfg;
  scfg.initial_heading = 0.0;
  auto traj = smoothPath(pathOf({{2, 2, 0}, {6, 12, 0}, {7, 20, 0}, {15, 20, 0}, {18, 17, 0}, {24.5, 15, 0}, {27, 3, 0}}),
                         *world, *sc.vehicle, scfg);
  for (auto controller : {ControllerType::FeedforwardFeedback, ControllerType::PurePursuit}) {
    auto cfg = loopConfig(*sc.vehicle);
    cfg.tracker.controller = controller;
    const auto r = runClosedLoop(traj, cfg, world.get());
    EXPECT_TRUE(r.goal_reached) << "controller " << static_cast<int>(controller);
    EXPECT_EQ(r.track_states_in_collision, 0u);
    EXPECT_LE(traj.report.max_heading_jump, sc.vehicle->omega_max * traj.dt + 1e-9);
    // The vehicle's own heading steps obey omega_max up to the yaw-rate disturbance.
    EXPECT_LE(r.max_heading_step, (sc.vehicle->omega_max + 5 * cfg.vehicle.noise.sigma_omega) * cfg.control_dt);
    std::printf("controller %d: mean CTE %.4f max %.4f mean pos %.4f time %.2f (trajectory %.2f)\n", static_cast<int>(controller),
                r.status.mean_cross_track_error, r.status.max_cross_track_error, r.status.mean_position_error, r.time,
                traj.duration());
    if (controller == ControllerType::FeedforwardFeedback) {
      EXPECT_LT(r.status.mean_cross_track_error, 0.1);
      EXPECT_LT(r.status.max_cross_track_error, 0.5);
      EXPECT_LT(r.time, traj.duration() + 5.0);
    } else {
      EXPECT_LT(r.status.mean_cross_track_error, 0.5);
    }
  }
}

TEST(ClosedLoop, WithoutNoiseTheErrorIsTiny) {
  auto sc = scenario2d(30, 0.3, "", 2.0, 0.628);
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig scfg;
  scfg.shortcut = false;
  auto traj = smoothPath(pathOf({{2, 2, 0}, {20, 2, 0}, {20, 20, 0}, {5, 25, 0}}), *world, *sc.vehicle, scfg);
  auto cfg = loopConfig(*sc.vehicle, VehicleNoise::none());
  const auto r = runClosedLoop(traj, cfg, world.get());
  EXPECT_TRUE(r.goal_reached);
  EXPECT_LT(r.status.mean_cross_track_error, 0.02);
}

TEST(ClosedLoop, PlannedPathOnTheDemoScenario) {
  const auto sc = ddsnav::planner::loadScenario(std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  ddsnav::planner::PlanProblem problem;
  problem.world = world.get();
  problem.start.position = sc.start;
  problem.start.heading = sc.start_heading.value_or(0.0);
  problem.goal = sc.goal;
  problem.goal_radius = sc.goal_radius;
  problem.vehicle = sc.vehicle;
  problem.seed = 3;
  problem.max_iterations = 3000;
  problem.anytime = true;
  const auto plan = ddsnav::planner::makePlanner("rrtstar")->solve(problem);
  ASSERT_TRUE(plan.solved);

  SmootherConfig scfg;
  scfg.initial_heading = sc.start_heading;
  const auto traj = smoothPath(plan.path, *world, *sc.vehicle, scfg);
  EXPECT_EQ(traj.report.samples_in_collision, 0u);
  EXPECT_LE(traj.report.max_heading_jump, sc.vehicle->omega_max * traj.dt + 1e-9);
  EXPECT_LE(traj.report.max_yaw_rate, sc.vehicle->omega_max);
  EXPECT_LE(traj.report.max_speed, sc.vehicle->v_max);

  auto cfg = loopConfig(*sc.vehicle);
  const auto r = runClosedLoop(traj, cfg, world.get());
  EXPECT_TRUE(r.goal_reached);
  EXPECT_LE((r.track.back().position - sc.goal).norm(), sc.goal_radius);
  EXPECT_LT(r.status.mean_cross_track_error, 0.1);
  EXPECT_EQ(r.track_states_in_collision, 0u);
}

TEST(ClosedLoop, ThreeDimensionalClimb) {
  const std::string text =
      "name: t3\ndimensions: 3\nbounds: {min: [0, 0, 0], max: [30, 30, 20]}\nrobot_radius: 0.3\nstart: [1, 1, 1]\n"
      "goal: [20, 20, 10]\ngoal_radius: 1\nvehicle: {model: unicycle, v_max: 2.0, omega_max: 0.6, vz_max: 0.5, dt: 1.0}\n"
      "obstacles:\n  - {type: sphere, center: [15, 5, 5], radius: 2}\n";
  const auto sc = ddsnav::planner::parseScenario(text, "t3");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto traj = smoothPath(pathOf({{2, 2, 1}, {10, 2, 8}, {10, 12, 8}, {20, 20, 3}}), *world, *sc.vehicle);
  auto cfg = loopConfig(*sc.vehicle);
  cfg.vehicle.dimensions = 3;
  const auto r = runClosedLoop(traj, cfg, world.get());
  EXPECT_TRUE(r.goal_reached);
  EXPECT_LT(r.status.mean_cross_track_error, 0.1);
  EXPECT_NEAR(r.track.back().position.z(), 3.0, 0.1);
  EXPECT_EQ(r.track_states_in_collision, 0u);
}

// A 40 x 10 x 20 m lane along x for a UAV of 4 m/s, 0.6 rad/s and 1.5 m/s up (descend_3d's), from (2, 5, 12) to
// (38, 5, 12), with one obstacle (a scenario-format line).
static ddsnav::planner::Scenario uavLane(const std::string& obstacle) {
  return ddsnav::planner::parseScenario(
      "name: lane\ndimensions: 3\nbounds: {min: [0, 0, 0], max: [40, 10, 20]}\nrobot_radius: 0.3\nstart: [2, 5, 12]\n"
      "goal: [38, 5, 12]\ngoal_radius: 1\nvehicle: {model: unicycle, v_max: 4.0, omega_max: 0.6, vz_max: 1.5, dt: 1.0}\n"
      "obstacles:\n  - " + obstacle + "\n",
      "lane");
}

// A descent under the edge of an overhang, level under it, then a climb past its other edge: 0.1 m from the edges,
// the corners are tightened for room, so the climb changes within a metre or so. The vehicle's vertical speed changes
// at max_vertical_accel at most; a trajectory that changes it faster at full speed left the vehicle 0.35 m below it
// (before the smoother capped the speed there, 2026-12-06: the trajectory took 15.4 s, now 18.4 s).
TEST(ClosedLoop, AChangeOfClimbIsFlownWithinTheVerticalAcceleration) {
  const auto sc = uavLane("{type: box, min: [15, 0, 7.0], max: [25, 10, 20]}");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig scfg;
  scfg.initial_heading = 0.0;
  const auto traj = smoothPath(pathOf({{2, 5, 12}, {15, 5, 6.6}, {25, 5, 6.6}, {38, 5, 12}}), *world, *sc.vehicle, scfg);
  // The reference's own vertical speed changes within the limit, over any half second.
  const double a_z = scfg.limit_fraction * scfg.max_vertical_accel;
  for (std::size_t i = 0, j = 0; i < traj.samples.size(); ++i) {
    while (j < traj.samples.size() && traj.samples[j].time < traj.samples[i].time + 0.5) ++j;
    if (j == traj.samples.size()) break;
    const double dt = traj.samples[j].time - traj.samples[i].time;
    EXPECT_LE(std::abs(traj.samples[j].vz - traj.samples[i].vz), a_z * dt * 1.15 + 0.05) << "at t = " << traj.samples[i].time;
  }
  auto cfg = loopConfig(*sc.vehicle);
  cfg.vehicle.dimensions = 3;
  ASSERT_EQ(cfg.vehicle.max_vertical_accel, scfg.max_vertical_accel);  // one default for the smoother and the vehicle
  const auto r = runClosedLoop(traj, cfg, world.get());
  EXPECT_TRUE(r.goal_reached);
  double deepest = 0.0;  // how far the vehicle sank below the trajectory at its position along it
  for (const auto& s : r.track) {
    const auto& ref = *std::min_element(traj.samples.begin(), traj.samples.end(), [&](const TrajectorySample& a, const TrajectorySample& b) {
      return (a.position - s.position).head<2>().norm() < (b.position - s.position).head<2>().norm();
    });
    deepest = std::max(deepest, ref.position.z() - s.position.z());
  }
  EXPECT_LT(deepest, 0.15);
  EXPECT_LT(r.status.max_cross_track_error, 0.2);
}

// A replan from a descent onto a level path over a floor that leaves no room to descend far: a level lead-in makes
// the reference's vz jump from -1.24 m/s to 0 at the start, and the vehicle, changing vz at max_vertical_accel, sinks
// below it (descend_3d: 0.69 m, with the vehicle 0.07 m into a hill). The start keeps the descent and turns it level
// within the vertical acceleration, slower where the room is short.
TEST(ClosedLoop, ADescendingStartTurnsLevelWithinTheVerticalAcceleration) {
  const auto sc = uavLane("{type: box, min: [0, 0, 0], max: [40, 10, 10.6]}");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig scfg;
  scfg.initial_heading = 0.0;
  scfg.initial_speed = 3.4;
  scfg.initial_vz = -1.24;
  const auto traj = smoothPath(pathOf({{2, 5, 12}, {38, 5, 12}}), *world, *sc.vehicle, scfg);
  // The reference's vz starts where the vehicle's is, within what kVerticalKinkM (0.05 m of lag) allows.
  const double a_z = scfg.limit_fraction * scfg.max_vertical_accel;
  EXPECT_LE(std::abs(traj.samples.front().vz - scfg.initial_vz), std::sqrt(2 * a_z * 0.05) + 1e-6);
  auto cfg = loopConfig(*sc.vehicle);
  cfg.vehicle.dimensions = 3;
  VehicleState moving;
  moving.v = 3.4;
  moving.vz = -1.24;
  cfg.start_motion = moving;
  const auto r = runClosedLoop(traj, cfg, world.get());
  EXPECT_TRUE(r.goal_reached);
  EXPECT_EQ(r.track_states_in_collision, 0u);
  double lowest = 1e9;
  for (const auto& s : r.track) lowest = std::min(lowest, s.position.z());
  double lowest_reference = 1e9;
  for (const auto& s : traj.samples) lowest_reference = std::min(lowest_reference, s.position.z());
  EXPECT_GT(lowest, lowest_reference - 0.1);  // the vehicle sinks no deeper than its trajectory, give or take the lag
  EXPECT_LT(r.status.max_cross_track_error, 0.15);
}

// A trajectory switched to late (planned from a predicted start the vehicle has passed) is followed from
// the vehicle's projection, not from its start behind the vehicle.
TEST(Tracker, SkipsToTheVehicleOnALateSwitch) {
  auto sc = scenario2d(40, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;
  cfg.initial_speed = 0.8;
  auto traj = smoothPath(pathOf({{1, 5, 0}, {35, 5, 0}}), *world, *sc.vehicle, cfg);
  VehicleState s;
  s.position = {3.0, 5.05, 0};  // 2 m past the start
  s.v = 0.8;
  TrajectoryTracker late(traj, *sc.vehicle);
  const double skipped = late.skipToVehicle(s.position, 5.0);
  EXPECT_GT(skipped, 1.0);
  EXPECT_NEAR(traj.at(skipped).position.x(), 3.0, 0.05);
  late.update(s, 0.05);
  EXPECT_NEAR(late.status().along_track_error, 0.0, 0.1);
  // Only the first within_s seconds are searched, and not once the trajectory is being followed.
  TrajectoryTracker bounded(traj, *sc.vehicle);
  EXPECT_LT(bounded.skipToVehicle({30.0, 5.0, 0}, 2.0), 2.0 + 0.1);
  EXPECT_DOUBLE_EQ(late.skipToVehicle({20.0, 5.0, 0}, 30.0), 0.0);
  // A vehicle at (or behind) the start skips nothing.
  TrajectoryTracker on_time(traj, *sc.vehicle);
  EXPECT_DOUBLE_EQ(on_time.skipToVehicle({0.5, 5.0, 0}, 5.0), 0.0);
  EXPECT_DOUBLE_EQ(on_time.status().reference_time, 0.0);
}

TEST(BrakeAlong, BrakesHarderOnlyWhenTheBlockIsCloserThanTheComfortableStop) {
  // 5 m/s at 1.7 m/s^2 needs 7.35 m: with 20 m of room the comfortable rate; with 6.5 m, 5^2 / (2 * 6.5) = 1.92;
  // with 5 m the vehicle's limit (it cannot do better); from rest, the comfortable one.
  EXPECT_DOUBLE_EQ(brakingDecel(5.0, 20.0, 1.7, 2.0), 1.7);
  EXPECT_NEAR(brakingDecel(5.0, 6.5, 1.7, 2.0), 25.0 / 13.0, 1e-12);
  EXPECT_DOUBLE_EQ(brakingDecel(5.0, 5.0, 1.7, 2.0), 2.0);
  EXPECT_DOUBLE_EQ(brakingDecel(5.0, 0.0, 1.7, 2.0), 2.0);
  EXPECT_DOUBLE_EQ(brakingDecel(0.0, 1.0, 1.7, 2.0), 1.7);
  EXPECT_DOUBLE_EQ(brakingDecel(5.0, std::nan(""), 1.7, 2.0), 2.0);
}

// A curve smoothed in an open 60 m world for a 4 m/s, 1 rad/s vehicle.
static Trajectory openCurve(std::initializer_list<Vec3> points) {
  const auto world = ddsnav::planner::makeScenarioWorld(scenario2d(60, 0.3, ""));
  ddsnav::planner::VehicleLimits limits;
  limits.v_max = 4.0;
  limits.omega_max = 1.0;
  return smoothPath(pathOf(points), *world, limits);
}

TEST(BrakeAlong, TimeAtArcLengthInvertsTheTrajectorysArcLength) {
  const auto t = openCurve({{5, 5, 0}, {30, 5, 0}, {40, 20, 0}});
  for (double f : {0.1, 0.37, 0.5, 0.93}) {
    const double time = f * t.duration();
    EXPECT_NEAR(timeAtArcLength(t, t.at(time).arc_length), time, 1e-6) << f;
  }
  EXPECT_DOUBLE_EQ(timeAtArcLength(t, -5.0), 0.0);
  EXPECT_DOUBLE_EQ(timeAtArcLength(t, 1e9), t.duration());
  EXPECT_DOUBLE_EQ(timeAtArcLength(Trajectory{}, 3.0), 0.0);
}

TEST(BrakeAlong, StopsOnThePathWithinTheBrakingDistance) {
  // A curve driven at speed: braking from its middle keeps to the same path and comes to rest v^2 / 2a on.
  auto sc = scenario2d(60, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  ddsnav::planner::VehicleLimits limits;
  limits.v_max = 4.0;
  limits.omega_max = 1.0;
  const auto t = smoothPath(pathOf({{5, 5, 0}, {30, 5, 0}, {40, 20, 0}, {40, 50, 0}}), *world, limits);
  const double from = 0.5 * t.duration();
  const auto at = t.at(from);
  ASSERT_GT(at.speed, 1.0);
  const double decel = 1.5;
  const auto b = brakeAlong(t, from, at.speed, decel);
  ASSERT_GE(b.samples.size(), 2u);
  EXPECT_NEAR(b.samples.back().speed, 0.0, 1e-12);
  EXPECT_NEAR(b.samples.back().arc_length, at.speed * at.speed / (2 * decel), 1e-6);
  EXPECT_NEAR(b.samples.front().speed, at.speed, 1e-9);
  for (std::size_t i = 0; i < b.samples.size(); ++i) {
    const auto& s = b.samples[i];
    // On the original path (its samples are at most a few cm apart).
    double nearest = 1e9;
    for (const auto& o : t.samples) nearest = std::min(nearest, (o.position - s.position).norm());
    EXPECT_LT(nearest, 0.2) << "sample " << i;
    if (i > 0) {
      EXPECT_GT(s.time, b.samples[i - 1].time);
      EXPECT_LE(s.speed, b.samples[i - 1].speed + 1e-12);
      EXPECT_LE(b.samples[i - 1].speed - s.speed, decel * (s.time - b.samples[i - 1].time) + 1e-9);
    }
  }
  TrajectoryTracker follower(b, limits);  // a trajectory the follower takes
  // Braking past the end stops at the end; a stop from rest holds the position.
  const auto late = brakeAlong(t, t.duration() - 0.5, 3.0, 0.1);
  EXPECT_NEAR((late.samples.back().position - t.samples.back().position).norm(), 0.0, 1e-9);
  EXPECT_NEAR(late.samples.back().speed, 0.0, 1e-12);
  const auto hold = brakeAlong(t, from, 0.0, decel);
  ASSERT_EQ(hold.samples.size(), 2u);
  EXPECT_EQ(hold.samples[0].position, hold.samples[1].position);
  EXPECT_THROW(brakeAlong(t, from, -1.0, decel), std::invalid_argument);
  EXPECT_THROW(brakeAlong(t, from, 1.0, 0.0), std::invalid_argument);
}

// A vehicle without noise at rest at `position`, heading along +x.
static UnicycleVehicle noiselessVehicleAt(const VehicleLimits& limits, const Vec3& position) {
  VehicleConfig vc;
  vc.limits = limits;
  vc.noise = VehicleNoise::none();
  VehicleState start;
  start.position = position;
  return UnicycleVehicle(vc, start);
}

// A vehicle behind its reference (a late switch: the reference ran max_lead ahead while it stood) must not catch up
// faster than it can still brake for where the reference stops: stunnel_1.0, a catch-up at 2.4 m/s toward a stop
// 2.3 m ahead next to a wall, overshot it by 0.5 m into the wall.
static double overshootAfterALateStart(double catch_up_decel, bool* capped) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto traj = smoothPath(pathOf({{1, 5, 0}, {7, 5, 0}}), *world, *sc.vehicle);
  TrackerConfig cfg;
  cfg.catch_up_decel = catch_up_decel;
  TrajectoryTracker tracker(traj, *sc.vehicle, cfg);
  UnicycleVehicle vehicle = noiselessVehicleAt(*sc.vehicle, {1, 5, 0});
  for (int i = 0; i < 40; ++i) tracker.update(vehicle.state(), 0.05);  // standing: the reference runs ahead
  *capped = true;
  double farthest = 0.0;
  for (int i = 0; i < 400 && !tracker.status().goal_reached; ++i) {
    const auto cmd = tracker.update(vehicle.state(), 0.05);
    const double to_end = traj.samples.back().position.x() - vehicle.state().position.x();
    if (cmd.v > std::sqrt(2 * 1.0 * std::max(0.0, to_end)) + 1e-9) *capped = false;
    vehicle.step(cmd, 0.05);
    farthest = std::max(farthest, vehicle.state().position.x());
  }
  return farthest - traj.samples.back().position.x();
}

TEST(Tracker, CatchingUpNeverOutrunsTheBrakingDistanceToTheNextStop) {
  bool capped = false;
  const double overshoot = overshootAfterALateStart(1.0, &capped);
  EXPECT_TRUE(capped);
  EXPECT_LT(overshoot, 0.05);
  bool uncapped_within = true;
  const double uncapped = overshootAfterALateStart(0.0, &uncapped_within);
  EXPECT_FALSE(uncapped_within);  // without the cap the command exceeds it (the test can fail)
  std::printf("overshoot past the stop: %.3f m with the cap, %.3f m without\n", overshoot, uncapped);
}

// Stopping within observed space: a vehicle at speed on a straight 20 m trajectory whose map has observed it free only
// for its first 8 m stops before 8 m, holds there, and drives on to the end once the bound is lifted (the space seen).
TEST(Tracker, AVehicleStopsBeforeSpaceTheMapHasNotObservedFree) {
  auto sc = scenario2d(40, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto traj = smoothPath(pathOf({{1, 5, 0}, {21, 5, 0}}), *world, *sc.vehicle);
  const double unobserved_from_x = 9.0;  // the trajectory's arc length 8 m
  const double stop_arc = observedStopArc(traj, 0.0, 100.0, [&](const Vec3& p) -> std::optional<bool> {
    return p.x() < unobserved_from_x;
  });
  ASSERT_LT(stop_arc, 8.0);
  EXPECT_GT(stop_arc, 7.5);  // the last sample before 8 m
  TrajectoryTracker tracker(traj, *sc.vehicle);
  tracker.limitToObservedSpace(stop_arc, 1.0);
  UnicycleVehicle vehicle = noiselessVehicleAt(*sc.vehicle, {1, 5, 0});
  double farthest = 0.0;
  for (int i = 0; i < 600; ++i) {
    vehicle.step(tracker.update(vehicle.state(), 0.05), 0.05);
    farthest = std::max(farthest, vehicle.state().position.x());
  }
  EXPECT_LE(farthest, 1.0 + stop_arc + 0.05);
  EXPECT_GT(farthest, 1.0 + stop_arc - 0.5);  // it got there, held rather than stopped early
  EXPECT_LT(tracker.observedSpaceCap(), 0.5);
  EXPECT_FALSE(tracker.status().goal_reached);
  tracker.limitToObservedSpace(std::numeric_limits<double>::infinity(), 1.0);
  for (int i = 0; i < 1200 && !tracker.status().goal_reached; ++i) vehicle.step(tracker.update(vehicle.state(), 0.05), 0.05);
  EXPECT_TRUE(tracker.status().goal_reached);
  EXPECT_NEAR(vehicle.state().position.x(), 21.0, 0.2);

  // Every sample observed, or none that can be judged: no bound. The first sample unobserved: stop where the vehicle is.
  EXPECT_EQ(observedStopArc(traj, 0.0, 100.0, [](const Vec3&) -> std::optional<bool> { return true; }),
            std::numeric_limits<double>::infinity());
  EXPECT_EQ(observedStopArc(traj, 0.0, 100.0, [](const Vec3&) -> std::optional<bool> { return std::nullopt; }),
            std::numeric_limits<double>::infinity());
  EXPECT_EQ(observedStopArc(traj, 3.0, 100.0, [](const Vec3&) -> std::optional<bool> { return false; }), 3.0);
  // Beyond the reach nothing is looked at.
  EXPECT_EQ(observedStopArc(traj, 0.0, 5.0, [&](const Vec3& p) -> std::optional<bool> { return p.x() < unobserved_from_x; }),
            std::numeric_limits<double>::infinity());
  EXPECT_THROW(tracker.limitToObservedSpace(std::nan(""), 1.0), std::invalid_argument);
  EXPECT_THROW(tracker.limitToObservedSpace(5.0, 0.0), std::invalid_argument);
  EXPECT_THROW(tracker.limitToObservedSpace(5.0, 1.0, -1.0), std::invalid_argument);
  // With a crawl speed the bound never holds the vehicle below it.
  TrajectoryTracker crawling(traj, *sc.vehicle);
  crawling.limitToObservedSpace(0.0, 1.0, 0.4);
  crawling.update(noiselessVehicleAt(*sc.vehicle, {1, 5, 0}).state(), 0.05);
  EXPECT_DOUBLE_EQ(crawling.observedSpaceCap(), 0.4);
}

// A scan from the origin: a wall at x = 5 for y in [-1, 1] (returns at bearings within ~11 degrees), nothing else
// within the 20 m range. A disc before the wall, or off its bearings, was looked through; behind it, or beyond the
// range, or outside a forward field of view, it was not.
TEST(ScanFreeSpace, WhatTheBeamsLookedThroughIsEmptyWhatIsBehindReturnsIsNot) {
  std::vector<Vec3> wall;
  for (double y = -1.0; y <= 1.0; y += 0.05) wall.emplace_back(5.0, y, 0.0);
  ScanFreeSpace all_round(0.5 * M_PI / 180, 20.0, 2 * M_PI);
  EXPECT_FALSE(all_round.discSeenEmpty(Vec3(2, 0, 0), 0.5));  // before the first scan
  all_round.update(Vec3::Zero(), 0.0, wall);
  EXPECT_TRUE(all_round.discSeenEmpty(Vec3(3, 0, 0), 0.5));    // before the wall
  EXPECT_FALSE(all_round.discSeenEmpty(Vec3(4.7, 0, 0), 0.5)); // reaching over it
  EXPECT_FALSE(all_round.discSeenEmpty(Vec3(8, 0, 0), 0.5));   // behind it
  EXPECT_FALSE(all_round.discSeenEmpty(Vec3(8, 1.4, 0), 0.5)); // behind its end: the disc's bearings reach the returns
  EXPECT_TRUE(all_round.discSeenEmpty(Vec3(8, 3, 0), 0.5));    // beside it: no return on those bearings
  EXPECT_TRUE(all_round.discSeenEmpty(Vec3(-10, 0, 0), 0.5));  // behind the sensor, all round
  EXPECT_FALSE(all_round.discSeenEmpty(Vec3(-19.8, 0, 0), 0.5));  // its far side beyond the range
  EXPECT_TRUE(all_round.discSeenEmpty(Vec3(0.2, 0, 0), 0.5));     // around the sensor itself, all round
  all_round.update(Vec3(4.7, 0, 0), 0.0, wall);
  EXPECT_FALSE(all_round.discSeenEmpty(Vec3(4.8, 0, 0), 0.5));    // ... unless a return lies within it
  ScanFreeSpace forward(0.5 * M_PI / 180, 20.0, M_PI / 2);  // 90 degrees, facing +y
  forward.update(Vec3::Zero(), M_PI / 2, wall);
  EXPECT_TRUE(forward.discSeenEmpty(Vec3(0, 6, 0), 0.5));
  EXPECT_FALSE(forward.discSeenEmpty(Vec3(-10, 0, 0), 0.5));  // outside the field of view
  EXPECT_FALSE(forward.discSeenEmpty(Vec3(0.2, 0, 0), 0.5));  // around the sensor: partly behind it
  forward.update(Vec3(std::nan(""), 0, 0), 0.0, wall);
  EXPECT_FALSE(forward.discSeenEmpty(Vec3(0, 6, 0), 0.5));  // a scan without an origin sees nothing
  EXPECT_THROW(ScanFreeSpace(0.0, 20.0, 1.0), std::invalid_argument);
  EXPECT_THROW(ScanFreeSpace(0.01, 0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(ScanFreeSpace(0.01, 20.0, 7.0), std::invalid_argument);
}
