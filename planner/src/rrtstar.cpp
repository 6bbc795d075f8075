#include "ddsnav/planner/rrtstar.hpp"

#include "ddsnav/planner/planners.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::planner {

bool StarInsertion::childrenStayReachable(const SearchTree& tree, const Steering& steering, int node,
                                          double new_heading) const {
  if (!steering.kinodynamic()) return true;
  const TreeNode& n = tree.node(node);
  const State moved{n.state.position, new_heading};
  for (int child : n.children) {
    const Vec3& p = tree.node(child).state.position;
    // A child straight above/below inherited the old heading; re-heading it is not worth the bookkeeping.
    if (std::hypot(p.x() - n.state.position.x(), p.y() - n.state.position.y()) <= kNoDirectionLength) return false;
    if (!steering.reachable(moved, p)) return false;
  }
  return true;
}

int StarInsertion::insert(PlannerRun& run, const Steering& steering, const Vec3& to, int via, double radius,
                          Parts parts) {
  const CollisionWorld& world = run.world;
  SearchTree& tree = run.tree;
  if (parts.choose_parent || parts.rewire) tree.withinRadius(to, radius, near_);
  else near_.clear();

  // Cheapest parent: neighbours cheaper than `via` (in the order (cost, id)), checked in that order so
  // the first free edge wins; `via` itself needs no check.
  const std::pair<double, int> through_via{tree.node(via).cost + (to - tree.node(via).state.position).norm(), via};
  std::pair<double, int> chosen = through_via;
  if (parts.choose_parent) {
    candidates_.clear();
    for (int u : near_) {
      if (u == via) continue;
      const TreeNode& node = tree.node(u);
      const std::pair<double, int> through_u{node.cost + (to - node.state.position).norm(), u};
      if (through_u < through_via && steering.reachable(node.state, to)) candidates_.push_back(through_u);
    }
    std::sort(candidates_.begin(), candidates_.end());
    for (const auto& candidate : candidates_) {
      if (world.isSegmentFree(tree.node(candidate.second).state.position, to)) {
        chosen = candidate;
        break;
      }
    }
  }
  const auto [cost, parent] = chosen;
  const State& from = tree.node(parent).state;
  const State added{to, edgeHeading(from.position, to, from.heading)};
  const int id = run.addNode(added, parent, cost);
  if (!parts.rewire) return id;

  // Rewire: neighbours that become cheaper through the new node (never the root).
  for (int x : near_) {
    if (x == parent) continue;
    const TreeNode& node = tree.node(x);
    if (node.parent < 0) continue;
    const double new_cost = cost + (node.state.position - to).norm();
    if (new_cost >= node.cost - 1e-9) continue;
    if (steering.kinodynamic()) {
      // SearchTree::reparent re-heads x along the new edge, which needs a horizontal direction.
      if (std::hypot(node.state.position.x() - to.x(), node.state.position.y() - to.y()) <= kNoDirectionLength) continue;
      if (!steering.reachable(added, node.state.position)) continue;
      if (!childrenStayReachable(tree, steering, x, edgeHeading(to, node.state.position, node.state.heading))) continue;
    }
    if (!world.isSegmentFree(to, node.state.position)) continue;
    tree.reparent(x, id, new_cost);
    run.countRewire();
  }
  return id;
}

RrtStarPlanner::RrtStarPlanner() {
  addOption("goal_bias", &goal_bias, 0.0, 1.0, "probability of sampling the goal");
  addOption("rewire_factor", &rewire_factor, 0.01, 100.0, "scale of the RRT* neighbourhood constant gamma");
}

PlanResult RrtStarPlanner::solve(const PlanProblem& problem) {
  checkOptions();
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
    const double radius = rrtStarRadius(gamma, run.tree.size() + 1, d, steering.range());
    insertion_.insert(run, steering, to.position, nearest, radius);
  }
  return run.finish();
}

std::unique_ptr<Planner> makeRrtStarPlanner() { return std::make_unique<RrtStarPlanner>(); }

}  // namespace ddsnav::planner
