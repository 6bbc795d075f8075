// Fuzz target: the scenario parser (../shared/scenario-format.md) and the exact world built from it.
// Contract: ScenarioError naming the source, or a scenario the simulator and planners can use.
#include "fuzz_input.hpp"

#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/scenario.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ddsnav::planner;
  Scenario scenario;
  try {
    scenario = parseScenario(ddsnav::fuzz::text(data, size), "fuzz.yaml");
  } catch (const ScenarioError& e) {
    ddsnav::fuzz::expectNamed(e.what(), "fuzz.yaml");
    return 0;
  }
  (void)startHeading(scenario);
  const auto world = makeScenarioWorld(scenario);
  (void)world->isFree(scenario.start);
  (void)world->isSegmentFree(scenario.start, scenario.goal);
  (void)world->clearance(scenario.goal);
  return 0;
}
