// ddsnav-monitor: watches a running pipeline and writes what happened as a report a person can open:
// out_dir/report.html (the world, the perceived ellipses, every planned path, the trajectory and the
// driven track, with the numbers), report.svg and summary.json. Ends with status 0 when the tracker
// reports the goal reached and the vehicle's true position (vehicle/state) is in the goal region, 1 when
// timeout_s passes first or a component fails (summary.json's not_reached_why says which).

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/bus/printable.hpp>
#include "ddsnav/nodes/run_report.hpp"
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>
#include <ddsnav/tracker/mission.hpp>

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
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
};

// What the report needs from the messages, as plain types.
nodes::RunObservations toRunObservations(const std::string& scenario, double elapsed, const Observations& seen) {
  nodes::RunObservations run;
  run.scenario = scenario;
  run.elapsed_s = elapsed;
  run.failure = seen.failure;
  run.clouds = seen.clouds;
  run.cloud_points = seen.cloud_points;
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

class MonitorComponent : public runtime::Component {
 public:
  struct Params {
    std::string scenario;
    std::string out_dir;
    double timeout_s;
    explicit Params(runtime::Parameters& p)
        : scenario(p.require<std::string>("scenario", runtime::ParamSpec{.doc = "scenario file: the world, goal and goal radius"})),
          out_dir(p.declare<std::string>("out_dir", "out/demo", {.doc = "where report.html, report.svg and summary.json go"})),
          timeout_s(p.declare<double>("timeout_s", 120.0, {.above = 0, .unit = "s", .doc = "give up (exit status 1) after this long"})) {}
  };

  explicit MonitorComponent(runtime::Context& ctx)
      : Component(ctx), params_(ctx.params()), scenario_(planner::loadScenario(params_.scenario)), out_dir_(params_.out_dir) {
    std::filesystem::create_directories(out_dir_);
    // Every input is checked before it can reach the report (NaN in the SVG, null in summary.json) or the
    // verdict: a bad sample is dropped with a warning naming topic and field, and counted.
    subs_.push_back(subscribe(runtime::topics::vehicle_state, [this](const msg::VehicleState& m) {
      if (const auto error = nodes::checkVehicleState(m, nodes::kWorldFrame); !error.empty()) return bad_states_.drop(error);
      const auto p = nodes::fromMsg(m.position());
      seen_.vehicle = p;
      if (seen_.track.empty() || (seen_.track.back() - p).norm() > 0.05) seen_.track.push_back(p);
    }));
    subs_.push_back(subscribe(runtime::topics::obstacles, [this](const msg::ObstacleArray& m) {
      // Drawn with toEllipsoidObstacles at the end, which refuses malformed obstacles: keep the last good array.
      if (const auto error = nodes::checkObstacleArray(m, ""); !error.empty()) {
        spdlog::warn("perception/obstacles: ignoring an array: {}", error);
        return;
      }
      seen_.obstacles = m;
    }));
    // Every answer counts (the report draws each planned path): a deeper queue than the topic's depth 1.
    subs_.push_back(ctx.subscribe<msg::Path>(runtime::topics::path.name, bus::Qos{runtime::topics::path.qos.reliability, runtime::topics::path.qos.durability, 64},
                                             [this](const msg::Path& m) {
                                               if (const auto error = nodes::checkPath(m); !error.empty()) return bad_paths_.drop(error);
                                               seen_.paths.push_back(m);
                                             }));
    subs_.push_back(subscribe(runtime::topics::trajectory, [this](const msg::Trajectory& m) {
      if (const auto error = nodes::checkTrajectory(m); !error.empty()) return bad_trajectories_.drop(error);
      seen_.trajectory = m;
    }));
    subs_.push_back(subscribe(runtime::topics::tracking, [this](const msg::TrackingStatus& m) {
      if (const auto error = nodes::checkTrackingStatus(m); !error.empty()) return bad_statuses_.drop(error);
      seen_.status = m;
    }));
    // Only the map's size and resolution are reported: those are checked (its octree is the planner's business).
    subs_.push_back(subscribe(runtime::topics::octomap, [this](const msg::OccupancyMap& m) {
      if (!(m.resolution() > 0.0) || !std::isfinite(m.resolution()))
        return bad_maps_.drop(fmt::format("resolution is {}, expected a positive finite number of metres", m.resolution()));
      seen_.map = m;
    }));
    subs_.push_back(subscribe(runtime::topics::points, [this](const msg::PointCloud& m) {
      ++seen_.clouds;
      seen_.cloud_points += m.xyz().size() / 3;
    }));
    // Every component's status (keyed: one instance per name), so a deeper queue than the topic's depth 1.
    subs_.push_back(ctx.subscribe<msg::ComponentStatus>(runtime::topics::status.name, bus::Qos::state(64), [this](const msg::ComponentStatus& m) {
      if (m.state() == msg::LifecycleState::LIFECYCLE_FAILED && seen_.failure.empty())
        seen_.failure = bus::printable(m.name()) + ": " + (m.detail().empty() ? std::string("failed") : bus::printable(m.detail()));
    }));
    started_ = last_log_ = std::chrono::steady_clock::now();
    check_ = every(std::chrono::milliseconds(100), [this] { check(); });
  }

  // The report, written once the executor has stopped; a goal not reached fails the component (exit 1).
  void shutdown() override {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    subs_.clear();
    nodes::RunObservations run = toRunObservations(scenario_.name, elapsed, seen_);
    nodes::judgeGoal(run, scenario_, seen_.status && seen_.status->goal_reached(), seen_.vehicle,
                     timed_out_ ? std::optional<double>(params_.timeout_s) : std::nullopt);
    nodes::writeReport(out_dir_, scenario_, run);
    spdlog::info("{}: {} after {:.1f} s; report in {}", scenario_.name, run.goal_reached ? "goal reached" : "goal NOT reached", elapsed,
                 (out_dir_ / "report.html").string());
    std::printf("%s\n", nodes::summaryJson(run).dump().c_str());
    if (!run.goal_reached) throw std::runtime_error("goal not reached: " + run.not_reached_why);
  }

 private:
  void check() {
    // The tracker's claim is checked against the vehicle's true position (the end of a trajectory is not the goal).
    const bool claimed = seen_.status && seen_.status->goal_reached();
    const auto goal = tracker::checkGoal(scenario_.goal, scenario_.goal_radius, seen_.vehicle);
    const bool reached = claimed && goal.reached;
    if (claimed && !goal.reached && !claim_logged_) {
      claim_logged_ = true;
      spdlog::warn("control/tracking says the goal is reached, but {}: not taken as reached", goal.why);
    }
    const auto now = std::chrono::steady_clock::now();
    timed_out_ = now - started_ > std::chrono::duration<double>(params_.timeout_s);
    if (reached || timed_out_) return ctx().requestShutdown();
    if (!seen_.failure.empty()) {
      spdlog::error("component failed: {}", seen_.failure);
      return ctx().requestShutdown();
    }
    if (now - last_log_ > std::chrono::seconds(3)) {
      last_log_ = now;
      spdlog::info("{:.0f} s: {} clouds, {} obstacles, {} paths, progress {:.0f} %, cross-track error {:.3f} m",
                   std::chrono::duration<double>(now - started_).count(), seen_.clouds, seen_.obstacles ? seen_.obstacles->obstacles().size() : 0,
                   seen_.paths.size(), seen_.status ? 100.0 * seen_.status->progress() : 0.0,
                   seen_.status ? seen_.status->cross_track_error() : 0.0);
    }
  }

  const Params params_;
  const planner::Scenario scenario_;
  const std::filesystem::path out_dir_;
  Observations seen_;
  nodes::DroppedSamples bad_states_{"vehicle/state"}, bad_paths_{"planning/path"}, bad_trajectories_{"control/trajectory"},
      bad_statuses_{"control/tracking"}, bad_maps_{"map/octomap", "keeping the last good map"};
  std::chrono::steady_clock::time_point started_, last_log_;
  bool timed_out_ = false, claim_logged_ = false;
  std::vector<bus::Subscription> subs_;
  runtime::Timer check_;
};

}  // namespace

int main(int argc, char** argv) { return runtime::runComponent<MonitorComponent>("monitor", argc, argv); }
