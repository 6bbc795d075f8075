#pragma once
// What a component process's code sees of the runtime: its bus, its parameters, its clock, and the
// lifecycle calls. Every ddsnav-<component> main is:
//
//   int main(int argc, char** argv) {
//     return nodes::runNode(argc, argv, "mapper", "Builds an OctoMap from sensors/points.", [](nodes::NodeContext& ctx) {
//       ... read params, create publishers / subscriptions ...
//       ctx.ready();
//       while (ctx.sleepFor(std::chrono::milliseconds(100))) { ... periodic work ... }
//       return 0;
//     });
//   }

#include <ddsnav/bus/bus.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

namespace ddsnav::nodes {

class NodeContext {
 public:
  virtual ~NodeContext() = default;

  virtual bus::Participant& bus() = 0;
  virtual const std::string& name() const = 0;

  // Parameters from --config FILE and --param key=value (overrides win). A value that does not parse as
  // the requested type, or a missing required parameter, throws with the parameter's name.
  virtual std::string paramString(const std::string& key, const std::string& fallback) = 0;
  virtual std::string requiredString(const std::string& key) = 0;
  virtual double paramDouble(const std::string& key, double fallback) = 0;
  virtual std::int64_t paramInt(const std::string& key, std::int64_t fallback) = 0;
  virtual bool paramBool(const std::string& key, bool fallback) = 0;

  // Marks the component ready on system/status.
  virtual void ready() = 0;
  // False once shutdown was requested (SIGINT/SIGTERM or requestShutdown).
  virtual bool running() const = 0;
  virtual void requestShutdown() = 0;
  // Sleeps up to `duration`; returns running() (wakes at once on shutdown).
  virtual bool sleepFor(std::chrono::nanoseconds duration) = 0;
  // The ddsnav clock, ns (system time, or recorded time when following one).
  virtual std::int64_t nowNs() const = 0;
};

// Parses the common options, creates the participant, publishes status, runs `body`, and reports the
// outcome. Returns the process exit status: body's, or 2 for a configuration error (printed naming the
// parameter), 1 for any other error.
int runNode(int argc, char** argv, const std::string& default_name, const std::string& description,
            const std::function<int(NodeContext&)>& body);

}  // namespace ddsnav::nodes
