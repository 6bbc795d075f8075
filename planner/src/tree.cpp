#include "ddsnav/planner/tree.hpp"

#include "ddsnav/planner/unicycle.hpp"

#include <algorithm>
#include <optional>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace ddsnav::planner {

int SearchTree::add(const State& state, int parent, double cost) {
  const int id = static_cast<int>(nodes_.size());
  TreeNode node;
  node.state = state;
  node.parent = parent;
  node.cost = cost;
  nodes_.push_back(std::move(node));
  if (parent >= 0) nodes_[static_cast<std::size_t>(parent)].children.push_back(id);
  index_.add(state.position);
  return id;
}

void SearchTree::reparent(int node, int new_parent, double new_cost) {
  TreeNode& n = nodes_[static_cast<std::size_t>(node)];
  if (n.parent >= 0) {
    auto& siblings = nodes_[static_cast<std::size_t>(n.parent)].children;
    siblings.erase(std::find(siblings.begin(), siblings.end(), node));
  }
  n.parent = new_parent;
  nodes_[static_cast<std::size_t>(new_parent)].children.push_back(node);
  n.state.heading = edgeHeading(nodes_[static_cast<std::size_t>(new_parent)].state.position, n.state.position, n.state.heading);
  const double delta = new_cost - n.cost;
  // Every descendant's cost-to-come changes by the same amount.
  stack_.assign(1, node);
  while (!stack_.empty()) {
    const int i = stack_.back();
    stack_.pop_back();
    nodes_[static_cast<std::size_t>(i)].cost += delta;
    for (int c : nodes_[static_cast<std::size_t>(i)].children) stack_.push_back(c);
  }
}

std::vector<State> SearchTree::pathTo(int node) const {
  std::vector<State> path;
  for (int i = node; i >= 0; i = nodes_[static_cast<std::size_t>(i)].parent) path.push_back(nodes_[static_cast<std::size_t>(i)].state);
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<TreeEdge> SearchTree::edges() const {
  std::vector<TreeEdge> out;
  out.reserve(nodes_.size());
  for (const TreeNode& n : nodes_) {
    if (n.parent >= 0) out.push_back({nodes_[static_cast<std::size_t>(n.parent)].state.position, n.state.position});
  }
  return out;
}

double Random::normal() {
  const double u1 = 1.0 - uniform();  // (0, 1]
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

Vec3 Random::position(const CollisionWorld& world) {
  const Vec3 lo = world.boundsMin(), hi = world.boundsMax();
  const double x = uniform(lo.x(), hi.x());
  const double y = uniform(lo.y(), hi.y());
  const double z = world.dimensions() == 3 ? uniform(lo.z(), hi.z()) : 0.0;
  return Vec3(x, y, z);
}

namespace {
std::string describe(const Vec3& p, int dims) {
  std::string s = "[" + std::to_string(p.x()) + ", " + std::to_string(p.y());
  if (dims == 3) s += ", " + std::to_string(p.z());
  return s + "]";
}
bool inside(const CollisionWorld& w, const Vec3& p) {
  for (int i = 0; i < w.dimensions(); ++i) {
    if (p[i] < w.boundsMin()[i] || p[i] > w.boundsMax()[i]) return false;
  }
  return true;
}
// Whether some state within `radius` of `goal` is free: the goal itself, then rings at 1/4, 1/2, 3/4 and
// 0.95 of the radius, 16 directions each (and 5 elevations in 3-D). A probe, not a proof: a free pocket
// thinner than the probe spacing is missed, which errs on the side of a clear error.
bool goalRegionHasFreeState(const CollisionWorld& w, const Vec3& goal, double radius) {
  if (w.isFree(goal)) return true;
  const int dims = w.dimensions();
  const double pi = std::numbers::pi;
  for (const double fraction : {0.25, 0.5, 0.75, 0.95}) {
    for (int e = 0; e < (dims == 3 ? 5 : 1); ++e) {
      const double elevation = dims == 3 ? (e - 2) * pi / 6.0 : 0.0;
      for (int a = 0; a < 16; ++a) {
        const double azimuth = a * pi / 8.0;
        const Vec3 offset(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                          std::sin(elevation));
        const Vec3 probe = goal + fraction * radius * offset;
        if (inside(w, probe) && w.isFree(probe)) return true;
      }
    }
  }
  return false;
}
}  // namespace

void validateProblem(const PlanProblem& problem, bool needs_vehicle) {
  if (problem.world == nullptr) throw std::invalid_argument("planning problem has no collision world");
  const CollisionWorld& w = *problem.world;
  const int dims = w.dimensions();
  for (int i = 0; i < dims; ++i) {
    if (!std::isfinite(w.boundsMin()[i]) || !std::isfinite(w.boundsMax()[i]) || !(w.boundsMax()[i] > w.boundsMin()[i])) {
      throw std::invalid_argument("degenerate bounds: max must be greater than min on every axis");
    }
    if (std::abs(w.boundsMin()[i]) > kMaxCoordinate || std::abs(w.boundsMax()[i]) > kMaxCoordinate) {
      throw std::invalid_argument("bounds " + describe(w.boundsMin(), dims) + " - " + describe(w.boundsMax(), dims) +
                                  ": every coordinate must be within +-" + std::to_string(kMaxCoordinate) + " m");
    }
  }
  if (!problem.start.position.allFinite() || !std::isfinite(problem.start.heading)) throw std::invalid_argument("start has non-finite numbers");
  if (!problem.goal.allFinite()) throw std::invalid_argument("goal has non-finite numbers");
  if (!(problem.goal_radius > 0.0) || !std::isfinite(problem.goal_radius)) throw std::invalid_argument("goal_radius must be positive and finite");
  if (!(problem.time_limit_s > 0.0) || std::isnan(problem.time_limit_s)) throw std::invalid_argument("time limit must be positive");
  if (!(problem.improve_for_s >= 0.0)) throw std::invalid_argument("improve_for_s must be >= 0");
  if (problem.max_iterations == 0) throw std::invalid_argument("max iterations must be positive");
  if (!inside(w, problem.start.position)) throw std::invalid_argument("start " + describe(problem.start.position, dims) + " is outside the bounds");
  if (!inside(w, problem.goal)) throw std::invalid_argument("goal " + describe(problem.goal, dims) + " is outside the bounds");
  if (!w.isFree(problem.start.position)) {
    throw std::invalid_argument("start " + describe(problem.start.position, dims) + " is in collision (or the robot does not fit inside the bounds there)");
  }
  // A path is solved when it ends within goal_radius of the goal (scenario format), so only a goal region
  // without any free state makes the problem invalid; the goal point itself may lie in an obstacle.
  if (!goalRegionHasFreeState(w, problem.goal, problem.goal_radius)) {
    throw std::invalid_argument("goal " + describe(problem.goal, dims) + " is in collision, and so is every probed state within goal_radius " +
                                std::to_string(problem.goal_radius) + " of it (or the robot does not fit inside the bounds there)");
  }
  if (!(problem.guide_bias >= 0.0 && problem.guide_bias <= 1.0)) throw std::invalid_argument("guide_bias must be in [0, 1]");
  if (!(problem.guide_spread_m >= 0.0 && problem.guide_spread_m <= kMaxCoordinate)) throw std::invalid_argument("guide_spread_m must be in [0, 1e9] m");
  for (const Vec3& p : problem.guide)
    if (!p.allFinite()) throw std::invalid_argument("a guide point has non-finite numbers");
  if (needs_vehicle) {
    if (!problem.vehicle) throw std::invalid_argument("this planner needs the vehicle limits (scenario 'vehicle' block)");
    const VehicleLimits& v = *problem.vehicle;
    if (!(v.v_max > 0.0) || !(v.omega_max > 0.0) || !(v.dt > 0.0) || !std::isfinite(v.v_max) || !std::isfinite(v.omega_max) ||
        !std::isfinite(v.dt) || !std::isfinite(v.vz_max) || v.vz_max < 0.0) {
      throw std::invalid_argument("vehicle limits must be finite with v_max, omega_max and dt positive");
    }
  }
}

double rrtStarGamma(const CollisionWorld& world) {
  const Vec3 extent = world.boundsMax() - world.boundsMin();
  const int d = world.dimensions();
  const double volume = d == 3 ? extent.x() * extent.y() * extent.z() : extent.x() * extent.y();
  const double unit_ball = d == 3 ? 4.0 / 3.0 * std::numbers::pi : std::numbers::pi;
  return 2.0 * std::pow(1.0 + 1.0 / d, 1.0 / d) * std::pow(volume / unit_ball, 1.0 / d);
}

double rrtStarRadius(double gamma, std::size_t n, int dimensions, double cap) {
  const double count = static_cast<double>(std::max<std::size_t>(n, 2));
  return std::min(cap, gamma * std::pow(std::log(count) / count, 1.0 / dimensions));
}

double pathLength(const std::vector<State>& path) {
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i].position - path[i - 1].position).norm();
  return length;
}

double treeCoverage(const SearchTree& tree, const CollisionWorld& world, std::size_t node_count,
                    const RunClock* clock) {
  node_count = std::min(node_count, tree.size());
  if (node_count == 0) return 1.0;
  const int dims = world.dimensions();
  const Vec3 lo = world.boundsMin(), hi = world.boundsMax();
  const Vec3 extent = hi - lo;
  const double volume = dims == 3 ? extent.x() * extent.y() * extent.z() : extent.x() * extent.y();
  const double target = dims == 3 ? 13824.0 : 4096.0;
  double delta = std::pow(volume / target, 1.0 / dims);
  // Long thin bounds: the +1 per axis would multiply the count (a 1e9 x 10 m strip gives 10^6 points per
  // row), so the spacing grows until the grid is within twice the target.
  auto points = [&](double d) {
    double n = 1.0;
    for (int i = 0; i < dims; ++i) n *= std::floor(extent[i] / d) + 1.0;
    return n;
  };
  while (points(delta) > 2.0 * target) delta *= 1.25;
  // An index over the first node_count nodes only (insertion order = growth order); the tree's own
  // index when that is all of them.
  std::optional<NearestIndex> partial;
  if (node_count < tree.size()) {
    partial.emplace(dims);
    for (std::size_t i = 0; i < node_count; ++i) partial->add(tree.node(static_cast<int>(i)).state.position);
  }
  const NearestIndex& index = partial ? *partial : tree.index();
  const int nx = std::max(1, static_cast<int>(std::floor(extent.x() / delta)) + 1);
  const int ny = std::max(1, static_cast<int>(std::floor(extent.y() / delta)) + 1);
  const int nz = dims == 3 ? std::max(1, static_cast<int>(std::floor(extent.z() / delta)) + 1) : 1;
  double sum = 0.0;
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        if (clock && (i & 255) == 0 && clock->expired()) return -1.0;
        const Vec3 g(lo.x() + i * delta, lo.y() + j * delta, dims == 3 ? lo.z() + k * delta : 0.0);
        const double d = (index.point(index.nearest(g)) - g).norm();
        sum += std::min(d, delta);
      }
    }
  }
  return sum / (delta * static_cast<double>(nx) * ny * nz);
}

double treeGrowth(const SearchTree& tree, const CollisionWorld& world, const RunClock* clock) {
  const std::size_t n = tree.size();
  if (n < 2) return 0.0;
  const std::size_t half = n / 2;
  const double full = treeCoverage(tree, world, n, clock);
  const double earlier = full < 0.0 ? -1.0 : treeCoverage(tree, world, half, clock);
  if (full < 0.0 || earlier < 0.0) return std::numeric_limits<double>::quiet_NaN();
  return -(full - earlier) / static_cast<double>(n - half);
}

std::int64_t firstGlanceConnect(const SearchTree& tree, const PlanProblem& problem,
                                const std::vector<std::int64_t>& node_iteration, std::int64_t up_to_iteration,
                                const RunClock* clock) {
  // Nodes are stored in insertion order, so the first one that sees the goal gives the answer. A solved
  // run only needs the nodes added up to its first solution; an unsolved one scans at most kMaxScan nodes
  // so the metric never costs much more than the search.
  constexpr std::size_t kMaxScan = 100000;
  for (std::size_t i = 0; i < tree.size() && i < kMaxScan; ++i) {
    const std::int64_t iteration = i < node_iteration.size() ? node_iteration[i] : 0;
    if (up_to_iteration >= 0 && iteration > up_to_iteration) break;
    if (clock && (i & 63) == 0 && clock->expired()) return -1;
    if (problem.world->isSegmentFree(tree.node(static_cast<int>(i)).state.position, problem.goal)) return iteration;
  }
  return -1;
}

void finishResult(PlanResult& result, int goal_node, const SearchTree& tree, const PlanProblem& problem,
                  const std::vector<std::int64_t>& node_iteration, std::uint64_t checks_at_start,
                  const RunClock& clock) {
  result.solved = goal_node >= 0;
  if (result.solved) result.path = tree.pathTo(goal_node);
  PlanStats& s = result.stats;
  s.time_s = clock.elapsed();  // the search's time: the metrics below are not part of it
  s.validity_checks = problem.world->validityChecks() - checks_at_start;
  s.vertices = tree.size();
  // Vertices added by sampling (the root is given, not added).
  const double added = tree.size() > 0 ? static_cast<double>(tree.size() - 1) : 0.0;
  s.pous = s.iterations > 0 ? added / static_cast<double>(s.iterations) : 0.0;
  s.por = added > 0.0 ? static_cast<double>(s.rewires) / added : 0.0;
  s.first_directive_connect = s.iterations_to_first_solution;
  if (problem.tree_metrics) {
    // Benchmark work: bounded by what is left of the run's time limit, like everything a request causes.
    s.coverage = treeCoverage(tree, *problem.world, tree.size(), &clock);
    s.growth = s.coverage < 0.0 ? 0.0 : treeGrowth(tree, *problem.world, &clock);
    s.first_glance_connect = firstGlanceConnect(tree, problem, node_iteration, s.iterations_to_first_solution, &clock);
    s.tree_metrics = s.coverage >= 0.0 && !std::isnan(s.growth) && !clock.expired();
    if (std::isnan(s.growth)) s.growth = 0.0;
  }
  result.tree = tree.edges();
  if (!result.path.empty()) {
    result.cost = pathLength(result.path);
    result.exact = (result.path.back().position - problem.goal).norm() <= problem.goal_radius;
  }
}

}  // namespace ddsnav::planner
