// rrt-controls: the kinodynamic RRT of LaValle & Kuffner (2001) over a discrete control set, the baseline
// the Li-RRT paper most likely measured against (docs/planners.md, "Li-RRT"). Each iteration: a uniform
// sample (the goal with probability goal_bias); the nearest node by Euclidean distance; every control of
// U applied to it; the successor closest to the sample is added when its edge is collision free (else
// the iteration is spent). U is Li-RRT's control set, so the two differ only in what Li-RRT adds.
// ddsnav's own `rrt --kinodynamic` is stronger: it steers exactly towards the sample inside R+.
#include "ddsnav/planner/lirrt.hpp"
#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/run.hpp"

#include <limits>

namespace ddsnav::planner {
namespace {

class RrtControlsPlanner final : public Planner {
 public:
  RrtControlsPlanner() {
    addOption("goal_bias", &goal_bias_, 0.0, 1.0, "probability of sampling the goal (Li-RRT's W)");
    addOption("turn_steps", &controls_.turn_steps, 1, 15, "control set: turns over [-max turn, max turn]");
    addOption("speed_steps", &controls_.speed_steps, 1, 4, "control set: lengths reach / 2^k");
    addOption("climb_steps", &controls_.climb_steps, 1, 3, "control set (3-D): climbs");
  }
  std::string name() const override { return "rrt-controls"; }

  PlanResult solve(const PlanProblem& problem) override {
    checkOptions();
    PlannerRun run(problem, name(), /*kinodynamic=*/true);
    const ForwardRegion region = forwardRegion(*run.problem.vehicle, run.world.dimensions());
    const std::vector<UnicycleControl> controls = lirrtControlSet(region, controls_);
    while (run.nextIteration()) {
      const Vec3 target = run.sample(goal_bias_);
      const int nearest = run.tree.nearest(target);
      const TreeNode& from = run.tree.node(nearest);
      State best;
      double best_distance = std::numeric_limits<double>::infinity();
      for (const UnicycleControl& u : controls) {
        const State next = driveUnicycle(from.state, u.turn, u.length, u.climb, region);
        const double d = (next.position - target).norm();
        if (d < best_distance) best_distance = d, best = next;
      }
      if (!run.world.isSegmentFree(from.state.position, best.position)) continue;
      run.addNode(best, nearest, from.cost + (best.position - from.state.position).norm());
    }
    return run.finish();
  }

 private:
  double goal_bias_ = 0.1;  // Li-RRT's default W, so both sample the goal equally often
  LirrtOptions controls_;   // only the control-set fields are used
};

}  // namespace

std::unique_ptr<Planner> makeRrtControlsPlanner() { return std::make_unique<RrtControlsPlanner>(); }

}  // namespace ddsnav::planner
