#pragma once
// One benchmark run (one scenario x planner x seed) and the pieces of ddsnav-bench that produce and
// report it. Private to planner/bench.

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/scenario.hpp"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace ddsnav::bench {

struct RunRecord {
  std::string scenario;
  std::string planner;
  std::uint64_t seed = 0;
  bool solved = false;
  bool exact = false;
  bool kinodynamic = false;  // every edge respects the unicycle's forward extending region
  bool valid = false;        // the returned path passed the independent check (collision, and R+ if kinodynamic)
  std::string invalid_reason;
  double time_s = 0.0;
  double time_to_first_s = -1.0;
  std::int64_t iterations = -1;  // -1: the planner does not report iterations (some OMPL planners)
  std::int64_t iterations_to_first = -1;
  std::int64_t vertices = 0;
  double cost = -1.0;
  double pous = -1.0;
  double por = -1.0;
  double coverage = -1.0;
  double growth = 0.0;
  std::uint64_t validity_checks = 0;
  std::int64_t fdc = -1;
  std::int64_t fgc = -1;
};

// The planning problem every planner of a grid cell gets (same start, heading, goal, limits).
planner::PlanProblem makeProblem(const planner::Scenario& scenario, const planner::CollisionWorld& world,
                                 std::uint64_t seed, double time_limit_s, bool kinodynamic, bool anytime);

// OMPL planners run on the same CollisionWorld. Names: ompl:rrt, ompl:rrtconnect, ompl:rrtstar,
// ompl:bitstar (geometric) and ompl:control-rrt, ompl:sst, ompl:est, ompl:pdst (unicycle, kinodynamic).
bool omplAvailable();
std::vector<std::string> omplPlannerNames();
bool isOmplKinodynamic(const std::string& name);
// Throws std::invalid_argument for an unknown OMPL name or when OMPL was not found at build time.
RunRecord runOmpl(const std::string& name, const planner::Scenario& scenario, const planner::CollisionWorld& world,
                  const planner::PlanProblem& problem);

// Runs `run` in a forked child and returns its record. A child that has not answered within twice the time
// limit plus `slack_s` is killed, and one that crashes is reported; both come back as an unsolved run of
// `identity` (scenario, planner, seed) whose note says what happened, so one bad run cannot stop a grid.
RunRecord runIsolated(const std::function<RunRecord()>& run, double time_limit_s, const RunRecord& identity,
                      double slack_s = 10.0);

// Reports.
void writeRunsCsv(const std::string& path, const std::vector<RunRecord>& runs);
void writeSummaryMarkdown(const std::string& path, const std::vector<RunRecord>& runs, const std::string& command,
                          double time_limit_s);
void writeChartSvg(const std::string& path, const std::vector<RunRecord>& runs, double time_limit_s);

}  // namespace ddsnav::bench
