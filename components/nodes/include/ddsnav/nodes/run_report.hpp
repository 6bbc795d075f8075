#pragma once
// The run report ddsnav-monitor writes at the end of a pipeline run: summary.json (the numbers),
// report.svg (world, perceived ellipses, planned paths, trajectory, driven track) and report.html (both
// together). No DDS here: the monitor converts what it heard on the bus into RunObservations.

#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace ddsnav::nodes {

// One path the planner published, in publication order.
struct PlannedPath {
  std::vector<planner::Vec3> states;
  std::string planner;        // planner name as published
  double cost_m = 0.0;        // path length
  double plan_time_s = 0.0;
  std::uint64_t iterations = 0;
};

// The tracker's last status.
struct TrackingSummary {
  double mean_cross_track_error_m = 0.0;
  double max_cross_track_error_m = 0.0;
  double progress = 0.0;  // 0..1 along the trajectory
};

// The last map the mapper published.
struct MapSummary {
  std::size_t bytes = 0;  // size of the serialised octree
  double resolution_m = 0.0;
};

// One planning/request the monitor heard (the first plan and every replan), in order.
struct PlanRequestSeen {
  std::uint32_t request_id = 0;
  double sim_time_s = 0.0;  // simulated seconds since the monitor started
  std::string reason;       // the requester's (msg::PlanRequest::reason); empty when it gave none
};

// The reason given to a request the monitor never heard but saw answered (notePathAnswer).
inline constexpr const char* kRequestNotHeard = "not heard (answered by a path; the monitor was still discovering the requester)";

// The most requests a run keeps (a mission makes tens; each is a few dozen bytes).
inline constexpr std::size_t kMaxRequestsSeen = 1 << 16;

// A planning/request heard: added in request-id order (up to kMaxRequestsSeen). A copy of one already in the list (the tracker repeats its
// first request until a planner answers) is the same plan; one known only from its answer gets its reason.
void noteRequest(std::vector<PlanRequestSeen>& requests, std::uint32_t request_id, double sim_time_s, std::string reason);
// A planning/path answering `request_id`: a request the monitor never heard (the first one can be published while
// the monitor and the tracker still discover each other: r3d_70, 2026-12-06, reported 0 plan requests for its one
// plan) is added with kRequestNotHeard as its reason, so that the plans are counted.
void notePathAnswer(std::vector<PlanRequestSeen>& requests, std::uint32_t request_id, double sim_time_s);

// The first word group of a reason, for counting: "path blocked: trajectory sample at ..." -> "path blocked".
std::string reasonKind(const std::string& reason);

struct RunObservations {
  std::string scenario;   // scenario name
  bool goal_reached = false;     // the vehicle's true position (vehicle/state) was in the scenario's goal region
  bool tracker_reported_goal = false;  // control/tracking said goal_reached (recorded, not needed)
  std::string not_reached_why;  // when not reached: why (timeout, a failure, the vehicle's distance to the goal)
  std::optional<double> goal_distance_m;  // the vehicle's last true position to the goal; none without one
  double elapsed_s = 0.0;       // wall time the monitor watched
  double sim_elapsed_s = 0.0;   // simulated time it watched (what timeout_s counts)
  // Simulated time from the first plan request heard (else the first trajectory) to the first true position
  // inside the goal region; nullopt when the goal was not reached.
  std::optional<double> sim_time_to_goal_s;
  // Ground truth (ground_truth.hpp): the driven track's smallest clearance to the true obstacles and the bounds' faces.
  std::optional<double> min_true_clearance_m;
  std::optional<planner::Vec3> min_true_clearance_at;  // the vehicle's true position there
  std::string min_true_clearance_to;                   // "obstacle" or "bounds" (nodes::closestApproach)
  std::string infeasible_why;   // set when the scenario's truth says the goal cannot be reached at all
  std::vector<PlanRequestSeen> requests;
  std::size_t tracked_obstacles_max = 0;  // the largest perception/obstacles array heard
  std::string failure;    // "component: detail" of the first component that failed; empty when none did
  // Each component's last non-empty status detail (system/status); those starting "waiting for" (what a tracker
  // still waits for before its first request) are named in not_reached_why when no plan was ever requested.
  std::map<std::string, std::string> details;
  std::size_t clouds = 0;
  std::size_t cloud_points = 0;
  // Perception's last obstacle array; nullopt when none arrived (reported as 0 obstacles).
  std::optional<std::vector<planner::EllipsoidObstacle>> obstacles;
  std::vector<PlannedPath> paths;                         // every plan, the last one is the current one
  std::optional<std::vector<planner::Vec3>> trajectory;   // positions of the last smoothed trajectory
  std::vector<planner::Vec3> track;                       // where the vehicle actually drove
  std::optional<TrackingSummary> tracking;
  std::optional<MapSummary> map;
};

// The monitor's verdict on a run: the goal is reached when the vehicle's true position (vehicle/state, the
// simulator's) is in the scenario's goal region (tracker::checkGoal) — the tracker's claim alone is not
// enough, and not needed. Otherwise `why` says what happened: the scenario's infeasibility (run.infeasible_why),
// the first component failure, the vehicle's distance to the goal (naming the tracker's claim when it made
// one), and whether timeout_s ran out. Fills goal_reached, tracker_reported_goal, not_reached_why and
// goal_distance_m of `run`.
void judgeGoal(RunObservations& run, const planner::Scenario& scenario, bool tracker_reported,
               const std::optional<planner::Vec3>& true_position, std::optional<double> timed_out_after_s);

// The summary.json content (keys in the order nlohmann::json keeps them: sorted).
nlohmann::json summaryJson(const RunObservations& run);

// report.svg: `world` gives the true geometry, start and goal; the title is the scenario name and outcome.
std::string reportSvg(const planner::Scenario& world, const RunObservations& run);

// report.html: the SVG above with a table of the summary numbers.
std::string reportHtml(const planner::Scenario& world, const RunObservations& run);

// Creates `dir` if needed and writes summary.json, report.svg and report.html into it. Throws
// std::runtime_error naming the directory or file that cannot be created or written.
void writeReport(const std::filesystem::path& dir, const planner::Scenario& world, const RunObservations& run);

}  // namespace ddsnav::nodes
