// Li-RRT (Li-RRT paper, Algorithm 2) on the unicycle edge model; liveness bookkeeping in lirrt_liveness.cpp.
#include "ddsnav/planner/lirrt.hpp"

#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/tree.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace ddsnav::planner {

namespace {

// Se(x) of eq. 3 and the bit mask of the free controls (bit i: control i's edge is collision free).
struct ControlSurvey {
  double se = 0.0;
  std::uint64_t free_mask = 0;
};

ControlSurvey surveyControls(const State& x, const std::vector<UnicycleControl>& controls,
                             const ForwardRegion& region, const CollisionWorld& world) {
  ControlSurvey survey;
  int free = 0;
  for (std::size_t i = 0; i < controls.size(); ++i) {
    const UnicycleControl& u = controls[i];
    const State next = driveUnicycle(x, u.turn, u.length, u.climb, region);
    if (world.isSegmentFree(x.position, next.position)) {
      survey.free_mask |= std::uint64_t{1} << i;
      ++free;
    }
  }
  survey.se = static_cast<double>(free) / static_cast<double>(controls.size());
  return survey;
}

// The i-th set bit of mask (0-based), picked uniformly by the caller.
int nthSetBit(std::uint64_t mask, int n) {
  for (int bit = 0; bit < 64; ++bit) {
    if ((mask >> bit) & 1u) {
      if (n == 0) return bit;
      --n;
    }
  }
  return -1;
}

}  // namespace

PlanResult LirrtPlanner::solve(const PlanProblem& problem) {
  validateProblem(problem, /*needs_vehicle=*/true);
  if (!(options_.drive_probability >= 0.0 && options_.drive_probability <= 1.0) ||
      !(options_.goal_bias >= 0.0 && options_.goal_bias <= 1.0) || !(options_.neighbour_radius > 0.0)) {
    throw std::invalid_argument("lirrt: B and W must be probabilities and H positive");
  }
  const CollisionWorld& world = *problem.world;
  const ForwardRegion region = forwardRegion(*problem.vehicle, world.dimensions());
  const std::vector<UnicycleControl> controls = lirrtControlSet(region, options_);
  const double near_radius = options_.neighbour_radius * region.reach;  // H

  RunClock clock(problem);
  const std::uint64_t checks_at_start = world.validityChecks();
  Random random(problem.seed);
  PlanResult result;
  result.planner = name();
  result.kinodynamic = true;

  SearchTree tree(world.dimensions());
  LivenessBook book;
  std::vector<std::uint64_t> free_controls;  // per node: which controls of U are collision free
  std::vector<std::int64_t> node_iteration;
  std::vector<int> near;

  auto addNode = [&](const State& s, int parent, double cost, const ControlSurvey& survey, std::int64_t iteration) {
    tree.withinRadius(s.position, near_radius, near);  // V3ch, before the node itself is indexed
    const int id = tree.add(s, parent, cost);
    const int book_id = book.add(parent, survey.se, near);
    if (book_id != id) throw std::logic_error("lirrt: tree and liveness ids diverged");
    free_controls.push_back(survey.free_mask);
    node_iteration.push_back(iteration);
    return id;
  };

  const ControlSurvey root_survey = surveyControls(problem.start, controls, region, world);
  addNode(problem.start, -1, 0.0, root_survey, 0);

  int best_goal = -1;
  if ((problem.start.position - problem.goal).norm() <= problem.goal_radius) best_goal = 0;

  std::uint64_t iteration = 0;
  while (best_goal < 0 || problem.anytime) {
    if (iteration >= problem.max_iterations || clock.expired()) break;
    ++iteration;
    if (problem.on_progress && iteration % 256 == 0) problem.on_progress(iteration);

    // Lines 3-19: choose x_rand and the node to drive from.
    const int most_alive = book.mostAlive();
    Vec3 x_rand;
    int x_nearest = -1;
    int driven_control = -1;  // the control of U used from most_alive, when x_nearest stays most_alive
    if (most_alive >= 0 && random.uniform() < options_.drive_probability) {
      // Lines 5-11: a random control of the most alive node (among its free ones: Se already found
      // which controls collide, re-trying those would only waste the iteration), then the closest
      // node within H of x_rand that can reach it inside its own R+.
      const std::uint64_t mask = free_controls[static_cast<std::size_t>(most_alive)];
      const int free_count = std::popcount(mask);
      driven_control = nthSetBit(mask, static_cast<int>(random.below(static_cast<std::uint64_t>(free_count))));
      const UnicycleControl& u = controls[static_cast<std::size_t>(driven_control)];
      const TreeNode& from = tree.node(most_alive);
      x_rand = driveUnicycle(from.state, u.turn, u.length, u.climb, region).position;
      x_nearest = most_alive;
      double best_distance = (from.state.position - x_rand).norm();
      tree.withinRadius(x_rand, near_radius, near);
      for (int n : near) {
        const double distance = (tree.node(n).state.position - x_rand).norm();
        if (distance < best_distance && !book.dead(n) && inForwardRegion(tree.node(n).state, x_rand, region)) {
          best_distance = distance;
          x_nearest = n;
        }
      }
    } else {
      // Lines 13-17: goal with probability W, else a uniform sample; the nearest node drives towards it.
      x_rand = random.uniform() < options_.goal_bias ? problem.goal : random.position(world);
      x_nearest = tree.nearest(x_rand);
    }

    // Lines 20-23: drive inside R+(x_nearest) and add the edge when it is collision free.
    const TreeNode& parent = tree.node(x_nearest);
    const State x_new = steerUnicycle(parent.state, x_rand, region);
    if ((x_new.position - parent.state.position).norm() < 1e-9) continue;
    if (!world.isSegmentFree(parent.state.position, x_new.position)) continue;
    const bool in_goal = (x_new.position - problem.goal).norm() <= problem.goal_radius;
    const ControlSurvey survey = surveyControls(x_new, controls, region, world);
    // A dead node (Se = 0) is removed from the tree (Section 3.3.1), unless it is the goal itself. When it
    // was reached by a control of U from the most alive node, that control is dead too: without this the
    // most alive node would keep drawing it, and its liveness would never change.
    if (survey.se <= 0.0 && !in_goal) {
      if (driven_control >= 0 && x_nearest == most_alive) {
        std::uint64_t& mask = free_controls[static_cast<std::size_t>(most_alive)];
        mask &= ~(std::uint64_t{1} << driven_control);
        book.reduceSe(most_alive, static_cast<double>(std::popcount(mask)) / static_cast<double>(controls.size()));
      }
      continue;
    }
    const double cost = parent.cost + (x_new.position - parent.state.position).norm();
    const int id = addNode(x_new, x_nearest, cost, survey, static_cast<std::int64_t>(iteration));

    // Lines 24-26.
    if (in_goal && (best_goal < 0 || cost < tree.node(best_goal).cost)) {
      if (best_goal < 0) {
        result.stats.time_to_first_solution_s = clock.elapsed();
        result.stats.iterations_to_first_solution = static_cast<std::int64_t>(iteration);
        result.stats.first_directive_connect = static_cast<std::int64_t>(iteration);
      }
      best_goal = id;
    }
  }

  result.stats.iterations = iteration;
  finishResult(result, best_goal, tree, problem, node_iteration, checks_at_start, clock);
  return result;
}

std::unique_ptr<Planner> makeLiRrtPlanner() {
  return std::make_unique<LirrtPlanner>();
}

}  // namespace ddsnav::planner
