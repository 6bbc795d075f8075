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
            "set.yaml:4: key 'colour': unknown key (expected one of: after, args, command, dds, liveness_timeout_s, "
            "max_restart_delay_s, max_restarts, name, namespace, params, ready_timeout_s, remap, required, restart, restart_delay_s, "
            "restart_window_s, wait_ready)");
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

// Issue 13 row 9: a duration from the launch file must be bounded where it enters, or the wait overflows.
TEST(LaunchConfig, DurationsOutsideTheirRangeNameFileLineKeyAndRange) {
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    ready_timeout_s: 1e10\n"),
            "set.yaml:4: key 'ready_timeout_s': must be in 0.1..3600 s, got 1e10");
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    ready_timeout_s: .inf\n"),
            "set.yaml:4: key 'ready_timeout_s': must be in 0.1..3600 s, got .inf");
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    ready_timeout_s: .nan\n"),
            "set.yaml:4: key 'ready_timeout_s': must be in 0.1..3600 s, got .nan");
  EXPECT_EQ(errorOf("shutdown_timeout_s: 1e300\nprocesses: [{name: a, command: x}]\n"),
            "set.yaml:1: key 'shutdown_timeout_s': must be in 0.1..600 s, got 1e300");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, liveness_timeout_s: 0}\n"),
            "set.yaml:2: key 'liveness_timeout_s': must be in 0.5..3600 s, got 0");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, restart_delay_s: -1}\n"),
            "set.yaml:2: key 'restart_delay_s': must be in 0..3600 s, got -1");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, restart_window_s: 1e999}\n"),
            "set.yaml:2: key 'restart_window_s': expected a number of seconds in 1..86400, got '1e999'");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, restart_delay_s: 5, max_restart_delay_s: 1}\n"),
            "set.yaml:2: key 'max_restart_delay_s': must be >= restart_delay_s (5 s)");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, max_restarts: 100000}\n"),
            "set.yaml:2: key 'max_restarts': must be in 0..10000");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, wait_ready: false, liveness_timeout_s: 3}\n"),
            "set.yaml:2: key 'liveness_timeout_s': needs heartbeats on system/status, which a process with "
            "wait_ready: false does not send");
}

TEST(LaunchConfig, SupervisionFieldsAndTheirDefaults) {
  const auto config = parseLaunchConfig(R"(
processes:
  - {name: a, command: x}
  - {name: b, command: y, restart: always, max_restarts: 5, restart_window_s: 30, restart_delay_s: 0.2,
     max_restart_delay_s: 4, liveness_timeout_s: 2.5}
)", "set.yaml");
  const auto& a = config.processes[0];
  EXPECT_EQ(a.max_restarts, 3);
  EXPECT_DOUBLE_EQ(a.restart_window_s, 60.0);
  EXPECT_DOUBLE_EQ(a.restart_delay_s, 0.5);
  EXPECT_DOUBLE_EQ(a.max_restart_delay_s, 30.0);
  EXPECT_DOUBLE_EQ(a.liveness_timeout_s, 5.0);
  const auto& b = config.processes[1];
  EXPECT_EQ(b.max_restarts, 5);
  EXPECT_DOUBLE_EQ(b.restart_window_s, 30.0);
  EXPECT_DOUBLE_EQ(b.restart_delay_s, 0.2);
  EXPECT_DOUBLE_EQ(b.max_restart_delay_s, 4.0);
  EXPECT_DOUBLE_EQ(b.liveness_timeout_s, 2.5);
}

// Issue 13 row 12: a 1.5 KB file of variables that expand each other reached 2 GB.
TEST(LaunchConfig, VariablesThatExpandEachOtherAreBounded) {
  std::string yaml = "variables:\n  v0: xxxxxxxxxxxxxxxx\n";
  for (int i = 1; i <= 30; ++i)
    yaml += "  v" + std::to_string(i) + ": \"${v" + std::to_string(i - 1) + "}${v" + std::to_string(i - 1) + "}\"\n";
  yaml += "processes: [{name: a, command: x, args: [\"${v30}\"]}]\n";
  const std::string error = errorOf(yaml);
  EXPECT_NE(error.find("set.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("key 'variables.v"), std::string::npos) << error;
  EXPECT_NE(error.find("expands to more than 65536 bytes (kMaxExpandedTextBytes)"), std::string::npos) << error;

  // A deep chain, each step small.
  std::string chain = "variables:\n  c0: x\n";
  for (int i = 1; i <= 40; ++i) chain += "  c" + std::to_string(i) + ": \"${c" + std::to_string(i - 1) + "}\"\n";
  chain += "processes: [{name: a, command: x}]\n";
  const std::string deep = errorOf(chain);
  EXPECT_NE(deep.find("more than 16 levels deep (kMaxVariableDepth)"), std::string::npos) << deep;
  EXPECT_NE(deep.find("key 'variables.c"), std::string::npos) << deep;

  // One moderate variable used many times in a single argument.
  std::string wide = "variables: {w: \"" + std::string(1000, 'w') + "\"}\nprocesses: [{name: a, command: x, args: [\"";
  for (int i = 0; i < 100; ++i) wide += "${w}";
  wide += "\"]}]\n";
  EXPECT_NE(errorOf(wide).find("set.yaml:2: key 'args': expands to more than 65536 bytes"), std::string::npos) << errorOf(wide);
}

TEST(LaunchConfig, OversizedLaunchFilesAreRefusedBeforeParsing) {
  const std::string big(kMaxLaunchFileBytes + 1, '#');
  EXPECT_EQ(errorOf(big), "set.yaml: 1048577 bytes is larger than the limit of 1048576 bytes for a launch file (kMaxLaunchFileBytes)");
  EXPECT_THROW(loadLaunchConfig("/dev/zero"), LaunchError);  // not a regular file: refused, not read forever
  try {
    loadLaunchConfig("/tmp");
    ADD_FAILURE();
  } catch (const LaunchError& e) {
    EXPECT_EQ(std::string(e.what()), "/tmp: not a regular file");
  }
}

// Issue 13 row 13: small ones.
TEST(LaunchConfig, ComplexKeysEmptyCommandsAndControlCharactersAreRefused) {
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: x\n    ? [p, q]\n    : 1\n"),
            "set.yaml:4: key 'processes.<key>': expected a plain text key, got a sequence");
  EXPECT_EQ(errorOf("? {k: v}\n: 1\nprocesses: [{name: a, command: x}]\n"),
            "set.yaml:1: key '<key>': expected a plain text key, got a mapping");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, params: {? [1] : 2}}\n"),
            "set.yaml:2: key 'params.<key>': expected a plain text key, got a sequence");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: \"\"}\n"), "set.yaml:2: key 'command': process 'a': the command is empty");
  EXPECT_EQ(errorOf("variables: {c: \"\"}\nprocesses:\n  - {name: a, command: \"${c}\"}\n"),
            "set.yaml:3: key 'command': process 'a': the command is empty");
  EXPECT_EQ(errorOf("processes:\n  - {name: \"pl\\0anner\", command: x}\n"),
            "set.yaml:2: key 'name': control character (byte 0) at offset 2 is not allowed");
  EXPECT_EQ(errorOf("processes:\n  - {name: \"a\\x1b[31m\", command: x}\n"),
            "set.yaml:2: key 'name': control character (byte 27) at offset 1 is not allowed");
  EXPECT_EQ(errorOf("processes:\n  - {name: \"\", command: x}\n"), "set.yaml:2: key 'name': must be 1..128 bytes long");
  EXPECT_EQ(errorOf("processes:\n  - {name: a, command: x, args: [\"a\\0b\"]}\n"),
            "set.yaml:2: key 'args': control character (byte 0) at offset 1 is not allowed");
  // A multi-line shell script stays allowed.
  EXPECT_EQ(errorOf("processes:\n  - name: a\n    command: /bin/sh\n    args:\n      - -c\n      - |\n        echo a\n        echo b\n"), "");
  EXPECT_THROW(parseLaunchConfig("processes: [{name: a, command: x}]\n", "s.yaml", {{"launch_dir", std::string("a\0b", 3)}}),
               LaunchError);
}
