// The lattice route: found through gaps (also ones only its corner probes resolve), "none" for a closed world,
// bounded by its limits; and samples guided along a route stay near it.
#include "ddsnav/planner/coarse_route.hpp"
#include "ddsnav/planner/run.hpp"
#include "ddsnav/planner/scenario.hpp"
#include "ddsnav/planner/tree.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace ddsnav::planner {
namespace {

// 50 x 50 m, r = 0.5, a wall across y = 24..26 with a gap [gap_min, gap_max] in x (none when gap_min == gap_max).
std::unique_ptr<CollisionWorld> wallWorld(double gap_min, double gap_max) {
  std::string yaml = R"(
name: wall
dimensions: 2
bounds: {min: [0, 0], max: [50, 50]}
robot_radius: 0.5
start: [10, 5]
goal: [40, 45]
goal_radius: 1.0
obstacles:
)";
  if (gap_min < gap_max) {
    yaml += "  - {type: box, min: [0, 24], max: [" + std::to_string(gap_min) + ", 26]}\n";
    yaml += "  - {type: box, min: [" + std::to_string(gap_max) + ", 24], max: [50, 26]}\n";
  } else {
    yaml += "  - {type: box, min: [0, 24], max: [50, 26]}\n";
  }
  return makeScenarioWorld(parseScenario(yaml, "test"));
}

const Vec3 kStart(10, 5, 0), kGoal(40, 45, 0);

TEST(CoarseRoute, GoesThroughTheGapWithEveryWaypointFree) {
  const auto world = wallWorld(30, 33);
  CoarseRouteOptions options;
  options.time_limit_s = 10.0;  // a loaded machine must not cut it short
  const CoarseRoute route = findCoarseRoute(*world, kStart, kGoal, 1.0, options);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  EXPECT_DOUBLE_EQ(route.cell_m, 0.5 / std::sqrt(2.0)) << "a 3 m gap is found on the coarser lattice, searched first";
  EXPECT_EQ(route.waypoints.front(), kStart);
  EXPECT_LE((route.waypoints.back() - kGoal).norm(), 1.0);
  bool through_gap = false;
  for (const Vec3& p : route.waypoints) {
    EXPECT_TRUE(world->isFree(p)) << p.transpose();
    if (p.y() > 24.5 && p.y() < 25.5) through_gap = through_gap || (p.x() > 30.5 && p.x() < 32.5);
  }
  EXPECT_TRUE(through_gap);
  // Weighted A* (weight 2) stays within twice the shortest way (start -> gap -> goal, about 46.6 m).
  EXPECT_LT(route.length_m, 2.0 * 46.6);
  EXPECT_GT(route.length_m, 46.0);
}

TEST(CoarseRoute, AClosedWorldHasNoneAfterTheReachableCellsAreSearched) {
  const auto world = wallWorld(0, 0);
  CoarseRouteOptions options;
  options.time_limit_s = 10.0;  // exhausting the lower half must not be cut short on a slow machine
  const CoarseRoute route = findCoarseRoute(*world, kStart, kGoal, 1.0, options);
  EXPECT_EQ(route.outcome, CoarseRoute::Outcome::none);
  EXPECT_TRUE(route.waypoints.empty());
  EXPECT_DOUBLE_EQ(route.cell_m, 0.25) << "\"none\" comes from the finer lattice";
  EXPECT_GT(route.cpu_s, 0.0);
  EXPECT_LE(route.cpu_s, route.time_s + 1e-3) << "one thread's CPU time within the wall time it took";
  // The lower half on both lattices: 200 x ~94 cells of 0.25 m free of the wall and the bounds' edge, and half as many
  // of 0.35 m.
  EXPECT_GT(route.expanded, 15000u + 7500u);
  EXPECT_LT(route.expanded, 200u * 100u + 142u * 71u);
}

TEST(CoarseRoute, ResolvesAGapOnlyItsCornerProbesFit) {
  // Centres of the robot fit in x in [24.95, 25.05] through the wall: no cell centre (24.875, 25.125) does, the
  // corners at x = 25 do.
  const auto world = wallWorld(24.45, 25.55);
  ASSERT_FALSE(world->isFree(Vec3(24.875, 25, 0)));
  ASSERT_FALSE(world->isFree(Vec3(25.125, 25, 0)));
  ASSERT_TRUE(world->isFree(Vec3(25.0, 25, 0)));
  CoarseRouteOptions options;
  options.time_limit_s = 10.0;  // both lattices are searched: not to be cut short on a slow (sanitizer) build
  const CoarseRoute route = findCoarseRoute(*world, kStart, kGoal, 1.0, options);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  EXPECT_DOUBLE_EQ(route.cell_m, 0.25) << "0.1 m of play: the coarser lattice has no route, the finer one has";
  for (const Vec3& p : route.waypoints) {
    if (p.y() >= 24.0 && p.y() <= 26.0) {  // inside the wall's thickness
      EXPECT_NEAR(p.x(), 25.0, 0.05 + 1e-9) << p.transpose();
    }
  }
}

TEST(CoarseRoute, GivesUpAtItsLimitsAndNotBefore) {
  const auto world = wallWorld(30, 33);
  CoarseRouteOptions few;
  few.max_cells_seen = 100;  // the start's cell and 8 neighbours per expansion: 13 expansions see 100 or more
  const CoarseRoute cut = findCoarseRoute(*world, kStart, kGoal, 1.0, few);
  EXPECT_EQ(cut.outcome, CoarseRoute::Outcome::gave_up);
  EXPECT_GE(cut.expanded, 10u);
  EXPECT_LE(cut.expanded, 100u);
  std::stop_source stop;
  stop.request_stop();
  CoarseRouteOptions stopped;
  stopped.stop = stop.get_token();
  EXPECT_EQ(findCoarseRoute(*world, kStart, kGoal, 1.0, stopped).outcome, CoarseRoute::Outcome::gave_up);
}

TEST(CoarseRoute, ACpuTimeLimitEndsTheSearchAndANegativeOneIsRefused) {
  const auto world = wallWorld(0, 0);  // closed: without a limit both lattices' lower halves are searched
  CoarseRouteOptions tiny;
  tiny.time_limit_s = 10.0;
  tiny.cpu_time_limit_s = 1e-9;  // spent by the first check, after 256 expansions at most
  const CoarseRoute cut = findCoarseRoute(*world, kStart, kGoal, 1.0, tiny);
  EXPECT_EQ(cut.outcome, CoarseRoute::Outcome::gave_up);
  EXPECT_LE(cut.expanded, 257u);
  CoarseRouteOptions negative;
  negative.cpu_time_limit_s = -1.0;
  EXPECT_THROW(findCoarseRoute(*world, kStart, kGoal, 1.0, negative), std::invalid_argument);
}

TEST(CoarseRoute, AStartInsideTheGoalRegionIsItsOwnRoute) {
  const auto world = wallWorld(30, 33);
  const CoarseRoute route = findCoarseRoute(*world, kStart, kStart + Vec3(0.5, 0, 0), 1.0);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  EXPECT_EQ(route.waypoints.size(), 1u);
}

TEST(CoarseRoute, CoarsensToItsCellBudgetAndChecksTheLongerMoves) {
  const auto world = wallWorld(30, 33);
  CoarseRouteOptions options;
  options.max_lattice_cells = 400;  // 2500 m^2 / 400 = 6.25 m^2: 2.5 m cells, longer than the robot radius
  const CoarseRoute route = findCoarseRoute(*world, kStart, kGoal, 1.0, options);
  EXPECT_DOUBLE_EQ(route.cell_m, 2.5);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  for (std::size_t i = 1; i < route.waypoints.size(); ++i)
    EXPECT_TRUE(world->isSegmentFree(route.waypoints[i - 1], route.waypoints[i])) << route.waypoints[i].transpose();
}

TEST(CoarseRoute, FindsTheWindowInA3dWall) {
  // A wall across y = 19..21, the whole height, with a 4 x 4 m window at x 18..22, z 8..12.
  const auto world = makeScenarioWorld(parseScenario(R"(
name: window
dimensions: 3
bounds: {min: [0, 0, 0], max: [40, 40, 20]}
robot_radius: 0.5
start: [5, 5, 3]
goal: [35, 35, 15]
goal_radius: 1.0
obstacles:
  - {type: box, min: [0, 19, 0], max: [18, 21, 20]}
  - {type: box, min: [22, 19, 0], max: [40, 21, 20]}
  - {type: box, min: [18, 19, 0], max: [22, 21, 8]}
  - {type: box, min: [18, 19, 12], max: [22, 21, 20]}
)",
                                                     "test"));
  CoarseRouteOptions options;
  options.time_limit_s = 10.0;
  const CoarseRoute route = findCoarseRoute(*world, Vec3(5, 5, 3), Vec3(35, 35, 15), 1.0, options);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  bool through_window = false;
  for (const Vec3& p : route.waypoints) {
    EXPECT_TRUE(world->isFree(p)) << p.transpose();
    if (p.y() > 19.0 && p.y() < 21.0) {
      EXPECT_TRUE(p.x() > 18.5 && p.x() < 21.5 && p.z() > 8.5 && p.z() < 11.5) << p.transpose();
      through_window = true;
    }
  }
  EXPECT_TRUE(through_window);
}

TEST(CoarseRoute, RefusesNonFiniteInputAndAStartOutsideTheBounds) {
  const auto world = wallWorld(30, 33);
  EXPECT_THROW(findCoarseRoute(*world, Vec3(NAN, 1, 0), kGoal, 1.0), std::invalid_argument);
  EXPECT_THROW(findCoarseRoute(*world, kStart, Vec3(1, INFINITY, 0), 1.0), std::invalid_argument);
  EXPECT_THROW(findCoarseRoute(*world, Vec3(-1, 5, 0), kGoal, 1.0), std::invalid_argument);
  EXPECT_THROW(findCoarseRoute(*world, kStart, kGoal, -1.0), std::invalid_argument);
  CoarseRouteOptions weight;
  weight.heuristic_weight = 0.5;
  EXPECT_THROW(findCoarseRoute(*world, kStart, kGoal, 1.0, weight), std::invalid_argument);
}

PlanProblem problemIn(const CollisionWorld& world) {
  PlanProblem problem;
  problem.world = &world;
  problem.start.position = kStart;
  problem.goal = kGoal;
  return problem;
}

// wall_cost: along a wall the route keeps two cells off it where there is room (0.65 m of clearance), for 1 % of
// length; at 0 it runs the wall's length in the first row passable at a cell centre (0.3 m).
TEST(CoarseRoute, KeepsOffAWallAlongWhichItRuns) {
  const auto world = makeScenarioWorld(parseScenario(R"(
name: along a wall
dimensions: 2
bounds: {min: [0, 0], max: [50, 50]}
robot_radius: 0.5
start: [5, 22.6]
goal: [45, 22.6]
goal_radius: 1.0
obstacles:
  - {type: box, min: [0, 20], max: [50, 22]}
)", "test"));
  const Vec3 start(5, 22.6, 0), goal(45, 22.6, 0);
  auto meanClearance = [&](const CoarseRoute& route) {
    double sum = 0.0;
    for (const Vec3& p : route.waypoints) sum += world->clearance(p);
    return sum / static_cast<double>(route.waypoints.size());
  };
  CoarseRouteOptions hug;
  hug.time_limit_s = 10.0;
  hug.wall_cost = 0.0;
  const CoarseRoute hugging = findCoarseRoute(*world, start, goal, 1.0, hug);
  // At or below heuristic_weight - 1 a penalty along a straight run is outweighed by the heuristic: the same route.
  CoarseRouteOptions weak = hug;
  weak.wall_cost = 0.5;
  EXPECT_DOUBLE_EQ(meanClearance(findCoarseRoute(*world, start, goal, 1.0, weak)), meanClearance(hugging));
  CoarseRouteOptions keep;  // the default wall_cost
  keep.time_limit_s = 10.0;
  const CoarseRoute kept = findCoarseRoute(*world, start, goal, 1.0, keep);
  ASSERT_EQ(hugging.outcome, CoarseRoute::Outcome::found);
  ASSERT_EQ(kept.outcome, CoarseRoute::Outcome::found);
  EXPECT_LT(meanClearance(hugging), 0.35);
  EXPECT_GT(meanClearance(kept), meanClearance(hugging) + 0.25);
  EXPECT_LT(kept.length_m, 1.02 * hugging.length_m);
  keep.wall_cost = -1.0;
  EXPECT_THROW(findCoarseRoute(*world, start, goal, 1.0, keep), std::invalid_argument);
}

// kStart to kGoal with 10 s to search, which a loaded machine does not cut short.
CoarseRoute routeWithoutTimeLimit(const CollisionWorld& world, double goal_radius) {
  CoarseRouteOptions options;
  options.time_limit_s = 10.0;
  return findCoarseRoute(world, kStart, kGoal, goal_radius, options);
}

// The route as the answer: a shortcut polyline from the exact start through the gap to the goal region, every edge free,
// with no more corners than the way needs, and no longer than the route.
TEST(PathAlongRoute, IsAFreeShortcutPolylineThroughTheGap) {
  const auto world = wallWorld(30, 33);
  const CoarseRoute route = routeWithoutTimeLimit(*world, 1.0);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  const State start{kStart, 1.0};
  const std::vector<State> path = pathAlongRoute(*world, route, start, kGoal, 1.0);
  ASSERT_GE(path.size(), 2u);
  EXPECT_EQ(path.front().position, kStart);
  EXPECT_DOUBLE_EQ(path.front().heading, 1.0) << "the start keeps its heading";
  EXPECT_LE((path.back().position - kGoal).norm(), 1.0);
  double length = 0.0;
  bool through_gap = false;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Vec3& a = path[i - 1].position;
    const Vec3& b = path[i].position;
    EXPECT_TRUE(world->isSegmentFree(a, b)) << a.transpose() << " -> " << b.transpose();
    EXPECT_NEAR(path[i].heading, std::atan2(b.y() - a.y(), b.x() - a.x()), 1e-12);
    length += (b - a).norm();
    // Where the edge crosses the wall's middle line (y = 25) it is inside the gap.
    if ((a.y() - 25.0) * (b.y() - 25.0) <= 0.0 && a.y() != b.y()) {
      const double x = a.x() + (25.0 - a.y()) / (b.y() - a.y()) * (b.x() - a.x());
      through_gap = through_gap || (x > 30.5 && x < 32.5);
    }
  }
  EXPECT_TRUE(through_gap);
  EXPECT_LE(length, route.length_m + 1e-9);
  // The corners are the route's own waypoints: the weighted A* route may leave the gap at its far side, and the
  // shortcut follows it there (50.4 m against 46.6 before the wall cost); the smoother shortcuts again between them.
  EXPECT_LT(length, 1.1 * 46.6) << "shortcut to within 10 % of start -> gap -> goal";
  EXPECT_LE(path.size(), 6u) << "one corner at the gap needs a few points, not the lattice's staircase";
}

TEST(PathAlongRoute, EndsAtTheGoalWhenTheLastCellIsOutsideTheGoalRadius) {
  const auto world = wallWorld(30, 33);
  // A goal radius below the cell: the goal region's cells are those within a cell of the goal.
  const CoarseRoute route = routeWithoutTimeLimit(*world, 0.01);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  const std::vector<State> path = pathAlongRoute(*world, route, State{kStart, 0.0}, kGoal, 0.01);
  ASSERT_FALSE(path.empty());
  EXPECT_LE((path.back().position - kGoal).norm(), 0.01);
}

TEST(PathAlongRoute, NothingForARouteNotFoundOrNotFreeInTheWorld) {
  const auto open = wallWorld(30, 33);
  CoarseRoute none;
  none.outcome = CoarseRoute::Outcome::none;
  EXPECT_TRUE(pathAlongRoute(*open, none, State{kStart, 0.0}, kGoal, 1.0).empty());
  // A route found in a world with a gap, answered in the same place with the wall closed: its edges are not free.
  const CoarseRoute route = routeWithoutTimeLimit(*open, 1.0);
  ASSERT_EQ(route.outcome, CoarseRoute::Outcome::found);
  const auto closed = wallWorld(0, 0);
  EXPECT_TRUE(pathAlongRoute(*closed, route, State{kStart, 0.0}, kGoal, 1.0).empty());
}

// The answer to a request given to both: the sampler's when it solved no longer (or was stopped), else the route's,
// counting the sampler's time and iterations; and the route as a result carries its own length as the cost.
TEST(PathAlongRoute, TheShorterAnswers) {
  const auto world = wallWorld(30, 33);
  const CoarseRoute route = routeWithoutTimeLimit(*world, 1.0);
  PlanProblem problem;
  problem.start = State{kStart, 0.0};
  problem.goal = kGoal;
  problem.goal_radius = 1.0;
  const auto along = resultAlongRoute(*world, route, problem);
  ASSERT_TRUE(along);
  EXPECT_EQ(along->planner, "lattice-route");
  EXPECT_TRUE(along->solved && along->exact);
  EXPECT_DOUBLE_EQ(along->cost, pathLength(along->path));

  PlanResult sampled;
  sampled.planner = "gart-lazy";
  sampled.stats.time_s = 0.25;
  sampled.stats.iterations = 7;
  PlanResult answer = shorterAnswer(sampled, *along);  // the sampler found none
  EXPECT_EQ(answer.planner, "lattice-route");
  EXPECT_DOUBLE_EQ(answer.stats.time_s, along->stats.time_s + 0.25);
  EXPECT_EQ(answer.stats.iterations, 7u);
  sampled.solved = true;
  sampled.cost = along->cost + 1.0;
  EXPECT_EQ(shorterAnswer(sampled, *along).planner, "lattice-route");
  sampled.cost = along->cost;
  EXPECT_EQ(shorterAnswer(sampled, *along).planner, "gart-lazy");
  sampled.solved = false;
  sampled.stopped = true;
  EXPECT_EQ(shorterAnswer(sampled, *along).planner, "gart-lazy") << "a stopped request is answered as stopped";
}

TEST(GuidedSampling, DrawsItsShareNearTheGuideAndTheRestAnywhere) {
  const auto world = wallWorld(30, 33);
  PlanProblem problem = problemIn(*world);
  problem.guide = {Vec3(31.5, 25, 0)};
  problem.guide_bias = 0.5;
  problem.guide_spread_m = 0.5;
  PlannerRun run(problem, "test", false);
  int near = 0;
  constexpr int kDraws = 4000;
  for (int i = 0; i < kDraws; ++i) near += (run.sample(0.0) - problem.guide.front()).norm() < 2.5;  // 5 sigma
  // Half of the draws, plus the uniform ones that land within 2.5 m (pi 2.5^2 / 2500 of them: 0.4 %).
  EXPECT_NEAR(double(near) / kDraws, 0.5 + 0.5 * 0.004, 0.03);
}

TEST(GuidedSampling, ABadGuideIsRefused) {
  const auto world = wallWorld(30, 33);
  PlanProblem problem = problemIn(*world);
  problem.guide_bias = 1.5;
  EXPECT_THROW(PlannerRun(problem, "test", false), std::invalid_argument);
  problem.guide_bias = 0.5;
  problem.guide = {Vec3(NAN, 0, 0)};
  EXPECT_THROW(PlannerRun(problem, "test", false), std::invalid_argument);
}

// An earlier path through the gap, planned from (10, 5); the vehicle is now at (20, 15), and the wall was found to
// reach over the gap's left half: the guide is the path ahead, a robot radius apart, without the blocked points.
TEST(PathGuide, IsThePathAheadOfTheStartWhereItIsFree) {
  const auto world = wallWorld(32, 33);  // the gap [30, 33] the path was planned through has narrowed to [32, 33]
  PlanProblem problem = problemIn(*world);
  problem.start.position = Vec3(20, 15, 0);
  const std::vector<Vec3> earlier{Vec3(10, 5, 0), Vec3(30.5, 25, 0), Vec3(40, 45, 0)};
  guideAlongPath(problem, earlier, 0.3);
  ASSERT_FALSE(problem.guide.empty());
  EXPECT_DOUBLE_EQ(problem.guide_bias, 0.3);
  EXPECT_DOUBLE_EQ(problem.guide_spread_m, 1.0) << "two robot radii";
  EXPECT_LT((problem.guide.front() - problem.start.position).norm(), 0.5) << "from the point nearest the start on";
  EXPECT_EQ(problem.guide.back(), earlier.back());
  for (const Vec3& p : problem.guide) {
    EXPECT_TRUE(world->isFree(p)) << p.transpose();
    EXPECT_GE(p.x(), 19.5) << "nothing behind the start";
  }
  // Points 0.5 m apart along the 38.6 m ahead, less those within the robot radius of the wall (y in 23.5..26.5 on the
  // blocked stretch): about 77 - 7.
  EXPECT_GT(problem.guide.size(), 60u);
  EXPECT_LT(problem.guide.size(), 75u);
}

TEST(PathGuide, LeavesTheProblemAloneWithoutAUsablePath) {
  const auto world = wallWorld(30, 33);
  PlanProblem problem = problemIn(*world);
  guideAlongPath(problem, {Vec3(10, 5, 0)}, 0.3);
  EXPECT_TRUE(problem.guide.empty()) << "one corner is no path";
  guideAlongPath(problem, {Vec3(10, 5, 0), Vec3(NAN, 5, 0)}, 0.3);
  EXPECT_TRUE(problem.guide.empty()) << "not finite";
  guideAlongPath(problem, {Vec3(0, 25, 0), Vec3(20, 25, 0)}, 0.3);
  EXPECT_TRUE(problem.guide.empty()) << "every point inside the wall";
  guideAlongPath(problem, {Vec3(10, 5, 0), Vec3(40, 45, 0)}, 0.0);
  EXPECT_TRUE(problem.guide.empty()) << "no share of the samples";
  EXPECT_DOUBLE_EQ(problem.guide_bias, 0.0);
}

TEST(PathGuide, AVeryLongPathIsThinnedToItsBound) {
  const auto world = wallWorld(30, 33);
  PlanProblem problem = problemIn(*world);
  std::vector<Vec3> zigzag;  // 400 crossings of the 50 m field below the wall: 20 km
  for (int i = 0; i <= 400; ++i) zigzag.emplace_back(i % 2 ? 49.0 : 1.0, 2.0 + 0.05 * i, 0.0);
  problem.start.position = zigzag.front();
  guideAlongPath(problem, zigzag, 0.3);
  EXPECT_LE(problem.guide.size(), kMaxPathGuidePoints);
  EXPECT_GT(problem.guide.size(), kMaxPathGuidePoints / 2) << "spread along the whole path, not its first 2 km";
  EXPECT_EQ(problem.guide.back(), zigzag.back()) << "to its end";
}

}  // namespace
}  // namespace ddsnav::planner
