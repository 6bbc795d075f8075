#include "ddsnav/launch/launch_config.hpp"

#include <gtest/gtest.h>

using namespace ddsnav::launch;

namespace {

std::string errorOf(const std::string& yaml) {
  try {
    parseLaunchConfig(yaml, "set.yaml");
  } catch (const LaunchError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(LaunchConfig, ParsesProcessesVariablesAndOrdersByDependencies) {
  const auto config = parseLaunchConfig(R"(
name: demo
domain: 17
dds: cyclonedds
variables: {scenario: worlds/a.yaml}
processes:
  - name: planner
    command: ddsnav-planner
    after: [sim]
    params: {world: "${scenario}", budget: 2}
    restart: on-failure
    max_restarts: 2
  - name: sim
    command: ddsnav-sim
    args: [--scenario, "${scenario}"]
    dds: fastdds
)", "set.yaml", {{"scenario", "worlds/b.yaml"}});
  EXPECT_EQ(config.name, "demo");
  ASSERT_TRUE(config.domain.has_value());
  EXPECT_EQ(*config.domain, 17);
  EXPECT_EQ(config.dds, "cyclonedds");
  ASSERT_EQ(config.processes.size(), 2u);
  EXPECT_EQ(config.processes[0].name, "sim");  // moved before planner, which waits for it
  EXPECT_EQ(config.processes[0].args, (std::vector<std::string>{"--scenario", "worlds/b.yaml"}));
  EXPECT_EQ(config.processes[0].dds.value_or(""), "fastdds");
  EXPECT_EQ(config.processes[1].params.at("world"), "worlds/b.yaml");
  EXPECT_EQ(config.processes[1].restart, RestartPolicy::OnFailure);
  EXPECT_EQ(config.processes[1].max_restarts, 2);
}

TEST(LaunchConfig, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    colour: red\n"),
            "set.yaml:4: key 'colour': unknown key (expected one of: after, args, command, dds, max_restarts, name, "
            "params, ready_timeout_s, required, restart, wait_ready)");
  EXPECT_NE(errorOf("processes:\n  - name: a\n    command: x\n    restart: sometimes\n").find("set.yaml:4: key 'restart'"),
            std::string::npos);
  EXPECT_NE(errorOf("domain: 900\nprocesses: [{name: a, command: x}]\n").find("key 'domain': must be in 0..232"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x}\n  - {name: a, command: y}\n").find("duplicate process name 'a'"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {command: x}\n").find("every process needs a name"), std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: \"${nope}\"}\n").find("unknown variable ${nope}"), std::string::npos);
  EXPECT_NE(errorOf("processes: []\n").find("non-empty list"), std::string::npos);
  EXPECT_NE(errorOf("processes: [\n").find("invalid YAML"), std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x, max_restarts: -1}\n").find("must be >= 0"), std::string::npos);
}

TEST(LaunchConfig, DuplicateKeysAreErrorsAtTheRepeat) {
  // yaml-cpp would keep both and hand back the first: the second `restart:` / `params:` would be ignored.
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    restart: never\n    restart: always\n"),
            "set.yaml:5: key 'processes.restart': duplicate key");
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    params: {v: 1}\n    params: {v: 2}\n"),
            "set.yaml:5: key 'processes.params': duplicate key");
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    params:\n      v: 1\n      v: 2\n"),
            "set.yaml:6: key 'params.v': duplicate key");
  EXPECT_EQ(errorOf("variables:\n  w: a\n  w: b\nprocesses: [{name: a, command: x}]\n"),
            "set.yaml:3: key 'variables.w': duplicate key");
  EXPECT_EQ(errorOf("domain: 1\nprocesses: [{name: a, command: x}]\ndomain: 2\n"), "set.yaml:3: key 'domain': duplicate key");
  // The same key in two different processes is fine.
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, restart: never}\n  - {name: b, command: y, restart: always}\n"), "");
}

TEST(LaunchConfig, RejectsUnknownDependenciesAndCycles) {
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x, after: [ghost]}\n").find("unknown process 'ghost'"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x, after: [b]}\n  - {name: b, command: y, after: [a]}\n")
                .find("cycle among: a, b"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, command: x, wait_ready: false}\n  - {name: b, command: y, after: [a]}\n")
                .find("wait_ready: false"),
            std::string::npos);
}

TEST(LaunchConfig, CommandLineOverridesMustNameDeclaredVariables) {
  EXPECT_THROW(parseLaunchConfig("processes: [{name: a, command: x}]\n", "set.yaml", {{"typo", "1"}}), LaunchError);
}

TEST(LaunchConfig, VariablesExpandOtherVariablesAndLaunchDir) {
  const auto config = parseLaunchConfig(R"(
variables: {root: /data, world: "${root}/w.yaml", here: "${launch_dir}/x"}
processes: [{name: a, command: x, args: ["${world}", "${here}"]}]
)", "/etc/ddsnav/set.yaml");
  EXPECT_EQ(config.processes[0].args, (std::vector<std::string>{"/data/w.yaml", "/etc/ddsnav/x"}));
  EXPECT_THROW(parseLaunchConfig("variables: {a: \"${b}\", b: \"${a}\"}\nprocesses: [{name: a, command: x}]\n", "s.yaml"),
               LaunchError);
}

TEST(LaunchConfig, RequiredVariablesMustBeSetOnTheCommandLine) {
  const std::string yaml = "variables:\n  out: out/x\n  recording: ~\nprocesses: [{name: a, command: x, args: [\"${recording}\"]}]\n";
  const std::string error = errorOf(yaml);
  EXPECT_NE(error.find("set.yaml:3: key 'variables.recording': required: give it with --set recording=VALUE"),
            std::string::npos)
      << error;
  const auto config = parseLaunchConfig(yaml, "set.yaml", {{"recording", "/data/run.mcap"}});
  EXPECT_EQ(config.processes[0].args, (std::vector<std::string>{"/data/run.mcap"}));
}
