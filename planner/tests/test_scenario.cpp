// Scenario parsing: the documented example, the shipped scenarios, and every kind of bad input, each
// error naming the file, the line and the key.
#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/scenario.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace ddsnav::planner {
namespace {

const char* kHeader2d =
    "name: t\n"
    "dimensions: 2\n"
    "bounds: {min: [0, 0], max: [110, 110]}\n"
    "robot_radius: 0.5\n"
    "start: [5, 5]\n"
    "goal: [100, 100]\n"
    "goal_radius: 2.0\n";

// Parses `text`, expects a ScenarioError whose message contains "<file>:<line>: key '<key>'" and `detail`.
void expectError(const std::string& text, int line, const std::string& key, const std::string& detail = "") {
  try {
    parseScenario(text, "bad.yaml");
    ADD_FAILURE() << "accepted:\n" << text;
  } catch (const ScenarioError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bad.yaml:" + std::to_string(line) + ": key '" + key + "'"), std::string::npos) << what;
    EXPECT_NE(what.find(detail), std::string::npos) << what;
  }
}

// The example of scenario-format.md as written (2-D, vz_max in the vehicle block), minus its hill: the
// format's rules make a hill 3-D only (HillIn2DAndDimensionMismatches checks that error).
TEST(Scenario, ParsesTheDocumentedExample) {
  const std::string text = std::string(kHeader2d) +
                           "vehicle:\n  model: unicycle\n  v_max: 5.0\n  omega_max: 0.628\n  vz_max: 2.0\n  dt: 1.0\n"
                           "obstacles:\n"
                           "  - {type: box, min: [10, 10], max: [20, 30]}\n"
                           "  - {type: box, center: [50, 50], size: [10, 4], yaw: 0.3}\n"
                           "  - {type: sphere, center: [70, 20], radius: 5}\n"
                           "  - {type: ellipsoid, center: [30, 80], semi_axes: [8, 3], yaw: 1.0}\n";
  const Scenario s = parseScenario(text, "example.yaml");
  EXPECT_EQ(s.name, "t");
  EXPECT_EQ(s.source, "example.yaml");
  EXPECT_EQ(s.dimensions, 2);
  EXPECT_EQ(s.bounds_max, Vec3(110, 110, 0));
  EXPECT_DOUBLE_EQ(s.robot_radius, 0.5);
  EXPECT_FALSE(s.start_heading.has_value());
  ASSERT_TRUE(s.vehicle.has_value());
  EXPECT_DOUBLE_EQ(s.vehicle->omega_max, 0.628);
  EXPECT_DOUBLE_EQ(s.vehicle->vz_max, 0.0);  // accepted, no effect in 2-D
  ASSERT_EQ(s.obstacles.size(), 4u);
  // {min, max} becomes centre + size + yaw 0.
  EXPECT_EQ(s.obstacles[0].center, Vec3(15, 20, 0));
  EXPECT_EQ(s.obstacles[0].size, Vec3(10, 20, 0));
  EXPECT_DOUBLE_EQ(s.obstacles[1].yaw, 0.3);
  EXPECT_DOUBLE_EQ(s.obstacles[2].radius, 5);
  EXPECT_EQ(s.obstacles[3].semi_axes, Vec3(8, 3, 0));
}

TEST(Scenario, StartHeadingAnd3DHill) {
  const Scenario two = parseScenario(std::string(kHeader2d).replace(std::string(kHeader2d).find("[5, 5]"), 6, "[5, 5, 0.7]"));
  ASSERT_TRUE(two.start_heading.has_value());
  EXPECT_DOUBLE_EQ(*two.start_heading, 0.7);
  const Scenario three = parseScenario(
      "dimensions: 3\nbounds: {min: [0, 0, 0], max: [10, 10, 10]}\nstart: [1, 1, 1]\ngoal: [9, 9, 9]\ngoal_radius: 1\n"
      "obstacles:\n  - {type: hill, center: [5, 5], height: 4, sigma: 2}\n");
  ASSERT_EQ(three.obstacles.size(), 1u);
  EXPECT_EQ(three.obstacles[0].type, ObstacleType::Hill);
  EXPECT_DOUBLE_EQ(three.obstacles[0].sigma, 2);
}

TEST(Scenario, UnknownKeysAndTypesNameFileLineAndKey) {
  expectError(std::string(kHeader2d) + "colour: red\n", 8, "colour", "unknown key");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: cone, center: [1, 1]}\n", 9, "obstacles[0].type", "unknown obstacle type 'cone'");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: sphere, center: [1, 1], radius: 1, height: 2}\n", 9,
              "obstacles[0].height", "unknown key");
  expectError(std::string(kHeader2d) + "vehicle: {v_max: 1, omega_max: 1, wheels: 4}\n", 8, "vehicle.wheels", "unknown key");
  expectError(std::string(kHeader2d) + "vehicle: {model: bicycle, v_max: 1, omega_max: 1}\n", 8, "vehicle.model", "unknown model");
  expectError(std::string(kHeader2d) + "name: again\n", 8, "name", "duplicate key");
}

TEST(Scenario, MissingAndMistypedValues) {
  expectError("dimensions: 2\nbounds: {min: [0, 0], max: [1, 1]}\nstart: [0.5, 0.5]\ngoal: [0.6, 0.6]\n", 1, "goal_radius", "missing");
  expectError("bounds: {min: [0, 0], max: [1, 1]}\n", 1, "dimensions", "missing");
  expectError("dimensions: 4\n", 1, "dimensions", "expected 2 or 3");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: sphere, center: [1, 1], radius: abc}\n", 9, "obstacles[0].radius", "expected a number");
  expectError(std::string(kHeader2d) + "obstacles: {type: sphere}\n", 8, "obstacles", "expected a list");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: sphere, center: [1, 1]}\n", 9, "obstacles[0].radius", "missing");
}

TEST(Scenario, NonFiniteNumbers) {
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: sphere, center: [.nan, 1], radius: 1}\n", 9, "obstacles[0].center[0]", "finite");
  expectError("dimensions: 2\nbounds: {min: [0, 0], max: [.inf, 1]}\n", 2, "bounds.max[0]", "finite");
}

TEST(Scenario, WrongArrayLengths) {
  expectError("dimensions: 2\nbounds: {min: [0, 0, 0], max: [1, 1]}\n", 2, "bounds.min", "expected 2 numbers, got 3");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: ellipsoid, center: [1, 1], semi_axes: [1, 2, 3]}\n", 9,
              "obstacles[0].semi_axes", "expected 2 numbers");
  expectError(std::string(kHeader2d).replace(std::string(kHeader2d).find("[100, 100]"), 10, "[100]"), 6, "goal", "expected 2 numbers");
}

TEST(Scenario, DegenerateAndNegativeSizes) {
  expectError("dimensions: 2\nbounds: {min: [0, 0], max: [10, 0]}\n", 2, "bounds.max", "degenerate bounds");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: sphere, center: [1, 1], radius: -2}\n", 9, "obstacles[0].radius", "positive");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: box, min: [5, 5], max: [4, 6]}\n", 9, "obstacles[0].max", "greater");
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: box, center: [5, 5], size: [0, 6]}\n", 9, "obstacles[0].size", "positive");
  expectError(std::string(kHeader2d).replace(std::string(kHeader2d).find("0.5"), 3, "-0.5"), 4, "robot_radius", ">= 0");
  expectError(std::string(kHeader2d).replace(std::string(kHeader2d).find("2.0"), 3, "0"), 7, "goal_radius", "positive");
}

TEST(Scenario, HillIn2DAndDimensionMismatches) {
  expectError(std::string(kHeader2d) + "obstacles:\n  - {type: hill, center: [5, 5], height: 3, sigma: 1}\n", 9, "obstacles[0].type", "3-D");
  expectError(std::string(kHeader2d) + "vehicle: {v_max: 1, omega_max: 1, vz_max: -1}\n", 8, "vehicle.vz_max", ">= 0");
  expectError(std::string(kHeader2d) + "vehicle: {v_max: 1, omega_max: 1, vz: 1}\n", 8, "vehicle.vz", "unknown key");
  expectError(std::string(kHeader2d).replace(std::string(kHeader2d).find("[5, 5]"), 6, "[500, 5]"), 5, "start", "outside bounds");
}

TEST(Scenario, SyntaxErrorsAndMissingFiles) {
  expectError("dimensions: [2\n", 2, "<syntax>");
  expectError("- just\n- a list\n", 1, "<document>", "expected a mapping");
  try {
    loadScenario("/nonexistent/scenario.yaml");
    ADD_FAILURE();
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/scenario.yaml"), std::string::npos);
  }
}

TEST(Scenario, ShippedScenariosParseWithFreeStartAndGoal) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios")) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const Scenario s = loadScenario(entry.path().string());
    const auto world = makeScenarioWorld(s);
    EXPECT_TRUE(world->isFree(s.start));
    EXPECT_TRUE(world->isFree(s.goal));
    ++count;
  }
  EXPECT_GE(count, 10);
}

}  // namespace
}  // namespace ddsnav::planner

namespace ddsnav::planner {
namespace {

std::string scenarioErrorOf(const std::function<void()>& load) {
  try {
    load();
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "";
}

// Issue 13 row 12: a 59 MB scenario took 4.5 GB and minutes to parse. It is refused before parsing,
// naming the file, its size and the limit.
TEST(Scenario, OversizedFilesAreRefusedBeforeParsing) {
  const auto path = (std::filesystem::temp_directory_path() / ("ddsnav_big_scenario_" + std::to_string(::getpid()) + ".yaml")).string();
  std::ofstream(path) << kHeader2d << "obstacles:\n";
  std::filesystem::resize_file(path, 59u << 20);  // sparse: 59 MB without writing them
  const std::string error = scenarioErrorOf([&] { loadScenario(path); });
  std::filesystem::remove(path);
  EXPECT_EQ(error, path + ": key '<file>': 61865984 bytes, larger than the limit of 4194304 bytes for a "
                   "scenario (kMaxScenarioFileBytes)");
  EXPECT_NE(scenarioErrorOf([] { loadScenario("/tmp"); }).find("/tmp: key '<file>': not a regular file"), std::string::npos);
  EXPECT_NE(scenarioErrorOf([] { parseScenario(std::string(kMaxScenarioFileBytes + 1, '#'), "s.yaml"); }).find("kMaxScenarioFileBytes"),
            std::string::npos);
}

TEST(Scenario, ObstacleCountIsCapped) {
  std::string text = std::string(kHeader2d) + "obstacles:\n";
  for (std::size_t i = 0; i <= kMaxScenarioObstacles; ++i) text += "- {type: sphere, center: [50, 50], radius: 1}\n";
  ASSERT_LT(text.size(), kMaxScenarioFileBytes);
  const std::string error = scenarioErrorOf([&] { parseScenario(text, "many.yaml"); });
  EXPECT_EQ(error, "many.yaml:9: key 'obstacles': 50001 obstacles, more than the limit of 50000 (kMaxScenarioObstacles)");
}

}  // namespace
}  // namespace ddsnav::planner
