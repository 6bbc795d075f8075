// Fuzz target: the launch-file parser (docs/launch.md), variables and ordering included.
// Contract: LaunchError naming the file, or a config whose processes all have a name and a command.
#include "fuzz_input.hpp"

#include <ddsnav/launch/launch_config.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto config = ddsnav::launch::parseLaunchConfig(ddsnav::fuzz::text(data, size), "fuzz.yaml");
    for (const auto& p : config.processes) (void)ddsnav::launch::toString(p.restart);
  } catch (const ddsnav::launch::LaunchError& e) {
    ddsnav::fuzz::expectNamed(e.what(), "fuzz.yaml");
  }
  return 0;
}
