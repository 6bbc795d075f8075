// GART (GART paper, Algorithm 1): sampling, dynamically feasible parent choice, redistribution (see
// gart_redistribute.cpp), and RRT*'s insertion and rewiring (StarInsertion) keeping every edge inside R+.
#include "ddsnav/planner/gart.hpp"

#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_set>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ddsnav::planner {
namespace {

// Whether the tree still grows into space it had not reached: cells a robot radius wide (a hash set of the
// cells any node was added in). A run whose nodes only pile up where the tree already is for
// `patience x 2^restarts` iterations is stuck, typically a branch whose headings all end in a wall
// (kinodynamic trees in narrow corridors have a heavy-tailed run time; restarts with a doubling patience
// cut that tail and keep completeness: each attempt may run longer than the last).
class StagnationWatch {
 public:
  StagnationWatch(const CollisionWorld& world, int patience)
      : cell_(std::max(world.robotRadius(), world.checkResolution())),
        origin_(world.boundsMin()),
        three_d_(world.dimensions() == 3),
        patience_(static_cast<std::uint64_t>(patience)) {
    // A dense bitmap when the bounds hold at most 2^24 cells (a 110 m world at a 0.5 m robot radius: 49 k),
    // else the hash set: a node-based set allocates on every new cell, a bitmap never.
    const Vec3 extent = (world.boundsMax() - world.boundsMin()) / cell_;
    const double nx = std::floor(extent.x()) + 1.0, ny = std::floor(extent.y()) + 1.0;
    const double nz = three_d_ ? std::floor(extent.z()) + 1.0 : 1.0;
    if (patience_ > 0 && nx * ny * nz <= double(1 << 24)) {
      nx_ = static_cast<std::uint64_t>(nx);
      ny_ = static_cast<std::uint64_t>(ny);
      dense_.assign(static_cast<std::size_t>(nx * ny * nz), false);
    }
  }

  void reached(const Vec3& p) {
    if (patience_ == 0) return;
    const Vec3 c = (p - origin_) / cell_;
    const auto cx = static_cast<std::uint64_t>(c.x()), cy = static_cast<std::uint64_t>(c.y());
    const auto cz = three_d_ ? static_cast<std::uint64_t>(c.z()) : 0;
    if (!dense_.empty()) {
      const std::size_t index = static_cast<std::size_t>(cx + nx_ * (cy + ny_ * cz));
      if (index < dense_.size() && !dense_[index]) {
        dense_[index] = true;
        since_new_cell_ = 0;
      }
      return;
    }
    // Cell coordinates inside validated bounds (|x| <= 1e9 m) fit 21 bits each at any robot radius >= 1e-3 m.
    const auto key = (cx & 0x1FFFFF) | ((cy & 0x1FFFFF) << 21) | ((cz & 0x1FFFFF) << 42);
    if (cells_.insert(key).second) since_new_cell_ = 0;
  }
  // Counts one iteration; true when the tree has stagnated.
  bool stalled() { return patience_ > 0 && ++since_new_cell_ > patience_ << std::min<std::uint64_t>(restarts_, 20); }
  void restart() {
    cells_.clear();
    std::fill(dense_.begin(), dense_.end(), false);
    since_new_cell_ = 0;
    ++restarts_;
  }

 private:
  double cell_;
  Vec3 origin_;
  bool three_d_;
  std::uint64_t patience_;
  std::uint64_t restarts_ = 0;
  std::uint64_t since_new_cell_ = 0;
  std::uint64_t nx_ = 0, ny_ = 0;
  std::vector<bool> dense_;
  std::unordered_set<std::uint64_t> cells_;
};

}  // namespace

GartOptions gartLazyOptions() {
  GartOptions o;
  o.event1_min_edge = 0.1;
  o.defer_optimisation = true;
  o.attraction_patience = 20;
  o.goal_bias = 0.1;  // only used while the attraction is active (docs/planners.md)
  o.explore_nearest = true;
  o.explore_event1_budget = 3;
  o.restart_patience = 5000;
  return o;
}

GartPlanner::GartPlanner(GartOptions options, std::string name) : options_(options), name_(std::move(name)) {
  GartOptions& o = options_;
  addOption("k_nearest", &o.k_nearest, 1, 1000, "candidate parents examined per sample");
  addOption("goal_bias", &o.goal_bias, 0.0, 1.0, "probability of sampling the goal");
  addOption("turn_weight", &o.turn_weight, 0.0, 1000.0, "lambda: weight of the turn in the control effort");
  addOption("detection_range", &o.detection_range, 1e-3, 100.0, "J_dm as a fraction of the reach");
  addOption("attraction_gain", &o.attraction_gain, 0.0, 10.0, "event 2's pull towards the margin nodes' centroid");
  addOption("repulsion_gain", &o.repulsion_gain, 0.0, 10.0, "event 3's push, k2 = gain * J_dm^2");
  addOption("max_push", &o.max_push, 0.0, 10.0, "cap of an obstacle push, fraction of the reach");
  addOption("goal_gain", &o.goal_gain, 0.0, 10.0, "goal attraction step, fraction of the reach");
  addOption("event1_turn_steps", &o.event1_turn_steps, 1, 64, "event 1: directions tried per side");
  addOption("event1_min_edge", &o.event1_min_edge, 0.0, 100.0, "event 1's shortest edge in robot radii (0: J/4)");
  addOption("attraction_patience", &o.attraction_patience, 0, 1000000,
            "attracted iterations without goal progress before the attraction halves (0: always attract)");
  addOption("attraction_progress", &o.attraction_progress, 0.0, 1000.0,
            "goal progress that restores the attraction, in robot radii");
  addOption("rewire_gamma", &o.rewire_gamma, 0.0, 1e12, "RRT* gamma; 0 derives it from the bounds");
  addOption("event1", &o.event1, "collision redistribution (event 1)");
  addOption("event2", &o.event2, "attraction between obstacles (event 2)");
  addOption("event3", &o.event3, "repulsion from one obstacle (event 3)");
  addOption("goal_attraction", &o.goal_attraction, "final pull towards the goal");
  addOption("forward_region", &o.forward_region, "v_near among the k nearest that can reach the sample");
  addOption("effort_parent", &o.effort_parent, "v_near by the dynamic cost metric");
  addOption("choose_parent", &o.choose_parent, "RRT* cheapest-parent choice at insertion");
  addOption("rewire", &o.rewire, "RRT* rewiring");
  addOption("defer_optimisation", &o.defer_optimisation, "parent choice and rewiring only after the first solution");
  addOption("restart_patience", &o.restart_patience, 0, 100000000,
            "iterations without a node in a new cell before the tree is grown again (doubles per restart; 0: never)");
  addOption("explore_nearest", &o.explore_nearest, "non-attracting iterations extend the nearest node (RRT's choice)");
  addOption("explore_field", &o.explore_field, "exploring iterations apply events 2 and 3");
  addOption("explore_event1", &o.explore_event1, "exploring iterations apply event 1");
  addOption("explore_event1_budget", &o.explore_event1_budget, 0, 255,
            "exploring iterations apply event 1 from a node at most this many times (0: no limit)");
}

PlanResult GartPlanner::solve(const PlanProblem& problem) {
  checkOptions();
  PlannerRun run(problem, name(), /*kinodynamic=*/true);
  const CollisionWorld& world = run.world;
  const ForwardRegion region = forwardRegion(*run.problem.vehicle, world.dimensions());
  const Steering steering = Steering::unicycle(region);
  const double edge_reach = std::hypot(region.reach, region.max_climb);
  const double gamma = options_.rewire_gamma > 0.0 ? options_.rewire_gamma : rrtStarGamma(world);
  const StarInsertion::Parts parts{options_.choose_parent, options_.rewire};
  const StarInsertion::Parts feasibility_first{false, false};
  const std::size_t k = options_.forward_region ? static_cast<std::size_t>(options_.k_nearest) : 1;
  StarInsertion insertion;
  std::vector<int> knn;
  std::vector<GartCandidate> candidates;  // one buffer for every iteration's redistributed states
  std::vector<std::uint8_t> event1_uses;  // per node: exploring iterations whose event 1 started from it
  // Self-limiting goal attraction (docs/planners.md, gart-lazy): level L, record distance to the goal.
  const bool self_limiting = options_.goal_attraction && options_.attraction_patience > 0;
  const double progress_step = options_.attraction_progress * world.robotRadius();
  double attraction_level = 1.0;
  int fruitless_attractions = 0;
  double closest_to_goal = (run.problem.start.position - run.problem.goal).norm();
  GartOptions step_options = options_;
  StagnationWatch stagnation(world, options_.restart_patience);

  while (run.nextIteration()) {
    // Whether this iteration attracts towards the goal (always, unless the attraction is self-limiting).
    const bool attract = !self_limiting || run.rng.uniform() < attraction_level;
    step_options.goal_attraction = options_.goal_attraction && attract;

    // Line 3: sample.
    const Vec3 sample = run.sample(attract ? options_.goal_bias : 0.0);

    // Line 4: among the k nearest, the dynamically feasible parent of least control effort (or, with
    // effort_parent off, the closest feasible one); when none is feasible (the sample is behind every
    // near node) the nearest one steers at its maximum turn.
    const bool explore = self_limiting && options_.explore_nearest && !attract;
    run.tree.kNearest(sample, explore ? 1 : k, knn);
    if (knn.empty()) continue;  // no node at a finite distance (cannot happen inside validated bounds)
    // Exploring iterations redistribute like attracting ones, except that event 1 starts from one node at
    // most explore_event1_budget times: a node pinned against a wall that keeps being the nearest one to far
    // samples has had its turns away from the wall (docs/planners.md, session 6).
    const auto near_id = static_cast<std::size_t>(knn.front());
    if (event1_uses.size() < run.tree.size()) event1_uses.resize(run.tree.size(), 0);
    const bool within_budget = options_.explore_event1_budget == 0 || event1_uses[near_id] < options_.explore_event1_budget;
    step_options.event1 = options_.event1 && (!explore || (options_.explore_event1 && within_budget));
    step_options.event2 = options_.event2 && (!explore || options_.explore_field);
    step_options.event3 = options_.event3 && (!explore || options_.explore_field);
    int v_near = knn.front();
    double best = std::numeric_limits<double>::infinity();
    // With one node (an exploring iteration) there is nothing to choose: its effort is not computed.
    for (std::size_t i = 0; knn.size() > 1 && i < knn.size(); ++i) {
      const int n = knn[i];
      const double effort = gartControlEffort(run.tree.node(n).state, sample, region, options_.turn_weight);
      const double score = options_.effort_parent || !std::isfinite(effort) ? effort : (run.tree.node(n).state.position - sample).norm();
      if (score < best) {
        best = score;
        v_near = n;
      }
    }

    // Lines 5-13: redistribute into one or two collision-free states inside R+(v_near).
    gartRedistribute(run.tree.node(v_near).state, sample, run.problem.goal, world, region, step_options, candidates);
    // A blocked extension from near_id used its event 1 (every candidate then comes from event 1, or none).
    const bool blocked = candidates.empty() || candidates.front().from_collision;
    if (explore && step_options.event1 && blocked && event1_uses[near_id] < 255) ++event1_uses[near_id];

    // Lines 14-16: add each state with the cheapest R+-feasible parent, then rewire around it. v_near's
    // edge was checked by the redistribution.
    bool progress = false;
    for (const GartCandidate& candidate : candidates) {
      const double radius = rrtStarRadius(gamma, run.tree.size(), world.dimensions(), edge_reach);
      const int added = insertion.insert(run, steering, candidate.state.position, v_near, radius,
                                         options_.defer_optimisation && !run.solved() ? feasibility_first : parts);
      if (added < 0) continue;
      stagnation.reached(run.tree.node(added).state.position);
      const double distance = (run.tree.node(added).state.position - run.problem.goal).norm();
      if (distance < closest_to_goal - progress_step) {
        closest_to_goal = distance;
        progress = true;
      }
    }
    if (!run.solved() && stagnation.stalled()) {
      run.restart();
      stagnation.restart();
      event1_uses.clear();
      attraction_level = 1.0;
      fruitless_attractions = 0;
      closest_to_goal = (run.problem.start.position - run.problem.goal).norm();
      continue;
    }
    if (!self_limiting) continue;
    if (progress) {
      attraction_level = 1.0;
      fruitless_attractions = 0;
    } else if (attract && ++fruitless_attractions >= options_.attraction_patience) {
      attraction_level *= 0.5;
      fruitless_attractions = 0;
    }
  }
  return run.finish();
}

std::unique_ptr<Planner> makeGartPlanner() {
  return std::make_unique<GartPlanner>();
}

std::unique_ptr<Planner> makeGartLazyPlanner() { return std::make_unique<GartPlanner>(gartLazyOptions(), "gart-lazy"); }

}  // namespace ddsnav::planner
