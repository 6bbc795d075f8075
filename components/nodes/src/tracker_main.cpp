// ddsnav-tracker: drives the vehicle to the scenario's goal. Asks for a plan (planning/request), smooths
// the answer into a trajectory (control/trajectory), follows it with the trajectory controller
// (control/cmd_vel, control/tracking), and asks again from the current state when the vehicle
// deviates or newly perceived obstacles block the rest of the trajectory.

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/runtime/component.hpp>
#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/tracker/smoother.hpp>
#include <ddsnav/tracker/tracker.hpp>

#include <spdlog/spdlog.h>

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
    const double replan_check_period = ctx.params().declare<double>("replan_check_period_s", 0.5);
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
    auto state_sub = ctx.bus().subscribe<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), [&](const msg::VehicleState& s) {
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
    nodes::WorldSource world_source(ctx.bus(), nodes::parseWorldKind(ctx.params().declare<std::string>("world", "obstacles")), scenario);
    // nullptr (logged) when there is none yet or it cannot be built: the tracker keeps running either way.
    auto currentWorld = [&](const Eigen::Vector3d& position) -> std::unique_ptr<planner::CollisionWorld> {
      try {
        return world_source.snapshot(position);
      } catch (const std::exception& e) {
        spdlog::warn("cannot build the planner's world: {}", e.what());
        return nullptr;
      }
    };

    std::uint32_t request_id = 0;
    std::int64_t attempts = 0;
    // A failed attempt is retried after plan_retry_delay_s; kNoRetry: none pending. (A plain sentinel, not
    // std::optional: GCC 12 reports a false maybe-uninitialized on the optional here.)
    constexpr std::int64_t kNoRetry = -1;
    std::int64_t retry_at_ns = kNoRetry;
    std::optional<std::int64_t> pending_since;
    auto requestPlan = [&](const tracker::VehicleState& from, const std::string& why) {
      msg::PlanRequest request;
      msg::Header header;
      header.stamp_ns(ctx.clock().nowNs());
      header.frame_id(nodes::kWorldFrame);
      request.header(header);
      request.request_id(++request_id);
      request.start(nodes::toMsg(planner::State{from.position, from.heading}));
      request.goal(nodes::toMsg(planner::State{scenario.goal, 0.0}));
      request.goal_radius(scenario.goal_radius);
      request.planner(planner_name);
      request.time_budget_s(time_budget);
      request.seed(seed + request_id - 1);
      ++attempts;
      pending_since = ctx.clock().nowNs();
      spdlog::info("requesting plan {} with {} ({})", request_id, planner_name, why);
      requests.publish(request);
    };
    auto stop = [&] { commands.publish(nodes::toMsg(tracker::VehicleCommand{}, ctx.clock().nowNs())); };

    // Wait for the vehicle (and the first obstacles) before the first request; readiness first, so the
    // launcher can start whoever waits for us.
    ctx.ready();
    if (!requests.waitForSubscribers(1, std::chrono::seconds(20))) spdlog::warn("no planner subscribed to planning/request yet");
    std::optional<tracker::TrajectoryTracker> follower;
    bool goal_reached = false;
    const double dt = 1.0 / control_rate;
    const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / control_rate));
    double since_replan_check = 0.0;
    msg::TrackingStatus last_status;
    while (sleepFor(ctx, period)) {
      std::optional<tracker::VehicleState> state;
      std::optional<msg::Path> path;
      {
        std::lock_guard lock(mutex);
        state = vehicle;
        path.swap(new_path);
      }
      if (goal_reached) {
        statuses.publish(last_status);  // keep saying so: the status topic is best effort
        continue;
      }
      if (!state) continue;
      if (request_id == 0) {
        // The planner's world must exist before the first request (perception's first scan, the first map).
        if (wait_for_world && !world_source.available()) continue;
        requestPlan(*state, "start");
        continue;
      }
      if (path && path->request_id() == request_id) {
        pending_since.reset();
        if (!path->solved()) {
          spdlog::warn("plan {} failed", request_id);
          if (attempts >= max_attempts) throw std::runtime_error("no plan after " + std::to_string(attempts) + " attempts");
          retry_at_ns = ctx.clock().nowNs() + static_cast<std::int64_t>(retry_delay * 1e9);
          continue;
        }
        try {
          auto world = currentWorld(state->position);
          if (!world) throw tracker::SmoothingError("the tracker has no usable world of the planner yet");
          smoother_config.initial_heading = state->heading;
          auto trajectory = tracker::smoothPath(nodes::statesOf(*path), *world, limits, smoother_config);
          spdlog::info("trajectory {}: {:.1f} m, {:.1f} s, max curvature {:.3f} 1/m, min clearance {:.2f} m", request_id,
                       trajectory.report.length, trajectory.report.duration, trajectory.report.max_curvature,
                       trajectory.report.min_clearance);
          trajectories.publish(nodes::toMsg(trajectory, request_id, ctx.clock().nowNs()));
          follower.emplace(std::move(trajectory), limits, tracker_config);
          attempts = 0;
        } catch (const std::exception& e) {
          spdlog::warn("cannot smooth plan {}: {}", request_id, e.what());
          if (attempts >= max_attempts) throw std::runtime_error("no drivable trajectory after " + std::to_string(attempts) + " attempts");
          retry_at_ns = ctx.clock().nowNs() + static_cast<std::int64_t>(retry_delay * 1e9);
          continue;
        }
      }
      if (retry_at_ns != kNoRetry && ctx.clock().nowNs() >= retry_at_ns) {
        retry_at_ns = kNoRetry;
        requestPlan(*state, "retrying");
        continue;
      }
      if (!follower) {
        // A request may be lost while the planner restarts: ask again after twice its budget. Unanswered
        // requests count as attempts, so a missing planner ends the mission instead of being asked forever.
        if (pending_since && (ctx.clock().nowNs() - *pending_since) * 1e-9 > 2 * time_budget + 2) {
          spdlog::warn("plan {}: no answer from the planner", request_id);
          if (attempts >= max_attempts)
            throw std::runtime_error("no answer from the planner (planning/path) after " + std::to_string(attempts) + " attempts");
          requestPlan(*state, "no answer");
        }
        continue;
      }
      const auto command = follower->update(*state, dt);
      const auto& status = follower->status();
      commands.publish(nodes::toMsg(command, ctx.clock().nowNs()));
      msg::TrackingStatus out;
      out.stamp_ns(ctx.clock().nowNs());
      out.request_id(request_id);
      out.cross_track_error(status.cross_track_error);
      out.along_track_error(status.along_track_error);
      out.mean_cross_track_error(status.mean_cross_track_error);
      out.max_cross_track_error(status.max_cross_track_error);
      out.progress(status.progress);
      // The mission's goal is the scenario's goal region; the controller's own test (trajectory finished and
      // the vehicle within its tolerance of the end) is stricter than that.
      const bool in_goal_region = status.progress > 0.95 && (state->position - scenario.goal).norm() <= scenario.goal_radius;
      const bool arrived = status.goal_reached || in_goal_region;
      out.goal_reached(arrived);
      statuses.publish(out);
      last_status = out;
      if (arrived) {
        goal_reached = true;
        stop();
        spdlog::info("goal reached: mean cross-track error {:.3f} m, max {:.3f} m", status.mean_cross_track_error,
                     status.max_cross_track_error);
        continue;
      }
      since_replan_check += dt;
      if (since_replan_check >= replan_check_period) {
        since_replan_check = 0.0;
        const auto world = currentWorld(state->position);
        const auto decision = world ? follower->checkReplan(*world) : tracker::ReplanDecision{};
        if (decision.needed) {
          stop();
          follower.reset();
          requestPlan(*state, decision.message);
        }
      }
    }
    stop();
  });
}
