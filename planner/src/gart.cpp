// GART (GART paper, Algorithm 1): sampling, dynamically feasible parent choice, redistribution (see
// gart_redistribute.cpp), and RRT*-style insertion and rewiring that keep every edge inside R+.
#include "ddsnav/planner/gart.hpp"

#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/tree.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ddsnav::planner {

namespace {

// Every child of `node` stays inside R+ of `node` if node's heading becomes `heading`.
bool childrenStayReachable(const SearchTree& tree, int node, double heading, const ForwardRegion& region) {
  const TreeNode& n = tree.node(node);
  for (int c : n.children) {
    const Vec3& p = tree.node(c).state.position;
    // A child straight above/below inherited the old heading; re-heading it is not worth the bookkeeping.
    if (std::hypot(p.x() - n.state.position.x(), p.y() - n.state.position.y()) <= kNoDirectionLength) return false;
    if (!inForwardRegion(State{n.state.position, heading}, p, region, 1e-9)) return false;
  }
  return true;
}

}  // namespace

PlanResult GartPlanner::solve(const PlanProblem& problem) {
  validateProblem(problem, /*needs_vehicle=*/true);
  if (options_.k_nearest < 1 || !(options_.goal_bias >= 0.0 && options_.goal_bias <= 1.0) ||
      !(options_.detection_range > 0.0)) {
    throw std::invalid_argument("gart: k_nearest >= 1, goal_bias in [0, 1] and detection_range > 0 required");
  }
  const CollisionWorld& world = *problem.world;
  const ForwardRegion region = forwardRegion(*problem.vehicle, world.dimensions());
  const double edge_reach = std::hypot(region.reach, region.max_climb);
  const double gamma = options_.rewire_gamma > 0.0 ? options_.rewire_gamma : rrtStarGamma(world);

  RunClock clock(problem);
  const std::uint64_t checks_at_start = world.validityChecks();
  Random random(problem.seed);
  PlanResult result;
  result.planner = name();
  result.kinodynamic = true;

  SearchTree tree(world.dimensions());
  std::vector<std::int64_t> node_iteration;
  std::vector<int> goal_nodes;
  std::vector<int> knn, near;
  std::vector<std::pair<double, int>> parent_order;

  tree.add(problem.start, -1, 0.0);
  node_iteration.push_back(0);
  if ((problem.start.position - problem.goal).norm() <= problem.goal_radius) goal_nodes.push_back(0);

  auto bestGoal = [&]() {
    int best = -1;
    for (int g : goal_nodes) {
      if (best < 0 || tree.node(g).cost < tree.node(best).cost) best = g;
    }
    return best;
  };

  std::uint64_t iteration = 0;
  while (goal_nodes.empty() || problem.anytime) {
    if (iteration >= problem.max_iterations || clock.expired()) break;
    ++iteration;
    if (problem.on_progress && iteration % 256 == 0) problem.on_progress(iteration);

    // Line 3: sample.
    const Vec3 sample = random.uniform() < options_.goal_bias ? problem.goal : random.position(world);

    // Line 4: among the k nearest, the dynamically feasible parent of least control effort; when none is
    // feasible (the sample is behind every near node) the nearest one steers at its maximum turn.
    tree.kNearest(sample, static_cast<std::size_t>(options_.k_nearest), knn);
    int v_near = knn.front();
    double best_effort = std::numeric_limits<double>::infinity();
    for (int n : knn) {
      const double effort = gartControlEffort(tree.node(n).state, sample, region, options_.turn_weight);
      if (effort < best_effort) {
        best_effort = effort;
        v_near = n;
      }
    }

    // Lines 5-13: redistribute into one or two collision-free states inside R+(v_near).
    const std::vector<GartCandidate> candidates =
        gartRedistribute(tree.node(v_near).state, sample, problem.goal, world, region, options_);

    // Lines 14-16: add each state with the cheapest R+-feasible parent, then rewire around it.
    for (const GartCandidate& candidate : candidates) {
      const Vec3 p = candidate.state.position;
      const double radius = rrtStarRadius(gamma, tree.size(), world.dimensions(), edge_reach);
      tree.withinRadius(p, radius, near);

      // v_near's edge is known free, so it is always a valid parent: only cheaper neighbours (in the
      // order (cost, id) the sort below uses) can win, and only they need the R+ test.
      parent_order.clear();
      const std::pair<double, int> through_v_near{
          tree.node(v_near).cost + (p - tree.node(v_near).state.position).norm(), v_near};
      parent_order.push_back(through_v_near);
      for (int u : near) {
        if (u == v_near) continue;
        const std::pair<double, int> through_u{tree.node(u).cost + (p - tree.node(u).state.position).norm(), u};
        if (!(through_u < through_v_near) || !inForwardRegion(tree.node(u).state, p, region, 1e-9)) continue;
        parent_order.push_back(through_u);
      }
      std::sort(parent_order.begin(), parent_order.end());
      int parent = -1;
      double cost = 0.0;
      for (const auto& [c, u] : parent_order) {
        // v_near's edge was checked by the redistribution.
        if (u == v_near || world.isSegmentFree(tree.node(u).state.position, p)) {
          parent = u;
          cost = c;
          break;
        }
      }
      const State& from = tree.node(parent).state;
      const State state{p, edgeHeading(from.position, p, from.heading)};
      const int id = tree.add(state, parent, cost);
      node_iteration.push_back(static_cast<std::int64_t>(iteration));

      for (int x : near) {
        if (x == parent) continue;
        const TreeNode& xn = tree.node(x);
        if (xn.parent < 0) continue;  // never re-parent the root
        const double new_cost = cost + (xn.state.position - p).norm();
        if (new_cost >= xn.cost - 1e-9) continue;
        // SearchTree::reparent re-heads x along the new edge, which needs a horizontal direction.
        if (std::hypot(xn.state.position.x() - p.x(), xn.state.position.y() - p.y()) <= kNoDirectionLength) continue;
        if (!inForwardRegion(state, xn.state.position, region, 1e-9)) continue;
        const double new_heading = edgeHeading(p, xn.state.position, state.heading);
        if (!childrenStayReachable(tree, x, new_heading, region)) continue;
        if (!world.isSegmentFree(p, xn.state.position)) continue;
        tree.reparent(x, id, new_cost);
        ++result.stats.rewires;
      }

      if ((p - problem.goal).norm() <= problem.goal_radius) {
        if (goal_nodes.empty()) {
          result.stats.time_to_first_solution_s = clock.elapsed();
          result.stats.iterations_to_first_solution = static_cast<std::int64_t>(iteration);
          result.stats.first_directive_connect = static_cast<std::int64_t>(iteration);
        }
        goal_nodes.push_back(id);
      }
    }
  }

  result.stats.iterations = iteration;
  finishResult(result, bestGoal(), tree, problem, node_iteration, checks_at_start, clock);
  return result;
}

std::unique_ptr<Planner> makeGartPlanner() {
  return std::make_unique<GartPlanner>();
}

}  // namespace ddsnav::planner
