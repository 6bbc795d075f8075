// ddsnav-plan end to end: one JSON line with the documented fields, an SVG, determinism, and a clear
// error with exit status 2 for every kind of bad input.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;

struct CliRun {
  int status = -1;
  std::string out, err;
};

const std::string kScenarios = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/";

class PlanCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ddsnav_plan_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  CliRun plan(const std::string& args) { return run(DDSNAV_PLAN_BINARY, args); }
  CliRun bench(const std::string& args) { return run(DDSNAV_BENCH_BINARY, args); }

  CliRun run(const std::string& binary, const std::string& args) {
    const fs::path out = dir_ / "stdout", err = dir_ / "stderr";
    const std::string command = "'" + binary + "' " + args + " >'" + out.string() + "' 2>'" + err.string() + "'";
    const int raw = std::system(command.c_str());
    CliRun r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
  }

  // A copy of demo_2d.yaml with one line replaced (the line starting with `key:`).
  std::string variant(const std::string& key, const std::string& line) {
    std::ifstream in(kScenarios + "demo_2d.yaml");
    std::string text, l;
    while (std::getline(in, l)) text += (l.rfind(key + ":", 0) == 0 ? line : l) + "\n";
    const fs::path p = dir_ / (key + ".yaml");
    std::ofstream(p) << text;
    return p.string();
  }

  void expectError(const std::string& args, const std::string& pattern) {
    const CliRun r = plan(args);
    EXPECT_EQ(r.status, 2) << args;
    EXPECT_TRUE(std::regex_search(r.err, std::regex(pattern))) << args << "\nstderr: " << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }

  fs::path dir_;
};

TEST_F(PlanCli, JsonIsOneLineWithEveryField) {
  const CliRun r = plan("--scenario " + kScenarios + "demo_2d.yaml --planner rrtstar --seed 4 --json --svg " + (dir_ / "run.svg").string());
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"scenario", "planner", "seed", "solved", "exact", "time_s", "iterations", "vertices", "cost", "pous",
                          "por", "path", "fdc", "fgc", "coverage", "growth", "validity_checks", "kinodynamic", "rewires"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["planner"], "rrtstar");
  EXPECT_EQ(j["seed"], 4);
  EXPECT_TRUE(j["solved"].get<bool>());
  EXPECT_FALSE(j["kinodynamic"].get<bool>());
  for (const auto& state : j["path"]) EXPECT_EQ(state.size(), 3u);  // [x, y, theta]
  EXPECT_NE(slurp(dir_ / "run.svg").find("<svg"), std::string::npos);
}

TEST_F(PlanCli, ThreeDimensionalStatesCarryZ) {
  const CliRun r = plan("--scenario " + kScenarios + "gart_terrain_3d.yaml --planner rrt --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_FALSE(j["path"].empty());
  for (const auto& state : j["path"]) EXPECT_EQ(state.size(), 4u);  // [x, y, z, theta]
}

TEST_F(PlanCli, SameSeedSamePath) {
  const std::string args = "--scenario " + kScenarios + "stunnel_small_0.5.yaml --planner rrt --kinodynamic --seed 9 --json";
  const auto a = nlohmann::json::parse(plan(args).out), b = nlohmann::json::parse(plan(args).out);
  EXPECT_EQ(a["path"].dump(), b["path"].dump());
  EXPECT_EQ(a["iterations"], b["iterations"]);
  EXPECT_TRUE(a["kinodynamic"].get<bool>());
}

TEST_F(PlanCli, BadInputExitsWithStatus2AndSaysWhy) {
  const std::string demo = "--scenario " + kScenarios + "demo_2d.yaml";
  expectError(demo + " --planner astar", "unknown planner 'astar' \\(known: .*rrtstar");
  expectError(demo + " --planner rrt --time-limit 0", "--time-limit must be a positive");
  expectError(demo + " --planner rrt --time-limit nan", "--time-limit must be a positive");
  expectError(demo + " --planner rrt --max-iterations 0", "--max-iterations must be positive");
  expectError("--scenario " + (dir_ / "missing.yaml").string() + " --planner rrt", "missing.yaml: key '<file>': cannot open");
  expectError("--scenario " + variant("start", "start: [11, 10]") + " --planner rrt", "start .* is in collision");
  expectError("--scenario " + variant("goal", "goal: [60, 10]") + " --planner rrt", "goal.yaml:[0-9]+: key 'goal': outside bounds");
  expectError("--scenario " + variant("bounds", "bounds: {min: [0, 0], max: [40, 0]}") + " --planner rrt", "degenerate bounds");
  expectError("--scenario " + variant("robot_radius", "robot_radius: .nan") + " --planner rrt",
              "robot_radius.yaml:[0-9]+: key 'robot_radius': expected a finite number");
  expectError("--scenario " + variant("vehicle", "") + " --planner rrt --kinodynamic", "--kinodynamic needs a 'vehicle' block");
}

TEST_F(PlanCli, OptionsAreValidatedWithPlannerOptionAndRange) {
  const std::string demo = "--scenario " + kScenarios + "demo_2d.yaml";
  expectError(demo + " --planner gart --option k_nearest=0", "planner gart, option k_nearest: expected an integer in \\[1, 1000\\], got '0'");
  expectError(demo + " --planner gart --option rewire=perhaps", "option rewire: expected true or false");
  expectError(demo + " --planner gart --option rewire_factor=2", "planner gart has no option 'rewire_factor'");
  expectError(demo + " --planner rrt --option goal_bias=0.1", "planner rrt has no option 'goal_bias' \\(it has no options\\)");
  expectError(demo + " --planner lirrt --option turn_steps", "not of the form name=value");
  const CliRun r = plan(demo + " --planner rrtstar --option rewire_factor=3 --option goal_bias=0.2 --json --tree-metrics");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["tree_metrics"].get<bool>());
  EXPECT_TRUE(j["coverage"].is_number());
  const CliRun live = plan(demo + " --planner rrtstar --json");
  EXPECT_TRUE(nlohmann::json::parse(live.out)["coverage"].is_null());  // metrics only when asked
}

// gart-lazy's options from both front ends (issue 10, item 4): set, refused out of range naming planner,
// option and range, and refused on a planner without them. The library test (test_request_bounds.cpp)
// walks every option; here the command lines carry them.
TEST_F(PlanCli, GartLazyOptionsFromPlanAndBench) {
  const std::string demo = "--scenario " + kScenarios + "demo_2d.yaml";
  expectError(demo + " --planner gart-lazy --option restart_patience=-1",
              "planner gart-lazy, option restart_patience: expected an integer in \\[0, 100000000\\], got '-1'");
  expectError(demo + " --planner gart-lazy --option explore_event1=maybe",
              "planner gart-lazy, option explore_event1: expected true or false, got 'maybe'");
  expectError(demo + " --planner gart-lazy --option explore_event1_budget=256",
              "planner gart-lazy, option explore_event1_budget: expected an integer in \\[0, 255\\], got '256'");
  expectError(demo + " --planner rrt --kinodynamic --option explore_event1_budget=0", "planner rrt has no option 'explore_event1_budget'");
  const CliRun ok = plan(demo + " --planner gart-lazy --option explore_event1_budget=0 --option attraction_patience=30 --json");
  ASSERT_EQ(ok.status, 0) << ok.err;
  EXPECT_TRUE(nlohmann::json::parse(ok.out)["solved"].get<bool>());

  const std::string grid = "--scenarios " + kScenarios + "demo_2d.yaml --seeds 1 --time-limit 5 --out '" + (dir_ / "grid").string() + "'";
  const CliRun bad = bench(grid + " --planners 'gart-lazy{attraction_progress=-0.5}'");
  EXPECT_NE(bad.status, 0);
  // The bench logs its error line through spdlog (stdout).
  EXPECT_NE((bad.out + bad.err).find("planner gart-lazy, option attraction_progress: expected a number in [0, 1000]"), std::string::npos)
      << bad.out << bad.err;
  const CliRun foreign = bench(grid + " --planners rrt,gart-lazy --option explore_field=false");
  EXPECT_NE(foreign.status, 0);
  EXPECT_NE((foreign.out + foreign.err).find("planner rrt has no option 'explore_field'"), std::string::npos) << foreign.out << foreign.err;
  const CliRun good = bench(grid + " --planners 'gart-lazy{explore_event1_budget=0,k_nearest=5}' --option explore_field=false");
  ASSERT_EQ(good.status, 0) << good.err;
  const std::string csv = slurp(dir_ / "grid" / "runs.csv");
  EXPECT_NE(csv.find("gart-lazy{explore_event1_budget=0,k_nearest=5}"), std::string::npos) << csv;
}

// Issue 13 rows 2 and 8: bounds of 1e15 ignored --time-limit, bounds of 1e200 crashed gart.
TEST_F(PlanCli, HugeBoundsAreAnError) {
  for (const char* size : {"1e15", "1e200"}) {
    const std::string file = variant("bounds", std::string("bounds: {min: [0, 0], max: [") + size + ", " + size + "]}");
    expectError("--scenario " + file + " --planner gart --time-limit 1 --tree-metrics", "must be within");
  }
}

TEST_F(PlanCli, NoPathEndsAtTheLimitUnsolved) {
  const fs::path walled = dir_ / "walled.yaml";
  std::ofstream(walled) << "dimensions: 2\nbounds: {min: [0, 0], max: [20, 20]}\nstart: [2, 2]\ngoal: [15, 15]\ngoal_radius: 0.5\n"
                           "obstacles:\n  - {type: box, min: [10, 0], max: [11, 20]}\n";
  const CliRun r = plan("--scenario " + walled.string() + " --planner rrt --time-limit 0.2 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_FALSE(j["solved"].get<bool>());
  EXPECT_TRUE(j["path"].empty());
  EXPECT_TRUE(j["cost"].is_null());
  EXPECT_GE(j["time_s"].get<double>(), 0.2);
}

}  // namespace
