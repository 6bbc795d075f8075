// The base every ddsnav process uses: common options, parameters, logging, the bus participant, a
// clock, a `system/status` heartbeat and clean shutdown on SIGINT/SIGTERM.
//
//   int main(int argc, char** argv) {
//     return ddsnav::runtime::runComponent("mapper", argc, argv, [](ddsnav::runtime::Context& ctx) {
//       double res = ctx.params().declare<double>("resolution", 0.1, "leaf size, m");
//       auto pub = ctx.bus().publisher<msg::OccupancyMap>("map/octomap", bus::Qos::state());
//       auto sub = ctx.bus().subscribe<msg::PointCloud>("sensors/points", bus::Qos::sensorData(),
//                                                       [&](const msg::PointCloud& c) { ... });
//       ctx.ready();                 // checks parameters, heartbeat says READY
//       ctx.spin(std::chrono::milliseconds(100), [&] { ... });  // until SIGINT/SIGTERM; tick optional
//     });                            // returns the exit code: 0, 1 (error), 2 (bad command line)
//   }
//
// Common options: --dds fastdds|cyclonedds (default $DDSNAV_DDS, else fastdds), --domain N (default
// $DDSNAV_DOMAIN, else 0), --config FILE.yaml, --param key=value (repeatable), --log-level
// trace|debug|info|warn|error|off, --name (instance name; default the component name), --security DIR
// (DDS Security with the identity named after the component; default $DDSNAV_SECURITY), --network IFACE
// --peers host,... [--multicast] (default $DDSNAV_NETWORK..., else loopback only).
// Parameters the runtime itself reads: heartbeat_period_s (1.0), shutdown_timeout_s (5.0),
// clock ("system" | "topic": follow msg::Clock on system/clock).
//
// Lifecycle (published on system/status, keyed by name, transient local):
// STARTING -> CONFIGURING (body runs) -> READY (ctx.ready()) -> SHUTTING_DOWN (signal) -> FINISHED,
// or FAILED with the error in `detail` when the body throws.
#pragma once

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/runtime/clock.hpp>
#include <ddsnav/runtime/parameters.hpp>

#include <spdlog/logger.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>

namespace CLI {
class App;
}

namespace ddsnav::runtime {

class Context {
 public:
  virtual ~Context() = default;
  virtual const std::string& name() const = 0;
  virtual Parameters& params() = 0;
  virtual bus::Participant& bus() = 0;
  virtual const Clock& clock() const = 0;
  virtual spdlog::logger& log() = 0;

  // Rejects undeclared parameters (typos), then announces READY.
  virtual void ready() = 0;
  // Updates the heartbeat's detail text (e.g. "waiting for map").
  virtual void setDetail(const std::string& detail) = 0;

  virtual bool shutdownRequested() const = 0;
  // Blocks until SIGINT/SIGTERM (or requestShutdown), calling tick every period when given.
  virtual void spin(std::chrono::milliseconds period = std::chrono::milliseconds(100),
                    const std::function<void()>& tick = {}) = 0;
  // Sleeps up to `timeout`; returns early (true) when shutdown was requested.
  virtual bool waitForShutdown(std::chrono::milliseconds timeout) = 0;
  virtual void requestShutdown() = 0;
};

// Extra command-line options of one component, added to the common ones before parsing.
using OptionsHook = std::function<void(CLI::App& app)>;

// Runs `body` as component `name` (see the top of this file). Exceptions from body are logged and
// published as FAILED; the return value is the process exit code.
int runComponent(const std::string& name, int argc, char** argv, const std::function<void(Context&)>& body,
                 const OptionsHook& options = {});

}  // namespace ddsnav::runtime
