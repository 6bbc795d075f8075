// Launch files that compose: namespace: on groups, remap: per process, include: of another launch file
// with its own variables and namespace; bad names refused naming the character.
#include "ddsnav/launch/launch_config.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

using namespace ddsnav::launch;
namespace fs = std::filesystem;

namespace {

std::string errorOf(const std::string& yaml) {
  try {
    parseLaunchConfig(yaml, "set.yaml");
  } catch (const LaunchError& e) {
    return e.what();
  }
  return "";
}

const ProcessSpec& byName(const LaunchConfig& c, const std::string& name) {
  for (const auto& p : c.processes)
    if (p.name == name) return p;
  throw std::runtime_error("no process " + name);
}

}  // namespace

TEST(LaunchGroups, NamespaceGroupPrefixesNamesAndTopicsAndResolvesAfterInside) {
  const auto config = parseLaunchConfig(R"(
processes:
  - name: monitor
    command: ddsnav-monitor
    after: [uav1/tracker]
  - namespace: uav1
    processes:
      - name: sim
        command: ddsnav-sim
      - name: tracker
        command: ddsnav-tracker
        after: [sim]
        remap: {planning/path: /shared/path}
)", "set.yaml");
  ASSERT_EQ(config.processes.size(), 3u);
  const auto& tracker = byName(config, "uav1/tracker");
  EXPECT_EQ(tracker.ns, "uav1");
  EXPECT_EQ(tracker.after, std::vector<std::string>{"uav1/sim"});
  EXPECT_EQ(tracker.remap.at("planning/path"), "/shared/path");
  EXPECT_EQ(byName(config, "monitor").ns, "");
  // Dependencies first.
  EXPECT_EQ(config.processes.back().name, "monitor");
}

TEST(LaunchGroups, BadNamesAreRefusedNamingTheCharacter) {
  EXPECT_NE(errorOf("processes:\n  - namespace: uav-1\n    processes:\n      - {name: a, command: x}\n").find("contains '-'"), std::string::npos)
      << errorOf("processes:\n  - namespace: uav-1\n    processes:\n      - {name: a, command: x}\n");
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x, remap: {sensors/points: 'a b'}}\n").find("contains ' '"), std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x, remap: {system/status: b}}\n").find("never remapped"), std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x}\n  - namespace: n\n    processes: [{name: b, command: x, after: [c]}]\n")
                .find("unknown process 'c'"),
            std::string::npos);
}

TEST(LaunchGroups, IncludeTakesItsOwnVariablesAndNamespaceTwice) {
  const fs::path dir = fs::temp_directory_path() / ("ddsnav_launch_include_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "pipeline.yaml") << R"(
dds: cyclonedds
variables:
  scenario: ~
  planner: gart
processes:
  - name: sim
    command: ddsnav-sim
    params: {scenario: "${scenario}"}
  - name: tracker
    command: ddsnav-tracker
    params: {scenario: "${scenario}", planner: "${planner}"}
    after: [sim]
)";
  std::ofstream(dir / "two.yaml") << R"(
variables: {world: w.yaml}
processes:
  - include: pipeline.yaml
    namespace: uav1
    variables: {scenario: "${world}"}
  - include: pipeline.yaml
    namespace: uav2
    variables: {scenario: other.yaml, planner: rrt}
)";
  const auto config = loadLaunchConfig((dir / "two.yaml").string());
  ASSERT_EQ(config.processes.size(), 4u);
  EXPECT_EQ(byName(config, "uav1/sim").params.at("scenario"), "w.yaml");
  EXPECT_EQ(byName(config, "uav2/tracker").params.at("planner"), "rrt");
  EXPECT_EQ(byName(config, "uav2/tracker").after, std::vector<std::string>{"uav2/sim"});
  EXPECT_EQ(byName(config, "uav2/tracker").ns, "uav2");
  EXPECT_EQ(byName(config, "uav1/sim").dds.value_or(""), "cyclonedds");  // the included file's default vendor
  // A required variable of the included file must be given by the include.
  std::ofstream(dir / "missing.yaml") << "processes:\n  - include: pipeline.yaml\n";
  try {
    loadLaunchConfig((dir / "missing.yaml").string());
    ADD_FAILURE() << "expected a LaunchError";
  } catch (const LaunchError& e) {
    EXPECT_NE(std::string(e.what()).find("scenario"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("include variables:"), std::string::npos) << e.what();
  }
  // An include of itself ends at the depth limit.
  std::ofstream(dir / "loop.yaml") << "processes:\n  - include: loop.yaml\n    namespace: x\n";
  EXPECT_THROW(loadLaunchConfig((dir / "loop.yaml").string()), LaunchError);
  fs::remove_all(dir);
}

TEST(LaunchGroups, ContainerHoldsComponentsWithTheirOwnNamesAndAfterNamesThem) {
  const auto config = parseLaunchConfig(R"(
processes:
  - name: recorder
    command: ddsnav-record
    after: [uav1/perception]
  - namespace: uav1
    processes:
      - container: pipeline
        required: true
        components:
          - {component: sim, params: {scenario: s.yaml}}
          - name: perception
            component: perception
            namespace: coarse
            remap: {perception/obstacles: perception/coarse}
            args: [--log-level, debug]
)", "set.yaml");
  ASSERT_EQ(config.processes.size(), 2u);
  const auto& container = byName(config, "uav1/pipeline");
  EXPECT_EQ(container.command, "ddsnav-container");
  EXPECT_TRUE(container.required);
  EXPECT_TRUE(container.ns.empty()) << "the namespace goes to each component, not the container";
  ASSERT_EQ(container.components.size(), 2u);
  EXPECT_EQ(container.components[0].name, "uav1/sim");
  EXPECT_EQ(container.components[0].component, "sim");
  EXPECT_EQ(container.components[0].ns, "uav1");
  EXPECT_EQ(container.components[0].params.at("scenario"), "s.yaml");
  EXPECT_EQ(container.components[1].name, "uav1/perception");
  EXPECT_EQ(container.components[1].ns, "uav1/coarse");
  EXPECT_EQ(container.components[1].remap.at("perception/obstacles"), "perception/coarse");
  EXPECT_EQ(container.components[1].args, (std::vector<std::string>{"--log-level", "debug"}));
  EXPECT_EQ(container.reportingNames(), (std::vector<std::string>{"uav1/sim", "uav1/perception"}));
  // Waiting for a component waits for its container; the container starts first.
  EXPECT_EQ(byName(config, "recorder").after, (std::vector<std::string>{"uav1/pipeline"}));
  EXPECT_EQ(config.processes.front().name, "uav1/pipeline");
}

TEST(LaunchGroups, BadContainersAreRefusedNamingTheKey) {
  EXPECT_NE(errorOf("processes:\n  - container: c\n").find("needs a non-empty list of components"), std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - container: c\n    components: [{name: a}]\n").find("every component names its kind"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - container: c\n    command: x\n    components: [{component: sim}]\n").find("key 'command': unknown key"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: sim, command: ddsnav-sim}\n  - container: c\n    components: [{component: sim}]\n")
                .find("duplicate process name 'sim'"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - container: c\n    components: [{component: sim}, {component: sim}]\n").find("duplicate"),
            std::string::npos);
}
