// ddsnav-monitor: watches a running pipeline and writes what happened as a report a person can open:
// out_dir/report.html (the world, the perceived ellipses, every planned path, the trajectory and the
// driven track, with the numbers), report.svg and summary.json. Ends with status 0 when the vehicle's true
// position (vehicle/state) enters the scenario's goal region, 1 when timeout_s passes first, a component
// fails, the followed clock stops, or the scenario's truth shows the goal cannot be reached (checked at
// start; summary.json's not_reached_why says which). Time is the component's clock: on `clock: topic`
// timeout_s and every sim_* number count simulated time.

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/ground_truth.hpp"
#include <ddsnav/bus/printable.hpp>
#include "ddsnav/nodes/run_report.hpp"
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>
#include <ddsnav/tracker/mission.hpp>

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <mutex>
#include <optional>

using namespace ddsnav;

namespace {

struct Observations {
  std::vector<Eigen::Vector3d> track;
  std::optional<Eigen::Vector3d> vehicle;  // the newest true position (vehicle/state, the simulator's)
  std::optional<msg::ObstacleArray> obstacles;
  std::vector<msg::Path> paths;
  std::optional<msg::Trajectory> trajectory;
  std::optional<msg::TrackingStatus> status;
  std::optional<msg::OccupancyMap> map;
  std::string failure;  // "component: detail" of the first component that reported LIFECYCLE_FAILED
  std::size_t clouds = 0;
  std::size_t cloud_points = 0;
  std::size_t tracked_obstacles_max = 0;
  std::vector<nodes::PlanRequestSeen> requests;
  std::optional<std::int64_t> first_trajectory_ns;  // clock time the first trajectory was heard
  std::optional<std::int64_t> goal_entered_ns;      // clock time of the first true position in the goal region
  std::optional<Eigen::Vector3d> goal_entered_at;   // and that position
};

// What the report needs from the messages, as plain types.
nodes::RunObservations toRunObservations(const std::string& scenario, double elapsed, const Observations& seen) {
  nodes::RunObservations run;
  run.scenario = scenario;
  run.elapsed_s = elapsed;
  run.failure = seen.failure;
  run.clouds = seen.clouds;
  run.cloud_points = seen.cloud_points;
  run.tracked_obstacles_max = seen.tracked_obstacles_max;
  run.requests = seen.requests;
  if (seen.obstacles) run.obstacles = nodes::toEllipsoidObstacles(*seen.obstacles);
  for (const auto& m : seen.paths) {
    nodes::PlannedPath path;
    for (const auto& s : m.states()) path.states.emplace_back(s.x(), s.y(), s.z());
    path.planner = m.planner();
    path.cost_m = m.cost();
    path.plan_time_s = m.statistics().time_s();
    path.iterations = m.statistics().iterations();
    run.paths.push_back(std::move(path));
  }
  if (seen.trajectory) {
    run.trajectory.emplace();
    for (const auto& s : seen.trajectory->samples()) run.trajectory->push_back(nodes::fromMsg(s.position()));
  }
  run.track = seen.track;
  if (seen.status)
    run.tracking = nodes::TrackingSummary{seen.status->mean_cross_track_error(), seen.status->max_cross_track_error(),
                                          seen.status->progress()};
  if (seen.map) run.map = nodes::MapSummary{seen.map->octree().size(), seen.map->resolution()};
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  return runtime::runComponent("monitor", argc, argv, [](runtime::Context& ctx) {
    const auto scenario = planner::loadScenario(ctx.params().require<std::string>("scenario"));
    const std::filesystem::path out_dir = ctx.params().declare<std::string>("out_dir", "out/demo");
    const double timeout = ctx.params().declare<double>("timeout_s", 120.0, "on the component's clock (simulated on clock: topic)");
    if (!(timeout > 0)) throw runtime::ParameterError("parameter timeout_s: expected > 0");
    const double stall_limit = ctx.params().declare<double>("clock_stall_s", 20.0, "wall seconds the followed clock may stand still");
    if (!(stall_limit > 0)) throw runtime::ParameterError("parameter clock_stall_s: expected > 0");
    std::filesystem::create_directories(out_dir);

    // A goal the truth says cannot be reached ends the run now, with the reason, instead of at the timeout.
    // A scenario without a vehicle: the simulator and the tracker refuse it too, but the report must say so.
    const auto feasibility =
        scenario.vehicle ? nodes::checkGoalFeasible(scenario)
                         : nodes::GoalFeasibility{false, "the scenario has no 'vehicle' block: the simulator has no vehicle to drive "
                                                         "and the tracker no limits to plan with"};
    if (!feasibility.feasible) {
      nodes::RunObservations run;
      run.scenario = scenario.name;
      run.infeasible_why = feasibility.why;
      nodes::judgeGoal(run, scenario, false, std::nullopt, std::nullopt);
      nodes::writeReport(out_dir, scenario, run);
      std::printf("%s\n", nodes::summaryJson(run).dump().c_str());
      throw std::runtime_error(scenario.source + ": " + feasibility.why);
    }

    std::mutex mutex;
    Observations seen;
    auto& bus = ctx.bus();
    const auto& clock = ctx.clock();
    // Every input is checked before it can reach the report (NaN in the SVG, null in summary.json) or the
    // verdict: a bad sample is dropped with a warning naming topic and field, and counted.
    nodes::DroppedSamples bad_states("vehicle/state"), bad_paths("planning/path"), bad_trajectories("control/trajectory"),
        bad_statuses("control/tracking");
    auto s1 = bus.subscribe<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), [&](const msg::VehicleState& m) {
      if (const auto error = nodes::checkVehicleState(m, nodes::kWorldFrame); !error.empty()) return bad_states.drop(error);
      std::lock_guard lock(mutex);
      const auto p = nodes::fromMsg(m.position());
      seen.vehicle = p;
      if (seen.track.empty() || (seen.track.back() - p).norm() > 0.05) seen.track.push_back(p);
      if (!seen.goal_entered_ns && tracker::checkGoal(scenario.goal, scenario.goal_radius, p).reached) {
        seen.goal_entered_ns = clock.nowNs();
        seen.goal_entered_at = p;
        if (seen.track.back() != p) seen.track.push_back(p);
      }
    });
    auto s2 = bus.subscribe<msg::ObstacleArray>("perception/obstacles", bus::Qos::state(), [&](const msg::ObstacleArray& m) {
      // Drawn with toEllipsoidObstacles at the end, which refuses malformed obstacles: keep the last good array.
      if (const auto error = nodes::checkObstacleArray(m, ""); !error.empty()) {
        spdlog::warn("perception/obstacles: ignoring an array: {}", error);
        return;
      }
      std::lock_guard lock(mutex);
      seen.tracked_obstacles_max = std::max(seen.tracked_obstacles_max, m.obstacles().size());
      seen.obstacles = m;
    });
    auto s3 = bus.subscribe<msg::Path>("planning/path", bus::Qos::state(), [&](const msg::Path& m) {
      if (const auto error = nodes::checkPath(m); !error.empty()) return bad_paths.drop(error);
      std::lock_guard lock(mutex);
      seen.paths.push_back(m);
    });
    std::int64_t started_ns = 0;  // clock time the watch began (set before ctx.ready(), read under the mutex)
    auto s4 = bus.subscribe<msg::Trajectory>("control/trajectory", bus::Qos::state(), [&](const msg::Trajectory& m) {
      if (const auto error = nodes::checkTrajectory(m); !error.empty()) return bad_trajectories.drop(error);
      std::lock_guard lock(mutex);
      if (!seen.first_trajectory_ns) seen.first_trajectory_ns = clock.nowNs();
      seen.trajectory = m;
    });
    auto s9 = bus.subscribe<msg::PlanRequest>("planning/request", bus::Qos::commands(), [&](const msg::PlanRequest& m) {
      std::lock_guard lock(mutex);
      const double at = started_ns ? (clock.nowNs() - started_ns) * 1e-9 : 0.0;
      seen.requests.push_back({m.request_id(), at, bus::printable(m.reason())});
    });
    auto s5 = bus.subscribe<msg::TrackingStatus>("control/tracking", bus::Qos::sensorData(), [&](const msg::TrackingStatus& m) {
      if (const auto error = nodes::checkTrackingStatus(m); !error.empty()) return bad_statuses.drop(error);
      std::lock_guard lock(mutex);
      seen.status = m;
    });
    // Only the map's size and resolution are reported: those are checked (its octree is the planner's business).
    nodes::DroppedSamples bad_maps("map/octomap", "keeping the last good map");
    auto s6 = bus.subscribe<msg::OccupancyMap>("map/octomap", bus::Qos::state(), [&](const msg::OccupancyMap& m) {
      if (!(m.resolution() > 0.0) || !std::isfinite(m.resolution()))
        return bad_maps.drop(fmt::format("resolution is {}, expected a positive finite number of metres", m.resolution()));
      std::lock_guard lock(mutex);
      seen.map = m;
    });
    auto s7 = bus.subscribe<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), [&](const msg::PointCloud& m) {
      std::lock_guard lock(mutex);
      ++seen.clouds;
      seen.cloud_points += m.xyz().size() / 3;
    });

    auto s8 = bus.subscribe<msg::ComponentStatus>("system/status", bus::Qos::state(), [&](const msg::ComponentStatus& m) {
      std::lock_guard lock(mutex);
      if (m.state() == msg::LifecycleState::LIFECYCLE_FAILED && seen.failure.empty())
        seen.failure = bus::printable(m.name()) + ": " + (m.detail().empty() ? std::string("failed") : bus::printable(m.detail()));
    });

    // Waits for the followed clock (the simulator's) before the watch starts: timeout_s counts from there.
    const auto wall_started = std::chrono::steady_clock::now();
    ctx.ready();
    while (!clock.valid() && !ctx.shutdownRequested()) {
      if (std::chrono::steady_clock::now() - wall_started > std::chrono::duration<double>(stall_limit)) break;
      ctx.waitForShutdown(std::chrono::milliseconds(20));
    }
    {
      std::lock_guard lock(mutex);
      started_ns = clock.nowNs();
    }
    auto last_log = started_ns;
    auto last_tick = std::make_pair(started_ns, std::chrono::steady_clock::now());  // the clock's last advance
    bool reached = false, timed_out = false;
    std::string clock_stopped;
    if (!clock.valid()) clock_stopped = fmt::format("no system/clock sample within clock_stall_s ({:g} s): is the simulator running?", stall_limit);
    bool claim_logged = false;
    while (clock_stopped.empty() && !ctx.waitForShutdown(std::chrono::milliseconds(50))) {
      std::lock_guard lock(mutex);
      reached = seen.goal_entered_ns.has_value();
      const bool claimed = seen.status && seen.status->goal_reached();
      if (claimed && !reached && !claim_logged) {
        claim_logged = true;
        spdlog::warn("control/tracking says the goal is reached, but {}: not taken as reached",
                     tracker::checkGoal(scenario.goal, scenario.goal_radius, seen.vehicle).why);
      }
      const auto now = clock.nowNs();
      const auto wall_now = std::chrono::steady_clock::now();
      if (now != last_tick.first) last_tick = {now, wall_now};
      if (wall_now - last_tick.second > std::chrono::duration<double>(stall_limit))
        clock_stopped = fmt::format("the clock stood still for clock_stall_s ({:g} s of wall time): is the simulator running?", stall_limit);
      timed_out = (now - started_ns) * 1e-9 > timeout;
      if (reached || timed_out) break;
      if (!seen.failure.empty()) {
        spdlog::error("component failed: {}", seen.failure);
        break;
      }
      if (now - last_log > 3'000'000'000) {
        last_log = now;
        spdlog::info("{:.0f} s: {} clouds, {} obstacles, {} paths, progress {:.0f} %, cross-track error {:.3f} m", (now - started_ns) * 1e-9,
                     seen.clouds, seen.obstacles ? seen.obstacles->obstacles().size() : 0, seen.paths.size(),
                     seen.status ? 100.0 * seen.status->progress() : 0.0, seen.status ? seen.status->cross_track_error() : 0.0);
      }
    }
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_started).count();
    s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = s9 = bus::Subscription();

    std::lock_guard lock(mutex);  // the subscriptions are gone: only for the analyser
    nodes::RunObservations run = toRunObservations(scenario.name, elapsed, seen);
    run.sim_elapsed_s = (clock.nowNs() - started_ns) * 1e-9;
    if (!clock_stopped.empty()) run.failure = run.failure.empty() ? clock_stopped : run.failure + "; " + clock_stopped;
    if (seen.goal_entered_ns) {
      // From the mission's start: the first plan request, else (it was missed) the first trajectory.
      const auto from = !seen.requests.empty() ? std::optional<std::int64_t>(started_ns + static_cast<std::int64_t>(seen.requests.front().sim_time_s * 1e9))
                                               : seen.first_trajectory_ns;
      if (from) run.sim_time_to_goal_s = (*seen.goal_entered_ns - *from) * 1e-9;
    }
    run.min_true_clearance_m = nodes::minTrueClearance(scenario, seen.track);
    nodes::judgeGoal(run, scenario, seen.status && seen.status->goal_reached(), seen.goal_entered_at ? seen.goal_entered_at : seen.vehicle,
                     timed_out ? std::optional<double>(timeout) : std::nullopt);
    nodes::writeReport(out_dir, scenario, run);
    spdlog::info("{}: {} after {:.1f} s simulated ({:.1f} s wall); report in {}", scenario.name,
                 run.goal_reached ? "goal reached" : "goal NOT reached", run.sim_elapsed_s, elapsed, (out_dir / "report.html").string());
    std::printf("%s\n", nodes::summaryJson(run).dump().c_str());
    if (!run.goal_reached) throw std::runtime_error("goal not reached: " + run.not_reached_why);
  });
}
