// Built instead of ompl_adapters.cpp when OMPL was not found: the grid runs ddsnav's planners only.
#include "bench_run.hpp"

#include <stdexcept>

namespace ddsnav::bench {

bool omplAvailable() { return false; }
std::vector<std::string> omplPlannerNames() { return {}; }
bool isOmplKinodynamic(const std::string&) { return false; }
RunRecord runOmpl(const std::string& name, const planner::Scenario&, const planner::CollisionWorld&,
                  const planner::PlanProblem&) {
  throw std::invalid_argument("planner '" + name + "' needs OMPL, which was not found when ddsnav was built");
}

}  // namespace ddsnav::bench
