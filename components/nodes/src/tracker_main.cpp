// ddsnav-tracker: drives the vehicle to the scenario's goal. Asks for a plan (planning/request), smooths
// the answer into a trajectory (control/trajectory), follows it with the trajectory controller
// (control/cmd_vel, control/tracking), and asks again when the vehicle deviates or newly perceived
// obstacles truly block the rest of the trajectory within the horizon (tracker::ReplanGate: hysteresis,
// and a start predicted along the trajectory, which the vehicle keeps flying meanwhile). The mission's
// decisions (when to ask, retry, give up, when the goal is reached) are tracker::Mission's; this file
// carries them out. The slow steps — the replan check against a world snapshot and smoothing a new path —
// run on a worker (std::async) so that the control loop keeps commanding the vehicle at its rate meanwhile:
// a control loop blocked for a second at speed 4 leaves the vehicle on its last command for 4 simulated
// seconds (it drove into an obstacle that way).

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/map_scale.hpp"
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>
#include <ddsnav/runtime/pending_work.hpp>
#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/planner/tree.hpp>
#include <ddsnav/sim/sensor_choice.hpp>
#include <ddsnav/tracker/mission.hpp>
#include <ddsnav/tracker/path_pieces.hpp>
#include <ddsnav/tracker/replan.hpp>
#include <ddsnav/tracker/scan_free_space.hpp>
#include <ddsnav/tracker/smoother.hpp>
#include <ddsnav/tracker/tracker.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <future>
#include <numbers>
#include <mutex>
#include <optional>

using namespace ddsnav;

namespace {

class TrackerComponent : public runtime::Component {
 public:
  struct Params {
    std::string scenario, planner;
    nodes::WorldParameters world;  // world, unknown_space: the planner's, to smooth and check against
    std::optional<double> unknown_margin_m;  // the planner's preference, smoothed on first (default: nodes::defaultUnknownMargin)
    double control_rate_hz, time_budget_s;
    std::int64_t seed, max_plan_attempts;
    double plan_retry_delay_s;
    double refused_retry_delay_s;
    bool wait_for_world;
    double replan_check_period_s;
    tracker::ReplanPolicy replan;
    tracker::TrackerConfig tracker;
    std::optional<double> replan_horizon_m;
    std::optional<double> piece_length_m;
    tracker::SmootherConfig smoother;
    double max_decel;
    bool stop_within_observed;
    double observed_hold_s;
    std::optional<double> observed_crawl_speed;  // default: a stop from it takes a quarter of the robot radius
    std::optional<double> improve_for_s;         // default: 0.25 s in 3-D, 0 (off) in 2-D
    tracker::ImprovementPolicy improvement;
    tracker::StallPolicy stall;
    std::optional<double> repair_distance;       // default: the robot radius
    std::optional<double> catch_up_decel;   // default: the smoother's max_accel in 2-D, off in 3-D
    std::optional<double> short_braking_m;  // default: the robot's diameter
    std::optional<double> flown_braking_decel;  // default: the stop's (limit_fraction x max_decel)
    explicit Params(runtime::Parameters& p)
        : scenario(p.require<std::string>("scenario", runtime::ParamSpec{.doc = "scenario file: goal, goal radius, vehicle limits"})),
          planner(p.declare<std::string>("planner", "gart-lazy", {.doc = "planner asked for in each request (docs/planners.md)"})),
          world(p),
          unknown_margin_m(p.declareOptional<double>(
              "unknown_margin_m",
              {.min = 0, .max = 100, .unit = "m",
               .doc = "2-D map and fused worlds, optimistic: smooth first keeping never-observed space this close to a seen surface blocked, "
                      "as the planner plans (its unknown_margin_m), then on the plain map (docs/tracking.md); 0: off; default min(1 m, 2 x the "
                      "robot radius)"})),
          control_rate_hz(p.declare<double>("control_rate_hz", 20.0, {.above = 0, .max = 1000, .unit = "Hz", .doc = "controller rate"})),
          time_budget_s(p.declare<double>("time_budget_s", 5.0, {.above = 0, .unit = "s", .doc = "time budget of each plan request"})),
          seed(p.declare<std::int64_t>("seed", 1, {.doc = "seed of the first request (the n-th asks seed + n - 1)"})),
          max_plan_attempts(p.declare<std::int64_t>("max_plan_attempts", 10, {.min = 1, .doc = "failed plans in a row before giving up"})),
          plan_retry_delay_s(p.declare<double>("plan_retry_delay_s", 1.0, {.min = 0, .unit = "s", .doc = "pause before asking again after a failed plan, or after the second path in a row "
                                                             "that could not be smoothed (refused_retry_delay_s: the first)"})),
          // One period of the mapper's default publish rate (5 Hz): a path refused on the tracker's newer map is planned
          // anew only once the planner has that map too; asked at once, stunnel_1.0's planner answered with the same path
          // 28 ms later, refused again, and the vehicle stopped (failed_ahead).
          refused_retry_delay_s(p.declare<double>(
              "refused_retry_delay_s", 0.2,
              {.min = 0, .max = 3600, .unit = "s",
               .doc = "pause before asking again after the first path in a row that could not be smoothed (a collision on the tracker's "
                      "newer map; docs/tracking.md)"})),
          wait_for_world(p.declare<bool>("wait_for_world", true, {.doc = "the first request waits for the planner's world"})),
          replan_check_period_s(p.declare<double>("replan_check_period_s", 0.1, {.above = 0, .unit = "s", .doc = "how often the rest of the trajectory is checked"})) {
      replan.confirm_checks = static_cast<int>(p.declare<std::int64_t>(
          "replan_confirm_checks", replan.confirm_checks,
          {.min = 1, .max = 1000, .doc = "consecutive blocked checks that confirm a block (hysteresis; docs/tracking.md, \"Replanning\")"}));
      replan.near_confirm_checks = static_cast<int>(p.declare<std::int64_t>(
          "replan_near_confirm_checks", replan.near_confirm_checks,
          {.min = 1, .max = 1000, .doc = "consecutive blocked checks that confirm a block too near to replan ahead of, which stops the vehicle (at most replan_confirm_checks)"}));
      replan.block_margin = p.declare<double>("replan_block_margin", replan.block_margin,
                                              {.min = 0, .max = 100, .unit = "m", .doc = "overlap with an obstacle that confirms a block at the first check"});
      replan.stop_margin_s = p.declare<double>("replan_stop_margin_s", replan.stop_margin_s,
                                               {.min = 0, .max = 600, .unit = "s", .doc = "time kept between a predicted replan start and the blocked sample"});
      replan.planning_time_s = p.declare<double>("expected_planning_time_s", replan.planning_time_s,
                                                 {.min = 0, .max = 600, .unit = "s", .doc = "least expected time from a request to its trajectory"});
      catch_up_decel = p.declareOptional<double>(
          "catch_up_decel",
          {.min = 0, .max = 1000, .unit = "m/s^2",
           .doc = "a vehicle behind its reference speeds up no more than still brakes, at this rate, for every slower part ahead "
                  "(docs/tracking.md); default: the smoother's max_accel (1 m/s^2) in 2-D, 0 in 3-D; 0: no cap"});
      tracker.replan_deviation = p.declare<double>("replan_deviation", tracker.replan_deviation,
                                                   {.above = 0, .unit = "m", .doc = "ask again when the vehicle is this far off the trajectory"});
      tracker.replan_horizon = p.declare<double>("replan_horizon_s", 8.0, {.above = 0, .unit = "s", .doc = "how far ahead obstacles are checked (or replan_horizon_m, whichever reaches farther)"});
      replan_horizon_m = p.declareOptional<double>(
          "replan_horizon_m", {.min = 0, .max = 1e5, .unit = "m",
                               .doc = "trajectory length ahead checked for obstacles; default: the simulator's default sensor range for the scenario (docs/tracking.md)"});
      piece_length_m = p.declareOptional<double>(
          "piece_length_m", {.min = 0, .max = 1e6, .unit = "m",
                             .doc = "a path longer than 1.5 x this is smoothed and flown a piece this long at a time, the next piece smoothed "
                                    "when half of one is flown (docs/tracking.md); default: the larger of 100 m and 2 x the replan horizon "
                                    "distance; 0: the whole path at once"});
      max_decel = p.declare<double>("max_decel", 2.0,
                                    {.above = 0, .max = 1000, .unit = "m/s^2",
                                     .doc = "deceleration the vehicle can brake at; a stop brakes along the trajectory at limit_fraction (0.85) of it"});
      // A 2-D replan check only sees what the map has: a wall's face scanned at grazing incidence from down a corridor
      // is found when the vehicle is about a second from it (an unseen S-tunnel layout, 2026-12-05: the block seen
      // 0.95 s ahead at 4.2 m/s, the vehicle 0.3 m into the wall; docs/tracking.md, "Stopping within observed space").
      stop_within_observed = p.declare<bool>(
          "stop_within_observed", true,
          {.doc = "2-D map and fused worlds: the vehicle never goes faster than still stops, at limit_fraction of max_decel, before "
                  "the first point of its trajectory whose robot disc neither the map observed free nor the newest scan looked "
                  "through (docs/tracking.md); observed_crawl_speed at least"});
      observed_hold_s = p.declare<double>(
          "observed_hold_s", 3.0,
          {.above = 0, .max = 1e4, .unit = "s",
           .doc = "a vehicle held at rest this long by stop_within_observed (observed_crawl_speed 0) stops waiting and plans again "
                  "from where it is"});
      stall.stall_s = p.declare<double>(
          "stall_s", stall.stall_s,
          {.min = 0, .max = 1e4, .unit = "s",
           .doc = "a vehicle meant to fly a trajectory that moved less than 0.2 m and turned less than 20 degrees for this long "
                  "(mission time) stops and plans again from where it is (reason stalled); 0: never"});
      observed_crawl_speed = p.declareOptional<double>(
          "observed_crawl_speed", {.min = 0, .max = 1000, .unit = "m/s",
                                   .doc = "stop_within_observed slows the vehicle to no less than this (a passage is seen into only "
                                          "from its mouth); default: the speed a stop from which takes a quarter of the robot radius"});
      world.keep_observed_free = stop_within_observed;
      // On in 3-D, where the planner's first solutions were the detours of the missions over 1.5x the oracle (random
      // worlds 67 and 69: 1.72x and 1.70x, 2026-12-06) and no lattice route guides it; 2-D plans follow a lattice route.
      improve_for_s = p.declareOptional<double>(
          "improve_for_s", {.min = 0, .max = 60, .unit = "s",
                            .doc = "wall time the planner may improve its first solution for the mission's first plan and for a shorter "
                                   "route asked while the vehicle flies on (improve_every_s; docs/tracking.md, \"Shorter routes\"), never "
                                   "for a blocked trajectory; default 0.25 s in 3-D, 0 (off) in 2-D"});
      improvement.every_s = p.declare<double>(
          "improve_every_s", improvement.every_s,
          {.min = 0, .max = 1e5, .unit = "s",
           .doc = "with improve_for_s: ask for a shorter route from a start ahead at most this often (mission time; doubled after each "
                  "ask that brought none, up to 8 times), flown when it saves improve_min_gain of the time left; 0: never"});
      improvement.min_gain = p.declare<double>(
          "improve_min_gain", improvement.min_gain,
          {.min = 0, .max = 0.99, .doc = "share of the time left to the goal a shorter route must save to be flown"});
      smoother.sample_dt = p.declare<double>("sample_dt", smoother.sample_dt, {.above = 0, .unit = "s", .doc = "trajectory sample spacing"});
      // Perceived obstacles grow as more of them is scanned: on gart_cluttered_2d ellipses grew by 0.05-0.32 m
      // next to trajectories kept 0.16-0.2 m away, the vehicle touched them and then stood inside the
      // planner's world. 0.5 m covers that growth; narrower passages are still crossed in their middle.
      smoother.clearance_target = p.declare<double>(
          "clearance_target", tracker::SmootherConfig::kTrackerClearanceTargetM, {.min = 0, .max = 100, .unit = "m", .doc = "the smoother moves the path this far from obstacles where there is room (docs/tracking.md)"});
      // Off by default: measured against refusing such plans, it did not shorten the bug-trap missions (docs/tracking.md).
      smoother.lead_in_decel = p.declare<double>(
          "lead_in_decel", 0.0,
          {.min = 0, .max = 1000, .unit = "m/s^2",
           .doc = "deceleration of a braking lead-in, the stop along the heading a plan that cannot be flown through at speed may start "
                  "with (docs/tracking.md); 0: none, such a plan is refused"});
      short_braking_m = p.declareOptional<double>(
          "short_braking_m", {.min = 0, .max = 1000, .unit = "m",
                              .doc = "without lead_in_decel, a plan that cannot be flown through at speed still starts with a braking "
                                     "lead-in (at the smoother's max_accel) when that stop is at most this long, instead of being "
                                     "refused (docs/tracking.md); default: the robot's diameter; 0: only with lead_in_decel"});
      flown_braking_decel = p.declareOptional<double>(
          "flown_braking_decel", {.min = 0, .max = 1000, .unit = "m/s^2",
                                  .doc = "a plan that cannot be flown through at speed starts by braking to rest along the trajectory "
                                         "being flown, at this deceleration, then turns in place and joins the path, instead of being "
                                         "refused (docs/tracking.md); default: the deceleration of a stop (0.85 x max_decel); 0: refused"});
      // A plan whose state or edge is in collision on the tracker's world was refused and asked again a retry delay later:
      // 12 and 9 such refusals in the two arms of eight 2-D missions each (2026-12-06). The two worlds differ: the tracker's
      // may be built from a newer map, and it is seen from the path's start.
      repair_distance = p.declareOptional<double>(
          "repair_distance", {.min = 0, .max = 100, .unit = "m",
                              .doc = "a plan's state in collision on the tracker's world is moved to the nearest free position within "
                                     "this distance, and a blocked edge bridged through the nearest free position to the middle of its stretch in "
                                     "collision, "
                                     "before the plan is refused (docs/tracking.md); 0: refuse; default: the robot radius"});
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
        world_source_(ctx, params_.world, scenario_, params_.unknown_margin_m.value_or(nodes::defaultUnknownMargin(scenario_)),
                      /*preferred_on_demand=*/true),
        mission_(missionConfig()),
        improve_for_s_(params_.improve_for_s.value_or(scenario_.dimensions == 3 ? 0.25 : 0.0)),
        improvement_gate_(params_.improvement),
        stall_watch_(params_.stall),
        replan_gate_(params_.replan),
        tracker_config_(trackerConfig()),
        // Twice the horizon: half a piece, when the next is smoothed, still reaches as far as the replan check looks. The
        // 100 m floor keeps paths that smooth in a few milliseconds whole; the floor was 200 m until 2026-12-06, and a
        // 300 m path on a 110 m paper world took 50-120 ms to smooth at real time (stunnel_0.5), most of a replan's wait.
        piece_length_m_(params_.piece_length_m.value_or(std::max(100.0, 2.0 * tracker_config_.replan_horizon_distance))),
        observed_crawl_speed_(params_.observed_crawl_speed.value_or(std::sqrt(2 * comfortableDecel() * 0.25 * scenario_.robot_radius))) {
    smoother_config_.repair_distance = params_.repair_distance.value_or(scenario_.robot_radius);
    smoother_config_.short_braking_m = params_.short_braking_m.value_or(2.0 * scenario_.robot_radius);
    flown_braking_decel_ = params_.flown_braking_decel.value_or(comfortableDecel());
    spdlog::info("replan check: {:.1f} s or {:.1f} m of the trajectory ahead, whichever reaches farther", tracker_config_.replan_horizon,
                 tracker_config_.replan_horizon_distance);
    if (piece_length_m_ > 0) spdlog::info("paths longer than {:.0f} m are smoothed and flown {:.0f} m at a time", 1.5 * piece_length_m_, piece_length_m_);
    // A state with a non-finite number would reach the controller (and its commands the vehicle): drop it
    // here, once, and keep following the last good one.
    if (params_.stop_within_observed && scenario_.dimensions == 2) startScanView();
    state_sub_ = subscribe(runtime::topics::vehicle_state, [this](const msg::VehicleState& s) {
      if (const auto error = nodes::checkVehicleState(s, nodes::kWorldFrame); !error.empty()) return dropped_states_.drop(error);
      vehicle_ = nodes::fromMsg(s);
    });
    // A new obstacle array is checked against the trajectory at once (an obstacle that appears is seen
    // within one check, not up to a replan period later), and so is a new map once it is built into the world
    // (a wall or a hillside it has just added); the periodic check covers the rest.
    world_source_.onObstacles([this] { checkOnWorldChange(); });
    world_source_.onMap([this] { checkOnWorldChange(); });
    path_sub_ = subscribe(runtime::topics::path, [this](const msg::Path& p) {
      new_path_ = p;
      planner_answered_ = true;
      // Taken up now rather than at the next control step (up to 1 / control_rate_hz later): a posted task, so
      // that a mission failure it finds ends the component as one from the control timer does.
      this->ctx().executor().post([this] { takeUpNow(Arrived::Path); });
    });
    started_ = std::chrono::steady_clock::now();
    last_step_ns_ = clock().nowNs();
    control_ = every(std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / params_.control_rate_hz)), [this] { control(); });
  }

  void shutdown() override { stop(); }

  // A replan check and a smoothing run on their own threads with `this`: they are waited for before any member goes.
  // Left to the futures' own destructors, the wait came after the members declared later were gone (the check read
  // scan_view_ after it was freed: UndefinedBehaviorSanitizer, the composed demo in CI, 2026-12-07).
  ~TrackerComponent() override {
    if (checking_.valid()) checking_.wait();
    if (smoothing_.valid()) smoothing_.wait();
  }

 private:
  static planner::VehicleLimits vehicleOf(const planner::Scenario& scenario) {
    if (!scenario.vehicle) throw std::invalid_argument(scenario.source + ": the tracker needs a 'vehicle' block");
    return *scenario.vehicle;
  }

  // The distance horizon: a block is worth seeing as far ahead as the sensor sees (docs/tracking.md).
  tracker::TrackerConfig trackerConfig() const {
    tracker::TrackerConfig c = params_.tracker;
    c.replan_horizon_distance = params_.replan_horizon_m.value_or(sim::defaultMaxRange(scenario_));
    // 2-D: the smoother's own rate (the reference obeys it); it took the largest tracking errors of the 2-D missions
    // from 0.5 to 0.2 m. 3-D: off — the missions took a third longer with it (gart_terrain_3d 1.16-1.43x in six runs
    // against 0.97-1.20x in four without; with the vehicle's braking rate instead, 1.13 and 1.41x), the cause not
    // yet analysed (docs/benchmarks/mission.md).
    c.catch_up_decel = params_.catch_up_decel.value_or(scenario_.dimensions == 2 ? params_.smoother.max_accel : 0.0);
    return c;
  }

  tracker::MissionConfig missionConfig() const {
    tracker::MissionConfig c;
    c.goal = scenario_.goal;
    c.goal_radius = scenario_.goal_radius;
    c.max_plan_attempts = params_.max_plan_attempts;
    c.plan_retry_delay_s = params_.plan_retry_delay_s;
    c.refused_retry_delay_s = params_.refused_retry_delay_s;
    c.time_budget_s = params_.time_budget_s;
    c.replan_check_period_s = params_.replan_check_period_s;
    c.wait_for_world = params_.wait_for_world;
    return c;
  }

  void stop() { commands_.publish(nodes::toMsg(tracker::VehicleCommand{}, clock().nowNs())); }

  // nullptr (logged) when there is none yet or it cannot be built: the tracker keeps running either way.
  std::unique_ptr<planner::CollisionWorld> currentWorld(const Eigen::Vector3d& position, bool preferred = false) {
    try {
      return world_source_.snapshot(position, scenario_.goal, scenario_.goal_radius, preferred);
    } catch (const std::exception& e) {
      spdlog::warn("cannot build the planner's world: {}", e.what());
      return nullptr;
    }
  }

  // Carries out what the mission decided; returns whether the vehicle should be driven this period.
  bool act(const tracker::MissionDecision& d) {
    if (!d.warning.empty()) spdlog::warn("{}", d.warning);
    if (!d.note.empty()) spdlog::info("{}", d.note);
    switch (d.action) {
      case tracker::MissionAction::RequestPlan: {
        // Plans that failed twice in a row (unsolved, or not smoothable) while the vehicle flies on: their start ahead
        // on the trajectory leads nowhere (bugtrap_0.4: at the neck's end, heading into its wall, nine plans from
        // there failed, 5 s each, and the mission ended "no plan after 10 attempts"). Stop, and plan from rest, where
        // the vehicle may turn in place first. This request is not sent: the one asked at rest supersedes it.
        if (mission_.driving() && follower_ && d.reason == "retrying" && mission_.attempts() - 1 >= kFailedAheadBeforeStop) {
          stopToPlanAtRest(d.from, fmt::format("failed_ahead: {} plans in a row from a start ahead on the trajectory failed",
                                                mission_.attempts() - 1));
          return false;
        }
        tracker::VehicleState from = d.from;
        std::optional<tracker::TrajectorySample> ahead;
        // A retry (or a repeat of a lost request) while the vehicle flies on: like a replan ahead, it starts
        // where the vehicle will be on its trajectory when the plan is ready, not where it is now.
        if (mission_.driving() && follower_ && (d.reason == "retrying" || d.reason == "no answer")) {
          const double at = follower_->status().reference_time + replan_gate_.expectedPlanningTime();
          if (at < follower_->trajectory().duration()) {
            ahead = follower_->trajectory().at(at);
            from.position = ahead->position;
            from.heading = tracker::wrapAngle(ahead->heading);
          }
        }
        // At rest the vehicle turns in place before it drives, so the plan may start from another heading: one
        // the planner's tree can grow along when the vehicle faces an obstacle (docs/tracking.md).
        double start_heading = from.heading;
        if (!(mission_.driving() && follower_)) start_heading = restStartHeading(from);
        msg::PlanRequest request;
        msg::Header header;
        header.stamp_ns(clock().nowNs());
        header.frame_id(nodes::kWorldFrame);
        request.header(header);
        request.request_id(d.request_id);
        request.start(nodes::toMsg(planner::State{from.position, start_heading}));
        request.goal(nodes::toMsg(planner::State{scenario_.goal, 0.0}));
        request.goal_radius(scenario_.goal_radius);
        request.planner(params_.planner);
        request.time_budget_s(params_.time_budget_s);
        request.seed(static_cast<std::uint64_t>(params_.seed) + d.request_id - 1);
        request.reason(d.reason);
        // The first plan (at rest, nothing changed waits for it) and a shorter route may take longer for a better path.
        if (improve_for_s_ > 0.0 && (d.request_id == kFirstRequestId || mission_.improving())) request.improve_for_s(improve_for_s_);
        spdlog::info("requesting plan {} with {} ({})", d.request_id, params_.planner, d.reason);
        requested_at_ns_ = clock().nowNs();
        request_heading_ = from.heading;
        request_speed_ = ahead ? ahead->speed : 0.0;  // a replan ahead sets its predicted speed after this
        request_vz_ = ahead ? ahead->vz : 0.0;
        switch_at_.reset();  // set again by a replan ahead, after this
        if (ahead) switch_at_ = ahead->time;
        next_trajectory_.reset();
        next_rest_.clear();
        requests_.publish(request);
        world_source_.prefetchPreferred();  // built while the planner plans, ready when its path comes to be smoothed
        unanswered_request_ = request;
        unanswered_sent_ = std::chrono::steady_clock::now();
        return false;
      }
      case tracker::MissionAction::Failed: throw std::runtime_error(d.reason);
      case tracker::MissionAction::Finished: statuses_.publish(last_status_); return false;  // best effort: keep saying so
      case tracker::MissionAction::Drive: return true;
      default: return false;
    }
  }

  double restStartHeading(const tracker::VehicleState& from) {
    const auto world = currentWorld(from.position);
    if (!world) return from.heading;
    // Room for a few of the planner's shortest useful edges, and at least a metre; more after each plan that
    // failed since the last trajectory (tracker::restStartRoom).
    const double min_free = tracker::restStartRoom(scenario_.robot_radius, mission_.attempts() - 1);
    const double heading = tracker::restStartHeading(*world, from.position, from.heading, min_free,
                                                     scenario_.robot_radius + world_source_.surfaceMargin());
    if (heading != from.heading)
      spdlog::info("at rest with less than {:.1f} m free ahead ({} failed plans before): the plan starts at heading {:.0f} deg, the vehicle "
                   "turns in place from {:.0f} deg first",
                   min_free, std::max<std::int64_t>(0, mission_.attempts() - 1), heading * 180 / std::numbers::pi, from.heading * 180 / std::numbers::pi);
    return heading;
  }

  struct Smoothed {
    std::uint32_t request_id = 0;
    std::optional<tracker::Trajectory> trajectory;  // none: it could not be smoothed (`error` says why)
    std::string error;
    std::vector<planner::State> rest;  // the path after the trajectory's end: a long path's later pieces
    // A long path's next piece (not an answer to a request): the trajectory it continues, from its sample at
    // `switch_at`.
    bool next_piece = false;
    std::uint64_t continues_serial = 0;
    double switch_at = 0.0;
    std::int64_t started_ns = 0;
    // A replan ahead: the trajectory being flown from the plan's start, braked to rest along itself (flown_braking_decel),
    // for a plan that can only start at rest there (tracker::smoothAfterBraking).
    std::optional<tracker::Trajectory> braking;
  };

  // Smooths the answer to the current request on the worker (its first piece, when it is long);
  // adoptSmoothed() takes the result.
  // The world is seen from the path's start, as the planner saw it (its sensor view in 3-D, the hidden continuation's
  // room around the robot in 2-D). Seen from the vehicle, still behind that start and lower on a climb, the smoother
  // refused 1-10 plans a run on u_window_3d as "path state ... is in collision" (space above the lidar's fan from
  // there), none since (docs/benchmarks/mission.md); the replan check judges the trajectory from the vehicle anyway.
  void startSmoothing(const msg::Path& path, const tracker::VehicleState& state) {
    smoother_config_.initial_heading = request_heading_;
    smoother_config_.initial_speed = request_speed_;
    smoother_config_.initial_vz = request_vz_;
    // A replan ahead may lead in along the trajectory the vehicle flies (SmootherConfig::lead_in_path): a little farther
    // than the longest straight lead-in (twice the turn radius) reaches.
    smoother_config_.lead_in_path.clear();
    if (switch_at_ && follower_ && request_speed_ > 0.0) {
      const double reach = 2.5 * limits_.v_max / limits_.omega_max + 1.0;
      for (const auto& s : tracker::continuationPath(follower_->trajectory(), *switch_at_, {}, 0.5)) {
        if (!smoother_config_.lead_in_path.empty() && (s.position - smoother_config_.lead_in_path.front()).norm() > reach) break;
        smoother_config_.lead_in_path.push_back(s.position);
      }
    }
    const std::vector<planner::State> states = nodes::statesOf(path);
    auto pieces = tracker::splitPath(states, piece_length_m_);
    const Eigen::Vector3d viewpoint = pieces.piece.empty() ? state.position : pieces.piece.front().position;
    Smoothed job;
    job.request_id = path.request_id();
    job.rest = std::move(pieces.rest);
    if (switch_at_ && follower_ && request_speed_ > kFlownThrough && flown_braking_decel_ > 0 && mayBrakeFirst(states)) {
      const auto& flown = follower_->trajectory();
      const auto at = flown.at(*switch_at_);
      try {
        job.braking = tracker::brakeAlong(flown, *switch_at_, std::hypot(at.speed, at.vz), flown_braking_decel_);
      } catch (const std::exception& e) {
        spdlog::debug("plan {}: no braking stretch along the flown trajectory: {}", job.request_id, e.what());
      }
    }
    runSmoothing(std::move(job), std::move(pieces.piece), viewpoint, smoother_config_);
  }

  // Whether a plan that could only start at rest may be answered by braking to rest first (flown_braking_decel): when
  // its path turns back (a point of it, on a state or an edge, beyond its first robot diameter or metre, and within
  // twice the turn radius — the longest straight lead-in the smoother tries — lies more than a right angle from the
  // heading), when that stop is short (short_braking_m), or when the plan before it was refused for starting at rest.
  // A first corner too tight for the speed is asked again first: the vehicle a little farther on, or the next plan,
  // mostly gets round it at speed, where a stop cost a bugtrap_0.4 mission 20 s (1.55x, 2026-12-06). A path that comes
  // back behind its start within the lead-in's reach cannot be flown at speed from any start near there, and braking is
  // used only when the plan cannot take over anyway. Until 2026-12-07 only the first metre counted: r3d_69 at speed 2
  // had a path that turned back within 14.3 m (the smoother's words) refused, asked again and braked for only then,
  // 0.69 s from the request to a trajectory (not recorded: whether that path came back behind its start is not known).
  bool mayBrakeFirst(const std::vector<planner::State>& states) const {
    if (rest_start_refusals_ >= 1) return true;
    const double stop = request_speed_ * request_speed_ / (2 * flown_braking_decel_);
    if (stop <= smoother_config_.short_braking_m) return true;
    if (states.empty()) return false;
    const double reach = std::max(1.0, 2.0 * scenario_.robot_radius);
    const double lead_in_reach = std::max(reach, 2.0 * limits_.v_max / limits_.omega_max);
    const Eigen::Vector2d heading(std::cos(request_heading_), std::sin(request_heading_));
    // Along the edges, not only at the states: a first edge longer than the lead-in's reach that goes back (bugtrap_1.0,
    // 2026-12-07: 31 m straight back from a replan ahead) has no state within it.
    const Eigen::Vector2d start = states.front().position.head<2>();
    for (std::size_t i = 1; i < states.size(); ++i) {
      const Eigen::Vector2d a = states[i - 1].position.head<2>(), b = states[i].position.head<2>();
      const int steps = std::clamp(static_cast<int>(std::ceil((b - a).norm() / 0.5)), 1, 1000);
      for (int k = 1; k <= steps; ++k) {
        const Eigen::Vector2d away = a + (b - a) * (static_cast<double>(k) / steps) - start;
        if (away.norm() < reach) continue;
        if (away.norm() > lead_in_reach) return false;
        if (away.dot(heading) < 0.0) return true;
      }
    }
    return false;
  }

  // A long path's next piece, smoothed while the vehicle flies the current one: from the current trajectory's
  // sample where the vehicle will be when it is ready (at its speed and heading), along that trajectory to
  // its end, then along the rest of the planner's path. adoptNextPiece() takes the result.
  void startNextPiece() {
    const auto& trajectory = follower_->trajectory();
    const double expected_s = last_piece_smoothing_s_ >= 0 ? last_piece_smoothing_s_ : replan_gate_.expectedPlanningTime();
    const double switch_at = follower_->status().reference_time + std::max(1.0, 3.0 * expected_s);
    if (switch_at >= trajectory.duration()) return;  // too late: the trajectory's end asks for a new plan
    const tracker::TrajectorySample from = trajectory.at(switch_at);
    tracker::SmootherConfig config = smoother_config_;
    config.initial_heading = tracker::wrapAngle(from.heading);
    config.initial_speed = from.speed;
    config.initial_vz = from.vz;
    // Half a metre apart: chords that close stay within 6 cm of a 0.5 m-radius curve.
    auto pieces = tracker::splitPath(tracker::continuationPath(trajectory, switch_at, rest_of_path_, 0.5), piece_length_m_);
    rest_of_path_.clear();  // the job has it now
    Smoothed job;
    job.request_id = flown_request_id_;
    job.rest = std::move(pieces.rest);
    job.next_piece = true;
    job.continues_serial = trajectory_serial_;
    job.switch_at = switch_at;
    runSmoothing(std::move(job), std::move(pieces.piece), vehicle_ ? vehicle_->position : from.position, config);
  }

  void runSmoothing(Smoothed job, std::vector<planner::State> states, const Eigen::Vector3d& position, const tracker::SmootherConfig& config) {
    job.started_ns = clock().nowNs();
    // The progress report (pacing) waits for it like for a Worker's job.
    smoothing_ = std::async(std::launch::async, [this, job = std::move(job), states = std::move(states), position, config,
                                                 token = std::make_shared<runtime::PendingWork>()]() mutable {
      const std::string what = (job.next_piece ? "the next piece of plan " : "plan ") + std::to_string(job.request_id);
      try {
        const auto t0 = std::chrono::steady_clock::now();
        auto world = currentWorld(position);
        if (!world) throw tracker::SmoothingError("the tracker has no usable world of the planner yet");
        const auto t1 = std::chrono::steady_clock::now();
        // First on the world the planner prefers, where unseen space next to seen surfaces is blocked: shortcuts
        // and corners on the plain map cut into exactly the space the planner kept out of (stunnel_1.0: a
        // shortcut back across the unseen part of a wall made a hairpin, and the check blocked it 10 s later).
        // A path the planner could only find on the plain map is in collision there: smoothed on the plain map.
        std::unique_ptr<planner::CollisionWorld> preferred;
        if (world_source_.hasPreferredWorld()) {
          try {
            if ((preferred = currentWorld(position, /*preferred=*/true))) job.trajectory = tracker::smoothPath(states, *preferred, limits_, config);
          } catch (const tracker::SmoothingError& e) {
            spdlog::debug("{}: not smoothed keeping clear of unseen surfaces ({}); on the plain map", what, e.what());
          }
        }
        const planner::CollisionWorld& on = job.trajectory ? *preferred : *world;  // the world it was smoothed on
        if (!job.trajectory) job.trajectory = tracker::smoothPath(states, *world, limits_, config);
        // No lead-in fits where the vehicle arrives moving: brake along the flown trajectory and go on from rest,
        // instead of a refusal (adoptSmoothed), a second request, a stop and a plan from rest.
        if (job.braking && cannotTakeOver(*job.trajectory, config.initial_speed)) {
          try {
            auto braked = tracker::smoothAfterBraking(states, *job.braking, on, limits_, config);
            braked.report.lead_in_failure = job.trajectory->report.lead_in_failure;
            job.trajectory = std::move(braked);
          } catch (const std::exception& e) {  // the plan is then refused as before
            job.trajectory->report.lead_in_failure += "; braking along the flown trajectory: " + std::string(e.what());
          }
        }
        const auto t2 = std::chrono::steady_clock::now();
        spdlog::debug("{}: world snapshot {:.1f} ms, smoothing {:.1f} ms (wall)", what, std::chrono::duration<double, std::milli>(t1 - t0).count(),
                      std::chrono::duration<double, std::milli>(t2 - t1).count());
      } catch (const std::exception& e) {
        job.error = e.what();
        spdlog::warn("cannot smooth {}: {}", what, e.what());
      }
      token.reset();
      ctx().executor().post([this] { takeUpNow(Arrived::Smoothing); });
      return std::move(job);
    });
  }

  // Asks a plan from `ahead`, a sample of the trajectory being flown, while the vehicle flies on to it; the new
  // trajectory is switched to there.
  // `optional`: a shorter route (Mission::improveAhead), not a replan.
  void replanAheadFrom(const tracker::TrajectorySample& ahead, const tracker::VehicleState& state, const std::string& reason,
                       bool optional = false) {
    tracker::VehicleState from = state;
    from.position = ahead.position;
    from.heading = tracker::wrapAngle(ahead.heading);
    from.v = ahead.speed;
    const auto decision = optional ? mission_.improveAhead(clock().nowNs(), from, reason) : mission_.replanAhead(clock().nowNs(), from, reason);
    if (decision.action != tracker::MissionAction::RequestPlan) return;
    act(decision);
    switch_at_ = ahead.time;
    request_speed_ = ahead.speed;
    request_vz_ = ahead.vz;
  }

  // Shorter routes (docs/tracking.md): while the trajectory flown is not blocked, now and then an optional plan from
  // where the vehicle will be when it is ready — the usual planning time ahead, plus the time the planner improves its
  // first solution for — taken only when it saves improve_min_gain of what is left (shorterRouteTaken).
  void askForAShorterRoute(const tracker::VehicleState& state) {
    if (improve_for_s_ <= 0.0 || !follower_ || !mission_.driving() || mission_.awaitingPlan() || smoothing_.valid() || next_trajectory_ ||
        stopping_for_ || braking_)
      return;
    const auto& trajectory = follower_->trajectory();
    const double lead = replan_gate_.expectedPlanningTime() + improve_for_s_ * mission_.config().clock_speed;
    const double at = follower_->status().reference_time + lead;
    if (at + lead >= trajectory.duration() && rest_of_path_.empty()) return;  // nearly there
    const double from = std::min(at, trajectory.duration());
    const auto ahead = trajectory.at(from);
    const double remaining_s = timeLeft(trajectory, from, rest_length_m_);
    const double straight = std::max(0.0, (scenario_.goal - ahead.position).norm() - scenario_.goal_radius);
    if (!improvement_gate_.due(nowS(), wallS(), remaining_s, straight / limits_.v_max)) return;
    improvement_gate_.asked(nowS(), wallS());
    improvement_open_ = true;
    replanAheadFrom(ahead, state,
                    fmt::format("shorter_route: {:.1f} s left from ({:.1f}, {:.1f}, {:.1f}), {:.1f} m straight to the goal region",
                                remaining_s, ahead.position.x(), ahead.position.y(), ahead.position.z(), straight),
                    /*optional=*/true);
  }

  // Seconds left to the goal from `from` on `trajectory`, with `rest_m` of path after it at top speed (a piece at a time).
  double timeLeft(const tracker::Trajectory& trajectory, double from, double rest_m) const {
    return std::max(0.0, trajectory.duration() - from) + rest_m / limits_.v_max;
  }

  // Whether the smoothed answer to a shorter-route request is flown: sooner at the goal by improve_min_gain than what is
  // left of the trajectory flown (and the path after it) from the same start, and able to take over there.
  bool shorterRouteTaken(const tracker::Trajectory& trajectory, const Smoothed& smoothed) {
    bool taken = false;
    if (follower_ && switch_at_) {
      const auto& current = follower_->trajectory();
      const double left_s = timeLeft(current, std::min(*switch_at_, current.duration()), rest_length_m_);
      const double offered_s = timeLeft(trajectory, 0.0, planner::pathLength(smoothed.rest));
      const std::string refusal = takeOverRefusal(trajectory, request_speed_);
      taken = improvement_gate_.worthTaking(left_s, offered_s) && refusal.empty();
      spdlog::info("plan {} (shorter route): {:.1f} s ({:.1f} m) against {:.1f} s left of the trajectory flown: {}", smoothed.request_id,
                   offered_s, trajectory.report.length, left_s,
                   taken ? "flown" : !refusal.empty() ? "not flown, it cannot take over (" + refusal + ")" : "not flown, not soon enough");
    }
    if (taken) improvement_gate_.answered(true, wallS());
    return taken;
  }

  // A shorter-route ask that ended without being flown (not shorter, failed, lost or superseded): the gate backs off.
  void settleImprovement() {
    if (!improvement_open_ || mission_.improving()) return;
    improvement_open_ = false;
    improvement_gate_.answered(false, wallS());
  }

  double nowS() const { return static_cast<double>(clock().nowNs()) * 1e-9; }
  static double wallS() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

  // A long path's next piece waits for its switch point like a replan ahead's trajectory. One that is stale (the
  // trajectory it continues was replaced, or is being replanned) is dropped; one that could not be smoothed (the
  // rest of the path is no longer free, or only a start at rest fits) is replanned ahead.
  void adoptNextPiece(Smoothed smoothed, const tracker::VehicleState& state) {
    if (!follower_ || smoothed.continues_serial != trajectory_serial_ || next_trajectory_ || mission_.awaitingPlan() || stopping_for_) return;
    last_piece_smoothing_s_ = static_cast<double>(clock().nowNs() - smoothed.started_ns) * 1e-9;
    const auto& current = follower_->trajectory();
    if (smoothed.trajectory) {
      const double arrival = current.at(smoothed.switch_at).speed;
      if (const std::string refusal = takeOverRefusal(*smoothed.trajectory, arrival); !refusal.empty()) {
        smoothed.error = fmt::format("it could only start at {:.1f} m/s, where the vehicle flies on at {:.1f} m/s ({})",
                                     smoothed.trajectory->samples.front().speed, arrival, refusal);
        smoothed.trajectory.reset();
      }
    }
    if (!smoothed.trajectory) {
      const double at = std::min(follower_->status().reference_time + replan_gate_.expectedPlanningTime(), current.duration());
      replanAheadFrom(current.at(at), state, "next_piece_failed: " + smoothed.error);
      return;
    }
    auto& trajectory = *smoothed.trajectory;
    spdlog::info("trajectory {}, next piece: {:.1f} m, {:.1f} s, max curvature {:.3f} 1/m, min clearance {:.2f} m, starts at {:.1f} m/s{}, "
                 "{:.0f} m of the path after it, smoothed in {:.3f} s",
                 smoothed.request_id, trajectory.report.length, trajectory.report.duration, trajectory.report.max_curvature,
                 trajectory.report.min_clearance, trajectory.samples.front().speed, trajectoryNotes(trajectory.report),
                 planner::pathLength(smoothed.rest), last_piece_smoothing_s_);
    const double due_in_s = smoothed.switch_at - follower_->status().reference_time;
    if (due_in_s > 0) {
      trajectories_.publish(nodes::toMsg(trajectory, smoothed.request_id, clock().nowNs() + static_cast<std::int64_t>(due_in_s * 1e9)));
      next_trajectory_ = std::move(trajectory);
      next_request_id_ = smoothed.request_id;
      next_rest_ = std::move(smoothed.rest);
      next_is_piece_ = true;
      switch_at_ = smoothed.switch_at;
      next_since_ns_ = clock().nowNs();
      next_wait_limit_s_ = 1.5 * due_in_s + 2.0;
    } else {
      switchTrajectory(std::move(trajectory), std::move(smoothed.rest), /*next_piece=*/true, smoothed.request_id, state);
    }
  }

  // ", braking to rest in 6.2 m (no lead-in at speed: ...)" for a trajectory whose lead-in brakes, ", 1.3 s below a
  // quarter of its top speed on the way (...)" for one that nearly stops between its fast parts; empty otherwise.
  static std::string trajectoryNotes(const tracker::TrajectoryReport& report) {
    std::string note;
    if (report.lead_in_braking > 0)
      note = fmt::format(", braking to rest in {:.1f} m (no lead-in at speed: {})", report.lead_in_braking, report.lead_in_failure);
    if (report.lead_in_along_flown > 0)
      note += fmt::format(", led in along the flown trajectory for {:.1f} m (no straight lead-in fitted)", report.lead_in_along_flown);
    if (report.repaired_waypoints > 0)
      note += fmt::format(", {} path point(s) moved off obstacles or added around one (repair_distance)", report.repaired_waypoints);
    if (report.slow_s >= 0.5)
      note += fmt::format(", {:.1f} s below a quarter of its top speed on the way (slowest at ({:.1f}, {:.1f}, {:.1f}))", report.slow_s,
                          report.slowest_at.x(), report.slowest_at.y(), report.slowest_at.z());
    return note;
  }

  // The smoothed answer becomes the trajectory to follow (now, or at its predicted start); false when it
  // could not be smoothed.
  bool adoptSmoothed(Smoothed smoothed, const tracker::VehicleState& state) {
    refused_for_speed_ = false;
    if (!smoothed.trajectory) return false;
    auto& trajectory = *smoothed.trajectory;
    if (mission_.improving() && !shorterRouteTaken(trajectory, smoothed)) return false;
    // A plan from a predicted start the vehicle reaches at speed must be flown through; one that starts at
    // rest (no lead-in along the heading was free) would make it overshoot its start, one that starts much slower
    // run ahead of it round a curve it cannot turn at that speed (cannotTakeOver). Asked again (ahead, or from rest
    // once the block is close enough to stop for it).
    // One whose lead-in brakes to rest first is flown.
    if (const std::string refusal = takeOverRefusal(trajectory, request_speed_); !refusal.empty()) {
      if (trajectory.samples.front().speed < kAtRestStart) {
        spdlog::warn("trajectory {} starts at rest, but the vehicle reaches its start at {:.1f} m/s: not flown (no lead-in along its heading: {})",
                     smoothed.request_id, request_speed_, trajectory.report.lead_in_failure);
      } else {
        refused_for_speed_ = true;
        spdlog::warn("trajectory {} starts at {:.1f} m/s, but the vehicle reaches its start at {:.1f} m/s: not flown ({}{}{})",
                     smoothed.request_id, trajectory.samples.front().speed, request_speed_, refusal,
                     trajectory.report.lead_in_failure.empty() ? "" : "; ", trajectory.report.lead_in_failure);
      }
      // Twice in a row: nothing ahead leaves room to go on at speed (inside a bug trap every plan turns back), and
      // flying on toward the block between refusals only makes it worse (bugtrap_1.0: 23 refusals, 74 m short at
      // the timeout). Stop, and plan from rest.
      if (++rest_start_refusals_ >= 2 && follower_) {
        stopToPlanAtRest(state, fmt::format("rest_start: {} plans in a row could only start at rest or too slowly while the vehicle flies on",
                                            rest_start_refusals_));
        rest_start_refusals_ = 0;
      }
      return false;
    }
    rest_start_refusals_ = 0;
    const double latency = static_cast<double>(clock().nowNs() - requested_at_ns_) * 1e-9;
    spdlog::info("trajectory {}: {:.1f} m, {:.1f} s, max curvature {:.3f} 1/m, min clearance {:.2f} m, starts at {:.1f} m/s{}, ready {:.3f} s after its request",
                 smoothed.request_id, trajectory.report.length, trajectory.report.duration, trajectory.report.max_curvature,
                 trajectory.report.min_clearance, trajectory.samples.front().speed, trajectoryNotes(trajectory.report), latency);
    // The mission's first request may wait for the planner's world (3.3 s of simulated time on gart_terrain_3d), and a
    // shorter route takes its time to improve: neither is a planning time to predict replans by.
    if (mission_.improving()) {
      improvement_open_ = false;
    } else {
      if (smoothed.request_id != kFirstRequestId) replan_gate_.planReady(latency);
      improvement_gate_.newTrajectory(nowS());
    }
    if (stopping_for_ && braking_rest_) {
      // Asked from where the braking ends: published now, stamped with when the braking reaches its end, and flown
      // once the vehicle is at rest (control).
      const double due_in_s = braking_ ? std::max(0.0, braking_->trajectory().duration() - braking_->status().reference_time) : 0.0;
      trajectories_.publish(nodes::toMsg(trajectory, smoothed.request_id, clock().nowNs() + static_cast<std::int64_t>(due_in_s * 1e9)));
      spdlog::info("trajectory {}: flown once the vehicle is at rest (in about {:.1f} s)", smoothed.request_id, due_in_s);
      next_trajectory_ = std::move(trajectory);
      next_request_id_ = smoothed.request_id;
      next_rest_ = std::move(smoothed.rest);
      next_is_piece_ = false;
      next_since_ns_ = clock().nowNs();
      next_wait_limit_s_ = std::numeric_limits<double>::infinity();
      return true;
    }
    if (follower_ && switch_at_ && follower_->status().reference_time < *switch_at_) {
      // Published now, stamped with when its first sample is due (the reference reaches the switch point in
      // about that many seconds): the new trajectory is known from the moment it is ready, which is what the
      // latency from a scan to a new trajectory measures, not the wait for its start.
      const double due_in_s = *switch_at_ - follower_->status().reference_time;
      trajectories_.publish(nodes::toMsg(trajectory, smoothed.request_id, clock().nowNs() + static_cast<std::int64_t>(due_in_s * 1e9)));
      next_trajectory_ = std::move(trajectory);
      next_request_id_ = smoothed.request_id;
      next_rest_ = std::move(smoothed.rest);
      next_is_piece_ = false;
      next_since_ns_ = clock().nowNs();
      // The reference reaches the switch point in about that many seconds; a wait well beyond it (the
      // vehicle held back) switches anyway. A fixed 2 s used to switch the AUV 50 s (90 m) before its
      // predicted start when a plan expected to take 64 s came in 15 s: a 92 m deviation, a stop and a replan.
      next_wait_limit_s_ = 1.5 * (*switch_at_ - follower_->status().reference_time) + 2.0;
    } else {
      switchTrajectory(std::move(trajectory), std::move(smoothed.rest), /*next_piece=*/false, smoothed.request_id, state);
      switch_at_.reset();
    }
    return true;
  }

  // Until some planner has answered once, the request is sent again every 0.2 s of wall time (the planner
  // ignores a copy of a request it has taken): a Cyclone planner matched for over a second can still miss the
  // first request of a Fast DDS tracker on a loaded machine (gart_terrain_3d at speed 4: plan 1 lost 1.6 s after
  // the planner was ready, the answer timeout of 38 s of simulated time waited for). Once an answer came, both
  // directions are discovered and the answer timeout covers the rest. Every second, as before, left the vehicle
  // standing 4 simulated seconds at speed 4 when the first copy was lost (bugtrap_0.6: 8 % of the oracle's time).
  void repeatUntilAPlannerAnswers() {
    if (planner_answered_ || !unanswered_request_ || !mission_.awaitingPlan()) return;
    if (unanswered_request_->request_id() != mission_.requestId()) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - unanswered_sent_ < std::chrono::milliseconds(200)) return;
    unanswered_sent_ = now;
    if (unanswered_copies_++ == 0)
      spdlog::info("no planner has answered yet: sending request {} again every 0.2 s", unanswered_request_->request_id());
    requests_.publish(*unanswered_request_);
  }

  static constexpr double kAtRest = 0.05;  // m/s: the vehicle has stopped
  // A plan asked from where a braking was predicted to end is flown from rest when the vehicle stopped within this
  // share of replan_deviation of its start; farther off, it is asked again from where the vehicle is.
  static constexpr double kRestStartTolerance = 0.5;
  // A trajectory starting slower than kAtRestStart starts at rest; a vehicle reaching its start faster than kFlownThrough
  // would overshoot it (adoptSmoothed refuses such a plan).
  static constexpr double kAtRestStart = tracker::kAtRestSpeed, kFlownThrough = tracker::kFlownThroughSpeed;
  // Whether a trajectory cannot take over from a vehicle arriving at `arrival_speed` (tracker::cannotTakeOver: at rest,
  // or slower where the vehicle, braking at max_decel, would reach a curve too fast to turn, a climb too steep for its
  // speed, or a stop; takeOverRefusal says which). Such a plan is braked for along the flown trajectory where that is
  // allowed (mayBrakeFirst), else refused and asked again.
  // A first version refused every start more than tracker::kStartSpeedSlack slower: the terrain's climbs, flown safely
  // before, were refused and asked again in 4 of 6 runs (330 ms each, docs/benchmarks/mission.md 2026-12-06 15:3x).
  bool cannotTakeOver(const tracker::Trajectory& trajectory, double arrival_speed) const { return !takeOverRefusal(trajectory, arrival_speed).empty(); }
  std::string takeOverRefusal(const tracker::Trajectory& trajectory, double arrival_speed) const {
    return tracker::takeOverRefusal(trajectory, arrival_speed, params_.max_decel, limits_.omega_max, tracker::kFlownThroughSpeed,
                                    tracker::kAtRestSpeed, tracker::kStartSpeedSlack, limits_.vz_max);
  }
  static constexpr std::int64_t kFailedAheadBeforeStop = 2;  // failed plans from a start ahead before stopping for one from rest
  static constexpr std::uint32_t kFirstRequestId = 1;  // tracker::Mission numbers its requests from 1

  // The clock's speed (simulated seconds per wall second) over the last few seconds, for the mission's
  // answer timeout: the planner's budget is wall time.
  void measureClockSpeed() {
    const auto wall = std::chrono::steady_clock::now();
    const std::int64_t now = clock().nowNs();
    if (speed_window_clock_ns_ == 0) {
      speed_window_clock_ns_ = now, speed_window_wall_ = wall;
      return;
    }
    const double wall_s = std::chrono::duration<double>(wall - speed_window_wall_).count();
    if (wall_s < 3.0) return;
    mission_.setClockSpeed(static_cast<double>(now - speed_window_clock_ns_) * 1e-9 / wall_s);
    speed_window_clock_ns_ = now, speed_window_wall_ = wall;
  }

  template <class T>
  static bool ready(const std::future<T>& f) {
    return f.valid() && f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  }

  // The replan check of the trajectory being flown, on the worker: a copy of the follower (its trajectory
  // and where it is on it), checked against a world snapshot at the vehicle's position.
  struct Checked {
    std::uint64_t trajectory_serial = 0;
    double reference_time = 0.0;
    tracker::ReplanDecision decision;
    double took_s = 0.0;
    double observed_stop_arc = std::numeric_limits<double>::infinity();  // stop_within_observed: where to have stopped by
  };
  void checkOnWorldChange() {
    if (!follower_ || !vehicle_ || stopping_for_ || next_trajectory_ || checking_.valid() || !mission_.driving()) return;
    startCheck(*vehicle_);
  }

  void startCheck(const tracker::VehicleState& state) {
    last_check_ns_ = clock().nowNs();
    // At least as far ahead as a plan takes, twice, plus the stop margin: a slow vehicle with a long-range
    // sensor (the AUV: 2 m/s, a 200 m sonar; a plan of 600 m took 49 simulated seconds at speed 10) must
    // see the block while there is time to plan around it ahead.
    const double horizon = 2 * replan_gate_.expectedPlanningTime() + params_.replan.stop_margin_s;
    checking_ = std::async(std::launch::async, [this, follower = *follower_, serial = trajectory_serial_, position = state.position, horizon,
                                                token = std::make_shared<runtime::PendingWork>()]() mutable {
      const auto started = std::chrono::steady_clock::now();
      Checked out{serial, follower.status().reference_time, {}, 0.0};
      if (const auto world = currentWorld(position)) out.decision = follower.checkReplan(*world, horizon);
      if (params_.stop_within_observed) out.observed_stop_arc = observedStopArc(follower);
      out.took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      token.reset();
      ctx().executor().post([this] { takeUpNow(Arrived::Check); });
      return out;
    });
  }

  // stop_within_observed: where on the follower's trajectory the vehicle must have stopped to stay in space the
  // newest 2-D map has observed free, looked for as far as a stop from top speed reaches, and a little more (the
  // next check comes a period later); infinity without such a map.
  double observedStopArc(const tracker::TrajectoryTracker& follower) const {
    const auto observed = world_source_.observedSpace();
    if (!observed) return std::numeric_limits<double>::infinity();
    const double reach = limits_.v_max * limits_.v_max / (2 * comfortableDecel()) + limits_.v_max + 2 * scenario_.robot_radius;
    std::shared_ptr<const tracker::ScanFreeSpace> scan;
    {
      std::lock_guard lock(scan_view_mutex_);
      scan = scan_view_;
    }
    return tracker::observedStopArc(follower.trajectory(), vehicleArc(follower), reach, [&](const planner::Vec3& p) -> std::optional<bool> {
      const std::optional<bool> in_map = planner::robotInObservedFreeSpace(*observed, p);
      if (in_map && !*in_map && scan && scan->discSeenEmpty(p, scenario_.robot_radius)) return true;
      return in_map;
    });
  }

  // The newest scan as seen-empty space (tracker::ScanFreeSpace), for stop_within_observed: the map keeps free only
  // the space in front of returns, the scan also what its beams without a return looked through. Bins and reach are
  // the simulator's default sensor for the scenario; a scenario it has none for goes without.
  void startScanView() {
    try {
      const sim::RangeSensorConfig sensor = sim::chooseSensor(scenario_).config;
      const double fov = std::clamp(sensor.horizontal_fov_deg, 1e-3, 360.0) * std::numbers::pi / 180.0;
      const double bin = std::clamp(fov / std::max(1, sensor.columns), 1e-4, std::numbers::pi / 8);
      empty_scan_view_.emplace(bin, sensor.max_range, fov);
    } catch (const std::exception& e) {
      spdlog::warn("stop_within_observed: no default sensor for this scenario ({}): the map alone says what was observed", e.what());
      return;
    }
    clouds_sub_ = subscribe(runtime::topics::points, [this](const msg::PointCloud& cloud) {
      const auto origin = nodes::fromMsg(cloud.sensor_origin());
      if (cloud.header().frame_id() != nodes::kWorldFrame || cloud.xyz().size() % 3 != 0 || !origin.allFinite() || !vehicle_) return;
      const auto& xyz = cloud.xyz();
      std::vector<planner::Vec3> points(xyz.size() / 3);
      for (std::size_t i = 0; i < points.size(); ++i) points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
      auto view = std::make_shared<tracker::ScanFreeSpace>(*empty_scan_view_);
      view->update(origin, vehicle_->heading, points);
      std::lock_guard lock(scan_view_mutex_);
      scan_view_ = std::move(view);
    });
  }
  // The rate a stop brakes at unless a block is close: limit_fraction of max_decel.
  double comfortableDecel() const { return smoother_config_.limit_fraction * params_.max_decel; }

  // Where the vehicle is along the follower's trajectory: the reference's arc length plus the along-track error.
  static double vehicleArc(const tracker::TrajectoryTracker& follower) {
    const auto& status = follower.status();
    return std::max(0.0, follower.trajectory().at(status.reference_time).arc_length + status.along_track_error);
  }

  // A stop brakes along the trajectory being flown, until the vehicle is at rest (the control step follows it). A
  // zero command alone let the vehicle coast straight on along its heading while its speed ran down — metres off
  // a curving trajectory, next to the very surface that made it stop (likely how a real-time gart_terrain_3d run,
  // stopping at 4.2 m/s, went 0.9 m off its trajectory and 0.14 m into a hill).
  // The braking starts where the vehicle is, not at the reference: a vehicle lagging its reference by metres was
  // told to catch up at full speed first (a recorded gart_terrain_3d crossing: ~5 m/s for 0.3 s, then into the
  // hillside found 1.16 s ahead). `blocked_time`: the trajectory's time at its first blocked sample, when a block
  // made the stop; braking is harder than the comfortable rate, up to the vehicle's limit, when it is close.
  void startBraking(const tracker::VehicleState& state, std::optional<double> blocked_time = std::nullopt) {
    braking_.reset();
    if (follower_) {
      try {
        const auto& trajectory = follower_->trajectory();
        const double vehicle_arc = vehicleArc(*follower_);
        const double from_time = tracker::timeAtArcLength(trajectory, vehicle_arc);
        const double speed = std::max(std::hypot(state.v, state.vz), std::abs(trajectory.at(from_time).speed));
        const double comfortable = comfortableDecel();
        double decel = comfortable;
        if (blocked_time) {
          // A tenth of the room is kept: the blocked sample is where the robot already touches the obstacle.
          const double room = 0.9 * (trajectory.at(*blocked_time).arc_length - vehicle_arc);
          decel = tracker::brakingDecel(speed, room, comfortable, params_.max_decel);
          if (decel > comfortable)
            spdlog::info("braking at {:.2f} m/s^2 from {:.2f} m/s: {:.2f} m to the block", decel, speed, room / 0.9);
        }
        braking_.emplace(tracker::brakeAlong(trajectory, from_time, speed, decel), limits_, tracker_config_);
      } catch (const std::exception& e) {
        spdlog::warn("cannot brake along the trajectory ({}): stopping where the vehicle is heading", e.what());
      }
    }
    if (!braking_) stop();
  }

  // Brakes along the trajectory, drops it and holds the mission; once the vehicle is at rest the next request is
  // made from there with `reason` (control).
  void stopToPlanAtRest(const tracker::VehicleState& state, std::string reason) {
    startBraking(state);
    dropTrajectory();
    mission_.hold();
    stopping_for_ = std::move(reason);
    stopping_since_ns_ = clock().nowNs();
    spdlog::warn("stopping: {}", *stopping_for_);
    requestWhileBraking(state);
  }

  // The plan after a stop is asked for while the vehicle brakes, from where the braking along its trajectory ends (at
  // rest, its heading there), not once it is at rest: the braking from 4 m/s alone took 2-3.6 s, and the vehicle then
  // stood until the plan from rest was smoothed (4.1-4.3 s from the obstacles to a trajectory at real time, bugtrap_0.4
  // and stunnel_0.5, 2026-12-06). The answer is published when ready, stamped with when the braking ends, and flown
  // once the vehicle is at rest (control). Without a braking trajectory (the vehicle was told to stop where it is), the
  // request waits for rest as before.
  void requestWhileBraking(const tracker::VehicleState& state) {
    if (!braking_ || braking_->trajectory().samples.empty()) return;
    const auto& end = braking_->trajectory().samples.back();
    tracker::VehicleState rest = state;
    rest.position = end.position;
    rest.heading = tracker::wrapAngle(end.heading);
    rest.v = rest.omega = rest.vz = 0.0;
    braking_rest_ = rest;
    act(mission_.replan(clock().nowNs(), rest, *stopping_for_));
  }

  // The state the mission plans from: while the vehicle brakes to a plan asked from its rest point, that point.
  tracker::VehicleState missionState(const tracker::VehicleState& state) const { return braking_rest_ && stopping_for_ ? *braking_rest_ : state; }

  // `announced`: published when it was ready (a trajectory that waited for its switch point).
  // `rest`: the path after its end, smoothed when half of it is flown; `next_piece`: it continues the one flown.
  void switchTrajectory(tracker::Trajectory trajectory, std::vector<planner::State> rest, bool next_piece, std::uint32_t request_id,
                        const tracker::VehicleState& state, bool announced = false) {
    if (!announced) trajectories_.publish(nodes::toMsg(trajectory, request_id, clock().nowNs()));
    // The plan's progress counts the pieces flown before this one.
    flown_pieces_m_ = next_piece && follower_ ? flown_pieces_m_ + follower_->trajectory().at(follower_->status().reference_time).arc_length : 0.0;
    // A start that turns in place is never skipped: the skip to the vehicle's projection jumped past the turn (a
    // slow replan ahead at a stunnel_0.5 corner: 3.29 s in, the reference heading 1.2 rad off the vehicle's, which
    // swung 0.6 m off the trajectory into the wall).
    const bool turns_in_place = trajectory.samples.front().speed < 0.1 && std::abs(trajectory.initial_turn) > 1e-3;
    const bool moving_start = !turns_in_place && (request_speed_ > 0 || trajectory.samples.front().speed > 0);
    rest_of_path_ = std::move(rest);
    rest_length_m_ = planner::pathLength(rest_of_path_);
    flown_request_id_ = request_id;
    follower_.emplace(std::move(trajectory), limits_, tracker_config_);
    ++trajectory_serial_;  // a check still running on the previous one is stale
    replan_gate_.reset();
    // A plan from a predicted start that came later than predicted: the vehicle has flown past that start
    // meanwhile, so the reference begins at the vehicle's projection, not behind it.
    if (moving_start) {
      const double skipped = follower_->skipToVehicle(state.position, 2.0 * replan_gate_.expectedPlanningTime() + 2.0);
      if (skipped > 0) spdlog::info("trajectory {}: the switch came late, the reference starts {:.2f} s in, at the vehicle", request_id, skipped);
    }
  }

  void dropTrajectory() {
    follower_.reset();
    switch_at_.reset();
    next_trajectory_.reset();
    rest_of_path_.clear();
    next_rest_.clear();
  }

  // Progress along the whole plan when it is flown a piece at a time (the pieces flown, this one, the path after it).
  double planProgress(const tracker::TrackingStatus& status) const {
    if (!follower_ || (flown_pieces_m_ == 0 && rest_length_m_ == 0)) return status.progress;
    const double length = follower_->trajectory().length();
    const double total = flown_pieces_m_ + length + rest_length_m_;
    return total > 0 ? std::clamp((flown_pieces_m_ + status.progress * length) / total, 0.0, 1.0) : 1.0;
  }

  void control() {
    // The reference advances by the clock's time between two control steps, not by the nominal period: on
    // a loaded machine the timer fires late, and a fixed step would slow the reference (and the vehicle,
    // which the controller holds to it) in proportion. Capped, so one stall is not one jump.
    const double nominal_dt = 1.0 / params_.control_rate_hz;
    const std::int64_t step_ns = clock().nowNs();
    const double dt = std::clamp(static_cast<double>(step_ns - last_step_ns_) * 1e-9, 0.2 * nominal_dt, 5.0 * nominal_dt);
    last_step_ns_ = step_ns;
    sayWhatWeWaitFor();
    // Readiness first (so the launcher can start whoever waits for us), then wait up to 20 s for a planner,
    // matched both ways: a Cyclone planner may learn of this Fast DDS writer after the writer matched it, and
    // the first request, sent in between, was lost (then answered only after the answer timeout: 48 s of
    // simulated time at speed 4 on gart_cluttered_2d).
    // A subscriber of planning/request is not a planner: the monitor and a recorder subscribe too, and the monitor starts
    // first. A planner is there once its planning/path writer is matched as well; before that, the first request went
    // to the monitor alone and was answered after the planner's discovery, 0.4-1.0 s of wall time later, repeated every
    // 0.2 s meanwhile (bugtrap_1.0 at speed 4, 2026-12-07: 3.9 s of simulated time from the request to the first
    // trajectory, counted in the mission's time to goal).
    if (!planner_seen_) {
      const bool planner_there = requests_.settledSubscribers() > 0 && path_sub_.matchedPublishers() > 0;
      if (!planner_there && std::chrono::steady_clock::now() - started_ < std::chrono::seconds(20)) return;
      if (!planner_there) spdlog::warn("no planner is matched on planning/request and planning/path yet: asking anyway");
      planner_seen_ = true;
    }
    const std::optional<tracker::VehicleState> state = vehicle_;
    measureClockSpeed();
    repeatUntilAPlannerAnswers();
    settleImprovement();
    if (state && stall_watch_.update(nowS(), state->position, state->heading,
                                     !stopping_for_ && follower_ && mission_.driving() && !mission_.awaitingRequiredPlan())) {
      stopToPlanAtRest(*state, fmt::format("stalled: the vehicle moved less than {:.1f} m and turned less than {:.0f} degrees in {:.1f} s "
                                           "with a trajectory to fly ({:.1f} of its {:.1f} s flown{})",
                                           stall_watch_.policy().radius_m, stall_watch_.policy().turn_rad * 180.0 / std::numbers::pi,
                                           stall_watch_.policy().stall_s, follower_->status().reference_time,
                                           follower_->trajectory().duration(), rest_of_path_.empty() ? "" : ", more of the path after it"));
      return;
    }
    if (stopping_for_ && state) {
      if (braking_) commands_.publish(nodes::toMsg(braking_->update(*state, dt), clock().nowNs()));
      else stop();
      // The plan asked from the rest point meanwhile: its answer is smoothed and held (adoptSmoothed) while braking, and
      // a refused or failed one is asked again when its retry is due, not once the vehicle is at rest (r3d_69 at speed 4,
      // 2026-12-07: a path refused by the smoother 0.1 s after its request was asked again 1.45 s later, at rest).
      if (braking_rest_) {
        if (auto decision = takeSmoothed(missionState(*state))) act(*decision);
        else if (!smoothing_.valid() && (new_path_ || mission_.retryDue(clock().nowNs()))) act(missionUpdate(missionState(*state)));
      }
      const double stopping_s = static_cast<double>(clock().nowNs() - stopping_since_ns_) * 1e-9;
      if (std::abs(state->v) > kAtRest && stopping_s < 10.0) return;
      if (std::abs(state->v) > kAtRest)
        spdlog::warn("the vehicle is not at rest after {:.1f} s ({:.2f} m/s): {}", stopping_s, state->v,
                     braking_rest_ ? "going on" : "asking from here");
      braking_.reset();
      stop();
      if (braking_rest_) {
        // At rest: the plan's trajectory when it is ready, else its answer (or a retry, or the failure) comes as usual.
        braking_rest_.reset();
        const std::string stopped_for = *stopping_for_;
        stopping_for_.reset();
        if (next_trajectory_) {
          // Asked from where the braking was predicted to end. A vehicle that came to rest farther from there (a hard
          // stop at the vehicle's limit, a late switch to the braking) would be pulled to that start across space no
          // check has seen, its cross-track error then asking for a stop and a new plan (as read from the log of an
          // unrecorded u_large_3d run, 2026-12-07: 1.05 and 1.12 m, two deviation replans in a row). It is asked again
          // from where the vehicle is.
          const double missed = (state->position - next_trajectory_->samples.front().position).norm();
          if (missed > kRestStartTolerance * tracker_config_.replan_deviation) {
            spdlog::warn("trajectory {}: the vehicle came to rest {:.2f} m from its start (the predicted end of the braking): not flown",
                         next_request_id_, missed);
            next_trajectory_.reset();
            next_rest_.clear();
            act(mission_.replan(clock().nowNs(), *state, fmt::format("rest_point_missed: at rest {:.2f} m from the start of the plan asked "
                                                                          "while braking ({})", missed, stopped_for)));
            return;
          }
          switchTrajectory(std::move(*next_trajectory_), std::move(next_rest_), next_is_piece_, next_request_id_, *state, /*announced=*/true);
          next_trajectory_.reset();
        }
        return;
      }
      act(mission_.replan(clock().nowNs(), *state, *stopping_for_));
      stopping_for_.reset();
      return;
    }
    std::optional<tracker::MissionDecision> decision;
    if (state) decision = takeSmoothed(*state);
    if (!decision) decision = missionUpdate(state);
    if (!act(*decision)) return;
    drive(*state, dt);
  }

  // Until the first request the status detail says what the tracker waits for: a run that ends without a plan
  // request then says why in the monitor's report (not_reached_why). Published when it changes.
  void sayWhatWeWaitFor() {
    std::string waiting;
    if (mission_.requestId() == 0) {
      if (!planner_seen_) waiting = "waiting for a planner on planning/request and planning/path";
      else if (!vehicle_) waiting = "waiting for vehicle/state";
      else if (params_.wait_for_world)
        if (const std::string missing = world_source_.missing(); !missing.empty()) waiting = "waiting for the planner's world: " + missing;
    }
    if (waiting == said_waiting_) return;
    said_waiting_ = waiting;
    ctx().setDetail(waiting);
  }

  // A finished smoothing: the mission hears whether it gave a trajectory (a result for an older request than
  // the current one is stale and dropped). Nothing when no smoothing has finished.
  std::optional<tracker::MissionDecision> takeSmoothed(const tracker::VehicleState& state) {
    if (!ready(smoothing_)) return std::nullopt;
    Smoothed smoothed = smoothing_.get();
    if (smoothed.next_piece) {
      adoptNextPiece(std::move(smoothed), state);
      return std::nullopt;
    }
    if (smoothed.request_id != mission_.requestId()) return std::nullopt;
    const std::uint32_t request_id = smoothed.request_id;
    const bool flown = adoptSmoothed(std::move(smoothed), state);
    // A refusal that stopped the vehicle has asked the next plan already (requestWhileBraking): this answer's outcome
    // is no attempt of that one.
    if (request_id != mission_.requestId()) return std::nullopt;
    return mission_.pathSmoothed(clock().nowNs(), state, flown, refused_for_speed_);
  }

  // Between control steps, when a path, a smoothed trajectory or a replan check has just come in: what the
  // next control step would do with it first, so that none of them waits for that step. Driving stays with
  // the control step; so does everything while the vehicle stops for a replan or no planner was seen yet.
  // A smoothing or a check posts this as its last step, so its result is ready within microseconds (the task
  // posts, then returns it): that one is waited for, briefly.
  enum class Arrived { Path, Smoothing, Check };
  void takeUpNow(Arrived what) {
    if (!planner_seen_ || (stopping_for_ && !braking_rest_) || !vehicle_) return;
    if (what == Arrived::Smoothing && smoothing_.valid()) smoothing_.wait_for(std::chrono::milliseconds(2));
    if (what == Arrived::Check && checking_.valid()) checking_.wait_for(std::chrono::milliseconds(2));
    const tracker::VehicleState state = missionState(*vehicle_);
    if (auto decision = takeSmoothed(state)) {
      act(*decision);
      // A refusal asked again at once (one for the vehicle's speed) is asked now, not at the next control step: that
      // step held such a retry 43 ms of a real-time gart_terrain_3d replan's 165 (2026-12-07).
      if (!smoothing_.valid() && mission_.retryDue(clock().nowNs())) act(missionUpdate(state));
    } else if (new_path_ && !smoothing_.valid()) {
      act(missionUpdate(state));
    }
    takeChecked(state);
  }

  void takeChecked(const tracker::VehicleState& state) {
    if (!ready(checking_)) return;
    Checked checked = checking_.get();
    if (checked.took_s > 1.0) spdlog::warn("replan check took {:.3f} s (world snapshot and trajectory check)", checked.took_s);
    if (follower_ && checked.trajectory_serial == trajectory_serial_) follower_->limitToObservedSpace(checked.observed_stop_arc, comfortableDecel(), observed_crawl_speed_);
    // Only a check of the trajectory still flown counts, and only while no new one waits for its switch;
    // while one is smoothed only a stop counts (react).
    if (follower_ && checked.trajectory_serial == trajectory_serial_ && !next_trajectory_) react(checked, state);
  }

  tracker::MissionDecision missionUpdate(const std::optional<tracker::VehicleState>& state) {
    std::optional<msg::Path> path;
    if (!smoothing_.valid()) path.swap(new_path_);  // one answer at a time: a newer one waits for the smoothing
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
    if (decision.action != tracker::MissionAction::SmoothPath) return decision;
    startSmoothing(*path, *state);
    // Meanwhile the vehicle keeps flying the current trajectory (a replan ahead), or stays stopped.
    tracker::MissionDecision meanwhile;
    meanwhile.action = mission_.driving() && follower_ ? tracker::MissionAction::Drive : tracker::MissionAction::Wait;
    return meanwhile;
  }

  void drive(const tracker::VehicleState& current, double dt) {
    const std::optional<tracker::VehicleState> state = current;
    if (next_trajectory_ && (follower_->status().reference_time >= *switch_at_ ||
                             static_cast<double>(clock().nowNs() - next_since_ns_) * 1e-9 > next_wait_limit_s_)) {
      switchTrajectory(std::move(*next_trajectory_), std::move(next_rest_), next_is_piece_, next_request_id_, *state, /*announced=*/true);
      next_trajectory_.reset();
      switch_at_.reset();
    }
    if (!rest_of_path_.empty() && !next_trajectory_ && !smoothing_.valid() && !mission_.awaitingPlan() &&
        follower_->trajectory().length() - follower_->trajectory().at(follower_->status().reference_time).arc_length < 0.5 * piece_length_m_)
      startNextPiece();
    const auto command = follower_->update(*state, dt);
    const auto& status = follower_->status();
    if (heldByUnobservedSpace(*state)) return;
    // A line every 10 s of driving, so a run that creeps along one trajectory says why in the log (the
    // reference held back by max_lead, a slow vehicle, a small command).
    if (clock().nowNs() - last_progress_log_ns_ > 10'000'000'000LL) {
      last_progress_log_ns_ = clock().nowNs();
      spdlog::info("driving trajectory {}: reference at {:.1f} of {:.1f} s, progress {:.0f} %, along-track {:.2f} m, cross-track {:.2f} m, "
                   "vehicle at {:.2f} m/s (vz {:.2f}), command {:.2f} m/s (vz {:.2f})",
                   flown_request_id_, status.reference_time, follower_->trajectory().duration(), 100 * status.progress,
                   status.along_track_error, status.cross_track_error, state->v, state->vz, command.v, command.vz);
    }
    commands_.publish(nodes::toMsg(command, clock().nowNs()));
    const auto next = mission_.tracked(clock().nowNs(), *state, status, dt);
    msg::TrackingStatus out;
    out.stamp_ns(clock().nowNs());
    out.request_id(flown_request_id_);
    out.cross_track_error(status.cross_track_error);
    out.along_track_error(status.along_track_error);
    out.mean_cross_track_error(status.mean_cross_track_error);
    out.max_cross_track_error(status.max_cross_track_error);
    out.progress(planProgress(status));
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
      dropTrajectory();
      act(next);
    } else if (next.action == tracker::MissionAction::CheckReplan && !next_trajectory_ && !checking_.valid() &&
               static_cast<double>(clock().nowNs() - last_check_ns_) * 1e-9 >= 0.5 * params_.replan_check_period_s) {
      startCheck(*state);  // unless a new obstacle array was just checked
    }
    takeChecked(*state);
  }

  // stop_within_observed holds the vehicle before space the map has not observed free until it is seen; a vehicle
  // held at rest for observed_hold_s (the space stays unseen: hidden behind the vehicle's own trajectory's corner,
  // or never reached by a ray) stops waiting and plans again from where it is. True when it did.
  bool heldByUnobservedSpace(const tracker::VehicleState& state) {
    const double cap = follower_->observedSpaceCap();
    const bool held = cap < 0.05 * limits_.v_max && std::abs(state.v) < 0.05 * limits_.v_max && !mission_.awaitingPlan() &&
                      !next_trajectory_ && !smoothing_.valid();
    if (!held) {
      held_since_ns_.reset();
      if (cap < 0.5 * limits_.v_max && clock().nowNs() - last_observed_log_ns_ > 5'000'000'000LL) {
        last_observed_log_ns_ = clock().nowNs();
        const double stop_arc = follower_->observedSpaceArc();
        const auto& samples = follower_->trajectory().samples;
        const auto unseen = std::find_if(samples.begin(), samples.end(), [&](const auto& s) { return s.arc_length > stop_arc; });
        const planner::Vec3 where = unseen != samples.end() ? unseen->position : samples.back().position;
        spdlog::info("slowing to {:.2f} m/s: the map has observed the trajectory free for only {:.1f} m ahead of the vehicle at ({:.1f}, {:.1f}), "
                     "up to ({:.1f}, {:.1f})",
                     cap, stop_arc - vehicleArc(*follower_), state.position.x(), state.position.y(), where.x(), where.y());
      }
      return false;
    }
    if (!held_since_ns_) held_since_ns_ = clock().nowNs();
    if (static_cast<double>(clock().nowNs() - *held_since_ns_) * 1e-9 < params_.observed_hold_s) return false;
    held_since_ns_.reset();
    stopToPlanAtRest(state, fmt::format("unobserved_ahead: held {:.1f} s before space the map has not observed free", params_.observed_hold_s));
    return true;
  }

  void react(Checked checked, const tracker::VehicleState& current) {
    const std::optional<tracker::VehicleState> state = current;
    {
      // The vehicle flew on while the check ran: the blocked sample is that much closer.
      auto replan = checked.decision;
      replan.time_ahead = std::max(0.0, replan.time_ahead - (follower_->status().reference_time - checked.reference_time));
      const auto verdict = replan_gate_.check(replan, follower_->trajectory(), follower_->status().reference_time);
      if (verdict.action == tracker::ReplanAction::StopAndReplan) {
        // Stop, and ask from where the vehicle comes to rest: a plan from where it started braking would
        // begin metres behind it (v^2 / 2a), and one still on its way from a predicted start ahead would
        // begin where it never arrives. A newer request supersedes that one.
        std::optional<double> blocked_time;
        if (replan.reason == tracker::ReplanReason::TrajectoryBlocked) blocked_time = follower_->status().reference_time + replan.time_ahead;
        startBraking(current, blocked_time);
        dropTrajectory();
        mission_.hold();
        if (mission_.awaitingPlan()) spdlog::warn("stopping; plan {} is superseded: {}", mission_.requestId(), verdict.reason);
        else spdlog::info("stopping to replan from where the vehicle comes to rest: {}", verdict.reason);
        stopping_for_ = verdict.reason;
        stopping_since_ns_ = clock().nowNs();
        requestWhileBraking(current);
      } else if (verdict.action == tracker::ReplanAction::ReplanAhead && !mission_.awaitingRequiredPlan() &&
                 (!smoothing_.valid() || mission_.improving())) {
        // A shorter route still asked or smoothed is superseded: its answer is dropped as stale (takeSmoothed).
        replanAheadFrom(verdict.start, *state, verdict.reason);
      } else if (verdict.action == tracker::ReplanAction::Continue) {
        askForAShorterRoute(*state);
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
  const double improve_for_s_;  // the parameter, or its default for the scenario
  tracker::ImprovementGate improvement_gate_;
  tracker::StallWatch stall_watch_;
  std::uint32_t flown_request_id_ = 0;  // the request whose trajectory is flown (the mission's may be a newer one)
  std::uint32_t next_request_id_ = 0;   // the request next_trajectory_ comes from
  bool improvement_open_ = false;         // a shorter route asked and not settled (settleImprovement)
  tracker::ReplanGate replan_gate_;
  const tracker::TrackerConfig tracker_config_;
  std::int64_t requested_at_ns_ = 0;  // the current request's time, for the gate's planning-time estimate
  double request_heading_ = 0.0;      // the vehicle's heading at its start: the new trajectory starts (turning in place) from it
  double request_speed_ = 0.0;        // and speed: > 0 for a replan ahead, flown through without a stop
  double request_vz_ = 0.0;           // and climb rate (3-D), for the lead-in's direction
  std::optional<tracker::TrajectoryTracker> follower_;
  std::optional<tracker::TrajectoryTracker> braking_;  // while stopping_for_: the rest of the trajectory, braked along
  std::optional<tracker::VehicleState> braking_rest_;  // while stopping_for_: where braking_ ends, the plan asked from there
  // A replan from a predicted start: the new trajectory waits until the vehicle's reference on the current
  // one reaches that start (switch_at_, s of the current trajectory), so a plan ready early is not flown
  // from behind its start; a late one is switched to at once.
  std::optional<double> switch_at_;
  std::optional<tracker::Trajectory> next_trajectory_;
  std::vector<planner::State> next_rest_;  // the path after next_trajectory_'s end
  bool next_is_piece_ = false;             // next_trajectory_ continues the one flown
  // A long path's later pieces: the path after the end of the trajectory flown (docs/tracking.md).
  const double piece_length_m_;
  double flown_braking_decel_ = 0.0;  // m/s^2 (parameter flown_braking_decel); 0: plans that could only start at rest are refused
  const double observed_crawl_speed_;  // observed_crawl_speed, or its default for the scenario
  std::vector<planner::State> rest_of_path_;
  double rest_length_m_ = 0.0;           // of rest_of_path_ when it was set (a next piece's job takes the path itself)
  double flown_pieces_m_ = 0.0;           // the plan's pieces flown before the current one, m
  double last_piece_smoothing_s_ = -1.0;  // clock seconds the last next piece took; < 0: none yet
  std::future<Smoothed> smoothing_;
  std::optional<std::int64_t> held_since_ns_;  // stop_within_observed: since when the vehicle is held at rest
  std::int64_t last_observed_log_ns_ = 0;
  unsigned rest_start_refusals_ = 0;  // plans refused in a row for starting at rest or too slowly while the vehicle is moving
  // The last smoothed answer was refused for starting too slowly for the vehicle (a curve it cannot brake for): asked
  // again at once, not after refused_retry_delay_s, which waits for the planner to build the map the tracker refused a
  // path on. Such a wait held a replan 84-104 ms of wall time at speed 4 (gart_terrain_3d, terrain_ridge_3d, city_3d,
  // 2026-12-07), most of what it took over 150 ms.
  bool refused_for_speed_ = false;
  std::optional<std::string> stopping_for_;  // a stop-and-replan's reason, until the vehicle is at rest
  std::int64_t stopping_since_ns_ = 0;
  std::int64_t speed_window_clock_ns_ = 0;
  std::chrono::steady_clock::time_point speed_window_wall_;
  std::future<Checked> checking_;
  std::int64_t last_check_ns_ = 0;  // clock time the last replan check started
  std::uint64_t trajectory_serial_ = 0;
  std::int64_t next_since_ns_ = 0;
  double next_wait_limit_s_ = 2.0;
  std::int64_t last_progress_log_ns_ = 0;
  std::int64_t last_step_ns_ = 0;
  msg::TrackingStatus last_status_;
  std::string said_waiting_;  // the status detail last published by sayWhatWeWaitFor
  std::chrono::steady_clock::time_point started_;
  bool planner_seen_ = false;
  bool planner_answered_ = false;  // some planning/path came: requests are no longer repeated
  std::optional<msg::PlanRequest> unanswered_request_;
  std::chrono::steady_clock::time_point unanswered_sent_{};
  int unanswered_copies_ = 0;  // copies of the unanswered request sent (logged once)
  bus::Subscription state_sub_, path_sub_, clouds_sub_;
  std::optional<tracker::ScanFreeSpace> empty_scan_view_;  // the default sensor's bins, range and field of view
  mutable std::mutex scan_view_mutex_;
  std::shared_ptr<const tracker::ScanFreeSpace> scan_view_;  // the newest scan, stop_within_observed
  runtime::Timer control_;
};

}  // namespace

DDSNAV_COMPONENT(TrackerComponent, "tracker")
