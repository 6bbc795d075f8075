// findCoarseRoute: A* on a lattice of cell centres, with the passability of each cell looked up once.
#include "ddsnav/planner/coarse_route.hpp"

#include "ddsnav/planner/tree.hpp"
#include "ddsnav/planner/unicycle.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <limits>
#include <queue>
#include <stdexcept>
#include <unordered_map>

namespace ddsnav::planner {
namespace {

constexpr std::uint32_t kNoParent = std::numeric_limits<std::uint32_t>::max();
constexpr std::int8_t kNotLookedUp = -2, kNone = -1;

struct Cell {
  double g = std::numeric_limits<double>::infinity();  // route length from the start's cell
  std::uint32_t parent = kNoParent;
  std::int8_t free_point = kNotLookedUp;  // which of the cell's probe points is free (Lattice::probe), or kNone
  bool closed = false;
  bool seen = false;  // looked up (DenseCells counts these)
};

// The cells the search has looked up, by lattice index. A lattice of at most kDenseCells cells (a 2-D world of
// 128 x 128 m at a 0.5 m robot) holds them all in one array, allocated once per search; a larger one in a hash map
// of the cells seen. Why: on a recorded bugtrap_0.4 map the hash map's lookups, rehashes and allocations took 60 % of
// a search (perf), and in the planner the search gave up after 30 ms with the preferred world still undecided.
constexpr std::size_t kDenseCells = std::size_t(1) << 18;  // 4 MB of cells

class DenseCells {
 public:
  explicit DenseCells(std::size_t n) : cells_(n) {}
  Cell& operator[](std::uint32_t index) {
    Cell& c = cells_[index];
    if (!c.seen) c.seen = true, ++seen_;
    return c;
  }
  std::size_t size() const { return seen_; }

 private:
  std::vector<Cell> cells_;
  std::size_t seen_ = 0;
};

class SparseCells {
 public:
  SparseCells() { cells_.reserve(4096); }
  Cell& operator[](std::uint32_t index) { return cells_[index]; }
  std::size_t size() const { return cells_.size(); }

 private:
  std::unordered_map<std::uint32_t, Cell> cells_;
};

class Lattice {
 public:
  Lattice(const CollisionWorld& world, double cell) : world_(world), cell_(cell), three_d_(world.dimensions() == 3) {
    const Vec3 extent = world.boundsMax() - world.boundsMin();
    auto count = [&](double e) { return std::max<std::uint32_t>(1, static_cast<std::uint32_t>(std::floor(e / cell))); };
    nx_ = count(extent.x());
    ny_ = count(extent.y());
    nz_ = three_d_ ? count(extent.z()) : 1;
  }

  std::uint32_t indexOf(const Vec3& p) const {
    const Vec3 c = (p - world_.boundsMin()) / cell_;
    auto clampTo = [](double v, std::uint32_t n) { return static_cast<std::uint32_t>(std::clamp(std::floor(v), 0.0, double(n - 1))); };
    return clampTo(c.x(), nx_) + nx_ * (clampTo(c.y(), ny_) + ny_ * (three_d_ ? clampTo(c.z(), nz_) : 0));
  }
  Vec3 centre(std::uint32_t index) const { return centre(index % nx_, (index / nx_) % ny_, index / (nx_ * ny_)); }
  Vec3 centre(std::int64_t i, std::int64_t j, std::int64_t k) const {
    Vec3 c = world_.boundsMin() + cell_ * Vec3(double(i) + 0.5, double(j) + 0.5, three_d_ ? double(k) + 0.5 : 0.0);
    if (!three_d_) c.z() = 0.0;
    return c;
  }
  std::size_t size() const { return std::size_t(nx_) * ny_ * nz_; }
  // Probe point k of a cell: its centre (k = 0), then its corners (1-4 in 2-D, 1-8 in 3-D). A cell is passable when
  // the robot is free at one of them: the corners halve the spacing at which a passage is resolved for a fifth (a
  // ninth) of the cost of a lattice twice as fine.
  int probes() const { return three_d_ ? 9 : 5; }
  Vec3 probe(std::uint32_t index, int k) const { return probeAround(centre(index), k); }
  Vec3 probeAround(Vec3 c, int k) const {
    if (k == 0) return c;
    const int corner = k - 1;
    c.x() += (corner & 1 ? 0.5 : -0.5) * cell_;
    c.y() += (corner & 2 ? 0.5 : -0.5) * cell_;
    if (three_d_) c.z() += (corner & 4 ? 0.5 : -0.5) * cell_;
    return c;
  }
  // Calls fn(neighbour index, its centre) for the 8 / 26 neighbours inside the lattice (the centre without the
  // divisions centre(index) takes: the search looks up every neighbour of every cell it expands).
  template <class Fn>
  void forNeighbours(std::uint32_t index, Fn&& fn) const {
    const std::int64_t i = index % nx_, j = (index / nx_) % ny_, k = index / (nx_ * ny_);
    const int dz = three_d_ ? 1 : 0;
    for (int z = -dz; z <= dz; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
          if (x == 0 && y == 0 && z == 0) continue;
          const std::int64_t a = i + x, b = j + y, c = k + z;
          if (a < 0 || b < 0 || c < 0 || a >= nx_ || b >= ny_ || c >= nz_) continue;
          fn(static_cast<std::uint32_t>(a + std::int64_t(nx_) * (b + std::int64_t(ny_) * c)), centre(a, b, c));
        }
  }
  // Calls fn(index, centre) for the cells two steps away along each axis (4 / 6), inside the lattice.
  template <class Fn>
  void forTwoAlongAxes(std::uint32_t index, Fn&& fn) const {
    const std::int64_t i = index % nx_, j = (index / nx_) % ny_, k = index / (nx_ * ny_);
    const std::int64_t steps[6][3] = {{2, 0, 0}, {-2, 0, 0}, {0, 2, 0}, {0, -2, 0}, {0, 0, 2}, {0, 0, -2}};
    for (int s = 0; s < (three_d_ ? 6 : 4); ++s) {
      const std::int64_t a = i + steps[s][0], b = j + steps[s][1], c = k + steps[s][2];
      if (a < 0 || b < 0 || c < 0 || a >= nx_ || b >= ny_ || c >= nz_) continue;
      fn(static_cast<std::uint32_t>(a + std::int64_t(nx_) * (b + std::int64_t(ny_) * c)), centre(a, b, c));
    }
  }

 private:
  const CollisionWorld& world_;
  double cell_;
  bool three_d_;
  std::uint32_t nx_ = 1, ny_ = 1, nz_ = 1;
};

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void checkFinite(const Vec3& v, const char* what) {
  if (!v.allFinite()) throw std::invalid_argument(std::string("findCoarseRoute: ") + what + " is not finite");
}

template <class Cells>
CoarseRoute search(const CollisionWorld& world, const Lattice& lattice, double cell, const Vec3& start, const Vec3& goal, double goal_radius,
                   const CoarseRouteOptions& options, Cells& cells, std::chrono::steady_clock::time_point started, double cpu_started) {
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(); };
  auto outOfTime = [&] {
    return elapsed() > options.time_limit_s ||
           (options.cpu_time_limit_s > 0.0 && threadCpuSeconds() - cpu_started > options.cpu_time_limit_s);
  };
  const bool three_d = world.dimensions() == 3;
  CoarseRoute route;
  route.cell_m = cell;
  // Moves join free probe points of neighbouring cells, at most two cell diagonals apart. They are not checked
  // between their ends while a wall could not lie there unseen (free at both ends means nothing within the robot
  // radius of either: a move up to twice the radius long cannot cross an obstacle, whatever its thickness) — the
  // default spacing. A coarsened lattice checks each move's segment.
  const double diagonal = cell * std::sqrt(three_d ? 3.0 : 2.0);
  const bool check_segments = diagonal > world.robotRadius();
  const double goal_reach = std::max(goal_radius, cell);

  using Entry = std::pair<double, std::uint32_t>;  // (g + h, index)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  auto heuristic = [&](const Vec3& c) { return options.heuristic_weight * std::max(0.0, (c - goal).norm() - goal_reach); };
  auto passable = [&](const Vec3& centre, Cell& c) {
    for (int k = 0; c.free_point == kNotLookedUp && k < lattice.probes(); ++k)
      if (world.isFree(lattice.probeAround(centre, k))) c.free_point = static_cast<std::int8_t>(k);
    if (c.free_point == kNotLookedUp) c.free_point = kNone;
    return c.free_point != kNone;
  };
  auto point = [&](std::uint32_t index) { return lattice.probe(index, std::max<int>(cells[index].free_point, 0)); };

  const std::uint32_t first = lattice.indexOf(start);
  {
    Cell& c = cells[first];
    c.g = 0.0;
    c.free_point = 0;  // passable: the vehicle is there
    open.emplace(heuristic(lattice.centre(first)), first);
  }
  std::uint32_t reached = kNoParent;
  while (!open.empty()) {
    if ((route.expanded & 255) == 0 && (outOfTime() || options.stop.stop_requested())) break;
    if (cells.size() >= options.max_cells_seen) break;
    const std::uint32_t index = open.top().second;  // a plain variable: lambdas below capture it
    open.pop();
    Cell& here = cells[index];
    if (here.closed) continue;
    here.closed = true;
    ++route.expanded;
    const Vec3 at = index == first ? start : point(index);
    if ((at - goal).norm() <= goal_reach) {
      reached = index;
      break;
    }
    const double g_here = here.g;
    // Near a wall when a neighbour, or a cell two steps away along an axis, is impassable (a cell outside the lattice is
    // the bounds, not a wall). The neighbours alone are not enough: the cells next to the impassable ones are passable
    // only at a corner probe, and the route ran in the row beyond them, at the least clearance the lattice holds. The
    // whole 5 x 5 square doubled the search's time on a bug trap's map; the axes add 4 cells to the 8.
    bool next_to_wall = false;
    if (options.wall_cost > 0.0) {
      const auto look = [&](std::uint32_t near, const Vec3& centre) { next_to_wall = next_to_wall || !passable(centre, cells[near]); };
      lattice.forNeighbours(index, look);
      if (!next_to_wall) lattice.forTwoAlongAxes(index, look);
    }
    const double move_cost = next_to_wall ? 1.0 + options.wall_cost : 1.0;
    lattice.forNeighbours(index, [&](std::uint32_t next, const Vec3& centre) {
      Cell& n = cells[next];
      if (n.closed || !passable(centre, n)) return;
      const Vec3 to = lattice.probeAround(centre, n.free_point);
      const double g = g_here + move_cost * (to - at).norm();
      if (g >= n.g) return;
      if (check_segments && !world.isSegmentFree(at, to)) return;
      n.g = g;
      n.parent = index;
      open.emplace(g + heuristic(to), next);
    });
  }

  route.time_s = elapsed();
  if (reached == kNoParent) {
    route.outcome = open.empty() ? CoarseRoute::Outcome::none : CoarseRoute::Outcome::gave_up;
    return route;
  }
  route.outcome = CoarseRoute::Outcome::found;
  for (std::uint32_t i = reached; i != kNoParent; i = cells[i].parent) route.waypoints.push_back(point(i));
  std::reverse(route.waypoints.begin(), route.waypoints.end());
  route.waypoints.front() = start;
  for (std::size_t i = 1; i < route.waypoints.size(); ++i) route.length_m += (route.waypoints[i] - route.waypoints[i - 1]).norm();
  return route;
}

}  // namespace

CoarseRoute findCoarseRoute(const CollisionWorld& world, const Vec3& start_in, const Vec3& goal_in, double goal_radius,
                            const CoarseRouteOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  const double cpu_started = threadCpuSeconds();
  checkFinite(start_in, "the start");
  checkFinite(goal_in, "the goal");
  if (!std::isfinite(goal_radius) || goal_radius < 0.0) throw std::invalid_argument("findCoarseRoute: goal_radius must be finite and >= 0");
  if (!(options.heuristic_weight >= 1.0 && options.heuristic_weight <= 100.0))
    throw std::invalid_argument("findCoarseRoute: heuristic_weight must be in [1, 100]");
  if (!(options.cell_m >= 0.0 && options.cell_m <= 1e6)) throw std::invalid_argument("findCoarseRoute: cell_m must be in [0, 1e6] m");
  if (!(options.cpu_time_limit_s >= 0.0)) throw std::invalid_argument("findCoarseRoute: cpu_time_limit_s must be >= 0");
  if (!(options.wall_cost >= 0.0 && options.wall_cost <= 100.0)) throw std::invalid_argument("findCoarseRoute: wall_cost must be in [0, 100]");
  const bool three_d = world.dimensions() == 3;
  Vec3 start = start_in, goal = goal_in;
  if (!three_d) start.z() = goal.z() = 0.0;
  const Vec3 lo = world.boundsMin(), hi = world.boundsMax();
  for (int a = 0; a < (three_d ? 3 : 2); ++a)
    if (start[a] < lo[a] || start[a] > hi[a]) throw std::invalid_argument("findCoarseRoute: the start is outside the bounds");

  // The spacing: as asked, or half the robot radius, coarsened to the cell budget (the bounds' volume over it).
  const Vec3 extent = hi - lo;
  const double volume = three_d ? extent.x() * extent.y() * extent.z() : extent.x() * extent.y();
  const double budget = static_cast<double>(std::max<std::size_t>(options.max_lattice_cells, 1));
  const double smallest = std::max(std::pow(volume / budget, three_d ? 1.0 / 3.0 : 0.5), 1e-3);
  auto searchAt = [&](double cell) {
    const Lattice lattice(world, cell);
    if (lattice.size() <= kDenseCells) {
      DenseCells cells(lattice.size());
      return search(world, lattice, cell, start, goal, goal_radius, options, cells, started, cpu_started);
    }
    SparseCells cells;
    return search(world, lattice, cell, start, goal, goal_radius, options, cells, started, cpu_started);
  };
  auto withCpu = [&](CoarseRoute route) {
    route.cpu_s = threadCpuSeconds() - cpu_started;
    return route;
  };
  if (options.cell_m > 0.0) return withCpu(searchAt(std::max(options.cell_m, smallest)));

  // By default two lattices, the coarser first: cells whose diagonal is the robot radius (the widest at which moves
  // need no segment checks) hold half the cells of the half-radius lattice in 2-D. From inside bugtrap_0.4's trap the
  // half-radius search has to fill the trap, ~37 000 cells, more than it expands in the planner's 30 ms; the coarse one
  // resolves passages with ~0.35 r of play instead of 0.25 r. Only when it finds no route is the finer lattice
  // searched, in the time left: "none" stays a statement about the finest lattice.
  const double fine = std::max(0.5 * world.robotRadius(), smallest);
  const double coarse = world.robotRadius() / std::sqrt(three_d ? 3.0 : 2.0);
  if (!(coarse > fine * 1.05)) return withCpu(searchAt(fine));
  CoarseRoute first = searchAt(coarse);
  if (first.outcome != CoarseRoute::Outcome::none) return withCpu(std::move(first));
  CoarseRoute second = searchAt(fine);
  second.expanded += first.expanded;
  return withCpu(std::move(second));
}


void guideAlong(PlanProblem& problem, const CoarseRoute& route, double bias) {
  if (route.outcome != CoarseRoute::Outcome::found || problem.world == nullptr) return;
  problem.guide = route.waypoints;
  problem.guide_bias = bias;
  problem.guide_spread_m = std::max(problem.world->robotRadius(), route.cell_m);
}

void guideAlongPath(PlanProblem& problem, const std::vector<Vec3>& path, double bias) {
  if (path.size() < 2 || problem.world == nullptr || !(bias > 0.0)) return;
  const double radius = std::max(problem.world->robotRadius(), 0.05);
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  if (!std::isfinite(length)) return;
  // Each edge adds at most one point more than its length / step: the bound holds along the whole path up to
  // kMaxPathGuidePoints / 2 edges (beyond, the points end early).
  const std::size_t edges = std::min(path.size() - 1, kMaxPathGuidePoints / 2);
  const double step = std::max(radius, length / static_cast<double>(kMaxPathGuidePoints - edges - 1));
  std::vector<Vec3> points;
  for (std::size_t i = 1; i < path.size() && points.size() < kMaxPathGuidePoints; ++i) {
    const Vec3 edge = path[i] - path[i - 1];
    const auto pieces = static_cast<std::size_t>(std::ceil(edge.norm() / step));
    for (std::size_t k = 0; k < pieces && points.size() < kMaxPathGuidePoints; ++k)
      points.push_back(path[i - 1] + edge * (static_cast<double>(k) / static_cast<double>(pieces)));
  }
  if (points.size() < kMaxPathGuidePoints) points.push_back(path.back());
  const auto nearest = std::min_element(points.begin(), points.end(), [&](const Vec3& a, const Vec3& b) {
    return (a - problem.start.position).squaredNorm() < (b - problem.start.position).squaredNorm();
  });
  std::vector<Vec3> guide;
  for (auto it = nearest; it != points.end(); ++it)
    if (problem.world->isFree(*it)) guide.push_back(*it);
  if (guide.empty()) return;
  problem.guide = std::move(guide);
  problem.guide_bias = bias;
  problem.guide_spread_m = 2.0 * radius;
}

namespace {

bool bridgeClippedMoves(const CollisionWorld& world, std::vector<Vec3>& points, double cell_m) {
  const bool in_3d = world.dimensions() == 3;
  std::vector<Vec3> offsets;
  for (const double scale : {0.5 * cell_m, cell_m})
    for (int dz = in_3d ? -1 : 0; dz <= (in_3d ? 1 : 0); ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (dx != 0 || dy != 0 || dz != 0) offsets.push_back(scale * Vec3(dx, dy, dz));
  std::vector<Vec3> bridged{points.front()};
  for (std::size_t i = 1; i < points.size(); ++i) {
    const Vec3 a = bridged.back();  // a copy: bridged grows below
    const Vec3& b = points[i];
    if (!world.isSegmentFree(a, b)) {
      const Vec3 middle = 0.5 * (a + b);
      const auto bridge = std::find_if(offsets.begin(), offsets.end(), [&](const Vec3& offset) {
        return world.isSegmentFree(a, middle + offset) && world.isSegmentFree(middle + offset, b);
      });
      if (bridge == offsets.end()) return false;
      bridged.push_back(middle + *bridge);
    }
    bridged.push_back(b);
  }
  points = std::move(bridged);
  return true;
}

}  // namespace

std::vector<State> pathAlongRoute(const CollisionWorld& world, const CoarseRoute& route, const State& start, const Vec3& goal,
                                  double goal_radius) {
  if (route.outcome != CoarseRoute::Outcome::found || route.waypoints.empty()) return {};
  // The start's cell centre is not where the vehicle is; the exact start takes its place.
  std::vector<Vec3> points{start.position};
  points.insert(points.end(), route.waypoints.begin() + 1, route.waypoints.end());
  if ((points.back() - goal).norm() > goal_radius) {
    if (!world.isFree(goal)) return {};
    points.push_back(goal);
  }
  // Two consecutive waypoints are both free, but on the coarse lattice the move between them is not checked, and where
  // one of them is a corner probe it may clip the corner it was probed beside by a centimetre (a 3 m gap in a wall:
  // 0.71 m moves past the wall's end). Such a move is bridged by a point half a cell or a cell off its middle that
  // sees both ends; with none, the route is no path.
  if (!bridgeClippedMoves(world, points, route.cell_m)) return {};
  // A shortcut keeps the smaller of its ends' clearances, up to a cell, less a tenth of a cell; consecutive points need
  // only be free (the route's own moves).
  std::vector<double> clearance(points.size(), std::numeric_limits<double>::quiet_NaN());
  const auto clearanceAt = [&](std::size_t i) {
    if (std::isnan(clearance[i])) clearance[i] = world.clearance(points[i]);
    return clearance[i];
  };
  const double cell = route.cell_m;
  const auto sees = [&](std::size_t from, std::size_t to) {
    if (!world.isSegmentFree(points[from], points[to])) return false;
    if (to == from + 1) return true;
    const double kept = std::min({cell, clearanceAt(from), clearanceAt(to)}) - 0.1 * cell;
    return segmentClearanceAtLeast(world, points[from], points[to], kept);
  };
  std::vector<State> path{start};
  const std::size_t last = points.size() - 1;
  std::size_t at = 0;
  while (at < last) {
    if (!sees(at, at + 1)) return {};
    // `seen` is in sight of `at`; `hidden` (when set, > seen) is not. Doubling finds a hidden one, bisection narrows.
    std::size_t seen = at + 1;
    std::size_t hidden = last + 1;
    for (std::size_t step = 2; seen < last; step *= 2) {
      const std::size_t probe = std::min(at + step, last);
      if (!sees(at, probe)) {
        hidden = probe;
        break;
      }
      seen = probe;
    }
    while (hidden <= last && hidden - seen > 1) {
      const std::size_t middle = seen + (hidden - seen) / 2;
      (sees(at, middle) ? seen : hidden) = middle;
    }
    const Vec3& from = points[at];
    const Vec3& to = points[seen];
    path.push_back(State{to, edgeHeading(from, to, path.back().heading)});
    at = seen;
  }
  return path;
}

std::optional<PlanResult> resultAlongRoute(const CollisionWorld& world, const CoarseRoute& route, const PlanProblem& problem) {
  const auto began = std::chrono::steady_clock::now();
  std::vector<State> path = pathAlongRoute(world, route, problem.start, problem.goal, problem.goal_radius);
  if (path.empty()) return std::nullopt;
  PlanResult result;
  result.planner = "lattice-route";
  result.solved = true;
  result.exact = (path.back().position - problem.goal).norm() <= problem.goal_radius;
  result.cost = pathLength(path);
  result.path = std::move(path);
  result.stats.time_s = route.time_s + std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  return result;
}

PlanResult shorterAnswer(PlanResult sampled, PlanResult along_route) {
  if (sampled.stopped || (sampled.solved && sampled.cost <= along_route.cost)) return sampled;
  along_route.stats.time_s += sampled.stats.time_s;
  along_route.stats.iterations = sampled.stats.iterations;
  return along_route;
}

}  // namespace ddsnav::planner
