// docs/parameters.md against the binaries: each stock component's `--describe` section must appear in it
// exactly (the page says how to regenerate it). No DDS: --describe starts nothing.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

namespace {

std::string run(const std::string& command) {
  std::string out;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return out;
  char buffer[4096];
  while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, n);
  const int status = ::pclose(pipe);
  return status == 0 ? out : "exit status " + std::to_string(status) + ": " + out;
}

TEST(Describe, DocsParameterTablesAreTheBinariesDescriptions) {
  std::ifstream in(std::string(DDSNAV_SOURCE_DIR) + "/docs/parameters.md");
  ASSERT_TRUE(in) << "docs/parameters.md not found";
  std::stringstream docs;
  docs << in.rdbuf();
  for (const char* component : {"sim", "perception", "mapper", "planner", "tracker", "monitor", "record", "play"}) {
    SCOPED_TRACE(component);
    const std::string described = run(std::string(DDSNAV_BIN_DIR) + "/ddsnav-" + component + " --describe");
    ASSERT_EQ(described.rfind("### ", 0), 0u) << described;
    EXPECT_NE(docs.str().find(described), std::string::npos)
        << "docs/parameters.md is out of date for " << component << " (regenerate it as the page says); --describe prints:\n"
        << described;
  }
}

TEST(Describe, EveryDeclaredRangeIsShown) {
  const std::string sim = run(std::string(DDSNAV_BIN_DIR) + "/ddsnav-sim --describe");
  EXPECT_NE(sim.find("| `lidar_rate_hz` | number | 10 | (0, 100] | Hz |"), std::string::npos) << sim;
  EXPECT_NE(sim.find("| `scenario` | string | (required) |"), std::string::npos) << sim;
}

// The container holds the same component classes: the same descriptions, and a kind it does not hold is
// refused (exit status 2) listing the ones it does. Nothing starts: no DDS.
TEST(Container, HoldsTheStockComponentsAndRefusesAnUnknownOneListingThem) {
  const std::string bin = DDSNAV_BIN_DIR;
  for (const char* component : {"sim", "perception", "mapper", "planner", "tracker", "monitor"}) {
    SCOPED_TRACE(component);
    EXPECT_EQ(run(bin + "/ddsnav-container -- " + component + " --describe"), run(bin + "/ddsnav-" + component + " --describe"));
  }
  const std::string unknown = run(bin + "/ddsnav-container -- sim --param scenario=x -- planer 2>&1");
  EXPECT_EQ(unknown.rfind("exit status 512: ", 0), 0u) << unknown;
  EXPECT_NE(unknown.find("unknown component 'planer': this container holds mapper, monitor, perception, planner, sim, tracker"),
            std::string::npos)
      << unknown;
}

}  // namespace
