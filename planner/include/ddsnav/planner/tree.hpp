#pragma once
// Search-tree bookkeeping shared by every planner: nodes with parent, cost-to-come and children, a k-d
// index over their positions, path extraction, and the run metrics (POUS, POR, c(G), g(G), FGC).

#include "ddsnav/planner/nearest.hpp"
#include "ddsnav/planner/planner.hpp"

#include <chrono>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace ddsnav::planner {

struct TreeNode {
  State state;
  int parent = -1;          // -1 for the root
  double cost = 0.0;        // path length from the root, m
  std::vector<int> children;
};

class SearchTree {
 public:
  explicit SearchTree(int dimensions) : index_(dimensions) {}

  int dimensions() const { return index_.dimensions(); }
  std::size_t size() const { return nodes_.size(); }
  bool empty() const { return nodes_.empty(); }
  const TreeNode& node(int i) const { return nodes_[static_cast<std::size_t>(i)]; }
  const NearestIndex& index() const { return index_; }

  // Adds a node; the root is added with parent -1. Returns its id (insertion order).
  int add(const State& state, int parent, double cost);

  // Moves `node` under `new_parent` with cost-to-come `new_cost` (RRT* rewire), updating every
  // descendant's cost and the node's heading (the direction of its new incoming edge).
  void reparent(int node, int new_parent, double new_cost);

  int nearest(const Vec3& p) const { return index_.nearest(p); }
  void kNearest(const Vec3& p, std::size_t k, std::vector<int>& out) const { index_.kNearest(p, k, out); }
  void withinRadius(const Vec3& p, double r, std::vector<int>& out) const { index_.withinRadius(p, r, out); }

  // States from the root to `node`.
  std::vector<State> pathTo(int node) const;
  // Every parent-child edge, for pictures.
  std::vector<TreeEdge> edges() const;

 private:
  std::vector<TreeNode> nodes_;
  NearestIndex index_;
  std::vector<int> stack_;  // reused by reparent
};

// Deterministic uniform numbers from a seed: the same seed gives the same stream on every run.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  // Uniform in [0, 1), from the top 53 bits (so the result does not depend on the library's distributions).
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : engine_() % n; }
  // Standard normal (Box-Muller; one value per call keeps the stream simple).
  double normal();
  // A uniform position inside the world's bounds (z = 0 in 2-D).
  Vec3 position(const CollisionWorld& world);

 private:
  std::mt19937_64 engine_;
};

// Wall-clock limits of a run: time limit and iteration cap.
class RunClock {
 public:
  explicit RunClock(const PlanProblem& problem)
      : start_(std::chrono::steady_clock::now()), limit_s_(problem.time_limit_s) {}
  double elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  bool expired() const { return elapsed() >= limit_s_; }

 private:
  std::chrono::steady_clock::time_point start_;
  double limit_s_;
};

// Throws std::invalid_argument for a problem no planner can start: no world, non-finite numbers,
// zero/negative limits, start or goal out of bounds or in collision, kinodynamic without a vehicle.
void validateProblem(const PlanProblem& problem, bool needs_vehicle);

// Path length of a polyline of states.
double pathLength(const std::vector<State>& path);

// Karaman-Frazzoli's RRT* constant for the world's bounds volume mu(X): gamma = 2 (1 + 1/d)^(1/d)
// (mu(X) / zeta_d)^(1/d), zeta_d the volume of the unit d-ball. RRT*, GART and APGD-RRT* scale it.
double rrtStarGamma(const CollisionWorld& world);
// The RRT* neighbourhood radius with n nodes (n counted as at least 2): min(cap, gamma (log n / n)^(1/d)).
double rrtStarRadius(double gamma, std::size_t n, int dimensions, double cap);

// Coordinates (bounds, start, goal) beyond this magnitude are rejected by validateProblem: there a
// double's spacing passes a tenth of a millimetre, and squared distances of the nearest-neighbour search
// would head for overflow. 1e9 m is 25 times the Earth's circumference.
inline constexpr double kMaxCoordinate = 1e9;

// c(G) of the Li-RRT paper (eq. 1): overlay a grid of n_g points with spacing delta on the bounds;
// c = (1/delta) * sum_j min(d_j, delta) / n_g, d_j the distance from grid point j to its nearest node.
// Only the first `node_count` nodes are used (the tree as it was when it had that many nodes).
// The grid has about 4096 points in 2-D and 13824 in 3-D (never more than twice that, whatever the
// bounds' aspect ratio); delta follows from the bounds. With a `clock`, returns -1 once it has expired.
double treeCoverage(const SearchTree& tree, const CollisionWorld& world, std::size_t node_count,
                    const RunClock* clock = nullptr);

// g(G) (eq. 2), in difference form: -(c(G_n) - c(G_{n/2})) / (n - n/2), n the final node count.
// NaN when the clock expired first.
double treeGrowth(const SearchTree& tree, const CollisionWorld& world, const RunClock* clock = nullptr);

// First-glance-connect: the iteration at which the first node was added from which the goal is visible
// (the straight segment node-goal is free). `node_iteration[i]` is the iteration that added node i.
// Only nodes added up to `up_to_iteration` are scanned (the first solution's iteration; -1: all, but at
// most the first 100000 nodes). -1 when no scanned node sees the goal, or when `clock` expired first.
// Its checks are not counted in the stats.
std::int64_t firstGlanceConnect(const SearchTree& tree, const PlanProblem& problem,
                                const std::vector<std::int64_t>& node_iteration, std::int64_t up_to_iteration = -1,
                                const RunClock* clock = nullptr);

// Fills the result of a finished run: the path to `goal_node` (-1: not solved) with its cost and
// exactness, and the derived statistics (vertices, POUS, POR, validity checks, time, tree edges) from the
// tree and the counters already in `result.stats`; with problem.tree_metrics also c(G), g(G) and FGC,
// within what is left of the run's time limit.
// `checks_at_start` is world.validityChecks() when the run began.
void finishResult(PlanResult& result, int goal_node, const SearchTree& tree, const PlanProblem& problem,
                  const std::vector<std::int64_t>& node_iteration, std::uint64_t checks_at_start,
                  const RunClock& clock);

}  // namespace ddsnav::planner
