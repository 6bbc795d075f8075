#pragma once
// The planner interface: a problem in, a result with statistics out. No DDS, no files, no threads.

#include "ddsnav/planner/collision_world.hpp"

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stop_token>
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
  // With anytime: stop this long after the first solution (within time_limit_s). A first solution in a bug trap is a
  // detour of 30-50 % (gart-lazy on bugtrap_0.6's ground truth: 190-224 m against 145 m after 0.3 s), and a
  // component cannot wait for the whole budget (docs/planners.md, "Improving the first solution").
  double improve_for_s = std::numeric_limits<double>::infinity();
  // Compute the tree metrics (coverage, growth, first-glance-connect) after the search: benchmark work,
  // off on the live planner. They share the run's time limit: whatever is left of it when the search ends
  // (a metric not finished in time is reported as unknown: -1).
  bool tree_metrics = false;
  std::function<void(std::uint64_t iterations)> on_progress;  // called now and then, may be empty
  // Points along a route a coarser search found (findCoarseRoute's waypoints): a share guide_bias of the samples is
  // drawn within guide_spread_m of one of them, picked at random, instead of anywhere in the bounds. In a narrow
  // passage a uniform sample lands in it about once per (bounds area / passage area) draws; the guided ones keep
  // the tree's growth along the way out (docs/planners.md, "Lattice routes"). Empty: uniform sampling only.
  std::vector<Vec3> guide;
  double guide_bias = 0.0;
  double guide_spread_m = 0.0;
  // A stop request ends the search at the next iteration, like the time limit (the result says `stopped`):
  // a component cancels a plan that a newer request superseded. Checked once per iteration (one atomic
  // load), so the same problem gives the same plan whether a token is given or not.
  std::stop_token stop;
  // Asked every 1024 iterations while there is no solution yet: true ends the search there, unsolved, with the
  // result's `abandoned` set. The planner component abandons a search on a map older than one built since it began,
  // so that it can search again on the newer one (docs/world-model.md, "A search that fails on an older map").
  // Empty: never. Not asked once a solution is found.
  std::function<bool()> abandon_unsolved;
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
  std::uint64_t restarts = 0;  // trees discarded for stagnation before a first solution (gart-lazy)
  double time_s = 0.0;
  double time_to_first_solution_s = -1.0;        // -1 when never solved
  std::int64_t iterations_to_first_solution = -1;
  // First-directive-connect / first-glance-connect (defined in docs/planners.md).
  std::int64_t first_directive_connect = -1;
  std::int64_t first_glance_connect = -1;
  double pous = 0.0;      // vertices added / iterations
  double por = 0.0;       // rewires / vertices added
  double coverage = -1.0;  // Li-RRT paper eq. 1; -1 when not computed (problem.tree_metrics off, or no time left)
  double growth = 0.0;     // Li-RRT paper eq. 2; 0 when not computed
  bool tree_metrics = false;  // coverage, growth and first_glance_connect were computed
};

struct PlanResult {
  std::string planner;
  bool solved = false;
  bool exact = false;        // last state within goal_radius of the goal
  bool kinodynamic = false;  // every edge respects the forward extending region
  bool stopped = false;      // the search ended on problem.stop, not on a limit or a solution
  bool abandoned = false;    // the search ended unsolved on problem.abandon_unsolved
  std::vector<State> path;   // start to goal, joined by straight edges
  double cost = std::numeric_limits<double>::infinity();  // path length, m
  PlanStats stats;
  std::vector<TreeEdge> tree;  // the final tree, for --svg
};

// The problem a scenario poses in `world`: its start (with startHeading), goal, goal radius and vehicle.
// Seed, limits and modes keep their defaults.
PlanProblem problemFromScenario(const Scenario& scenario, const CollisionWorld& world);

// A tuning option of a planner, set by name from text (`--option name=value` of ddsnav plan and bench,
// the planner component's `planner_options` parameter).
struct PlannerOption {
  enum class Type { kInteger, kReal, kBoolean };
  std::string name;
  std::string description;
  Type type = Type::kReal;
  double min = 0.0, max = 0.0;  // inclusive valid range (integers and reals)
  std::string value;            // the current value, as text
  std::string range() const;    // "an integer in [1, 64]", "a number in [0, 1]", "true or false"
};

class Planner {
 public:
  Planner() = default;
  Planner(const Planner&) = delete;  // options are bound to the members of this object
  Planner& operator=(const Planner&) = delete;
  virtual ~Planner() = default;
  virtual std::string name() const = 0;
  // Throws std::invalid_argument for a problem it cannot start (start in collision, no vehicle when one
  // is needed, non-finite numbers, ...).
  virtual PlanResult solve(const PlanProblem& problem) = 0;

  // The options this planner has, with their current values (empty for a planner without options).
  std::vector<PlannerOption> options() const;
  // Sets one option from text. Throws std::invalid_argument naming the planner and the option: for a name
  // it does not have (listing the ones it has), for text of the wrong type and for a value out of range.
  void setOption(const std::string& name, const std::string& value);

 protected:
  // Binds an option to a member of the derived planner (called from its constructor).
  void addOption(const std::string& name, int* target, int min, int max, const std::string& description);
  void addOption(const std::string& name, double* target, double min, double max, const std::string& description);
  void addOption(const std::string& name, bool* target, const std::string& description);
  // Throws std::invalid_argument (as setOption) when a bound member holds a value out of its range: options
  // set in code rather than through setOption are checked when solve() starts.
  void checkOptions() const;

 private:
  struct Binding {
    PlannerOption option;
    int* integer = nullptr;
    double* real = nullptr;
    bool* boolean = nullptr;
  };
  std::vector<Binding> bindings_;
};

// Names: rrt, rrtstar, lirrt, gart, apgd-rrtstar, rrrt, ddrrt (and the variants listed in docs/planners.md).
// Throws std::invalid_argument for others, listing the known names.
std::unique_ptr<Planner> makePlanner(const std::string& name);
std::vector<std::string> plannerNames();

// Applies "name=value" assignments with Planner::setOption (std::invalid_argument for a malformed one).
void applyOptions(Planner& planner, const std::vector<std::string>& assignments);

// Groups "planner.option=value" entries (the planner component's planner_options parameter) by planner:
// {"gart.k_nearest=12", "gart.rewire=false"} -> {gart: {"k_nearest=12", "rewire=false"}}. Throws
// std::invalid_argument for an entry without "planner." or "=".
std::map<std::string, std::vector<std::string>> parsePlannerOptions(const std::vector<std::string>& entries);

// A planner from a spec "name" or "name{k=v,k=v}" (the form ddsnav bench takes in --planners, so one
// grid can hold several configurations of one planner). Throws std::invalid_argument as the above.
std::unique_ptr<Planner> makePlannerFromSpec(const std::string& spec);

}  // namespace ddsnav::planner
