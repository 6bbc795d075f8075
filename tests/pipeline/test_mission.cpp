// Issue 9's missions on simulated time: `ddsnav launch configs/launch/demo.yaml --set speed=4` on a 3-D and a
// 2-D world other than the yard must reach the goal (judged by the monitor on the true vehicle position) with a
// positive true clearance, within a bounded wall time. Domains 140, 141 and 142 (the mission helper's 240-244 lie
// beyond DDS's 0..232).
//
// History: both needed issue 9 part B (the fused world model and replanning that converges); before it landed
// neither reached its goal (gart_terrain_3d: perception tiles the hills with thousands of tracks; the cluttered
// field: the vehicle stalls after its eighth plan), and were DISABLED_ until the pacing below.
// The cluttered field after the mission2d branch's replanning work (2026-12-01, docs/benchmarks/mission.md):
// of 9 runs at load 10-37 across the branch's commits, 5 reached the goal and 3 of those without touching an
// obstacle; the failures were obstacles seen late (true clearance -0.05 to -0.32 m, then every start in
// collision) and the 2.5 x oracle timeout. Not reliable enough yet for CI under ctest -j2.
// 2026-12-02 (branch mission, docs/benchmarks/mission.md): both reach the goal now (gart_cluttered_2d 3 of 3,
// gart_terrain_3d 2 of 2 after the executor fix), but with a negative true clearance (the cluttered field
// -0.04 to -0.21 m, the terrain -8.7 / -13.3 m through a hill), which this test rightly refuses: still disabled.
// 2026-12-02 evening: with the sensor view (docs/world-model.md) the terrain kept a positive clearance in 15 of 15
// runs at speed 2, but at speed 4 one of two grazed (-0.47 m) and 4 of 15 timed out; the cluttered field passed 3 of
// 3 alone and 2 of 3 beside a busy core (-0.07 m). Still disabled then.
// 2026-12-02 night: what a loaded machine changed was how much simulated time passed during each component's
// work. The simulator now holds its clock while a process lags more than 0.3 s (docs/simulator.md, "Pacing"),
// so load makes a run slower in wall time only: beside a busy-loop core the cluttered field passed 3 of 3 and the
// terrain 2 of 2. The terrain test is enabled (7 of 7 runs at speed 4 since, clearance +0.18 to +0.81 m); the
// wall-time bound allows for the slower clock (and a sanitizer's time factor). The cluttered field stays disabled:
// of 8 paced runs 2 grazed the circle at (75, 88) (-0.05, -0.17 m) on its side the scanner had not yet seen — a
// plan hugging the seen arc where the unseen part bulges out (docs/benchmarks/mission.md). With the 1.0 m room and
// the planner's unknown margin it passed 8 of 8 alone but 6 of 8 beside a busy-loop core (22:41-22:48): load still
// matters somewhat — the tracker's replan checks and smoothing ran on std::async, which the progress reports
// (executor and runtime::Worker only) did not cover. With them holding a runtime::PendingWork: 8 of 8 beside the
// busy core (22:50-22:54). Still disabled until more runs say it is reliable under ctest -j2.
// 2026-12-03: enabled. At speed 4 the cluttered field reached its goal with a positive true clearance in 8 of 8
// mission-benchmark runs of the session (0.17-0.94 m; 2-D maps now reach the scanner's whole range, a stale
// retry no longer drops a fresh trajectory) and this test passed 3 of 3 beside a busy-loop core. (At speed 1,
// 1 of 2 benchmark runs grazed a circle, -0.53 m, after a deviation: docs/benchmarks/mission.md.)

#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

using namespace ddsnav;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

// How many times slower than the plain build this run is (scripts/sanitize sets DDSNAV_TEST_TIME_FACTOR).
double timeFactor() {
  const char* text = std::getenv("DDSNAV_TEST_TIME_FACTOR");
  const double factor = text ? std::atof(text) : 1.0;
  return factor >= 1.0 && factor <= 100.0 ? factor : 1.0;
}

// Runs the demo launch file on `scenario` at speed 4 with a simulated timeout, and returns summary.json.
nlohmann::json runMission(int domain, const std::string& scenario, double timeout_s, std::string& log) {
  harness::Harness h(domain);
  const fs::path out = fs::temp_directory_path() / ("ddsnav_mission_" + std::to_string(domain) + "_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string source = DDSNAV_SOURCE_DIR;
  h.start({.name = "launcher",
           .command = "ddsnav-launch",
           .args = {source + "/configs/launch/demo.yaml", "--domain", std::to_string(domain), "--set",
                    "scenario=" + source + "/configs/scenarios/" + scenario, "--set", "speed=4", "--set",
                    "timeout_s=" + std::to_string(static_cast<int>(timeout_s)), "--set", "out=" + out.string()}});
  // The monitor ends the run at the goal or after timeout_s of simulated time (a quarter of it in wall time
  // at speed 4 if the machine keeps up; the simulator's pacing slows the clock on a loaded one, down to real
  // time and below); this bound only guards against a run that never ends.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>((timeout_s + 60) * timeFactor());
  while (h.running("launcher") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(200ms);
  const bool ended = !h.running("launcher");
  h.stop("launcher");
  log = h.log("launcher");
  if (!ended) return {{"error", "the run did not end within its wall-time bound"}};
  std::ifstream file(out / "summary.json");
  auto summary = nlohmann::json::parse(file, nullptr, /*allow_exceptions=*/false);
  if (!summary.is_object()) return nlohmann::json{{"error", "no summary.json in " + out.string()}};
  // A run that failed keeps its report, map and recording for a look (named in the summary the test prints).
  if (summary.value("goal_reached", false) && summary.value("min_true_clearance_m", -1.0) > 0.0) fs::remove_all(out);
  else summary["kept_run_directory"] = out.string();
  return summary;
}

void expectReached(const nlohmann::json& summary, const std::string& log) {
  ASSERT_FALSE(summary.contains("error")) << summary.dump(2) << "\n" << log;
  // The components' last words say why a run failed (CI keeps only this output).
  EXPECT_TRUE(summary.value("goal_reached", false)) << summary.dump(2) << "\n... the launcher's log, last part:\n"
                                                    << log.substr(log.size() > 12000 ? log.size() - 12000 : 0);
  EXPECT_GT(summary.value("min_true_clearance_m", -1.0), 0.0) << summary.dump(2);
  EXPECT_TRUE(summary.contains("sim_time_to_goal_s")) << summary.dump(2);
  EXPECT_GE(summary.value("plan_requests", 0), 1) << summary.dump(2);
}

}  // namespace

TEST(Mission, Terrain3dReachesTheGoalOnSimulatedTime) {
  std::string log;
  const auto summary = runMission(140, "gart_terrain_3d.yaml", 240, log);
  expectReached(summary, log);
  EXPECT_LE(summary.value("tracked_obstacles_max", 1 << 30), 2000) << summary.dump(2);
}

TEST(Mission, ClutteredField2dReachesTheGoalOnSimulatedTime) {
  std::string log;
  expectReached(runMission(141, "gart_cluttered_2d.yaml", 200, log), log);
}

// Issue 9, bad input: a run that ends without a single plan request says why. Without perception the tracker's fused
// world never exists (no obstacles, no map: the mapper is left out too), so the tracker never asks; the monitor's
// report names what it waited for instead of only the timeout (a CI run once ended with plan_requests 0 and no reason).
TEST(Mission, ARunWithoutAPlanRequestSaysWhatTheTrackerWaitedFor) {
  harness::Harness h(142);
  const fs::path dir = fs::temp_directory_path() / ("ddsnav_no_perception_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string scenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";
  {
    std::ofstream launch(dir / "launch.yaml");
    launch << "name: no_perception\ndds: fastdds\nshutdown_timeout_s: 5\nprocesses:\n"
           << "  - {name: monitor, command: ddsnav-monitor, required: true, params: {scenario: \"" << scenario << "\", out_dir: \""
           << (dir / "out").string() << "\", timeout_s: \"12\", clock: topic}}\n"
           << "  - {name: sim, command: ddsnav-sim, params: {scenario: \"" << scenario << "\", speed: \"4\"}}\n"
           << "  - {name: planner, command: ddsnav-planner, dds: cyclonedds, params: {scenario: \"" << scenario
           << "\", world: fused, clock: topic}}\n"
           << "  - {name: tracker, command: ddsnav-tracker, after: [planner, sim, monitor], params: {scenario: \"" << scenario
           << "\", world: fused, clock: topic}}\n";
  }
  h.start({.name = "launcher", .command = "ddsnav-launch", .args = {(dir / "launch.yaml").string(), "--domain", "142"}});
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(90 * timeFactor());
  while (h.running("launcher") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(200ms);
  const bool ended = !h.running("launcher");
  h.stop("launcher");
  ASSERT_TRUE(ended) << h.log("launcher");
  std::ifstream file(dir / "out" / "summary.json");
  const auto summary = nlohmann::json::parse(file, nullptr, /*allow_exceptions=*/false);
  fs::remove_all(dir);
  ASSERT_TRUE(summary.is_object()) << h.log("launcher");
  EXPECT_FALSE(summary.value("goal_reached", true)) << summary.dump(2);
  EXPECT_EQ(summary.value("plan_requests", -1), 0) << summary.dump(2);
  // (The runtime may append a queue's drop count to a status detail: the reason is matched up to there.)
  EXPECT_NE(summary.value("not_reached_why", std::string())
                .find("no plan was ever requested (tracker: waiting for the planner's world: no perception/obstacles yet"),
            std::string::npos)
      << summary.dump(2);
}
