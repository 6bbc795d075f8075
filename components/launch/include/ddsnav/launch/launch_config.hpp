#pragma once
// A launch file: a named set of component processes, how they depend on each other's readiness, and
// what to do when one exits. See docs/launch.md for the format.

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::launch {

enum class RestartPolicy { Never, OnFailure, Always };

struct ProcessSpec {
  std::string name;                         // also the component name it reports on system/status
  std::string command;                      // "ddsnav-sim" (found beside ddsnav) or a path
  std::vector<std::string> args;
  std::optional<std::string> dds;           // vendor override for this process
  std::map<std::string, std::string> params;  // passed as --param key=value
  std::vector<std::string> after;           // start only once these report ready
  bool wait_ready = true;                   // false: a plain program that never reports readiness
  RestartPolicy restart = RestartPolicy::Never;
  int max_restarts = 3;
  double ready_timeout_s = 20.0;
  bool required = false;                    // when it exits, the whole set is torn down
};

struct LaunchConfig {
  std::string name;
  std::string source;                        // file it was read from
  std::optional<int> domain;
  std::string dds = "fastdds";
  double shutdown_timeout_s = 5.0;
  std::map<std::string, std::string> variables;  // ${name} substitutions, overridable from the CLI
  std::vector<ProcessSpec> processes;          // in an order where every `after` comes first
};

class LaunchError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads and validates a launch file; `overrides` replace entries of its `variables:` block.
// Errors name the file, the line and the key.
LaunchConfig loadLaunchConfig(const std::string& path, const std::map<std::string, std::string>& overrides = {});
LaunchConfig parseLaunchConfig(const std::string& yaml_text, const std::string& source_name,
                               const std::map<std::string, std::string>& overrides = {});

RestartPolicy parseRestartPolicy(const std::string& text);
std::string toString(RestartPolicy policy);

}  // namespace ddsnav::launch
