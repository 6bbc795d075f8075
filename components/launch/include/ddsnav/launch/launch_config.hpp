#pragma once
// A launch file: a named set of component processes, how they depend on each other's readiness, and
// what to do when one exits. See docs/launch.md for the format.

#include <cstddef>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::launch {

enum class RestartPolicy { Never, OnFailure, Always };

// Limits on what a launch file may ask for; each is checked where the value enters, and an error names
// the file, the line, the key and the limit.
inline constexpr std::size_t kMaxLaunchFileBytes = 1 << 20;     // a launch file is a page of YAML
inline constexpr std::size_t kMaxExpandedTextBytes = 64 << 10;  // any value after ${...} expansion
inline constexpr int kMaxVariableDepth = 16;                    // ${a} -> ${b} -> ... chains
inline constexpr std::size_t kMaxProcesses = 256;
inline constexpr std::size_t kMaxNameBytes = 128;               // process names (system/status keys)
inline constexpr int kMaxRestartsLimit = 10000;                 // bound of max_restarts itself
inline constexpr int kMaxIncludeDepth = 8;                      // include: of include: of ...

// The valid range of every duration key, in seconds (see docs/launch.md).
struct DurationRange {
  const char* key;
  double min_s;
  double max_s;
};
inline constexpr DurationRange kReadyTimeoutRange{"ready_timeout_s", 0.1, 3600.0};
inline constexpr DurationRange kShutdownTimeoutRange{"shutdown_timeout_s", 0.1, 600.0};
inline constexpr DurationRange kLivenessTimeoutRange{"liveness_timeout_s", 0.5, 3600.0};
inline constexpr DurationRange kRestartDelayRange{"restart_delay_s", 0.0, 3600.0};
inline constexpr DurationRange kMaxRestartDelayRange{"max_restart_delay_s", 0.0, 3600.0};
inline constexpr DurationRange kRestartWindowRange{"restart_window_s", 1.0, 86400.0};

// One component of a container (`container:` entry, docs/launch.md): loaded into the container's process
// with its own name, parameters, namespace and remaps, as a process of its own would be started.
struct ComponentSpec {
  std::string name;       // on system/status (a group's namespace prefixed, like process names)
  std::string component;  // the kind: sim, perception, mapper, planner, tracker, monitor
  std::vector<std::string> args;
  std::map<std::string, std::string> params;
  std::string ns;
  std::map<std::string, std::string> remap;
};

struct ProcessSpec {
  std::string name;                         // also the component name it reports on system/status
  std::string command;                      // "ddsnav-sim" (found beside ddsnav) or a path
  std::vector<std::string> args;
  std::optional<std::string> dds;           // vendor override for this process
  std::map<std::string, std::string> params;  // passed as --param key=value
  std::string ns;                            // passed as --namespace (a group's and the process's, joined by '/')
  std::map<std::string, std::string> remap;  // passed as --remap from=to
  std::vector<std::string> after;           // start only once these report ready
  bool wait_ready = true;                   // false: a plain program that never reports readiness
  RestartPolicy restart = RestartPolicy::Never;
  int max_restarts = 3;                     // restarts allowed within restart_window_s; one more fails the set
  double restart_window_s = 60.0;
  double restart_delay_s = 0.5;             // wait before the first restart of a window, doubled per restart...
  double max_restart_delay_s = 30.0;        // ...up to this
  double ready_timeout_s = 20.0;
  double liveness_timeout_s = 5.0;          // silent on system/status this long after ready: killed (5 heartbeats)
  bool required = false;                    // when it exits, the whole set is torn down
  // Not empty: a container (command ddsnav-container); it is ready once every component reports ready
  // with the container's pid, and silent once any of them is.
  std::vector<ComponentSpec> components;
  // The names this process reports under on system/status: its components', or its own.
  std::vector<std::string> reportingNames() const {
    if (components.empty()) return {name};
    std::vector<std::string> names;
    for (const auto& c : components) names.push_back(c.name);
    return names;
  }
};

// `network:` — every process of the set talks on this interface with unicast discovery of the peers
// (see docs/bus.md); without it everything stays on loopback.
struct NetworkSpec {
  std::string interface;
  std::vector<std::string> peers;
  bool multicast = false;
};

struct LaunchConfig {
  std::string name;
  std::string source;                        // file it was read from
  std::optional<int> domain;
  std::string dds = "fastdds";
  bool dds_given = false;                    // `dds:` was in the file (an included file's default for its processes)
  double shutdown_timeout_s = 5.0;
  std::map<std::string, std::string> variables;  // ${name} substitutions, overridable from the CLI
  std::optional<std::string> security;         // `security: DIR` (absolute): DDS Security for every process
  std::optional<NetworkSpec> network;
  std::vector<ProcessSpec> processes;          // in an order where every `after` comes first
};

class LaunchError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Groups and includes (docs/launch.md): an entry of `processes:` may be a group
//   - namespace: uav1            # prefixes the group's topics (--namespace) and process names ("uav1/sim")
//     processes: [...]
// or an include of another launch file, with its own variables and a namespace:
//   - include: pipeline.yaml     # relative to this file's folder
//     namespace: uav2
//     variables: {scenario: ...}
// Inside a group, `after:` names the group's own processes by their short names.
//
// Reads and validates a launch file; `overrides` replace entries of its `variables:` block.
// Errors name the file, the line and the key.
LaunchConfig loadLaunchConfig(const std::string& path, const std::map<std::string, std::string>& overrides = {});
LaunchConfig parseLaunchConfig(const std::string& yaml_text, const std::string& source_name,
                               const std::map<std::string, std::string>& overrides = {});

RestartPolicy parseRestartPolicy(const std::string& text);
std::string toString(RestartPolicy policy);

}  // namespace ddsnav::launch
