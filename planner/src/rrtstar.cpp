#include "ddsnav/planner/rrtstar.hpp"

#include "ddsnav/planner/planners.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::planner {

bool RrtStarPlanner::childrenStayFeasible(const PlannerRun& run, const Steering& steering, int node,
                                          double new_heading) const {
  if (!steering.kinodynamic()) return true;
  const TreeNode& n = run.tree.node(node);
  State moved = n.state;
  moved.heading = new_heading;
  for (int child : n.children) {
    if (!steering.reachable(moved, run.tree.node(child).state.position)) return false;
  }
  return true;
}

PlanResult RrtStarPlanner::solve(const PlanProblem& problem) {
  const bool kino = problem.kinodynamic && kinodynamicCapable();
  PlannerRun run(problem, name(), kino);
  PlanProblem geometric_view = problem;
  geometric_view.kinodynamic = kino;
  const Steering steering = steeringFor(geometric_view);
  const CollisionWorld& world = run.world;

  const int d = world.dimensions();
  const double gamma = rewire_factor * rrtStarGamma(world);

  while (run.nextIteration()) {
    const Vec3 target = shapeSample(run, run.sample(goal_bias));
    const int nearest = run.tree.nearest(target);
    const State to = steering.steer(run.tree.node(nearest).state, target);
    const Vec3& from = run.tree.node(nearest).state.position;
    const double step = (to.position - from).norm();
    if (step < 1e-9 || !world.isSegmentFree(from, to.position)) continue;

    // Cheapest parent among the neighbours, checking edges in order of cost so the first free one wins.
    const double radius = rrtStarRadius(gamma, run.tree.size() + 1, d, steering.range());
    run.tree.withinRadius(to.position, radius, near_);
    int parent = nearest;
    double cost = run.tree.node(nearest).cost + step;
    candidates_.clear();
    for (int i : near_) {
      if (i == nearest) continue;
      const TreeNode& node = run.tree.node(i);
      const double c = node.cost + (to.position - node.state.position).norm();
      if (c < cost && steering.reachable(node.state, to.position)) candidates_.emplace_back(c, i);
    }
    std::sort(candidates_.begin(), candidates_.end());
    for (const auto& [c, i] : candidates_) {
      if (world.isSegmentFree(run.tree.node(i).state.position, to.position)) {
        parent = i, cost = c;
        break;
      }
    }
    State added = to;
    const State& parent_state = run.tree.node(parent).state;
    added.heading = edgeHeading(parent_state.position, to.position, parent_state.heading);
    const int id = run.addNode(added, parent, cost);

    // Rewire: neighbours that become cheaper through the new node.
    for (int i : near_) {
      if (i == parent) continue;
      const TreeNode& node = run.tree.node(i);
      const double c = cost + (node.state.position - added.position).norm();
      if (c >= node.cost - 1e-12) continue;
      if (!steering.reachable(added, node.state.position)) continue;
      if (!childrenStayFeasible(run, steering, i, edgeHeading(added.position, node.state.position, node.state.heading))) continue;
      if (!world.isSegmentFree(added.position, node.state.position)) continue;
      run.tree.reparent(i, id, c);
      run.countRewire();
    }
  }
  return run.finish();
}

std::unique_ptr<Planner> makeRrtStarPlanner() { return std::make_unique<RrtStarPlanner>(); }

}  // namespace ddsnav::planner
