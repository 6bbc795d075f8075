#pragma once
// The planner interface: a problem in, a result with statistics out. No DDS, no files, no threads.

#include "ddsnav/planner/collision_world.hpp"

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace ddsnav::planner {

// A tree state. heading is the direction of the edge that reached it (the start heading at the root).
struct State {
  Vec3 position = Vec3::Zero();
  double heading = 0.0;
};

struct PlanProblem {
  const CollisionWorld* world = nullptr;
  State start;
  Vec3 goal = Vec3::Zero();
  double goal_radius = 1.0;
  std::optional<VehicleLimits> vehicle;  // the unicycle limits; kinodynamic planners need it
  bool kinodynamic = false;              // rrt / rrtstar: grow edges inside the forward extending region
  std::uint64_t seed = 1;
  double time_limit_s = 10.0;
  std::uint64_t max_iterations = std::numeric_limits<std::uint64_t>::max();
  bool anytime = false;                  // keep improving until a limit instead of stopping at the first solution
  std::function<void(std::uint64_t iterations)> on_progress;  // called now and then, may be empty
};

// One tree edge, for pictures.
struct TreeEdge {
  Vec3 from;
  Vec3 to;
};

struct PlanStats {
  std::uint64_t iterations = 0;
  std::uint64_t vertices = 0;
  std::uint64_t validity_checks = 0;
  std::uint64_t rewires = 0;
  double time_s = 0.0;
  double time_to_first_solution_s = -1.0;        // -1 when never solved
  std::int64_t iterations_to_first_solution = -1;
  // First-directive-connect / first-glance-connect (defined in docs/planners.md).
  std::int64_t first_directive_connect = -1;
  std::int64_t first_glance_connect = -1;
  double pous = 0.0;      // vertices added / iterations
  double por = 0.0;       // rewires / vertices added
  double coverage = 0.0;  // Li-RRT paper eq. 1
  double growth = 0.0;    // Li-RRT paper eq. 2
};

struct PlanResult {
  std::string planner;
  bool solved = false;
  bool exact = false;        // last state within goal_radius of the goal
  bool kinodynamic = false;  // every edge respects the forward extending region
  std::vector<State> path;   // start to goal, joined by straight edges
  double cost = std::numeric_limits<double>::infinity();  // path length, m
  PlanStats stats;
  std::vector<TreeEdge> tree;  // the final tree, for --svg
};

// The problem a scenario poses in `world`: its start (with startHeading), goal, goal radius and vehicle.
// Seed, limits and modes keep their defaults.
PlanProblem problemFromScenario(const Scenario& scenario, const CollisionWorld& world);

class Planner {
 public:
  virtual ~Planner() = default;
  virtual std::string name() const = 0;
  // Throws std::invalid_argument for a problem it cannot start (start in collision, no vehicle when one
  // is needed, non-finite numbers, ...).
  virtual PlanResult solve(const PlanProblem& problem) = 0;
};

// Names: rrt, rrtstar, lirrt, gart, apgd-rrtstar, rrrt, ddrrt. Throws std::invalid_argument for others,
// listing the known names.
std::unique_ptr<Planner> makePlanner(const std::string& name);
std::vector<std::string> plannerNames();

}  // namespace ddsnav::planner
