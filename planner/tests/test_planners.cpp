// Every planner of this file's set solves small scenarios with paths that an independent check accepts,
// is deterministic per seed, and rejects bad problems.
#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/run.hpp"
#include "ddsnav/planner/scenario.hpp"
#include "ddsnav/planner/unicycle.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <ostream>
#include <string>

namespace ddsnav::planner {
namespace {

Scenario shipped(const std::string& name) {
  return loadScenario(std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/" + name + ".yaml");
}

PlanProblem problemFor(const Scenario& s, const CollisionWorld& world, std::uint64_t seed) {
  PlanProblem p = problemFromScenario(s, world);
  p.seed = seed;
  p.time_limit_s = 20.0;
  p.max_iterations = 2'000'000;
  return p;
}

// Checks the path against a freshly built world with a finer step than the planner's: every state free,
// every segment free when sampled at 1 cm, starts at the start, ends in the goal region, cost = length.
void expectValidPath(const Scenario& s, const PlanResult& r) {
  ASSERT_TRUE(r.solved);
  ASSERT_GE(r.path.size(), 2u);
  const auto world = makeScenarioWorld(s);
  EXPECT_EQ(r.path.front().position, s.start);
  EXPECT_LE((r.path.back().position - s.goal).norm(), s.goal_radius);
  EXPECT_TRUE(r.exact);
  double length = 0.0;
  for (std::size_t i = 0; i + 1 < r.path.size(); ++i) {
    const Vec3 a = r.path[i].position, b = r.path[i + 1].position;
    length += (b - a).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.01)));
    for (int k = 0; k <= steps; ++k) {
      ASSERT_TRUE(world->isFree(a + (b - a) * (double(k) / steps))) << "edge " << i << " state " << k;
    }
  }
  EXPECT_NEAR(r.cost, length, 1e-9);
}

struct Case {
  std::string planner;
  std::string scenario;
  bool kinodynamic;
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.planner << " on " << c.scenario << (c.kinodynamic ? " (unicycle)" : ""); }

class PlannerSolves : public ::testing::TestWithParam<Case> {};

TEST_P(PlannerSolves, PathIsValidAndStatsAreFilled) {
  const Case c = GetParam();
  const Scenario s = shipped(c.scenario);
  const auto world = makeScenarioWorld(s);
  PlanProblem problem = problemFor(s, *world, 7);
  problem.kinodynamic = c.kinodynamic;
  problem.tree_metrics = true;
  const PlanResult r = makePlanner(c.planner)->solve(problem);
  EXPECT_EQ(r.planner, c.planner);
  EXPECT_EQ(r.kinodynamic, c.kinodynamic);
  expectValidPath(s, r);
  if (c.kinodynamic) {
    const PathCheck check = checkUnicyclePath(r.path, forwardRegion(*s.vehicle, s.dimensions), world.get());
    EXPECT_TRUE(check.ok) << check.reason;
    EXPECT_DOUBLE_EQ(r.path.front().heading, problem.start.heading);
  }
  const PlanStats& st = r.stats;
  EXPECT_GT(st.iterations, 0u);
  EXPECT_EQ(st.vertices, r.tree.size() + 1);
  EXPECT_GT(st.validity_checks, 0u);
  EXPECT_EQ(st.iterations_to_first_solution, st.first_directive_connect);
  EXPECT_GE(st.time_to_first_solution_s, 0.0);
  EXPECT_LE(st.time_to_first_solution_s, st.time_s);
  EXPECT_DOUBLE_EQ(st.pous, double(st.vertices - 1) / double(st.iterations));
  EXPECT_GE(st.first_glance_connect, 0);
  EXPECT_LE(st.first_glance_connect, st.first_directive_connect);
  EXPECT_GT(st.coverage, 0.0);
  EXPECT_LE(st.coverage, 1.0);
}

INSTANTIATE_TEST_SUITE_P(
    Planners, PlannerSolves,
    ::testing::Values(Case{"rrt", "demo_2d", false}, Case{"rrt", "stunnel_small_0.5", false}, Case{"rrt", "demo_2d", true},
                      Case{"rrt", "stunnel_small_0.5", true}, Case{"rrtstar", "demo_2d", false},
                      Case{"rrtstar", "bugtrap_small_1.0", false}, Case{"rrtstar", "gart_terrain_3d", false},
                      Case{"rrtstar", "demo_2d", true}, Case{"rrtstar", "stunnel_small_1.0", true},
                      Case{"apgd-rrtstar", "demo_2d", false}, Case{"apgd-rrtstar", "stunnel_small_1.0", false},
                      Case{"rrrt", "demo_2d", false}, Case{"rrrt", "stunnel_small_0.5", false}, Case{"rrrt", "gart_terrain_3d", false},
                      Case{"ddrrt", "demo_2d", false}, Case{"ddrrt", "bugtrap_small_1.0", false}),
    [](const auto& info) {
      std::string n = info.param.planner + "_" + info.param.scenario + (info.param.kinodynamic ? "_unicycle" : "");
      for (char& ch : n) ch = std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
      return n;
    });

// gart-lazy's self-limiting goal attraction (docs/planners.md): in the paper-scale bug trap the goal pull
// is the local minimum behind the closed wall; backing it off must get out with far fewer iterations than
// the always-on attraction (attraction_patience = 0), and every path must stay valid.
TEST(Planners, GartLazyBacksOffGoalAttractionInBugTrap) {
  const Scenario s = shipped("bugtrap_1.0");
  const auto world = makeScenarioWorld(s);
  std::uint64_t self_limiting = 0, always_on = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    PlanProblem problem = problemFor(s, *world, seed);
    problem.max_iterations = 300000;
    auto lazy = makePlanner("gart-lazy");
    const PlanResult r = lazy->solve(problem);
    ASSERT_TRUE(r.solved) << "seed " << seed;
    expectValidPath(s, r);
    self_limiting += r.stats.iterations_to_first_solution;
    auto always = makePlanner("gart-lazy");
    applyOptions(*always, {"attraction_patience=0"});
    const PlanResult a = always->solve(problem);
    always_on += a.solved ? a.stats.iterations_to_first_solution : problem.max_iterations;
  }
  EXPECT_LT(2 * self_limiting, always_on) << "self-limiting " << self_limiting << ", always on " << always_on;
}

// gart-lazy's restarts (docs/planners.md): a tree that stops reaching new cells for the patience is grown
// again; with a tiny patience the narrow tunnel forces restarts, each doubling the patience, and the run still
// solves with a valid path. A solved run never restarts afterwards, and `gart` (patience 0) never restarts.
TEST(Planners, GartLazyRestartsAStagnantTreeAndStillSolves) {
  const Scenario s = shipped("stunnel_0.3");
  const auto world = makeScenarioWorld(s);
  PlanProblem problem = problemFor(s, *world, 4);
  problem.max_iterations = 400000;
  auto lazy = makePlanner("gart-lazy");
  applyOptions(*lazy, {"restart_patience=50"});
  const PlanResult r = lazy->solve(problem);
  ASSERT_TRUE(r.solved);
  expectValidPath(s, r);
  EXPECT_GT(r.stats.restarts, 0u);
  // Doubling patience: n restarts take at least 50 * (2^n - 1) iterations.
  EXPECT_GE(static_cast<double>(r.stats.iterations_to_first_solution), 50.0 * (std::pow(2.0, r.stats.restarts) - 1.0));
  const PlanResult faithful = makePlanner("gart")->solve(problemFor(shipped("demo_2d"), *makeScenarioWorld(shipped("demo_2d")), 1));
  EXPECT_EQ(faithful.stats.restarts, 0u);
}

// gart-lazy's event 1 budget (docs/planners.md, session 6): in the wide bug trap, nodes pinned against the
// inside walls stop re-running event 1 for far samples after 3 exploring iterations, so the same seeds solve
// with valid paths and under half the validity checks per iteration of the budget off (0): 8.0 vs 31.6.
TEST(Planners, GartLazyEvent1BudgetCutsTheCollisionWorkInABugTrap) {
  const Scenario s = shipped("bugtrap_1.0");
  const auto world = makeScenarioWorld(s);
  double budgeted_checks = 0, budgeted_iterations = 0, unlimited_checks = 0, unlimited_iterations = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    PlanProblem problem = problemFor(s, *world, seed);
    problem.max_iterations = 200000;
    const PlanResult r = makePlanner("gart-lazy")->solve(problem);
    ASSERT_TRUE(r.solved) << seed;
    expectValidPath(s, r);
    budgeted_checks += static_cast<double>(r.stats.validity_checks);
    budgeted_iterations += static_cast<double>(r.stats.iterations);
    auto unlimited = makePlanner("gart-lazy");
    applyOptions(*unlimited, {"explore_event1_budget=0"});
    const PlanResult u = unlimited->solve(problem);
    ASSERT_TRUE(u.solved) << seed;
    unlimited_checks += static_cast<double>(u.stats.validity_checks);
    unlimited_iterations += static_cast<double>(u.stats.iterations);
  }
  EXPECT_LT(budgeted_checks / budgeted_iterations, 0.5 * unlimited_checks / unlimited_iterations)
      << budgeted_checks << " / " << budgeted_iterations << " vs " << unlimited_checks << " / " << unlimited_iterations;
}

TEST(Planners, PlannerRunRefusesToRestartASolvedRun) {
  const Scenario s = shipped("demo_2d");
  const auto world = makeScenarioWorld(s);
  PlanProblem problem = problemFor(s, *world, 1);
  problem.goal = problem.start.position;  // the root is in the goal region: solved at once
  PlannerRun run(problem, "test", false);
  ASSERT_TRUE(run.solved());
  EXPECT_THROW(run.restart(), std::logic_error);
}

TEST(Planners, PathsStayValidOverManySeeds) {
  // Contact-driven growth (RRRT) and rewiring (RRT*) are where a wrong edge would slip in: sweep seeds.
  for (const std::string scenario : {"demo_2d", "stunnel_small_0.3", "bugtrap_small_1.0"}) {
    const Scenario s = shipped(scenario);
    const auto world = makeScenarioWorld(s);
    for (const std::string name : {"rrt", "rrtstar", "apgd-rrtstar", "rrrt", "ddrrt"}) {
      for (std::uint64_t seed = 1; seed <= 6; ++seed) {
        SCOPED_TRACE(scenario + " " + name + " seed " + std::to_string(seed));
        const PlanResult r = makePlanner(name)->solve(problemFor(s, *world, seed));
        expectValidPath(s, r);
      }
    }
  }
}

TEST(Planners, RegistryListsEveryPlannerOfTheIssue) {
  // The names users and configs rely on; registry.cpp lists them by hand.
  const auto names = plannerNames();
  for (const std::string name : {"rrt", "rrtstar", "lirrt", "gart", "apgd-rrtstar", "rrrt", "ddrrt", "rrt-controls"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
    EXPECT_EQ(makePlanner(name)->name(), name);
  }
}

TEST(Planners, SameSeedSameResultBitForBit) {
  const Scenario s = shipped("stunnel_small_0.5");
  const auto world = makeScenarioWorld(s);
  for (const std::string name : {"rrt", "rrtstar", "apgd-rrtstar", "rrrt", "ddrrt"}) {
    SCOPED_TRACE(name);
    PlanProblem p = problemFor(s, *world, 11);
    const PlanResult a = makePlanner(name)->solve(p);
    const PlanResult b = makePlanner(name)->solve(p);
    ASSERT_TRUE(a.solved);
    ASSERT_EQ(a.path.size(), b.path.size());
    for (std::size_t i = 0; i < a.path.size(); ++i) {
      EXPECT_EQ(a.path[i].position, b.path[i].position);
      EXPECT_EQ(a.path[i].heading, b.path[i].heading);
    }
    EXPECT_EQ(a.stats.iterations, b.stats.iterations);
    EXPECT_EQ(a.stats.vertices, b.stats.vertices);
    p.seed = 12;
    const PlanResult c = makePlanner(name)->solve(p);
    EXPECT_FALSE(c.path.size() == a.path.size() && c.stats.iterations == a.stats.iterations && c.cost == a.cost);
  }
}

TEST(Planners, RrtStarAnytimeImprovesAndRewires) {
  const Scenario s = shipped("demo_2d");
  const auto world = makeScenarioWorld(s);
  PlanProblem p = problemFor(s, *world, 3);
  const PlanResult first = makePlanner("rrtstar")->solve(p);
  p.anytime = true;
  p.max_iterations = 4000;
  const PlanResult better = makePlanner("rrtstar")->solve(p);
  expectValidPath(s, better);
  EXPECT_EQ(better.stats.iterations, 4000u);
  EXPECT_LT(better.cost, first.cost);
  EXPECT_GT(better.stats.rewires, 0u);
  EXPECT_GT(better.stats.por, 0.0);
  // The straight-line distance bounds every path from below.
  EXPECT_GT(better.cost, (s.goal - s.start).norm() - s.goal_radius);
}

// improve_for_s bounds the anytime search by the time since the first solution, not the whole budget: zero is
// exactly the first solution (same iteration, same path), a short window ends long before the limit and keeps a path
// no longer than the first one (gart-lazy in a bug trap, whose first solutions are detours).
TEST(Planners, ImproveForEndsTheAnytimeSearchAfterTheFirstSolution) {
  const Scenario s = shipped("bugtrap_1.0");
  const auto world = makeScenarioWorld(s);
  PlanProblem p = problemFor(s, *world, 2);
  p.kinodynamic = true;
  p.time_limit_s = 30.0;
  const PlanResult first = makePlanner("gart-lazy")->solve(p);
  ASSERT_TRUE(first.solved);
  p.anytime = true;
  p.improve_for_s = 0.0;
  const PlanResult same = makePlanner("gart-lazy")->solve(p);
  EXPECT_EQ(same.stats.iterations, first.stats.iterations);
  EXPECT_EQ(same.cost, first.cost);
  p.improve_for_s = 0.2;
  const PlanResult improved = makePlanner("gart-lazy")->solve(p);
  expectValidPath(s, improved);
  EXPECT_GT(improved.stats.iterations, first.stats.iterations);
  EXPECT_LE(improved.cost, first.cost);
  EXPECT_LT(improved.stats.time_s, 10.0);  // the window, not the 30 s limit (generous for a loaded machine)
  p.improve_for_s = -1.0;
  EXPECT_THROW(makePlanner("gart-lazy")->solve(p), std::invalid_argument);
}

// The demo yard with four walls round its goal: no path exists.
Scenario demoWithTheGoalWalledIn() {
  Scenario s = shipped("demo_2d");
  for (const auto& [c, size] : {std::pair{Vec3(36, 38.5, 0), Vec3(8, 1, 0)}, std::pair{Vec3(36, 31.5, 0), Vec3(8, 1, 0)},
                                std::pair{Vec3(32.5, 35, 0), Vec3(1, 8, 0)}, std::pair{Vec3(39.5, 35, 0), Vec3(1, 8, 0)}}) {
    Obstacle o;
    o.center = c;
    o.size = size;
    s.obstacles.push_back(o);
  }
  return s;
}

TEST(Planners, UnsolvableProblemEndsUnsolvedAtTheLimit) {
  const Scenario s = demoWithTheGoalWalledIn();
  const auto world = makeScenarioWorld(s);
  for (const std::string name : {"rrt", "rrtstar", "apgd-rrtstar", "rrrt", "ddrrt"}) {
    PlanProblem p = problemFor(s, *world, 1);
    p.max_iterations = 3000;
    const PlanResult r = makePlanner(name)->solve(p);
    EXPECT_FALSE(r.solved) << name;
    EXPECT_FALSE(r.exact) << name;
    EXPECT_TRUE(r.path.empty()) << name;
    EXPECT_EQ(r.stats.iterations, 3000u) << name;
    EXPECT_EQ(r.stats.iterations_to_first_solution, -1) << name;
  }
}


// abandon_unsolved ends a search that has found nothing, every 1024 iterations when asked, and is never asked once
// there is a solution (an anytime search keeps improving its path).
TEST(Planners, AbandonUnsolvedEndsOnlyASearchWithoutASolution) {
  const Scenario s = demoWithTheGoalWalledIn();
  const auto walled = makeScenarioWorld(s);
  for (const std::string name : {"rrt", "gart-lazy", "lirrt"}) {
    PlanProblem p = problemFor(s, *walled, 1);
    p.max_iterations = 100000;
    int asked = 0;
    p.abandon_unsolved = [&asked] { return ++asked == 3; };
    const PlanResult r = makePlanner(name)->solve(p);
    EXPECT_TRUE(r.abandoned) << name;
    EXPECT_FALSE(r.solved) << name;
    EXPECT_FALSE(r.stopped) << name;
    EXPECT_EQ(asked, 3) << name;
    EXPECT_EQ(r.stats.iterations, 3u * 1024u) << name;
  }
  const Scenario trap = shipped("bugtrap_1.0");
  const auto world = makeScenarioWorld(trap);
  PlanProblem p = problemFor(trap, *world, 2);
  p.kinodynamic = true;
  p.anytime = true;
  p.improve_for_s = 0.2;
  p.time_limit_s = 30.0;
  const PlanResult first = makePlanner("gart-lazy")->solve(p);
  ASSERT_TRUE(first.solved);
  const std::int64_t k = first.stats.iterations_to_first_solution;
  ASSERT_GT(k, 2048) << "a first solution this early asks too seldom to tell anything";
  int asked = 0;
  p.abandon_unsolved = [&asked] {
    ++asked;
    return false;
  };
  const PlanResult r = makePlanner("gart-lazy")->solve(p);
  ASSERT_TRUE(r.solved);
  EXPECT_FALSE(r.abandoned);
  EXPECT_EQ(r.stats.iterations_to_first_solution, k);  // asking changes nothing in the search
  // Asked before each 1024th iteration up to the first solution, never after it.
  EXPECT_EQ(static_cast<std::int64_t>(asked), (k - 1) / 1024);
  p.abandon_unsolved = [] { return true; };
  const PlanResult at_once = makePlanner("gart-lazy")->solve(p);
  EXPECT_EQ(at_once.solved, k <= 1024);
  EXPECT_EQ(at_once.abandoned, k > 1024);
}
TEST(Planners, BadProblemsAreRejected) {
  const Scenario s = shipped("demo_2d");
  const auto world = makeScenarioWorld(s);
  auto expectRejected = [&](const std::string& planner, PlanProblem p, const std::string& words) {
    try {
      makePlanner(planner)->solve(p);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  for (const std::string name : {"rrt", "rrtstar", "apgd-rrtstar", "rrrt", "ddrrt"}) {
    PlanProblem p = problemFor(s, *world, 1);
    p.start.position = Vec3(11, 10, 0);  // inside the first box
    expectRejected(name, p, "start");
    p = problemFor(s, *world, 1);
    p.goal = Vec3(50, 10, 0);
    expectRejected(name, p, "outside the bounds");
    p = problemFor(s, *world, 1);
    p.goal = Vec3(NAN, 3, 0);
    expectRejected(name, p, "non-finite");
    p = problemFor(s, *world, 1);
    p.time_limit_s = 0.0;
    expectRejected(name, p, "time limit");
    p = problemFor(s, *world, 1);
    p.world = nullptr;
    expectRejected(name, p, "world");
  }
  PlanProblem p = problemFor(s, *world, 1);
  p.kinodynamic = true;
  p.vehicle.reset();
  expectRejected("rrt", p, "vehicle");
  try {
    makePlanner("a-star");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("rrtstar"), std::string::npos) << e.what();
  }
}

// The scenario format solves a path that ends within goal_radius of the goal, so a goal point inside an
// obstacle is a valid problem while part of the goal disc is free, and an error only when none of it is.
TEST(BadInput, GoalPointInAnObstacleIsValidWhileItsRegionHasFreeSpace) {
  const std::string head = "dimensions: 2\nbounds: {min: [0, 0], max: [20, 20]}\nrobot_radius: 0.2\nstart: [2, 2]\n";
  const Scenario partly = parseScenario(head + "goal: [15, 15]\ngoal_radius: 2.0\n"
                                        "obstacles:\n  - {type: sphere, center: [15.5, 15.5], radius: 1.0}\n", "partly.yaml");
  const auto partly_world = makeScenarioWorld(partly);
  ASSERT_FALSE(partly_world->isFree(Vec3(15, 15, 0)));
  PlanProblem problem = problemFromScenario(partly, *partly_world);
  problem.time_limit_s = 5.0;
  const PlanResult result = makePlanner("rrt")->solve(problem);
  ASSERT_TRUE(result.solved);
  EXPECT_LE((result.path.back().position - Vec3(15, 15, 0)).norm(), 2.0 + 1e-9);
  EXPECT_TRUE(partly_world->isFree(result.path.back().position));

  const Scenario covered = parseScenario(head + "goal: [15, 15]\ngoal_radius: 2.0\n"
                                         "obstacles:\n  - {type: sphere, center: [15, 15], radius: 3.0}\n", "covered.yaml");
  const auto covered_world = makeScenarioWorld(covered);
  PlanProblem blocked = problemFromScenario(covered, *covered_world);
  try {
    makePlanner("rrt")->solve(blocked);
    ADD_FAILURE() << "a goal region without free space must be an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("every probed state within goal_radius"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ddsnav::planner

