#pragma once
// GART: guiding attraction-based random tree (GART paper, Algorithm 1) on the unicycle edge model.
//
// Each iteration: sample v_s (goal-biased); among the k nearest tree nodes keep the dynamically feasible
// ones (v_s within the max turn theta_m of their heading) and pick the one of least heading-based control
// effort as v_near; project v_s into the forward extending region R+(v_near); redistribute it with the
// bidirectional potential field (events 1-3, then goal attraction) into one or two collision-free states
// inside R+(v_near); add each with RRT*-style parent choice and rewiring that keep every edge in R+.
// The formulas are written out in docs/planners.md ("GART").

#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/unicycle.hpp"

#include <vector>

#include "ddsnav/planner/rrtstar.hpp"

namespace ddsnav::planner {

struct GartOptions {
  int k_nearest = 10;             // k of Nearest(k): candidate parents examined per sample
  double goal_bias = 0.05;        // probability of sampling the goal itself
  double turn_weight = 1.0;       // lambda: weight of the normalised turn in the control-effort cost
  double detection_range = 1.0;   // J_dm, as a fraction of the reach: obstacles farther are not seen
  double attraction_gain = 1.0;   // k1 scale: 1 moves a candidate onto the centroid of the margin nodes
  double repulsion_gain = 0.05;   // k2 = repulsion_gain * J_dm^2: push magnitude k2 / distance
  double max_push = 0.5;          // cap of any obstacle push, as a fraction of the reach
  double goal_gain = 0.2;         // goal attraction step, as a fraction of the reach
  int event1_turn_steps = 4;      // event 1: directions tried per side between the sample and theta_m
  double rewire_gamma = 0.0;      // RRT* gamma; 0 = derived from the bounds' volume (Karaman-Frazzoli)
  // Event 1's shortest edge, in robot radii: 0 keeps the paper's J/4; e.g. 0.5 halves J/4 until the edge
  // would be shorter than half the robot's radius (turning in a corridor barely wider than the robot).
  double event1_min_edge = 0.0;
  // Self-limiting goal attraction (gart-lazy): 0 = the paper's GART, goal attraction and goal sampling on
  // every iteration. k > 0: attraction (and the goal bias) is used with probability L, starting at 1;
  // after every k attracted iterations in a row that bring no node closer to the goal than the closest so
  // far (by at least attraction_progress robot radii), L halves; a new closest node restores L = 1.
  int attraction_patience = 0;
  double attraction_progress = 0.1;  // a "closer" node must beat the record by this many robot radii

  // The parts of the algorithm, each of which can be switched off for the ablation benchmark
  // (docs/benchmarks/planner.md). All on is the paper's GART.
  bool event1 = true;           // collision redistribution: a blocked sample turns into max-turn candidates
  bool event2 = true;           // attraction towards the margin nodes of two or more obstacles
  bool event3 = true;           // repulsion from a single obstacle
  bool goal_attraction = true;  // the final pull of every candidate towards the goal
  bool forward_region = true;   // v_near among the k nearest nodes that can reach the sample (R+); off: the nearest node
  bool effort_parent = true;    // v_near by the dynamic cost metric; off: the closest of the feasible ones
  bool choose_parent = true;    // RRT*'s cheapest-parent choice when a state is inserted
  bool rewire = true;           // RRT*'s rewiring around an inserted state
  // Feasibility first: choose_parent and rewire only start once a first solution exists (gart-lazy).
  bool defer_optimisation = false;
  // While the self-limiting attraction is off for an iteration, v_near is the nearest node (RRT's Voronoi
  // choice) instead of the least-effort one among the k nearest (gart-lazy; needs attraction_patience > 0).
  bool explore_nearest = false;
  // What exploring iterations (those explore_nearest applies to) redistribute with. Off, a part is skipped
  // there as in plain RRT: explore_field the obstacle field (events 2 / 3), explore_event1 event 1 (a
  // blocked extension adds nothing). explore_event1_budget > 0 (gart-lazy: 3): event 1 starts from one node
  // in at most that many exploring iterations; 0: no limit.
  bool explore_field = true;
  bool explore_event1 = true;
  int explore_event1_budget = 0;
  int restart_patience = 0;
};

// gart-lazy's defaults: the paper's GART with event 1's reach search refined down to a tenth of the robot's
// radius, RRT*'s parent choice and rewiring deferred until the first solution, a self-limiting goal
// attraction (attraction_patience 20, goal_bias 0.1), exploring iterations from the nearest node with
// event 1 at most 3 times per node, and restarts on stagnation (docs/planners.md).
GartOptions gartLazyOptions();

// Which branch of the bidirectional potential field produced a candidate.
enum class GartEvent {
  kFree = 0,       // the projected sample was reachable and no obstacle was in range: kept as is
  kCollision = 1,  // event 1: the projected sample collided; a max-turn candidate on one side
  kAttraction = 2, // event 2: two or more obstacles in range; pulled towards their margin nodes
  kRepulsion = 3,  // event 3: one obstacle in range; pushed away from its margin node
};

struct GartCandidate {
  State state;               // inside R+(parent), edge parent -> state collision free
  bool from_collision = false;  // generated by event 1
  GartEvent field = GartEvent::kFree;  // the obstacle force that finally applied (2, 3 or none)
  bool redistributed = false;  // the force / goal attraction moved it (false: fell back to the raw candidate)
};

// Heading-based control effort of reaching `target` from `from` (the dynamic cost metric):
//   c(v, v_s) = lambda * |phi(v, v_s - v)| / theta_m + |v_s - v| / J,
// phi the angle between v's heading and the direction to v_s. +inf when |phi| > theta_m (not feasible).
double gartControlEffort(const State& from, const Vec3& target, const ForwardRegion& region,
                         double turn_weight);

// Lines 5-13 of Algorithm 1: redistribute the sample v_s from the chosen parent. Returns zero, one or two
// candidates, each collision free and inside R+(parent). `goal` feeds the final goal attraction.
std::vector<GartCandidate> gartRedistribute(const State& parent, const Vec3& sample, const Vec3& goal,
                                            const CollisionWorld& world, const ForwardRegion& region,
                                            const GartOptions& options);
// The same into `out` (cleared first): the planner's loop reuses one buffer.
void gartRedistribute(const State& parent, const Vec3& sample, const Vec3& goal, const CollisionWorld& world,
                      const ForwardRegion& region, const GartOptions& options, std::vector<GartCandidate>& out);

// The obstacle part of the bidirectional potential field at `p` (events 2 and 3): the displacement it
// applies and which event fired (kFree when no obstacle is within the detection range).
struct GartForce {
  Vec3 displacement = Vec3::Zero();
  GartEvent event = GartEvent::kFree;
  int obstacles = 0;
};
GartForce gartObstacleForce(const Vec3& p, const CollisionWorld& world, const ForwardRegion& region,
                            const GartOptions& options);

class GartPlanner : public Planner {
 public:
  explicit GartPlanner(GartOptions options = {}, std::string name = "gart");
  std::string name() const override { return name_; }
  PlanResult solve(const PlanProblem& problem) override;
  const GartOptions& gartOptions() const { return options_; }

 private:
  GartOptions options_;
  std::string name_;
};

}  // namespace ddsnav::planner
