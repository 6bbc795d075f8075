// GART and Li-RRT solve small scenario worlds with every edge inside the forward extending region and
// collision free, and repeat themselves exactly for the same seed.
#include "ddsnav/planner/gart.hpp"
#include "ddsnav/planner/lirrt.hpp"
#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/tree.hpp"

#include <gtest/gtest.h>

#include <memory>

namespace ddsnav::planner {
namespace {

// 50 x 50 m, a wall with a 3 m gap, a disc and a rotated box; the GART paper's vehicle.
constexpr const char* kClutter2D = R"(
name: kino_test_2d
dimensions: 2
bounds: {min: [0, 0], max: [50, 50]}
robot_radius: 0.5
start: [3, 3, 0.0]
goal: [45, 45]
goal_radius: 2.0
vehicle: {model: unicycle, v_max: 5.0, omega_max: 0.628, dt: 1.0}
obstacles:
  - {type: box, min: [0, 24], max: [22, 26]}
  - {type: box, min: [25, 24], max: [50, 26]}
  - {type: sphere, center: [12, 12], radius: 4}
  - {type: box, center: [35, 38], size: [10, 3], yaw: 0.7}
)";

// 40 x 40 x 20 m terrain with two hills.
constexpr const char* kTerrain3D = R"(
name: kino_test_3d
dimensions: 3
bounds: {min: [0, 0, 0], max: [40, 40, 20]}
robot_radius: 0.5
start: [3, 3, 2]
goal: [36, 36, 3]
goal_radius: 2.0
vehicle: {model: unicycle, v_max: 5.0, omega_max: 0.628, vz_max: 2.0, dt: 1.0}
obstacles:
  - {type: hill, center: [15, 15], height: 14, sigma: 5}
  - {type: hill, center: [28, 26], height: 12, sigma: 4}
)";

struct KinoRun {
  PlanResult result;
  ForwardRegion region;
  std::unique_ptr<CollisionWorld> world;
};

KinoRun solveScenario(const std::string& planner, const char* yaml, std::uint64_t seed) {
  const Scenario scenario = parseScenario(yaml, "test");
  KinoRun run;
  run.world = makeScenarioWorld(scenario);
  PlanProblem problem;
  problem.world = run.world.get();
  problem.start = State{scenario.start, scenario.start_heading.value_or(0.0)};
  problem.goal = scenario.goal;
  problem.goal_radius = scenario.goal_radius;
  problem.vehicle = scenario.vehicle;
  problem.kinodynamic = true;
  problem.seed = seed;
  problem.time_limit_s = 20.0;
  problem.max_iterations = 200000;
  run.region = forwardRegion(*scenario.vehicle, scenario.dimensions);
  run.result = makePlanner(planner)->solve(problem);
  return run;
}

void expectKinodynamicSolution(const KinoRun& run, const Vec3& goal, double goal_radius) {
  const PlanResult& r = run.result;
  ASSERT_TRUE(r.solved);
  EXPECT_TRUE(r.exact);
  EXPECT_TRUE(r.kinodynamic);
  ASSERT_GE(r.path.size(), 2u);
  EXPECT_LE((r.path.back().position - goal).norm(), goal_radius);
  const PathCheck check = checkUnicyclePath(r.path, run.region, run.world.get());
  EXPECT_TRUE(check.ok) << check.reason;
  EXPECT_NEAR(r.cost, pathLength(r.path), 1e-6);
  EXPECT_GT(r.stats.vertices, 1u);
  EXPECT_GT(r.stats.iterations, 0u);
  EXPECT_GT(r.stats.validity_checks, 0u);
  EXPECT_EQ(r.stats.iterations_to_first_solution, r.stats.first_directive_connect);
  EXPECT_GT(r.stats.pous, 0.0);
}

// Two solves with one seed: the same path, pose by pose, and the same amount of work.
void expectSameSeedSameRun(const std::string& planner, std::uint64_t seed) {
  const KinoRun a = solveScenario(planner, kClutter2D, seed);
  const KinoRun b = solveScenario(planner, kClutter2D, seed);
  ASSERT_TRUE(a.result.solved) << planner;
  ASSERT_EQ(a.result.path.size(), b.result.path.size()) << planner;
  for (std::size_t i = 0; i < a.result.path.size(); ++i) {
    EXPECT_EQ(a.result.path[i].position, b.result.path[i].position) << planner << " pose " << i;
    EXPECT_EQ(a.result.path[i].heading, b.result.path[i].heading) << planner << " pose " << i;
  }
  EXPECT_EQ(a.result.stats.iterations, b.result.stats.iterations) << planner;
  EXPECT_EQ(a.result.stats.vertices, b.result.stats.vertices) << planner;
}

TEST(GartSolve, Clutter2DEveryEdgeInsideRegion) {
  const KinoRun run = solveScenario("gart", kClutter2D, 1);
  expectKinodynamicSolution(run, {45, 45, 0}, 2.0);
}

TEST(GartSolve, Terrain3DEveryEdgeInsideRegion) {
  const KinoRun run = solveScenario("gart", kTerrain3D, 3);
  expectKinodynamicSolution(run, {36, 36, 3}, 2.0);
}

TEST(GartSolve, SameSeedSamePath) { expectSameSeedSameRun("gart", 42); }

TEST(GartLazySolve, SameSeedSamePath) { expectSameSeedSameRun("gart-lazy", 42); }

TEST(LirrtSolve, Clutter2DEveryEdgeInsideRegion) {
  const KinoRun run = solveScenario("lirrt", kClutter2D, 1);
  expectKinodynamicSolution(run, {45, 45, 0}, 2.0);
}

TEST(LirrtSolve, Terrain3DEveryEdgeInsideRegion) {
  const KinoRun run = solveScenario("lirrt", kTerrain3D, 5);
  expectKinodynamicSolution(run, {36, 36, 3}, 2.0);
}

TEST(LirrtSolve, SameSeedSamePath) { expectSameSeedSameRun("lirrt", 9); }

TEST(KinoPlanners, NeedVehicleLimits) {
  Scenario scenario = parseScenario(kClutter2D, "test");
  const auto world = makeScenarioWorld(scenario);
  PlanProblem problem;
  problem.world = world.get();
  problem.start = State{scenario.start, 0.0};
  problem.goal = scenario.goal;
  problem.goal_radius = 2.0;
  for (const char* name : {"gart", "lirrt"}) {
    EXPECT_THROW(makePlanner(name)->solve(problem), std::invalid_argument) << name;
  }
}

}  // namespace
}  // namespace ddsnav::planner
