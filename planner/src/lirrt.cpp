// Li-RRT (Li-RRT paper, Algorithm 2) on the unicycle edge model; liveness bookkeeping in lirrt_liveness.cpp.
#include "ddsnav/planner/lirrt.hpp"

#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/run.hpp"
#include "ddsnav/planner/tree.hpp"

#include <algorithm>
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

LirrtPlanner::LirrtPlanner(LirrtOptions options) : options_(options) {
  LirrtOptions& o = options_;
  addOption("drive_probability", &o.drive_probability, 0.0, 1.0, "B: drive the most alive node");
  addOption("goal_bias", &o.goal_bias, 0.0, 1.0, "W: probability of sampling the goal");
  addOption("neighbour_radius", &o.neighbour_radius, 1e-3, 100.0, "H as a fraction of the reach");
  addOption("turn_steps", &o.turn_steps, 1, 15, "control set: turns over [-max turn, max turn]");
  addOption("speed_steps", &o.speed_steps, 1, 4, "control set: lengths reach / 2^k");
  addOption("climb_steps", &o.climb_steps, 1, 3, "control set (3-D): climbs over [-max climb, max climb]");
}

PlanResult LirrtPlanner::solve(const PlanProblem& problem) {
  checkOptions();
  PlannerRun run(problem, name(), /*kinodynamic=*/true);
  const CollisionWorld& world = run.world;
  const ForwardRegion region = forwardRegion(*run.problem.vehicle, world.dimensions());
  const std::vector<UnicycleControl> controls = lirrtControlSet(region, options_);
  const double near_radius = options_.neighbour_radius * region.reach;  // H
  SearchTree& tree = run.tree;

  LivenessBook book;
  std::vector<std::uint64_t> free_controls;  // per node: which controls of U are collision free
  std::vector<int> near;

  // The liveness bookkeeping of a node PlannerRun has just added.
  auto track = [&](int id, int parent, const ControlSurvey& survey) {
    tree.withinRadius(tree.node(id).state.position, near_radius, near);  // V3ch: the others within H
    near.erase(std::remove(near.begin(), near.end(), id), near.end());
    const int book_id = book.add(parent, survey.se, near);
    if (book_id != id) throw std::logic_error("lirrt: tree and liveness ids diverged");
    free_controls.push_back(survey.free_mask);
  };
  track(0, -1, surveyControls(tree.node(0).state, controls, region, world));

  while (run.nextIteration()) {
    // Lines 3-19: choose x_rand and the node to drive from.
    const int most_alive = book.mostAlive();
    Vec3 x_rand;
    int x_nearest = -1;
    int driven_control = -1;  // the control of U used from most_alive, when x_nearest stays most_alive
    if (most_alive >= 0 && run.rng.uniform() < options_.drive_probability) {
      // Lines 5-11: a random control of the most alive node (among its free ones: Se already found
      // which controls collide, re-trying those would only waste the iteration), then the closest
      // node within H of x_rand that can reach it inside its own R+.
      const std::uint64_t mask = free_controls[static_cast<std::size_t>(most_alive)];
      const int free_count = std::popcount(mask);
      driven_control = nthSetBit(mask, static_cast<int>(run.rng.below(static_cast<std::uint64_t>(free_count))));
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
      x_rand = run.sample(options_.goal_bias);
      x_nearest = tree.nearest(x_rand);
    }

    // Lines 20-23: drive inside R+(x_nearest) and add the edge when it is collision free.
    const TreeNode& parent = tree.node(x_nearest);
    const State x_new = steerUnicycle(parent.state, x_rand, region);
    if ((x_new.position - parent.state.position).norm() < 1e-9) continue;
    if (!world.isSegmentFree(parent.state.position, x_new.position)) continue;
    const bool in_goal = run.inGoal(x_new.position);
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
    // Lines 24-26: PlannerRun records goal nodes; the result is the cheapest of them.
    const double cost = parent.cost + (x_new.position - parent.state.position).norm();
    const int id = run.addNode(x_new, x_nearest, cost);
    track(id, x_nearest, survey);
  }
  return run.finish();
}

std::unique_ptr<Planner> makeLiRrtPlanner() {
  return std::make_unique<LirrtPlanner>();
}

}  // namespace ddsnav::planner
