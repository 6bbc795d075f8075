#include "ddsnav/nodes/run_report.hpp"

#include <ddsnav/planner/svg.hpp>
#include <ddsnav/tracker/mission.hpp>

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include <fstream>
#include <stdexcept>
#include <system_error>

namespace ddsnav::nodes {

namespace {

void writeFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

void judgeGoal(RunObservations& run, const planner::Scenario& scenario, bool tracker_reported,
               const std::optional<planner::Vec3>& true_position, std::optional<double> timed_out_after_s) {
  const tracker::GoalCheck goal = tracker::checkGoal(scenario.goal, scenario.goal_radius, true_position);
  run.goal_reached = goal.reached;
  run.tracker_reported_goal = tracker_reported;
  run.goal_distance_m.reset();
  if (true_position && std::isfinite(goal.distance)) run.goal_distance_m = goal.distance;
  run.not_reached_why.clear();
  if (run.goal_reached) return;
  std::string why;
  if (!run.infeasible_why.empty()) why = run.infeasible_why + "; ";
  if (!run.failure.empty()) why += "a component failed (" + run.failure + "); ";
  if (run.requests.empty()) {
    // What the components said they were waiting for (a tracker that never asked names it); other details (a
    // queue's drop count, say) are no reason.
    std::string said;
    for (const auto& [name, detail] : run.details)
      if (detail.starts_with("waiting for")) said += (said.empty() ? "" : "; ") + name + ": " + detail;
    why += "no plan was ever requested" + (said.empty() ? std::string() : " (" + said + ")") + "; ";
  }
  if (tracker_reported) why += "the tracker reported the goal reached, but ";
  why += goal.why;
  if (timed_out_after_s) why += fmt::format("; timeout_s ({:g} s) passed", *timed_out_after_s);
  run.not_reached_why = std::move(why);
}

void noteRequest(std::vector<PlanRequestSeen>& requests, std::uint32_t request_id, double sim_time_s, std::string reason) {
  const auto at = std::find_if(requests.begin(), requests.end(), [&](const PlanRequestSeen& r) { return r.request_id >= request_id; });
  if (at != requests.end() && at->request_id == request_id) {
    if (at->reason == kRequestNotHeard) at->reason = std::move(reason);
    return;
  }
  if (requests.size() >= kMaxRequestsSeen) return;  // a flood of made-up ids is not kept
  requests.insert(at, PlanRequestSeen{request_id, sim_time_s, std::move(reason)});
}

void notePathAnswer(std::vector<PlanRequestSeen>& requests, std::uint32_t request_id, double sim_time_s) {
  noteRequest(requests, request_id, sim_time_s, kRequestNotHeard);  // a request heard keeps its reason
}

std::string reasonKind(const std::string& reason) {
  // "kind: detail" gives the kind; a reason without one is its own kind with the numbers and the
  // parenthesised places taken out, so that "sample at t=8.3 s (14, 27, 0) blocked" and the same at another
  // place count together.
  const auto colon = reason.find(':');
  std::string kind;
  int depth = 0;
  bool in_number = false;
  for (char c : reason.substr(0, colon)) {
    if (c == '(') ++depth;
    if (depth == 0) {
      const bool digit = std::isdigit(static_cast<unsigned char>(c)) || ((c == '.' || c == '-') && in_number);
      if (digit && !in_number) kind += '#';
      in_number = digit;
      if (!digit && !(c == ' ' && (kind.empty() || kind.back() == ' '))) kind += c;
    }
    if (c == ')' && depth > 0) --depth;
  }
  while (!kind.empty() && kind.back() == ' ') kind.pop_back();
  return kind.empty() ? std::string("(no reason given)") : kind;
}

nlohmann::json summaryJson(const RunObservations& run) {
  nlohmann::json summary;
  summary["scenario"] = run.scenario;
  summary["goal_reached"] = run.goal_reached;
  if (!run.goal_reached && !run.not_reached_why.empty()) summary["not_reached_why"] = run.not_reached_why;
  if (run.goal_distance_m) summary["goal_distance_m"] = *run.goal_distance_m;
  summary["elapsed_s"] = run.elapsed_s;
  summary["sim_elapsed_s"] = run.sim_elapsed_s;
  summary["tracker_reported_goal"] = run.tracker_reported_goal;
  if (run.sim_time_to_goal_s) summary["sim_time_to_goal_s"] = *run.sim_time_to_goal_s;
  if (run.min_true_clearance_m) summary["min_true_clearance_m"] = *run.min_true_clearance_m;
  if (run.min_true_clearance_at)
    summary["min_true_clearance_at"] = {run.min_true_clearance_at->x(), run.min_true_clearance_at->y(), run.min_true_clearance_at->z()};
  if (!run.min_true_clearance_to.empty()) summary["min_true_clearance_to"] = run.min_true_clearance_to;
  if (!run.infeasible_why.empty()) summary["infeasible"] = run.infeasible_why;
  summary["tracked_obstacles_max"] = run.tracked_obstacles_max;
  // Every request after the first is a replan; each with its reason, and the count per kind of reason.
  nlohmann::json replans = nlohmann::json::array();
  nlohmann::json reasons = nlohmann::json::object();
  for (std::size_t i = 1; i < run.requests.size(); ++i) {
    const auto& r = run.requests[i];
    replans.push_back({{"request_id", r.request_id}, {"sim_time_s", r.sim_time_s}, {"reason", r.reason}});
    const std::string kind = reasonKind(r.reason);
    reasons[kind] = reasons.value(kind, 0) + 1;
  }
  summary["plan_requests"] = run.requests.size();
  summary["replans"] = replans;
  summary["replan_reasons"] = reasons;
  if (!run.failure.empty()) summary["failure"] = run.failure;
  summary["clouds"] = run.clouds;
  summary["cloud_points"] = run.cloud_points;
  summary["obstacles"] = run.obstacles ? run.obstacles->size() : 0;
  summary["plans"] = run.paths.size();
  if (!run.paths.empty()) {
    const auto& p = run.paths.back();
    summary["planner"] = p.planner;
    summary["path_cost_m"] = p.cost_m;
    summary["plan_time_s"] = p.plan_time_s;
    summary["plan_iterations"] = p.iterations;
  }
  if (run.trajectory) summary["trajectory_samples"] = run.trajectory->size();
  if (run.tracking) {
    summary["mean_cross_track_error_m"] = run.tracking->mean_cross_track_error_m;
    summary["max_cross_track_error_m"] = run.tracking->max_cross_track_error_m;
    summary["progress"] = run.tracking->progress;
  }
  if (run.map) {
    summary["map_bytes"] = run.map->bytes;
    summary["map_resolution_m"] = run.map->resolution_m;
  }
  return summary;
}

std::string reportSvg(const planner::Scenario& world, const RunObservations& run) {
  planner::SvgScene scene;
  scene.scenario = &world;
  scene.title = run.scenario + (run.goal_reached ? ": goal reached" : ": goal NOT reached");
  if (run.obstacles) scene.ellipses = *run.obstacles;
  // Every plan in red; the ones a replan replaced are thin and dashed, only the last one is in the legend.
  for (std::size_t i = 0; i < run.paths.size(); ++i) {
    const bool last = i + 1 == run.paths.size();
    planner::SvgPolyline line;
    line.points = run.paths[i].states;
    line.colour = "#d62728";
    line.width_px = last ? 2.0 : 1.0;
    line.dashed = !last;
    line.label = last ? "planned path" : "";
    scene.polylines.push_back(std::move(line));
  }
  if (run.trajectory) {
    planner::SvgPolyline line;
    line.points = *run.trajectory;
    line.colour = "#2ca02c";
    line.width_px = 2.0;
    line.label = "smoothed trajectory";
    scene.polylines.push_back(std::move(line));
  }
  scene.polylines.push_back({run.track, "#1f77b4", 2.0, true, "driven track"});
  return planner::renderSvg(scene, 900);
}

std::string reportHtml(const planner::Scenario& world, const RunObservations& run) {
  const std::string svg = reportSvg(world, run);
  const nlohmann::json summary = summaryJson(run);  // named: items() of a temporary would dangle in the loop
  std::string rows;
  for (const auto& [key, value] : summary.items())
    rows += "<tr><th>" + key + "</th><td>" + value.dump() + "</td></tr>\n";
  return "<!doctype html><html><head><meta charset='utf-8'><title>ddsnav demo: " + run.scenario +
         "</title><style>body{font-family:sans-serif;margin:2em}th{text-align:left;padding-right:2em}"
         "</style></head><body><h1>ddsnav demo: " + run.scenario + "</h1>\n" + svg +
         "<p>Grey: the world's true obstacles. Orange: the ellipses perception reported (probability bound "
         "from the obstacle message). Red: planned paths (dashed: replaced by a replan).</p>\n<table>\n" + rows +
         "</table></body></html>\n";
}

void writeReport(const std::filesystem::path& dir, const planner::Scenario& world, const RunObservations& run) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error("cannot create report directory " + dir.string() + ": " + error.message());
  writeFile(dir / "summary.json", summaryJson(run).dump(2) + "\n");
  writeFile(dir / "report.svg", reportSvg(world, run));
  writeFile(dir / "report.html", reportHtml(world, run));
}

}  // namespace ddsnav::nodes
