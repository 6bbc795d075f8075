// The monitor's run report built from hand-made observations: no DDS, no files except in a temp dir.
#include "ddsnav/nodes/run_report.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

using namespace ddsnav;

namespace {

planner::Scenario corridor() {
  planner::Scenario s;
  s.name = "corridor";
  s.dimensions = 2;
  s.bounds_min = {0, 0, 0};
  s.bounds_max = {10, 5, 0};
  s.robot_radius = 0.2;
  s.start = {1, 2.5, 0};
  s.goal = {9, 2.5, 0};
  s.goal_radius = 0.3;
  planner::Obstacle box;
  box.type = planner::ObstacleType::Box;
  box.center = {5, 2.5, 0};
  box.size = {1, 1, 0};
  s.obstacles.push_back(box);
  return s;
}

planner::EllipsoidObstacle ellipse(int id, const planner::Vec3& centre) {
  planner::EllipsoidObstacle e;
  e.id = id;
  e.center = centre;
  e.semi_axes = {0.6, 0.4, 0.1};
  e.axes = Eigen::Matrix3d::Identity();
  return e;
}

// A run that reached the goal after one replan.
nodes::RunObservations reachedRun() {
  nodes::RunObservations run;
  run.scenario = "corridor";
  run.goal_reached = true;
  run.elapsed_s = 12.5;
  run.clouds = 40;
  run.cloud_points = 12345;
  run.obstacles = std::vector{ellipse(1, {5, 2.5, 0}), ellipse(2, {7, 1, 0})};
  run.paths.push_back({{{1, 2.5, 0}, {5, 4, 0}, {9, 2.5, 0}}, "rrt", 9.1, 0.25, 700});
  run.paths.push_back({{{1, 2.5, 0}, {5, 1, 0}, {9, 2.5, 0}}, "rrt_star", 8.6, 0.5, 1500});
  run.trajectory = std::vector<planner::Vec3>{{1, 2.5, 0}, {3, 2, 0}, {5, 1.1, 0}, {9, 2.5, 0}};
  run.track = {{1, 2.5, 0}, {2, 2.3, 0}, {4, 1.4, 0}};
  run.tracking = nodes::TrackingSummary{0.04, 0.12, 1.0};
  run.map = nodes::MapSummary{2048, 0.1};
  return run;
}

// A run that heard nothing but a component failure.
nodes::RunObservations failedRun() {
  nodes::RunObservations run;
  run.scenario = "corridor";
  run.goal_reached = false;
  run.elapsed_s = 3.0;
  run.failure = "planner: start in collision";
  return run;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

struct TempDir {
  std::filesystem::path path = std::filesystem::temp_directory_path() / ("ddsnav_run_report_" + std::to_string(::getpid()));
  TempDir() { std::filesystem::remove_all(path); }
  ~TempDir() { std::filesystem::remove_all(path); }
};

}  // namespace

TEST(RunReport, SummaryOfAReachedGoalHasTheLastPlanAndTrackingNumbers) {
  const auto j = nodes::summaryJson(reachedRun());
  EXPECT_EQ(j.at("scenario"), "corridor");
  EXPECT_EQ(j.at("goal_reached"), true);
  EXPECT_DOUBLE_EQ(j.at("elapsed_s").get<double>(), 12.5);
  EXPECT_FALSE(j.contains("failure"));
  EXPECT_EQ(j.at("clouds"), 40);
  EXPECT_EQ(j.at("cloud_points"), 12345);
  EXPECT_EQ(j.at("obstacles"), 2);
  EXPECT_EQ(j.at("plans"), 2);
  EXPECT_EQ(j.at("planner"), "rrt_star");  // the last plan, not the first
  EXPECT_DOUBLE_EQ(j.at("path_cost_m").get<double>(), 8.6);
  EXPECT_DOUBLE_EQ(j.at("plan_time_s").get<double>(), 0.5);
  EXPECT_EQ(j.at("plan_iterations"), 1500);
  EXPECT_EQ(j.at("trajectory_samples"), 4);
  EXPECT_DOUBLE_EQ(j.at("mean_cross_track_error_m").get<double>(), 0.04);
  EXPECT_DOUBLE_EQ(j.at("max_cross_track_error_m").get<double>(), 0.12);
  EXPECT_DOUBLE_EQ(j.at("progress").get<double>(), 1.0);
  EXPECT_EQ(j.at("map_bytes"), 2048);
  EXPECT_DOUBLE_EQ(j.at("map_resolution_m").get<double>(), 0.1);
  EXPECT_EQ(j.size(), 23u);
}

TEST(RunReport, SummaryOfAFailedRunNamesTheFailureAndOmitsWhatNeverArrived) {
  const auto j = nodes::summaryJson(failedRun());
  EXPECT_EQ(j.at("goal_reached"), false);
  EXPECT_EQ(j.at("failure"), "planner: start in collision");
  EXPECT_EQ(j.at("obstacles"), 0);
  EXPECT_EQ(j.at("plans"), 0);
  EXPECT_EQ(j.at("clouds"), 0);
  for (const char* key : {"planner", "path_cost_m", "plan_time_s", "plan_iterations", "trajectory_samples",
                          "mean_cross_track_error_m", "max_cross_track_error_m", "progress", "map_bytes", "map_resolution_m"})
    EXPECT_FALSE(j.contains(key)) << key;
  EXPECT_EQ(j.size(), 14u);
  EXPECT_EQ(j.at("replans"), nlohmann::json::array());
  EXPECT_EQ(j.at("plan_requests"), 0);
}

TEST(RunReport, SvgDrawsEllipsesEveryPathTrajectoryTrackAndLegend) {
  const std::string svg = nodes::reportSvg(corridor(), reachedRun());
  EXPECT_NE(svg.find("<text x='" ), std::string::npos);
  EXPECT_NE(svg.find(">corridor: goal reached</text>"), std::string::npos);
  EXPECT_EQ(count(svg, "class='perceived'"), 2u);
  // Two paths + trajectory + track.
  EXPECT_EQ(count(svg, "<polyline fill='none'"), 4u);
  // Only the replaced plan is dashed, plus the driven track and its legend entry.
  EXPECT_EQ(count(svg, "stroke-dasharray"), 3u);
  // Legend: one entry per labelled line; the replaced plan has none.
  EXPECT_EQ(count(svg, ">planned path</text>"), 1u);
  EXPECT_EQ(count(svg, ">smoothed trajectory</text>"), 1u);
  EXPECT_EQ(count(svg, ">driven track</text>"), 1u);
  // Red: two path lines and one legend line.
  EXPECT_EQ(count(svg, "stroke='#d62728'"), 3u);
  EXPECT_EQ(count(svg, "class='obs'"), 1u);  // the scenario's one true box
}

TEST(RunReport, SvgOfAFailedRunSaysNotReachedAndDrawsNoPaths) {
  const std::string svg = nodes::reportSvg(corridor(), failedRun());
  EXPECT_NE(svg.find(">corridor: goal NOT reached</text>"), std::string::npos);
  EXPECT_EQ(count(svg, "class='perceived'"), 0u);
  EXPECT_EQ(count(svg, "<polyline fill='none'"), 0u);  // the empty track is skipped
  EXPECT_EQ(count(svg, "stroke='#d62728'"), 0u);
}

TEST(RunReport, HtmlEmbedsTheSvgAndTheSummaryNumbers) {
  const auto run = reachedRun();
  const std::string html = nodes::reportHtml(corridor(), run);
  const std::string svg = nodes::reportSvg(corridor(), run);
  EXPECT_EQ(html.rfind("<!doctype html>", 0), 0u);
  EXPECT_NE(html.find("<title>ddsnav demo: corridor</title>"), std::string::npos);
  EXPECT_NE(html.find(svg), std::string::npos);
  EXPECT_NE(html.find("<tr><th>planner</th><td>\"rrt_star\"</td></tr>"), std::string::npos);
  EXPECT_NE(html.find("<tr><th>plan_iterations</th><td>1500</td></tr>"), std::string::npos);
  EXPECT_NE(html.find("<tr><th>map_bytes</th><td>2048</td></tr>"), std::string::npos);
  EXPECT_NE(html.find("<tr><th>goal_reached</th><td>true</td></tr>"), std::string::npos);
  EXPECT_EQ(count(html, "<tr>"), nodes::summaryJson(run).size());
}

TEST(RunReport, WriteReportWritesTheThreeFiles) {
  TempDir tmp;
  const auto dir = tmp.path / "nested" / "out";
  const auto run = reachedRun();
  nodes::writeReport(dir, corridor(), run);
  EXPECT_EQ(nlohmann::json::parse(readFile(dir / "summary.json")), nodes::summaryJson(run));
  EXPECT_EQ(readFile(dir / "report.svg"), nodes::reportSvg(corridor(), run));
  EXPECT_EQ(readFile(dir / "report.html"), nodes::reportHtml(corridor(), run));
}

TEST(RunReport, WriteReportNamesADirectoryItCannotCreate) {
  TempDir tmp;
  std::filesystem::create_directories(tmp.path);
  const auto blocker = tmp.path / "a_file";
  std::ofstream(blocker) << "not a directory";
  const auto dir = blocker / "report";
  try {
    nodes::writeReport(dir, corridor(), failedRun());
    FAIL() << "expected an error for " << dir;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot create report directory " + dir.string()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir));
}

// Issue 13 row 5: the tracker's word is not enough; the vehicle's true position decides, and the report says why.
TEST(RunReport, GoalIsReachedOnlyWhenTheTrueVehicleIsInTheGoalRegion) {
  planner::Scenario world = corridor();
  world.goal = {9, 2.5, 0};
  world.goal_radius = 1.0;
  auto run = reachedRun();
  run.requests = {{1, 0.0, "start"}};
  nodes::judgeGoal(run, world, true, planner::Vec3{8.5, 2.5, 0}, std::nullopt);
  EXPECT_TRUE(run.goal_reached);
  EXPECT_EQ(run.not_reached_why, "");
  ASSERT_TRUE(run.goal_distance_m);
  EXPECT_DOUBLE_EQ(*run.goal_distance_m, 0.5);

  nodes::judgeGoal(run, world, true, planner::Vec3{-29, 2.5, 0}, 120.0);
  EXPECT_FALSE(run.goal_reached);
  EXPECT_EQ(run.not_reached_why, "the tracker reported the goal reached, but the vehicle is 38.00 m from the goal, outside "
                                 "the 1.00 m goal region; timeout_s (120 s) passed");
  auto j = nodes::summaryJson(run);
  EXPECT_EQ(j.at("goal_reached"), false);
  EXPECT_EQ(j.at("not_reached_why"), run.not_reached_why);
  EXPECT_DOUBLE_EQ(j.at("goal_distance_m").get<double>(), 38.0);

  // Issue 9: the true position decides alone; the tracker's silence is recorded, not needed.
  nodes::judgeGoal(run, world, false, planner::Vec3{8.5, 2.5, 0}, std::nullopt);
  EXPECT_TRUE(run.goal_reached);
  EXPECT_FALSE(run.tracker_reported_goal);
  EXPECT_EQ(nodes::summaryJson(run).at("tracker_reported_goal"), false);

  // A scenario whose truth rules the goal out says so first.
  run.infeasible_why = "the goal (9, 2.5) is inside obstacle #1";
  nodes::judgeGoal(run, world, false, planner::Vec3{1, 2.5, 0}, std::nullopt);
  EXPECT_FALSE(run.goal_reached);
  EXPECT_EQ(run.not_reached_why.rfind("the goal (9, 2.5) is inside obstacle #1; the vehicle is 8.00 m", 0), 0u) << run.not_reached_why;
  EXPECT_EQ(nodes::summaryJson(run).at("infeasible"), run.infeasible_why);

  auto failed = failedRun();
  nodes::judgeGoal(failed, world, false, std::nullopt, std::nullopt);
  EXPECT_FALSE(failed.goal_reached);
  EXPECT_EQ(failed.not_reached_why,
            "a component failed (planner: start in collision); no plan was ever requested; no vehicle position was received");
  j = nodes::summaryJson(failed);
  EXPECT_FALSE(j.contains("goal_distance_m"));
  EXPECT_EQ(j.at("not_reached_why"), failed.not_reached_why);

  // A run without a plan request says what the components last said they waited for.
  auto waited = failedRun();
  waited.failure.clear();
  waited.details = {{"tracker", "waiting for the planner's world: no perception/obstacles yet"}, {"sim", "dropped 3 of 9"}};
  nodes::judgeGoal(waited, world, false, planner::Vec3{1, 2.5, 0}, 200.0);
  EXPECT_EQ(waited.not_reached_why,
            "no plan was ever requested (tracker: waiting for the planner's world: no perception/obstacles yet); the vehicle is "
            "8.00 m from the goal, outside the 1.00 m goal region; timeout_s (200 s) passed");
}

// Issue 9: the mission numbers of summary.json.
TEST(RunReport, SummaryCountsReplansByReasonAndCarriesTheTruthNumbers) {
  auto run = reachedRun();
  run.requests = {{1, 0.5, "first plan"},
                  {2, 12.0, "path blocked: trajectory sample at t=3 s (4, 1, 0) is no longer collision free"},
                  {3, 20.5, "path blocked: trajectory sample at t=9 s (7, 2, 0) is no longer collision free"},
                  {4, 31.0, "deviation: cross-track error 2.1 m"},
                  {5, 40.0, ""}};
  run.sim_time_to_goal_s = 45.25;
  run.sim_elapsed_s = 46.0;
  run.min_true_clearance_m = 0.35;
  run.tracked_obstacles_max = 17;
  const auto j = nodes::summaryJson(run);
  EXPECT_EQ(j.at("plan_requests"), 5);
  ASSERT_EQ(j.at("replans").size(), 4u);
  EXPECT_EQ(j.at("replans")[0].at("request_id"), 2);
  EXPECT_DOUBLE_EQ(j.at("replans")[0].at("sim_time_s").get<double>(), 12.0);
  EXPECT_EQ(j.at("replans")[2].at("reason"), "deviation: cross-track error 2.1 m");
  EXPECT_EQ(j.at("replan_reasons"), (nlohmann::json{{"path blocked", 2}, {"deviation", 1}, {"(no reason given)", 1}}));
  EXPECT_DOUBLE_EQ(j.at("sim_time_to_goal_s").get<double>(), 45.25);
  EXPECT_DOUBLE_EQ(j.at("sim_elapsed_s").get<double>(), 46.0);
  EXPECT_DOUBLE_EQ(j.at("min_true_clearance_m").get<double>(), 0.35);
  EXPECT_EQ(j.at("tracked_obstacles_max"), 17);
  EXPECT_EQ(nodes::reasonKind("first plan"), "first plan");
  EXPECT_EQ(nodes::reasonKind("  : x"), "(no reason given)");
  EXPECT_EQ(nodes::reasonKind("trajectory sample at t=13.8 s (14.8, 25.9, 0) is no longer collision free"),
            "trajectory sample at t=# s is no longer collision free");
}

// The first request can be published while the monitor and the tracker still discover each other (r3d_70, 2026-12-06:
// one plan, "0 plan requests"): a path answering a request never heard counts it, with a reason that says so; the
// request heard late (a copy the tracker repeats) gives it its own reason; copies and answers add nothing more.
TEST(RunReport, ARequestKnownOnlyFromItsAnswerIsCounted) {
  std::vector<nodes::PlanRequestSeen> requests;
  nodes::notePathAnswer(requests, 1, 0.4);
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].reason, nodes::kRequestNotHeard);
  nodes::noteRequest(requests, 2, 5.0, "trajectory_blocked: x");
  nodes::notePathAnswer(requests, 2, 5.1);
  nodes::noteRequest(requests, 2, 5.2, "trajectory_blocked: x");  // a copy
  ASSERT_EQ(requests.size(), 2u);
  nodes::noteRequest(requests, 1, 5.3, "start");  // heard late: its reason, in its place
  ASSERT_EQ(requests.size(), 2u);
  EXPECT_EQ(requests[0].request_id, 1u);
  EXPECT_EQ(requests[0].reason, "start");
  EXPECT_DOUBLE_EQ(requests[0].sim_time_s, 0.4);
  EXPECT_EQ(requests[1].request_id, 2u);
  nodes::RunObservations run;
  run.requests = requests;
  const auto summary = nodes::summaryJson(run);
  EXPECT_EQ(summary["plan_requests"], 2);
  EXPECT_EQ(summary["replans"].size(), 1u);
}
