#pragma once
// RRT* (Karaman & Frazzoli 2011): RRT that picks the cheapest collision-free parent among the nodes within
// r_n = min(gamma * (log n / n)^(1/d), range) and rewires those neighbours through the new node when
// that is cheaper. gamma = rewire_factor * 2 (1 + 1/d)^(1/d) (mu(X) / zeta_d)^(1/d), mu(X) the volume of
// the bounds, zeta_d the unit ball's volume. APGD-RRT* derives from it and only reshapes the samples;
// GART inserts its states with the same StarInsertion.
//
// Unicycle mode (problem.kinodynamic): the new node must lie in R+ of its parent, and a neighbour is
// rewired only when it lies in R+ of the new node and its own children stay inside the R+ of its new
// heading, so every edge of the tree keeps the unicycle constraint.

#include "ddsnav/planner/run.hpp"

#include <utility>
#include <vector>

namespace ddsnav::planner {

// RRT*'s insertion step: adds `to` under the cheapest neighbour within `radius` whose edge is free and
// reachable by `steering` (R+ in unicycle mode), falling back to `via`, whose edge to `to` the caller
// has already found free; then rewires the neighbours that become cheaper through the new node.
class StarInsertion {
 public:
  struct Parts {
    bool choose_parent = true;  // off: `via` is the parent (plain RRT insertion)
    bool rewire = true;
  };
  // Returns the new node's id.
  int insert(PlannerRun& run, const Steering& steering, const Vec3& to, int via, double radius, Parts parts);
  int insert(PlannerRun& run, const Steering& steering, const Vec3& to, int via, double radius) {
    return insert(run, steering, to, via, radius, Parts{true, true});
  }

 private:
  bool childrenStayReachable(const SearchTree& tree, const Steering& steering, int node, double new_heading) const;

  std::vector<int> near_;
  std::vector<std::pair<double, int>> candidates_;
};

class RrtStarPlanner : public Planner {
 public:
  RrtStarPlanner();
  std::string name() const override { return "rrtstar"; }
  PlanResult solve(const PlanProblem& problem) override;

  double goal_bias = 0.05;
  double rewire_factor = 1.1;

 protected:
  // Hook for sample-shaping variants (APGD-RRT*): returns the point the tree grows towards.
  virtual Vec3 shapeSample(PlannerRun& run, const Vec3& sample) { return sample; }
  virtual bool kinodynamicCapable() const { return true; }

 private:
  StarInsertion insertion_;
};

}  // namespace ddsnav::planner
