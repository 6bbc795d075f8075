// RRT (LaValle 1998): grow towards uniform samples (the goal with a small bias) from the nearest node.
// In unicycle mode (problem.kinodynamic) each edge is steered inside the forward extending region.
#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/run.hpp"

namespace ddsnav::planner {
namespace {

class RrtPlanner final : public Planner {
 public:
  std::string name() const override { return "rrt"; }

  PlanResult solve(const PlanProblem& problem) override {
    PlannerRun run(problem, name(), problem.kinodynamic);
    const Steering steering = steeringFor(problem);
    while (run.nextIteration()) {
      const Vec3 target = run.sample(kGoalBias);
      const int nearest = run.tree.nearest(target);
      const TreeNode& from = run.tree.node(nearest);
      const State to = steering.steer(from.state, target);
      const double length = (to.position - from.state.position).norm();
      if (length < 1e-9 || !run.world.isSegmentFree(from.state.position, to.position)) continue;
      run.addNode(to, nearest, from.cost + length);
    }
    return run.finish();
  }

 private:
  static constexpr double kGoalBias = 0.05;
};

}  // namespace

std::unique_ptr<Planner> makeRrtPlanner() { return std::make_unique<RrtPlanner>(); }

}  // namespace ddsnav::planner
