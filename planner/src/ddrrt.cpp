// DDRRT, dynamic-domain RRT (Yershova et al. 2005, with the adaptive radius of Jaillet et al. 2005).
// Every node i has a domain radius R_i, infinite at first. A sample farther than R_near from its nearest
// node is rejected, so nodes next to obstacles ("boundary nodes") stop attracting samples from far away
// (the Voronoi bias that makes RRT stall in front of bug traps). On a failed extension R_near becomes R_0
// (first failure) or shrinks, R <- max(R_min, (1 - alpha) R); on a successful extension from a boundary
// node it grows, R <- (1 + alpha) R. R_0 = range, R_min = 5 * check resolution, alpha = 0.05.
// Geometric only.
#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/run.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace ddsnav::planner {
namespace {

class DdrrtPlanner final : public Planner {
 public:
  std::string name() const override { return "ddrrt"; }

  PlanResult solve(const PlanProblem& problem) override {
    PlannerRun run(problem, name(), false);
    const CollisionWorld& world = run.world;
    const Steering steering = Steering::geometric(defaultRange(world));
    const double r0 = steering.range();
    const double r_min = 5.0 * world.checkResolution();
    constexpr double kInfinite = std::numeric_limits<double>::infinity();
    std::vector<double> domain(1, kInfinite);  // per node, parallel to the tree
    while (run.nextIteration()) {
      const Vec3 target = run.sample(kGoalBias);
      const int nearest = run.tree.nearest(target);
      const State from = run.tree.node(nearest).state;
      if ((target - from.position).norm() > domain[static_cast<std::size_t>(nearest)]) continue;  // outside the dynamic domain
      const State to = steering.steer(from, target);
      const double length = (to.position - from.position).norm();
      if (length < 1e-9) continue;
      double& radius = domain[static_cast<std::size_t>(nearest)];
      if (world.isSegmentFree(from.position, to.position)) {
        if (radius < kInfinite) radius *= 1.0 + kAlpha;
        run.addNode(to, nearest, run.tree.node(nearest).cost + length);
        domain.push_back(kInfinite);
      } else {
        radius = radius == kInfinite ? r0 : std::max(r_min, radius * (1.0 - kAlpha));
      }
    }
    return run.finish();
  }

 private:
  static constexpr double kGoalBias = 0.05;
  static constexpr double kAlpha = 0.05;
};

}  // namespace

std::unique_ptr<Planner> makeDdrrtPlanner() { return std::make_unique<DdrrtPlanner>(); }

}  // namespace ddsnav::planner
