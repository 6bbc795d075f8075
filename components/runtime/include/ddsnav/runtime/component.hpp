// The base every ddsnav process uses: common options, parameters, logging, the bus participant, a
// clock, an executor, a `system/status` heartbeat and clean shutdown on SIGINT/SIGTERM.
//
// A component is a class constructed from its context, like an rclcpp component:
//
//   class Mapper : public runtime::Component {
//    public:
//     struct Params {  // every parameter, declared once with its descriptor (also for --describe)
//       double rate_hz;
//       explicit Params(runtime::Parameters& p)
//           : rate_hz(p.declare<double>("rate_hz", 1.0, {.above = 0, .max = 100, .unit = "Hz", .doc = "..."})) {}
//     };
//     explicit Mapper(runtime::Context& ctx) : Component(ctx), params_(ctx.params()) {
//       clouds_ = subscribe(runtime::topics::points, [this](const msg::PointCloud& c) { ... });
//       tick_ = every(std::chrono::milliseconds(100), [this] { ... });
//     }
//     void shutdown() override { ... }  // after the last callback, before the destructor
//   };
//   DDSNAV_COMPONENT(Mapper, "mapper")  // main() running it; with DDSNAV_COMPONENT_REGISTRY, its registration for the container
//
// Its callbacks and timers run on the component's executor thread (executor.hpp), never on a DDS thread;
// long work goes to a Worker. Every topic name goes through Context::topic: `--remap from=to` (repeatable)
// renames a topic the component uses, then `--namespace NS` prefixes it ("NS/sensors/points"); a name
// remapped to "/name" is absolute (no namespace). system/status is never remapped nor namespaced, and
// system/... names are not namespaced. A remap of a topic the component does not use is an error at start
// (a typo), and so is a namespace with a character a topic name cannot carry. `--describe` prints every
// parameter (default, range, unit, doc) as a Markdown table and exits.
//
// The older form, a body run on the main thread, still works (tools, tests):
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
#include <ddsnav/runtime/executor.hpp>
#include <ddsnav/runtime/parameters.hpp>
#include <ddsnav/runtime/topics.hpp>

#include <spdlog/logger.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

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

  // The name on the bus of a topic the component calls `name`: remapped, then namespaced (see the top).
  virtual std::string topic(const std::string& name) = 0;
  virtual const std::string& ns() const = 0;
  // The component's executor; runExecutor() runs it on the calling thread until shutdown is requested
  // (rethrowing a timer's exception).
  virtual Executor& executor() = 0;
  virtual void runExecutor() = 0;

  // A subscription whose callback runs on the executor (the name resolved by topic()).
  template <class T, class Callback>
  bus::Subscription subscribe(const Topic<T>& t, Callback callback) {
    return subscribe<T>(t.name, t.qos, std::move(callback));
  }
  template <class T, class Callback>
  bus::Subscription subscribe(const std::string& name, const bus::Qos& qos, Callback callback) {
    checkTopicUse(name, TopicUse::Subscribe);
    return executor().subscribe<T>(bus(), topic(name), qos, std::move(callback));
  }
  template <class T>
  bus::Publisher<T> publisher(const Topic<T>& t) {
    checkTopicUse(t.name, TopicUse::Publish);
    return bus().publisher<T>(topic(t.name), t.qos);
  }

  // Every topic opened through the two above (its name before remapping): a stock component may open a
  // stock topic only as the topic table lists it (topicUseError); throws std::logic_error otherwise.
  virtual void checkTopicUse(const std::string& name, TopicUse use) { (void)name, (void)use; }
};

// The base of a component class (see the top of this file).
class Component {
 public:
  explicit Component(Context& ctx) : ctx_(ctx) {}
  virtual ~Component() = default;
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;
  // Called once the executor has stopped (no callback runs any more), before the destructor; may
  // publish a last message or write files. An exception marks the component FAILED.
  virtual void shutdown() {}

 protected:
  Context& ctx() { return ctx_; }
  Parameters& params() { return ctx_.params(); }
  const Clock& clock() const { return ctx_.clock(); }
  spdlog::logger& log() { return ctx_.log(); }
  template <class T, class Callback>
  bus::Subscription subscribe(const Topic<T>& t, Callback callback) {
    return ctx_.subscribe(t, std::move(callback));
  }
  template <class T>
  bus::Publisher<T> publisher(const Topic<T>& t) {
    return ctx_.publisher(t);
  }
  [[nodiscard]] Timer every(std::chrono::nanoseconds period, std::function<void()> fn) {
    return ctx_.executor().every(period, std::move(fn));
  }

 private:
  Context& ctx_;
};

// Extra command-line options of one component, added to the common ones before parsing.
using OptionsHook = std::function<void(CLI::App& app)>;

// Runs `body` as component `name` (see the top of this file). Exceptions from body are logged and
// published as FAILED; the return value is the process exit code.
int runComponent(const std::string& name, int argc, char** argv, const std::function<void(Context&)>& body,
                 const OptionsHook& options = {});

// What runComponent needs to know about a component besides its body.
struct ComponentInfo {
  std::string name;
  // Declares every parameter on a describing Parameters (Parameters::describing()), for --describe.
  std::function<void(Parameters&)> declare;
  OptionsHook options;
};
int runComponent(const ComponentInfo& info, int argc, char** argv, const std::function<void(Context&)>& body);

// The parameters the runtime itself reads (clock, heartbeat_period_s, shutdown_timeout_s).
struct RuntimeParams {
  std::string clock = "system";
  double heartbeat_period_s = 1.0;
  double shutdown_timeout_s = 5.0;
  RuntimeParams() = default;
  explicit RuntimeParams(Parameters& p);
};

// The --describe text of a component: its parameters' table, then the runtime's.
std::string describeComponent(const std::string& name, const std::function<void(Parameters&)>& declare);

// Runs a component class C (constructed from its Context, with a nested C::Params constructed from
// Parameters&) until SIGINT/SIGTERM or requestShutdown().
template <class C>
int runComponent(const std::string& name, int argc, char** argv, const OptionsHook& options = {}) {
  ComponentInfo info{name, [](Parameters& p) { typename C::Params params(p); }, options};
  return runComponent(info, argc, argv, [](Context& ctx) {
    auto component = std::make_unique<C>(ctx);
    ctx.ready();
    ctx.runExecutor();
    component->shutdown();
  });
}

// Composition: the component classes one process (`ddsnav container`) can load, by kind.
struct ComponentFactory {
  std::string name;                                          // the kind: "planner"
  std::function<void(Parameters&)> declare;                  // as ComponentInfo::declare
  std::function<std::unique_ptr<Component>(Context&)> make;  // constructs it from its context
};
bool registerComponent(ComponentFactory factory);  // false when the kind is taken already
std::vector<std::string> registeredComponents();   // sorted
template <class C>
bool registerComponent(const std::string& name) {
  return registerComponent({name, [](Parameters& p) { typename C::Params params(p); },
                            [](Context& ctx) -> std::unique_ptr<Component> { return std::make_unique<C>(ctx); }});
}

// The container's main: `ddsnav-container -- KIND [options] [-- KIND [options] ...]`. Each segment is the
// command line the component takes on its own (--name, --param, --config, --namespace, --remap, --dds,
// --domain ...). Every component gets its own participant with intra-process delivery, its own status
// heartbeat and its own executor thread; SIGINT/SIGTERM shut all of them down, and so does one that
// fails (the container then exits non-zero). An unknown kind is refused listing the known ones.
int runContainer(int argc, char** argv);

// Ends a component's source file: its main() in the component's own program, or (compiled with
// DDSNAV_COMPONENT_REGISTRY, as for the container) its registration under `name`.
#ifdef DDSNAV_COMPONENT_REGISTRY
#define DDSNAV_COMPONENT(Class, name) \
  [[maybe_unused]] static const bool ddsnav_registered_component = ::ddsnav::runtime::registerComponent<Class>(name);
#else
#define DDSNAV_COMPONENT(Class, name) \
  int main(int argc, char** argv) { return ::ddsnav::runtime::runComponent<Class>(name, argc, argv); }
#endif

}  // namespace ddsnav::runtime
