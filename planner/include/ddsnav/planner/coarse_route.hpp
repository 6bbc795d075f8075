#pragma once
// A route on a lattice of robot-sized cells (A*): the cheap, resolution-complete answer a sampling planner lacks.
// A sampler that finds no path in its time cannot tell "there is none" from "not found yet", and in a narrow
// passage it may take a hundred times longer than on open ground (docs/planners.md, "Lattice routes"). The
// lattice search answers both in milliseconds on a 2-D world: "none" lets a caller skip a world that is closed, and
// a route found guides the sampler's samples along it (PlanProblem::guide).

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"

#include <cstddef>
#include <optional>
#include <stop_token>
#include <vector>

namespace ddsnav::planner {

struct CoarseRouteOptions {
  // Lattice spacing, coarsened until the bounds hold at most max_lattice_cells. 0: two lattices, the first with cells
  // whose diagonal is the robot radius, then, only if that one has no route, half the robot radius (with the corners
  // probed too, a passage with a quarter of the radius of play for the robot is resolved).
  double cell_m = 0.0;
  // Weighted A*: the route is at most this many times longer than the lattice's shortest, and is found after
  // expanding far fewer cells where obstacles stand across the straight line (a guide need not be shortest).
  double heuristic_weight = 2.0;
  // A move out of a cell with an impassable one within two steps costs this much more (1.5: 2.5 times its length), so
  // that the route keeps two cells off walls where the way allows and hugs them only where it must (a narrow passage,
  // a corner). It must exceed heuristic_weight - 1 to act at all: along a straight run the weighted heuristic falls
  // by heuristic_weight per metre while the cost rises by 1 + wall_cost, and a smaller penalty never makes the search
  // look aside (0.5 left the route where 0 did). Why: a route answered as the path (pathAlongRoute) runs along walls
  // at the least clearance the lattice holds, where a wall seen a little better blocks it (docs/planners.md, "The route
  // as the answer"). 0: length only.
  double wall_cost = 1.5;
  std::size_t max_lattice_cells = std::size_t(1) << 22;
  // Cells the search may hold (looked up or queued, ~40 bytes each) before it gives up: the memory bound (a 3-D
  // expansion looks at 26 neighbours).
  std::size_t max_cells_seen = std::size_t(1) << 21;
  double time_limit_s = 0.05;  // wall time
  // > 0: the search also ends after this much of the calling thread's CPU time. A planner on a busy machine bounds
  // the search by the work it does (cells looked at) and caps its latency with time_limit_s.
  double cpu_time_limit_s = 0.0;
  std::stop_token stop;
};

struct CoarseRoute {
  enum class Outcome {
    found,    // waypoints lead from the start's cell to a free cell in the goal region
    none,     // every lattice cell reachable from the start was searched: no route on this lattice
    gave_up,  // a limit (cells seen, time, stop) ended the search first
  };
  Outcome outcome = Outcome::gave_up;
  std::vector<Vec3> waypoints;  // cell centres, start first (found only; z = 0 in 2-D)
  double cell_m = 0.0;          // the lattice spacing used (the last one searched)
  std::size_t expanded = 0;     // cells taken off the open list (of both lattices when two were searched)
  double length_m = 0.0;        // along the waypoints (found only)
  double time_s = 0.0;
  double cpu_s = 0.0;  // of the calling thread's CPU time: beside time_s, it tells a slow search from a starved one
};

// 8-connected (2-D) or 26-connected (3-D) A* between the cells of `world`'s bounds. A cell is passable when the
// robot is free (world.isFree) at its centre or one of its corners, and the route goes through that point; on a
// lattice coarsened past the robot radius a move also checks its segment. The start's own cell counts as passable (the vehicle is there); the goal region is the cells
// whose centre lies within max(goal_radius, cell) of the goal. "none" is a statement about the lattice: a passage
// narrower than a cell's diagonal may still hold a continuous path. Throws std::invalid_argument on non-finite
// input or a start outside the bounds.
CoarseRoute findCoarseRoute(const CollisionWorld& world, const Vec3& start, const Vec3& goal, double goal_radius,
                            const CoarseRouteOptions& options = {});

// Guides problem's sampling along a found route: its waypoints, a share `bias` of the samples, spread by the larger of
// the robot radius and the lattice cell (wide enough to cover a passage the lattice found, narrow enough to stay in
// it). Leaves the problem as it is unless the route was found.
void guideAlong(PlanProblem& problem, const CoarseRoute& route, double bias);

// Guides problem's sampling along an earlier path (its corners, start to end), as execution-extended RRT samples near
// the waypoints of the last plan: points a robot radius apart along it (at most kMaxPathGuidePoints, thinned evenly on
// a longer path), from the one nearest problem.start on, those free in problem.world only (a blocked one is what the
// new path must leave), a share `bias` of the samples spread by two robot radii. Leaves the problem as it is when no
// such point is left, the path has fewer than two corners or is not finite.
inline constexpr std::size_t kMaxPathGuidePoints = 4096;
void guideAlongPath(PlanProblem& problem, const std::vector<Vec3>& path, double bias);

// A found route as a path to answer with, for a sampler that needs far longer than the lattice did (from inside a bug
// trap a guided gart-lazy took 1 300-2 500 iterations and 0.08-0.15 s for paths of 190-330 m where the route was
// 120-150 m long in 12-44 ms: docs/planners.md, "The route as the answer"). The path is the start, then the route's
// waypoints after it, shortcut: each point kept is joined to the farthest later waypoint found in sight of it by
// doubling and then bisecting (a handful of segment checks per corner, where trying every later waypoint would take
// hundreds). In sight means free, and keeping all along the smaller of the shortcut's two ends' clearances, up to a
// lattice cell: a taut line between two points off a bank would touch every outward corner of the bank. A move
// between consecutive waypoints that clips a corner (the coarse lattice does not check its moves) is bridged by a point
// half a cell or a cell off its middle. The path ends at the last waypoint when that lies within goal_radius of the
// goal, or else at the goal when the goal is free and in sight. Every edge is free by world.isSegmentFree; each state's
// heading is its incoming edge's horizontal direction (the start keeps its own, a pure climb its predecessor's). The
// edges are straight and turn by any angle: a kinodynamic planner's answer this is not, and the smoother rounds its
// corners as it does any planner's. Empty when the route was not found, a move cannot be bridged, or no end reaches the
// goal region.
std::vector<State> pathAlongRoute(const CollisionWorld& world, const CoarseRoute& route, const State& start, const Vec3& goal,
                                  double goal_radius);

// pathAlongRoute for problem's start, goal and goal radius as a solved result: planner "lattice-route", its length as
// the cost, the route search's and the shortcut's time. Nothing when the route is no path.
std::optional<PlanResult> resultAlongRoute(const CollisionWorld& world, const CoarseRoute& route, const PlanProblem& problem);

// The answer to a request the route and a sampler were both given: the sampler's result when it solved no longer than
// the route (or was stopped), else the route's, which then counts the sampler's time and iterations too.
PlanResult shorterAnswer(PlanResult sampled, PlanResult along_route);

}  // namespace ddsnav::planner
