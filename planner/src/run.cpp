#include "ddsnav/planner/run.hpp"

#include <algorithm>
#include <stdexcept>

namespace ddsnav::planner {
namespace {

// The problem as a run uses it: validated, and flat in a 2-D world (a z from outside, however large,
// never reaches a distance or a segment check).
PlanProblem validated(const PlanProblem& problem, bool kinodynamic) {
  validateProblem(problem, kinodynamic);
  PlanProblem flat = problem;
  if (problem.world->dimensions() == 2) {
    flat.start.position.z() = 0.0;
    flat.goal.z() = 0.0;
  }
  return flat;
}

}  // namespace

double defaultRange(const CollisionWorld& world) {
  Vec3 extent = world.boundsMax() - world.boundsMin();
  if (world.dimensions() == 2) extent.z() = 0.0;
  return 0.2 * extent.norm();
}

Steering steeringFor(const PlanProblem& problem) {
  if (problem.kinodynamic) return Steering::unicycle(forwardRegion(*problem.vehicle, problem.world->dimensions()));
  return Steering::geometric(defaultRange(*problem.world));
}

PlannerRun::PlannerRun(const PlanProblem& p, std::string planner_name, bool kinodynamic)
    : problem(validated(p, kinodynamic)),
      world(*problem.world),
      tree(p.world->dimensions()),
      rng(p.seed),
      clock_(problem) {
  result.planner = std::move(planner_name);
  result.kinodynamic = kinodynamic;
  checks_at_start_ = world.validityChecks();
  addNode(problem.start, -1, 0.0);
}

Vec3 PlannerRun::sample(double goal_bias) {
  if (rng.uniform() < goal_bias) return problem.goal;
  if (!problem.guide.empty() && problem.guide_bias > 0.0 && rng.uniform() < problem.guide_bias) {
    const Vec3& near = problem.guide[rng.below(problem.guide.size())];
    Vec3 offset(rng.normal(), rng.normal(), world.dimensions() == 3 ? rng.normal() : 0.0);
    Vec3 p = near + problem.guide_spread_m * offset;
    return p.cwiseMax(world.boundsMin()).cwiseMin(world.boundsMax());
  }
  return rng.position(world);
}

bool PlannerRun::nextIteration(bool stop_at_first) {
  PlanStats& s = result.stats;
  if (solved() && (stop_at_first || !problem.anytime)) return false;
  if (s.iterations >= problem.max_iterations) return false;
  // The clock is read every iteration: cheap next to one collision check, and the limit stays tight.
  if (clock_.expired()) return false;
  if (solved() && clock_.elapsed() - s.time_to_first_solution_s > problem.improve_for_s) return false;
  if (problem.stop.stop_requested()) {
    result.stopped = true;
    return false;
  }
  if (problem.abandon_unsolved && !solved() && s.iterations > 0 && (s.iterations & 1023) == 0 && problem.abandon_unsolved()) {
    result.abandoned = true;
    return false;
  }
  ++s.iterations;
  if (problem.on_progress && (s.iterations & 1023) == 0) problem.on_progress(s.iterations);
  return true;
}

int PlannerRun::addNode(const State& state, int parent, double cost) {
  const int id = tree.add(state, parent, cost);
  node_iteration_.push_back(static_cast<std::int64_t>(result.stats.iterations));
  if (inGoal(state.position)) {
    if (goal_nodes_.empty()) {
      result.stats.time_to_first_solution_s = clock_.elapsed();
      result.stats.iterations_to_first_solution = static_cast<std::int64_t>(result.stats.iterations);
    }
    goal_nodes_.push_back(id);
  }
  return id;
}

void PlannerRun::restart() {
  if (solved()) throw std::logic_error("PlannerRun::restart after a solution");
  tree = SearchTree(world.dimensions());
  node_iteration_.clear();
  ++result.stats.restarts;
  addNode(problem.start, -1, 0.0);
}

PlanResult PlannerRun::finish() {
  int best = -1;
  for (int g : goal_nodes_) {
    if (best < 0 || tree.node(g).cost < tree.node(best).cost) best = g;
  }
  finishResult(result, best, tree, problem, node_iteration_, checks_at_start_, clock_);
  return std::move(result);
}

}  // namespace ddsnav::planner
