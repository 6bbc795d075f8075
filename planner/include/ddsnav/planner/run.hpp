#pragma once
// The bookkeeping every tree planner repeats: the tree, the seeded random stream, the clock and limits,
// goal bookkeeping, first-solution statistics and the final result. A planner's solve() reads as its
// algorithm; this class does the accounting.

#include "ddsnav/planner/tree.hpp"
#include "ddsnav/planner/unicycle.hpp"

#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace ddsnav::planner {

// How an edge is grown from a tree state towards a target: either a straight step of at most `range`
// metres (geometric planners), or a unicycle edge inside the forward extending region R+.
class Steering {
 public:
  static Steering geometric(double range) {
    Steering s;
    s.range_ = range;
    return s;
  }
  static Steering unicycle(const ForwardRegion& region) {
    Steering s;
    s.region_ = region;
    s.range_ = region.reach;
    return s;
  }

  bool kinodynamic() const { return region_.has_value(); }
  double range() const { return range_; }
  const ForwardRegion& region() const { return *region_; }

  // The state reached from `from` towards `target` (exactly `target` when it is reachable in one edge).
  State steer(const State& from, const Vec3& target) const {
    if (region_) return steerUnicycle(from, target, *region_);
    const Vec3 d = target - from.position;
    const double length = d.norm();
    State to;
    to.position = length > range_ ? Vec3(from.position + d * (range_ / length)) : target;
    to.heading = edgeHeading(from.position, to.position, from.heading);
    return to;
  }

  // Whether a single edge from `from` may end at `to` (length in range; inside R+ for a unicycle).
  bool reachable(const State& from, const Vec3& to) const {
    if (region_) return inForwardRegion(from, to, *region_);
    return (to - from.position).norm() <= range_ * (1.0 + 1e-12);
  }

 private:
  double range_ = 1.0;
  std::optional<ForwardRegion> region_;
};

// Default geometric step: a fifth of the bounds' diagonal (OMPL's rule for its RRT family's range).
double defaultRange(const CollisionWorld& world);

// The steering a problem asks for: a unicycle edge when problem.kinodynamic, else geometric steps.
Steering steeringFor(const PlanProblem& problem);

class PlannerRun {
 public:
  // Validates the problem (throws std::invalid_argument) and plants the root at the start.
  PlannerRun(const PlanProblem& problem, std::string planner_name, bool kinodynamic);

  const PlanProblem problem;  // a copy; in a 2-D world the z of start and goal is set to 0 (ignored)
  const CollisionWorld& world;
  SearchTree tree;
  Random rng;
  PlanResult result;

  // The goal with probability goal_bias, else a uniform position in the bounds.
  Vec3 sample(double goal_bias);

  // Call at the top of every iteration: false when the run must stop (time limit, iteration cap, or
  // a first solution when not in anytime mode / `stop_at_first`). Counts the iteration.
  bool nextIteration(bool stop_at_first = false);
  std::uint64_t iteration() const { return result.stats.iterations; }

  // Adds a node and records whether it reaches the goal region.
  int addNode(const State& state, int parent, double cost);
  bool inGoal(const Vec3& p) const { return (p - problem.goal).norm() <= problem.goal_radius; }
  bool solved() const { return !goal_nodes_.empty(); }
  void countRewire() { ++result.stats.rewires; }

  // Discards the tree and plants a new root at the start (before a first solution only); the clock, the
  // random stream and the iteration count go on.
  void restart();

  // Builds the result: the cheapest node inside the goal region (costs may have dropped by rewiring).
  PlanResult finish();

 private:
  RunClock clock_;
  std::uint64_t checks_at_start_ = 0;
  std::vector<std::int64_t> node_iteration_;
  std::vector<int> goal_nodes_;
};

}  // namespace ddsnav::planner
