// ddsnav-tracker: drives the vehicle to the scenario's goal. Asks for a plan (planning/request), smooths
// the answer into a trajectory (control/trajectory), follows it with the trajectory controller
// (control/cmd_vel, control/tracking), and asks again when the vehicle deviates or newly perceived
// obstacles truly block the rest of the trajectory within the horizon (tracker::ReplanGate: hysteresis,
// and a start predicted along the trajectory, which the vehicle keeps flying meanwhile). The mission's
// decisions (when to ask, retry, give up, when the goal is reached) are tracker::Mission's; this file
// carries them out.

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>
#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/tracker/mission.hpp>
#include <ddsnav/tracker/replan.hpp>
#include <ddsnav/tracker/smoother.hpp>
#include <ddsnav/tracker/tracker.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <optional>

using namespace ddsnav;
using nodes::sleepFor;

int main(int argc, char** argv) {
  return runtime::runComponent("tracker", argc, argv, [](runtime::Context& ctx) {
    const auto scenario = planner::loadScenario(ctx.params().require<std::string>("scenario"));
    if (!scenario.vehicle) throw std::invalid_argument(scenario.source + ": the tracker needs a 'vehicle' block");
    const auto limits = *scenario.vehicle;
    const std::string planner_name = ctx.params().declare<std::string>("planner", "gart");
    const double control_rate = ctx.params().declare<double>("control_rate_hz", 20.0);
    const double time_budget = ctx.params().declare<double>("time_budget_s", 5.0);
    const auto seed = static_cast<std::uint64_t>(ctx.params().declare<std::int64_t>("seed", 1));
    const std::int64_t max_attempts = ctx.params().declare<std::int64_t>("max_plan_attempts", 10);
    const double retry_delay = ctx.params().declare<double>("plan_retry_delay_s", 1.0);
    const bool wait_for_world = ctx.params().declare<bool>("wait_for_world", true);
    const double replan_check_period = ctx.params().declare<double>("replan_check_period_s", 0.1);
    tracker::ReplanPolicy replan_policy;
    replan_policy.confirm_checks = static_cast<int>(ctx.params().declare<std::int64_t>("replan_confirm_checks", replan_policy.confirm_checks));
    replan_policy.block_margin = ctx.params().declare<double>("replan_block_margin", replan_policy.block_margin);
    replan_policy.stop_margin_s = ctx.params().declare<double>("replan_stop_margin_s", replan_policy.stop_margin_s);
    replan_policy.planning_time_s = ctx.params().declare<double>("expected_planning_time_s", replan_policy.planning_time_s);
    try {
      replan_policy.validate();
    } catch (const std::invalid_argument& e) {
      throw runtime::ParameterError(std::string("parameters replan_*, expected_planning_time_s: ") + e.what());
    }
    tracker::TrackerConfig tracker_config;
    tracker_config.replan_deviation = ctx.params().declare<double>("replan_deviation", tracker_config.replan_deviation);
    tracker_config.replan_horizon = ctx.params().declare<double>("replan_horizon_s", 8.0);
    tracker::SmootherConfig smoother_config;
    smoother_config.sample_dt = ctx.params().declare<double>("sample_dt", smoother_config.sample_dt);
    auto require = [](bool ok, const char* name, const char* expected, auto got) {
      if (!ok) throw runtime::ParameterError(fmt::format("parameter {}: expected {}, got {}", name, expected, got));
    };
    require(control_rate > 0 && control_rate <= 1000, "control_rate_hz", "(0, 1000] Hz", control_rate);
    require(time_budget > 0 && std::isfinite(time_budget), "time_budget_s", "a positive finite number of seconds", time_budget);
    require(max_attempts >= 1, "max_plan_attempts", "at least 1", max_attempts);
    require(retry_delay >= 0 && std::isfinite(retry_delay), "plan_retry_delay_s", "a finite number of seconds >= 0", retry_delay);
    require(replan_check_period > 0 && std::isfinite(replan_check_period), "replan_check_period_s",
            "a positive finite number of seconds", replan_check_period);
    require(tracker_config.replan_deviation > 0 && std::isfinite(tracker_config.replan_deviation), "replan_deviation",
            "a positive finite number of metres", tracker_config.replan_deviation);
    require(tracker_config.replan_horizon > 0, "replan_horizon_s", "a positive number of seconds (inf: the whole trajectory)",
            tracker_config.replan_horizon);
    require(smoother_config.sample_dt > 0 && std::isfinite(smoother_config.sample_dt), "sample_dt",
            "a positive finite number of seconds", smoother_config.sample_dt);

    std::mutex mutex;
    std::optional<tracker::VehicleState> vehicle;
    std::optional<msg::Path> new_path;
    // A state with a non-finite number would reach the controller (and its commands the vehicle): drop it
    // here, once, and keep following the last good one.
    nodes::DroppedSamples dropped_states("vehicle/state", "keeping the last good state");
    auto state_sub = ctx.bus().subscribe<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), [&](const msg::VehicleState& s) {
      if (const auto error = nodes::checkVehicleState(s, nodes::kWorldFrame); !error.empty()) return dropped_states.drop(error);
      std::lock_guard lock(mutex);
      vehicle = nodes::fromMsg(s);
    });
    auto path_sub = ctx.bus().subscribe<msg::Path>("planning/path", bus::Qos::state(), [&](const msg::Path& p) {
      std::lock_guard lock(mutex);
      new_path = p;
    });
    auto requests = ctx.bus().publisher<msg::PlanRequest>("planning/request", bus::Qos::commands());
    auto trajectories = ctx.bus().publisher<msg::Trajectory>("control/trajectory", bus::Qos::state());
    auto commands = ctx.bus().publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands());
    auto statuses = ctx.bus().publisher<msg::TrackingStatus>("control/tracking", bus::Qos::sensorData());

    // The same world the planner plans on (world parameter of both), seen from the vehicle's position.
    nodes::WorldSource world_source(ctx.bus(), nodes::declareWorldParameters(ctx.params()), scenario);
    // nullptr (logged) when there is none yet or it cannot be built: the tracker keeps running either way.
    auto currentWorld = [&](const Eigen::Vector3d& position) -> std::unique_ptr<planner::CollisionWorld> {
      try {
        return world_source.snapshot(position);
      } catch (const std::exception& e) {
        spdlog::warn("cannot build the planner's world: {}", e.what());
        return nullptr;
      }
    };

    tracker::MissionConfig mission_config;
    mission_config.goal = scenario.goal;
    mission_config.goal_radius = scenario.goal_radius;
    mission_config.max_plan_attempts = max_attempts;
    mission_config.plan_retry_delay_s = retry_delay;
    mission_config.time_budget_s = time_budget;
    mission_config.replan_check_period_s = replan_check_period;
    mission_config.wait_for_world = wait_for_world;
    tracker::Mission mission(mission_config);
    tracker::ReplanGate replan_gate(replan_policy);
    std::int64_t requested_at_ns = 0;     // the current request's time, for the gate's planning-time estimate
    double request_heading = 0.0;         // its start heading: the new trajectory starts there

    auto stop = [&] { commands.publish(nodes::toMsg(tracker::VehicleCommand{}, ctx.clock().nowNs())); };
    std::optional<tracker::TrajectoryTracker> follower;
    // A replan from a predicted start: the new trajectory waits until the vehicle's reference on the current
    // one reaches that start (switch_at, s of the current trajectory), so a plan ready early is not flown
    // from behind its start; a late one is switched to at once.
    std::optional<double> switch_at;
    std::optional<tracker::Trajectory> next_trajectory;
    std::int64_t next_since_ns = 0;
    auto switchTrajectory = [&](tracker::Trajectory trajectory, std::uint32_t request_id) {
      trajectories.publish(nodes::toMsg(trajectory, request_id, ctx.clock().nowNs()));
      follower.emplace(std::move(trajectory), limits, tracker_config);
      replan_gate.reset();
    };
    msg::TrackingStatus last_status;
    // Carries out what the mission decided; returns whether the vehicle should be driven this period.
    auto act = [&](const tracker::MissionDecision& d) {
      if (!d.warning.empty()) spdlog::warn("{}", d.warning);
      switch (d.action) {
        case tracker::MissionAction::RequestPlan: {
          msg::PlanRequest request;
          msg::Header header;
          header.stamp_ns(ctx.clock().nowNs());
          header.frame_id(nodes::kWorldFrame);
          request.header(header);
          request.request_id(d.request_id);
          request.start(nodes::toMsg(planner::State{d.from.position, d.from.heading}));
          request.goal(nodes::toMsg(planner::State{scenario.goal, 0.0}));
          request.goal_radius(scenario.goal_radius);
          request.planner(planner_name);
          request.time_budget_s(time_budget);
          request.seed(seed + d.request_id - 1);
          request.reason(d.reason);
          spdlog::info("requesting plan {} with {} ({})", d.request_id, planner_name, d.reason);
          requested_at_ns = ctx.clock().nowNs();
          request_heading = d.from.heading;
          switch_at.reset();  // set again by a replan ahead, after this
          next_trajectory.reset();
          requests.publish(request);
          return false;
        }
        case tracker::MissionAction::Failed: throw std::runtime_error(d.reason);
        case tracker::MissionAction::Finished: statuses.publish(last_status); return false;  // best effort: keep saying so
        case tracker::MissionAction::Drive: return true;
        default: return false;
      }
    };
    // The answer to the current request, smoothed into the trajectory to follow; false when it cannot be.
    auto smooth = [&](const msg::Path& path, const tracker::VehicleState& state) {
      try {
        auto world = currentWorld(state.position);
        if (!world) throw tracker::SmoothingError("the tracker has no usable world of the planner yet");
        smoother_config.initial_heading = request_heading;
        const auto smooth_started = std::chrono::steady_clock::now();
        auto trajectory = tracker::smoothPath(nodes::statesOf(path), *world, limits, smoother_config);
        if (const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - smooth_started).count(); took > 0.25)
          spdlog::warn("smoothing plan {} took {:.3f} s: the vehicle held its last command meanwhile", path.request_id(), took);
        const double latency = static_cast<double>(ctx.clock().nowNs() - requested_at_ns) * 1e-9;
        spdlog::info("trajectory {}: {:.1f} m, {:.1f} s, max curvature {:.3f} 1/m, min clearance {:.2f} m, ready {:.3f} s after its request",
                     path.request_id(), trajectory.report.length, trajectory.report.duration, trajectory.report.max_curvature,
                     trajectory.report.min_clearance, latency);
        replan_gate.planReady(latency);
        if (follower && switch_at && follower->status().reference_time < *switch_at) {
          next_trajectory = std::move(trajectory);
          next_since_ns = ctx.clock().nowNs();
        } else {
          switchTrajectory(std::move(trajectory), path.request_id());
          switch_at.reset();
        }
        return true;
      } catch (const std::exception& e) {
        spdlog::warn("cannot smooth plan {}: {}", path.request_id(), e.what());
        return false;
      }
    };

    // Wait for the vehicle (and the first obstacles) before the first request; readiness first, so the
    // launcher can start whoever waits for us.
    ctx.ready();
    if (!requests.waitForSubscribers(1, std::chrono::seconds(20))) spdlog::warn("no planner subscribed to planning/request yet");
    // The reference advances by the clock's time between two control steps, not by the nominal period: on
    // a loaded machine the loop runs late, and a fixed step would slow the reference (and the vehicle,
    // which the controller holds to it) in proportion. Capped, so one stall is not one jump.
    const double nominal_dt = 1.0 / control_rate;
    std::int64_t last_step_ns = ctx.clock().nowNs();
    const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / control_rate));
    while (sleepFor(ctx, period)) {
      const std::int64_t step_ns = ctx.clock().nowNs();
      const double dt = std::clamp(static_cast<double>(step_ns - last_step_ns) * 1e-9, 0.2 * nominal_dt, 5.0 * nominal_dt);
      last_step_ns = step_ns;
      std::optional<tracker::VehicleState> state;
      std::optional<msg::Path> path;
      {
        std::lock_guard lock(mutex);
        state = vehicle;
        path.swap(new_path);
      }
      std::optional<tracker::PlanAnswer> answer;
      if (path) {
        answer.emplace();
        answer->request_id = path->request_id();
        answer->solved = path->solved();
        answer->failure = path->failure();
        answer->exact = path->exact();
        if (!path->states().empty()) answer->path_end = nodes::fromMsg(path->states().back()).position;
        // A malformed answer is a failed one (the mission retries), with the reason in the log.
        if (const auto error = nodes::checkPath(*path); !error.empty()) {
          answer->solved = false;
          answer->failure = "planning/path: malformed answer: " + error;
        }
      }
      auto decision = mission.update(ctx.clock().nowNs(), state, world_source.available(), answer);
      if (decision.action == tracker::MissionAction::SmoothPath)
        decision = mission.pathSmoothed(ctx.clock().nowNs(), *state, smooth(*path, *state));
      if (!act(decision)) continue;

      if (next_trajectory && (follower->status().reference_time >= *switch_at ||
                              static_cast<double>(ctx.clock().nowNs() - next_since_ns) * 1e-9 > 2.0)) {
        switchTrajectory(std::move(*next_trajectory), mission.requestId());
        next_trajectory.reset();
        switch_at.reset();
      }
      const auto command = follower->update(*state, dt);
      const auto& status = follower->status();
      commands.publish(nodes::toMsg(command, ctx.clock().nowNs()));
      const auto next = mission.tracked(ctx.clock().nowNs(), *state, status, dt);
      msg::TrackingStatus out;
      out.stamp_ns(ctx.clock().nowNs());
      out.request_id(mission.requestId());
      out.cross_track_error(status.cross_track_error);
      out.along_track_error(status.along_track_error);
      out.mean_cross_track_error(status.mean_cross_track_error);
      out.max_cross_track_error(status.max_cross_track_error);
      out.progress(status.progress);
      out.goal_reached(next.action == tracker::MissionAction::Finished);
      statuses.publish(out);
      last_status = out;
      if (next.action == tracker::MissionAction::Finished) {
        stop();
        spdlog::info("goal reached: the vehicle is {:.2f} m from the goal (goal radius {:.2f} m); mean cross-track error {:.3f} m, max {:.3f} m",
                     mission.goalCheck(*state).distance, scenario.goal_radius, status.mean_cross_track_error,
                     status.max_cross_track_error);
      } else if (next.action == tracker::MissionAction::RequestPlan || next.action == tracker::MissionAction::Failed) {
        // The trajectory ended outside the goal region: stop, and ask again from here (or give up).
        stop();
        follower.reset();
        act(next);
      } else if (next.action == tracker::MissionAction::CheckReplan && !next_trajectory) {
        const auto check_started = std::chrono::steady_clock::now();
        const auto world = currentWorld(state->position);
        const auto replan = world ? follower->checkReplan(*world) : tracker::ReplanDecision{};
        if (const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - check_started).count(); took > 0.25)
          spdlog::warn("replan check took {:.3f} s (world snapshot and trajectory check): the vehicle held its last command meanwhile", took);
        const auto verdict = replan_gate.check(replan, follower->trajectory(), follower->status().reference_time);
        if (verdict.action == tracker::ReplanAction::StopAndReplan) {
          stop();
          follower.reset();
          switch_at.reset();
          if (mission.awaitingPlan()) {  // a plan is on its way already: wait for it here
            spdlog::warn("stopping to wait for plan {}: {}", mission.requestId(), verdict.reason);
            mission.hold();
          } else {
            act(mission.replan(ctx.clock().nowNs(), *state, verdict.reason));
          }
        } else if (verdict.action == tracker::ReplanAction::ReplanAhead && !mission.awaitingPlan()) {
          tracker::VehicleState from = *state;
          from.position = verdict.start.position;
          from.heading = tracker::wrapAngle(verdict.start.heading);
          act(mission.replanAhead(ctx.clock().nowNs(), from, verdict.reason));
          switch_at = verdict.start.time;
        }
      }
    }
    stop();
  });
}
