#include "ddsnav/nodes/run_report.hpp"

#include <ddsnav/planner/svg.hpp>
#include <ddsnav/tracker/mission.hpp>

#include <spdlog/fmt/fmt.h>

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
  run.goal_reached = tracker_reported && goal.reached;
  run.goal_distance_m.reset();
  if (true_position && std::isfinite(goal.distance)) run.goal_distance_m = goal.distance;
  run.not_reached_why.clear();
  if (run.goal_reached) return;
  std::string why;
  if (!run.failure.empty()) why = "a component failed (" + run.failure + "); ";
  if (tracker_reported) why += "the tracker reported the goal reached, but ";
  why += goal.reached ? std::string("the tracker did not report the goal reached") : goal.why;
  if (timed_out_after_s) why += fmt::format("; timeout_s ({:g} s) passed", *timed_out_after_s);
  run.not_reached_why = std::move(why);
}

nlohmann::json summaryJson(const RunObservations& run) {
  nlohmann::json summary;
  summary["scenario"] = run.scenario;
  summary["goal_reached"] = run.goal_reached;
  if (!run.goal_reached && !run.not_reached_why.empty()) summary["not_reached_why"] = run.not_reached_why;
  if (run.goal_distance_m) summary["goal_distance_m"] = *run.goal_distance_m;
  summary["elapsed_s"] = run.elapsed_s;
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
