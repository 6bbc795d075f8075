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
#include <optional>

using namespace ddsnav;

namespace {

class TrackerComponent : public runtime::Component {
 public:
  struct Params {
    std::string scenario, planner;
    nodes::WorldParameters world;  // world, unknown_space: the planner's, to smooth and check against
    double control_rate_hz, time_budget_s;
    std::int64_t seed, max_plan_attempts;
    double plan_retry_delay_s;
    bool wait_for_world;
    double replan_check_period_s;
    tracker::ReplanPolicy replan;
    tracker::TrackerConfig tracker;
    tracker::SmootherConfig smoother;
    explicit Params(runtime::Parameters& p)
        : scenario(p.require<std::string>("scenario", runtime::ParamSpec{.doc = "scenario file: goal, goal radius, vehicle limits"})),
          planner(p.declare<std::string>("planner", "gart", {.doc = "planner asked for in each request (docs/planners.md)"})),
          world(p),
          control_rate_hz(p.declare<double>("control_rate_hz", 20.0, {.above = 0, .max = 1000, .unit = "Hz", .doc = "controller rate"})),
          time_budget_s(p.declare<double>("time_budget_s", 5.0, {.above = 0, .unit = "s", .doc = "time budget of each plan request"})),
          seed(p.declare<std::int64_t>("seed", 1, {.doc = "seed of the first request (the n-th asks seed + n - 1)"})),
          max_plan_attempts(p.declare<std::int64_t>("max_plan_attempts", 10, {.min = 1, .doc = "failed plans in a row before giving up"})),
          plan_retry_delay_s(p.declare<double>("plan_retry_delay_s", 1.0, {.min = 0, .unit = "s", .doc = "pause before asking again"})),
          wait_for_world(p.declare<bool>("wait_for_world", true, {.doc = "the first request waits for the planner's world"})),
          replan_check_period_s(p.declare<double>("replan_check_period_s", 0.1, {.above = 0, .unit = "s", .doc = "how often the rest of the trajectory is checked"})) {
      replan.confirm_checks = static_cast<int>(p.declare<std::int64_t>(
          "replan_confirm_checks", replan.confirm_checks,
          {.min = 1, .max = 1000, .doc = "consecutive blocked checks that confirm a block (hysteresis; docs/tracking.md, \"Replanning\")"}));
      replan.block_margin = p.declare<double>("replan_block_margin", replan.block_margin,
                                              {.min = 0, .max = 100, .unit = "m", .doc = "overlap with an obstacle that confirms a block at the first check"});
      replan.stop_margin_s = p.declare<double>("replan_stop_margin_s", replan.stop_margin_s,
                                               {.min = 0, .max = 600, .unit = "s", .doc = "time kept between a predicted replan start and the blocked sample"});
      replan.planning_time_s = p.declare<double>("expected_planning_time_s", replan.planning_time_s,
                                                 {.min = 0, .max = 600, .unit = "s", .doc = "least expected time from a request to its trajectory"});
      tracker.replan_deviation = p.declare<double>("replan_deviation", tracker.replan_deviation,
                                                   {.above = 0, .unit = "m", .doc = "ask again when the vehicle is this far off the trajectory"});
      tracker.replan_horizon = p.declare<double>("replan_horizon_s", 8.0, {.above = 0, .unit = "s", .doc = "how far ahead obstacles are checked"});
      smoother.sample_dt = p.declare<double>("sample_dt", smoother.sample_dt, {.above = 0, .unit = "s", .doc = "trajectory sample spacing"});
    }
  };

  explicit TrackerComponent(runtime::Context& ctx)
      : Component(ctx),
        params_(ctx.params()),
        scenario_(planner::loadScenario(params_.scenario)),
        limits_(vehicleOf(scenario_)),
        smoother_config_(params_.smoother),
        dropped_states_("vehicle/state", "keeping the last good state"),
        requests_(publisher(runtime::topics::plan_request)),
        trajectories_(publisher(runtime::topics::trajectory)),
        commands_(publisher(runtime::topics::cmd_vel)),
        statuses_(publisher(runtime::topics::tracking)),
        // The same world the planner plans on (world parameter of both), seen from the vehicle's position.
        world_source_(ctx, params_.world, scenario_),
        mission_(missionConfig()),
        replan_gate_(params_.replan) {
    // A state with a non-finite number would reach the controller (and its commands the vehicle): drop it
    // here, once, and keep following the last good one.
    state_sub_ = subscribe(runtime::topics::vehicle_state, [this](const msg::VehicleState& s) {
      if (const auto error = nodes::checkVehicleState(s, nodes::kWorldFrame); !error.empty()) return dropped_states_.drop(error);
      vehicle_ = nodes::fromMsg(s);
    });
    path_sub_ = subscribe(runtime::topics::path, [this](const msg::Path& p) { new_path_ = p; });
    started_ = std::chrono::steady_clock::now();
    last_step_ns_ = clock().nowNs();
    control_ = every(std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / params_.control_rate_hz)), [this] { control(); });
  }

  void shutdown() override { stop(); }

 private:
  static planner::VehicleLimits vehicleOf(const planner::Scenario& scenario) {
    if (!scenario.vehicle) throw std::invalid_argument(scenario.source + ": the tracker needs a 'vehicle' block");
    return *scenario.vehicle;
  }

  tracker::MissionConfig missionConfig() const {
    tracker::MissionConfig c;
    c.goal = scenario_.goal;
    c.goal_radius = scenario_.goal_radius;
    c.max_plan_attempts = params_.max_plan_attempts;
    c.plan_retry_delay_s = params_.plan_retry_delay_s;
    c.time_budget_s = params_.time_budget_s;
    c.replan_check_period_s = params_.replan_check_period_s;
    c.wait_for_world = params_.wait_for_world;
    return c;
  }

  void stop() { commands_.publish(nodes::toMsg(tracker::VehicleCommand{}, clock().nowNs())); }

  // nullptr (logged) when there is none yet or it cannot be built: the tracker keeps running either way.
  std::unique_ptr<planner::CollisionWorld> currentWorld(const Eigen::Vector3d& position) {
    try {
      return world_source_.snapshot(position);
    } catch (const std::exception& e) {
      spdlog::warn("cannot build the planner's world: {}", e.what());
      return nullptr;
    }
  }

  // Carries out what the mission decided; returns whether the vehicle should be driven this period.
  bool act(const tracker::MissionDecision& d) {
    if (!d.warning.empty()) spdlog::warn("{}", d.warning);
    switch (d.action) {
      case tracker::MissionAction::RequestPlan: {
        msg::PlanRequest request;
        msg::Header header;
        header.stamp_ns(clock().nowNs());
        header.frame_id(nodes::kWorldFrame);
        request.header(header);
        request.request_id(d.request_id);
        request.start(nodes::toMsg(planner::State{d.from.position, d.from.heading}));
        request.goal(nodes::toMsg(planner::State{scenario_.goal, 0.0}));
        request.goal_radius(scenario_.goal_radius);
        request.planner(params_.planner);
        request.time_budget_s(params_.time_budget_s);
        request.seed(static_cast<std::uint64_t>(params_.seed) + d.request_id - 1);
        request.reason(d.reason);
        spdlog::info("requesting plan {} with {} ({})", d.request_id, params_.planner, d.reason);
        requested_at_ns_ = clock().nowNs();
        request_heading_ = d.from.heading;
        switch_at_.reset();  // set again by a replan ahead, after this
        next_trajectory_.reset();
        requests_.publish(request);
        return false;
      }
      case tracker::MissionAction::Failed: throw std::runtime_error(d.reason);
      case tracker::MissionAction::Finished: statuses_.publish(last_status_); return false;  // best effort: keep saying so
      case tracker::MissionAction::Drive: return true;
      default: return false;
    }
  }

  // The answer to the current request, smoothed into the trajectory to follow; false when it cannot be.
  bool smooth(const msg::Path& path, const tracker::VehicleState& state) {
    try {
      auto world = currentWorld(state.position);
      if (!world) throw tracker::SmoothingError("the tracker has no usable world of the planner yet");
      smoother_config_.initial_heading = request_heading_;
      const auto smooth_started = std::chrono::steady_clock::now();
      auto trajectory = tracker::smoothPath(nodes::statesOf(path), *world, limits_, smoother_config_);
      if (const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - smooth_started).count(); took > 0.25)
        spdlog::warn("smoothing plan {} took {:.3f} s: the vehicle held its last command meanwhile", path.request_id(), took);
      const double latency = static_cast<double>(clock().nowNs() - requested_at_ns_) * 1e-9;
      spdlog::info("trajectory {}: {:.1f} m, {:.1f} s, max curvature {:.3f} 1/m, min clearance {:.2f} m, ready {:.3f} s after its request",
                   path.request_id(), trajectory.report.length, trajectory.report.duration, trajectory.report.max_curvature,
                   trajectory.report.min_clearance, latency);
      replan_gate_.planReady(latency);
      if (follower_ && switch_at_ && follower_->status().reference_time < *switch_at_) {
        next_trajectory_ = std::move(trajectory);
        next_since_ns_ = clock().nowNs();
      } else {
        switchTrajectory(std::move(trajectory), path.request_id());
        switch_at_.reset();
      }
      return true;
    } catch (const std::exception& e) {
      spdlog::warn("cannot smooth plan {}: {}", path.request_id(), e.what());
      return false;
    }
  }

  void switchTrajectory(tracker::Trajectory trajectory, std::uint32_t request_id) {
    trajectories_.publish(nodes::toMsg(trajectory, request_id, clock().nowNs()));
    follower_.emplace(std::move(trajectory), limits_, params_.tracker);
    replan_gate_.reset();
  }

  void control() {
    // The reference advances by the clock's time between two control steps, not by the nominal period: on
    // a loaded machine the timer fires late, and a fixed step would slow the reference (and the vehicle,
    // which the controller holds to it) in proportion. Capped, so one stall is not one jump.
    const double nominal_dt = 1.0 / params_.control_rate_hz;
    const std::int64_t step_ns = clock().nowNs();
    const double dt = std::clamp(static_cast<double>(step_ns - last_step_ns_) * 1e-9, 0.2 * nominal_dt, 5.0 * nominal_dt);
    last_step_ns_ = step_ns;
    // Readiness first (so the launcher can start whoever waits for us), then wait up to 20 s for a planner.
    if (!planner_seen_) {
      if (requests_.matchedSubscribers() == 0 && std::chrono::steady_clock::now() - started_ < std::chrono::seconds(20)) return;
      if (requests_.matchedSubscribers() == 0) spdlog::warn("no planner subscribed to planning/request yet");
      planner_seen_ = true;
    }
    const std::optional<tracker::VehicleState> state = vehicle_;
    std::optional<msg::Path> path;
    path.swap(new_path_);
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
    auto decision = mission_.update(clock().nowNs(), state, world_source_.available(), answer);
    if (decision.action == tracker::MissionAction::SmoothPath) decision = mission_.pathSmoothed(clock().nowNs(), *state, smooth(*path, *state));
    if (!act(decision)) return;

    if (next_trajectory_ && (follower_->status().reference_time >= *switch_at_ ||
                             static_cast<double>(clock().nowNs() - next_since_ns_) * 1e-9 > 2.0)) {
      switchTrajectory(std::move(*next_trajectory_), mission_.requestId());
      next_trajectory_.reset();
      switch_at_.reset();
    }
    const auto command = follower_->update(*state, dt);
    const auto& status = follower_->status();
    commands_.publish(nodes::toMsg(command, clock().nowNs()));
    const auto next = mission_.tracked(clock().nowNs(), *state, status, dt);
    msg::TrackingStatus out;
    out.stamp_ns(clock().nowNs());
    out.request_id(mission_.requestId());
    out.cross_track_error(status.cross_track_error);
    out.along_track_error(status.along_track_error);
    out.mean_cross_track_error(status.mean_cross_track_error);
    out.max_cross_track_error(status.max_cross_track_error);
    out.progress(status.progress);
    out.goal_reached(next.action == tracker::MissionAction::Finished);
    statuses_.publish(out);
    last_status_ = out;
    if (next.action == tracker::MissionAction::Finished) {
      stop();
      spdlog::info("goal reached: the vehicle is {:.2f} m from the goal (goal radius {:.2f} m); mean cross-track error {:.3f} m, max {:.3f} m",
                   mission_.goalCheck(*state).distance, scenario_.goal_radius, status.mean_cross_track_error, status.max_cross_track_error);
    } else if (next.action == tracker::MissionAction::RequestPlan || next.action == tracker::MissionAction::Failed) {
      // The trajectory ended outside the goal region: stop, and ask again from here (or give up).
      stop();
      follower_.reset();
      act(next);
    } else if (next.action == tracker::MissionAction::CheckReplan && !next_trajectory_) {
      const auto check_started = std::chrono::steady_clock::now();
      const auto world = currentWorld(state->position);
      const auto replan = world ? follower_->checkReplan(*world) : tracker::ReplanDecision{};
      if (const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - check_started).count(); took > 0.25)
        spdlog::warn("replan check took {:.3f} s (world snapshot and trajectory check): the vehicle held its last command meanwhile", took);
      const auto verdict = replan_gate_.check(replan, follower_->trajectory(), follower_->status().reference_time);
      if (verdict.action == tracker::ReplanAction::StopAndReplan) {
        stop();
        follower_.reset();
        switch_at_.reset();
        if (mission_.awaitingPlan()) {  // a plan is on its way already: wait for it here
          spdlog::warn("stopping to wait for plan {}: {}", mission_.requestId(), verdict.reason);
          mission_.hold();
        } else {
          act(mission_.replan(clock().nowNs(), *state, verdict.reason));
        }
      } else if (verdict.action == tracker::ReplanAction::ReplanAhead && !mission_.awaitingPlan()) {
        tracker::VehicleState from = *state;
        from.position = verdict.start.position;
        from.heading = tracker::wrapAngle(verdict.start.heading);
        act(mission_.replanAhead(clock().nowNs(), from, verdict.reason));
        switch_at_ = verdict.start.time;
      }
    }
  }

  const Params params_;
  const planner::Scenario scenario_;
  const planner::VehicleLimits limits_;
  tracker::SmootherConfig smoother_config_;
  nodes::DroppedSamples dropped_states_;
  std::optional<tracker::VehicleState> vehicle_;
  std::optional<msg::Path> new_path_;
  bus::Publisher<msg::PlanRequest> requests_;
  bus::Publisher<msg::Trajectory> trajectories_;
  bus::Publisher<msg::VelocityCommand> commands_;
  bus::Publisher<msg::TrackingStatus> statuses_;
  nodes::WorldSource world_source_;
  tracker::Mission mission_;
  tracker::ReplanGate replan_gate_;
  std::int64_t requested_at_ns_ = 0;  // the current request's time, for the gate's planning-time estimate
  double request_heading_ = 0.0;      // its start heading: the new trajectory starts there
  std::optional<tracker::TrajectoryTracker> follower_;
  // A replan from a predicted start: the new trajectory waits until the vehicle's reference on the current
  // one reaches that start (switch_at_, s of the current trajectory), so a plan ready early is not flown
  // from behind its start; a late one is switched to at once.
  std::optional<double> switch_at_;
  std::optional<tracker::Trajectory> next_trajectory_;
  std::int64_t next_since_ns_ = 0;
  std::int64_t last_step_ns_ = 0;
  msg::TrackingStatus last_status_;
  std::chrono::steady_clock::time_point started_;
  bool planner_seen_ = false;
  bus::Subscription state_sub_, path_sub_;
  runtime::Timer control_;
};

}  // namespace

int main(int argc, char** argv) { return runtime::runComponent<TrackerComponent>("tracker", argc, argv); }
