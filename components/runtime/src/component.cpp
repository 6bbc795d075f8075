#include <ddsnav/runtime/component.hpp>
#include <ddsnav/runtime/topic_names.hpp>

#include <ddsnav/msg/messages.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <fmt/format.h>

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

namespace ddsnav::runtime {
namespace {

using namespace std::chrono_literals;

// Exit codes.
constexpr int kExitOk = 0;
constexpr int kExitError = 1;
constexpr int kExitUsage = 2;       // bad command line, config or parameter
constexpr int kExitHungShutdown = 3;  // did not finish within shutdown_timeout_s after a signal

// Bounds of the runtime's own duration parameters (see docs/bus.md).
constexpr double kHeartbeatPeriodMaxS = 60.0;
constexpr double kShutdownTimeoutMaxS = 600.0;

sigset_t shutdownSignals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

// Waits for SIGINT/SIGTERM on its own thread (they are blocked everywhere else, so DDS threads never see
// them). After the first signal the process has `bound` to finish, then exits with status 3. A second
// SIGINT (Ctrl-C pressed again) ends it at once; a repeated SIGTERM does not: supervisors may send one
// each (the launcher to the process group, PR_SET_PDEATHSIG when the launcher dies, a watchdog), and
// that must still be one clean shutdown.
class SignalWatcher {
 public:
  SignalWatcher(std::function<void()> on_signal, std::chrono::milliseconds bound)
      : on_signal_(std::move(on_signal)), bound_(bound), thread_([this] { run(); }) {}
  ~SignalWatcher() {
    finished_ = true;
    thread_.join();
  }

 private:
  void run() {
    sigset_t set = shutdownSignals();
    timespec tick{0, 100'000'000};
    std::optional<std::chrono::steady_clock::time_point> deadline;
    while (!finished_) {
      int sig = sigtimedwait(&set, nullptr, &tick);
      if (sig > 0 && !deadline) {
        spdlog::info("received {}, shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");
        deadline = std::chrono::steady_clock::now() + bound_;
        on_signal_();
      } else if (sig == SIGINT) {
        spdlog::warn("second SIGINT, exiting immediately");
        std::_Exit(kExitHungShutdown);
      } else if (sig > 0) {
        spdlog::debug("SIGTERM again: already shutting down");
      }
      if (deadline && std::chrono::steady_clock::now() > *deadline && !finished_) {
        spdlog::error("shutdown did not finish within {} ms, exiting", bound_.count());
        std::_Exit(kExitHungShutdown);
      }
    }
  }

  std::function<void()> on_signal_;
  std::chrono::milliseconds bound_;
  std::atomic<bool> finished_{false};
  std::thread thread_;
};

class ContextImpl : public Context {
 public:
  ContextImpl(std::string name, Parameters params, std::shared_ptr<spdlog::logger> logger)
      : name_(std::move(name)), params_(std::move(params)), logger_(std::move(logger)) {}

  // --namespace and --remap, checked before anything starts (ParameterError: exit status 2).
  void setNames(const std::string& ns, const std::vector<std::string>& remaps) {
    if (!ns.empty()) {
      if (const auto error = topicNameError(ns); !error.empty()) throw ParameterError("--namespace '" + ns + "' " + error);
    }
    ns_ = ns;
    for (const std::string& r : remaps) {
      const auto eq = r.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == r.size())
        throw ParameterError("--remap '" + r + "': expected FROM=TO, two topic names");
      const std::string from = r.substr(0, eq), to = r.substr(eq + 1);
      if (from == topics::status.name) throw ParameterError("--remap '" + r + "': system/status is never remapped");
      for (const std::string& n : {from, to.front() == '/' ? to.substr(1) : to})
        if (const auto error = topicNameError(n); !error.empty()) throw ParameterError("--remap '" + r + "': '" + n + "' " + error);
      if (!remaps_.emplace(from, to).second) throw ParameterError("--remap: topic '" + from + "' remapped twice");
    }
  }

  ~ContextImpl() override {
    stopProgress();
    stopHeartbeat();
  }

  void start(const bus::ParticipantOptions& options) {
    participant_ = std::make_unique<bus::Participant>(options);
    status_pub_ = participant_->publisher<msg::ComponentStatus>("system/status", bus::Qos::state(1));
    // The clock before the first status: a component on `clock: topic` stamps even its STARTING status
    // with simulated time (0 until the first clock sample), never with the wall clock.
    runtime_params_ = RuntimeParams(params_);
    if (runtime_params_.clock == "system")
      clock_ = std::make_unique<SystemClock>();
    else
      clock_ = std::make_unique<TopicClock>(*participant_, topics::clock.name);
    status_open_ = true;
    publishState(msg::LIFECYCLE_STARTING);
    heartbeat_period_ = runtime_params_.heartbeat_period_s;
    heartbeat_ = std::thread([this] { heartbeatLoop(); });
    publishState(msg::LIFECYCLE_CONFIGURING);
  }

  // The component's own name (the instance may be called otherwise): what the topic table lists.
  void setComponent(const std::string& component) { component_ = component; }
  void checkTopicUse(const std::string& name, TopicUse use) override {
    if (const auto error = topicUseError(component_, name, use); !error.empty()) throw std::logic_error(error);
  }

  const std::string& name() const override { return name_; }
  Parameters& params() override { return params_; }
  bus::Participant& bus() override { return *participant_; }
  const Clock& clock() const override { return *clock_; }
  spdlog::logger& log() override { return *logger_; }

  void ready() override {
    params_.rejectUndeclared();
    {
      std::lock_guard lock(names_mutex_);
      for (const auto& [from, to] : remaps_) {
        if (used_.count(from)) continue;
        std::string known;
        for (const auto& u : used_) known += (known.empty() ? "" : ", ") + u;
        throw ParameterError("--remap " + from + "=" + to + ": " + name_ + " uses no topic '" + from + "'; it uses: " +
                             (known.empty() ? "none" : known));
      }
    }
    publishState(msg::LIFECYCLE_READY);
    logger_->info("ready on {} domain {}", bus::vendorName(participant_->vendor()), participant_->domainId());
    if (runtime_params_.clock == "topic") startProgress();
  }

  void setDetail(const std::string& detail) override {
    {
      std::lock_guard lock(mutex_);
      detail_ = detail;
    }
    publishStatus();
  }

  bool shutdownRequested() const override { return shutdown_.load(); }

  void spin(std::chrono::milliseconds period, const std::function<void()>& tick) override {
    auto next = std::chrono::steady_clock::now() + period;
    while (!shutdown_) {
      std::unique_lock lock(mutex_);
      if (changed_.wait_until(lock, next, [&] { return shutdown_.load(); })) break;
      lock.unlock();
      next += period;
      if (tick) tick();
    }
  }

  bool waitForShutdown(std::chrono::milliseconds timeout) override {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return shutdown_.load(); });
  }

  void requestShutdown() override {
    if (shutdown_.exchange(true)) return;
    executor_.stop();
    publishState(msg::LIFECYCLE_SHUTTING_DOWN);
    changed_.notify_all();
  }

  std::string topic(const std::string& name) override {
    if (name == topics::status.name) return name;
    std::lock_guard lock(names_mutex_);
    used_.insert(name);
    std::string resolved = name;
    if (auto it = remaps_.find(name); it != remaps_.end()) resolved = it->second;
    if (resolved.front() == '/') return resolved.substr(1);  // absolute
    if (ns_.empty() || resolved.rfind("system/", 0) == 0) return resolved;
    return ns_ + "/" + resolved;
  }
  const std::string& ns() const override { return ns_; }

  Executor& executor() override { return executor_; }
  void runExecutor() override {
    if (shutdown_) return;
    executor_.run();
  }

  const RuntimeParams& runtimeParams() const { return runtime_params_; }
  spdlog::logger& logger() { return *logger_; }

  void finish(msg::LifecycleState state, const std::string& detail) {
    stopProgress();
    executor_.stop();
    if (!participant_) return;
    {
      std::lock_guard lock(mutex_);
      if (!detail.empty()) detail_ = detail;
    }
    publishState(state);
    stopHeartbeat();
    bus::Publisher<msg::ComponentStatus> status_pub;
    std::unique_ptr<Clock> clock;
    {
      // The signal thread may still be publishing SHUTTING_DOWN.
      std::lock_guard lock(publish_mutex_);
      status_open_ = false;
      status_pub = std::move(status_pub_);
      clock = std::move(clock_);
    }
    // Destroyed after publish_mutex_ is released: deleting a writer or reader takes the bus's and the vendor's
    // locks, and a callback on a vendor thread that holds the vendor's locks can be waiting for publish_mutex_
    // in publishStatus (ThreadSanitizer: lock-order inversion, ddsnav-echo under the bus tests).
    status_pub = {};
    clock.reset();
    participant_.reset();
  }

 private:
  void publishState(msg::LifecycleState state) {
    {
      std::lock_guard lock(mutex_);
      state_ = state;
    }
    publishStatus();
  }

  void publishStatus() {
    msg::ComponentStatus s;
    {
      std::lock_guard lock(mutex_);
      s.name(name_);
      s.state(state_);
      s.ready(state_ == msg::LIFECYCLE_READY);
      s.detail(detail_ + dropSummary());
    }
    s.pid(static_cast<std::int32_t>(getpid()));
    std::lock_guard lock(publish_mutex_);
    if (!status_open_) return;
    s.stamp_ns(clock_ ? clock_->nowNs() : SystemClock().nowNs());
    try {
      status_pub_.publish(s);
    } catch (const bus::BusError& e) {
      logger_->warn("could not publish status: {}", e.what());
    }
  }

  // " [dropped oldest: sensors/points 3 of 120]" when a subscription queue overflowed, else empty.
  std::string dropSummary() const {
    std::string out;
    for (const auto& q : executor_.queueStats())
      if (q.dropped > 0) out += fmt::format("{}{} {} of {}", out.empty() ? "" : ", ", q.topic, q.dropped, q.received);
    return out.empty() ? out : " [dropped oldest: " + out + "]";
  }

  void heartbeatLoop() {
    auto period = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(heartbeat_period_));
    std::unique_lock lock(heartbeat_mutex_);
    while (!heartbeat_stop_) {
      if (heartbeat_cv_.wait_for(lock, period, [&] { return heartbeat_stop_; })) break;
      lock.unlock();
      publishStatus();
      lock.lock();
    }
  }

  // On `clock: topic`: how far this process has caught up with the clock, on system/progress every 20 ms of
  // wall time, for the simulator's pacing (docs/simulator.md). The executor has caught up with clock tick T
  // when a task posted at T has run (it runs after every sample that arrived before it); the workers when
  // none of their pending jobs was submitted before T. A process that runs no executor counts as caught up
  // there.
  void startProgress() {
    progress_pub_ = participant_->publisher<msg::Progress>(topics::progress.name, topics::progress.qos);
    setWorkClock([clock = clock_.get()] { return clock->nowNs(); });
    progress_ = std::thread([this] { progressLoop(); });
  }

  void progressLoop() {
    std::unique_lock lock(progress_mutex_);
    while (!progress_stop_) {
      if (progress_cv_.wait_for(lock, std::chrono::milliseconds(20), [&] { return progress_stop_; })) break;
      lock.unlock();
      const std::int64_t now = clock_->nowNs();
      std::int64_t reached = now;
      if (executor_.running()) {
        if (!echo_pending_.exchange(true))
          executor_.post([this, now] {
            executor_reached_ = now;
            echo_pending_ = false;
          });
        reached = executor_reached_.load();
      }
      if (const auto work = oldestPendingWork()) reached = std::min(reached, *work);
      if (reached > 0) {
        msg::Progress p;
        p.name(name_);
        p.stamp_ns(reached);
        try {
          progress_pub_.publish(p);
        } catch (const bus::BusError& e) {
          logger_->warn("could not publish progress: {}", e.what());
        }
      }
      lock.lock();
    }
  }

  void stopProgress() {
    {
      std::lock_guard lock(progress_mutex_);
      progress_stop_ = true;
    }
    progress_cv_.notify_all();
    if (progress_.joinable()) {
      progress_.join();
      setWorkClock({});
    }
    progress_pub_ = {};
  }

  void stopHeartbeat() {
    {
      std::lock_guard lock(heartbeat_mutex_);
      heartbeat_stop_ = true;
    }
    heartbeat_cv_.notify_all();
    if (heartbeat_.joinable()) heartbeat_.join();
  }

  std::string name_;
  Parameters params_;
  std::shared_ptr<spdlog::logger> logger_;
  std::unique_ptr<bus::Participant> participant_;
  bus::Publisher<msg::ComponentStatus> status_pub_;
  std::mutex publish_mutex_;  // status_pub_ is used by the main, heartbeat and signal threads
  bool status_open_ = false;
  std::unique_ptr<Clock> clock_;

  std::mutex mutex_;
  std::condition_variable changed_;
  msg::LifecycleState state_ = msg::LIFECYCLE_STARTING;
  std::string detail_;
  std::atomic<bool> shutdown_{false};

  RuntimeParams runtime_params_;
  Executor executor_;
  std::mutex names_mutex_;
  std::string ns_;
  std::map<std::string, std::string> remaps_;
  std::set<std::string> used_;
  std::string component_;

  double heartbeat_period_ = 1.0;
  std::thread heartbeat_;
  std::mutex heartbeat_mutex_;
  std::condition_variable heartbeat_cv_;
  bool heartbeat_stop_ = false;

  bus::Publisher<msg::Progress> progress_pub_;
  std::thread progress_;
  std::mutex progress_mutex_;
  std::condition_variable progress_cv_;
  bool progress_stop_ = false;
  std::atomic<bool> echo_pending_{false};
  std::atomic<std::int64_t> executor_reached_{0};
};

}  // namespace

RuntimeParams::RuntimeParams(Parameters& p)
    : clock(p.declare<std::string>("clock", "system",
                                   {.doc = "where now comes from: the system clock, or msg::Clock samples on system/clock",
                                    .choices = {"system", "topic"}})),
      // Bounded where they enter, so NaN, inf and 1e300 never reach a std::chrono conversion.
      heartbeat_period_s(p.declare<double>("heartbeat_period_s", 1.0,
                                           {.above = 0, .max = kHeartbeatPeriodMaxS, .unit = "s", .doc = "period of the system/status heartbeat"})),
      shutdown_timeout_s(p.declare<double>("shutdown_timeout_s", 5.0,
                                           {.above = 0, .max = kShutdownTimeoutMaxS, .unit = "s",
                                            .doc = "time allowed for a clean shutdown after SIGINT/SIGTERM; then exit status 3"})) {}

std::string describeComponent(const std::string& name, const std::function<void(Parameters&)>& declare) {
  Parameters component = Parameters::describing(), runtime = Parameters::describing();
  if (declare) declare(component);
  const RuntimeParams declared(runtime);
  (void)declared;
  std::string out = "### " + name + "\n\n";
  out += component.descriptions().empty() ? "No parameters of its own.\n" : component.describeTable();
  out += "\nand the runtime's (every component):\n\n" + runtime.describeTable();
  return out;
}

int runComponent(const std::string& name, int argc, char** argv, const std::function<void(Context&)>& body,
                 const OptionsHook& options) {
  return runComponent(ComponentInfo{name, {}, options}, argc, argv, body);
}

namespace {

// One component's command line, parsed and checked: its context (not started yet) and bus options.
struct Prepared {
  // Kept for the component's lifetime: OptionsHook users keep CLI::Option pointers (e.g. record's
  // "was --max-file-s given?") and read them after parsing.
  std::unique_ptr<CLI::App> app;
  std::unique_ptr<ContextImpl> ctx;
  bus::ParticipantOptions bus;
  std::string instance;
};

// Parses a component's command line (the common options, then `info.options`). Returns an exit code
// when the process should end here (--help, --describe, a bad option), else fills `out`.
std::optional<int> prepare(const ComponentInfo& info, int argc, char** argv, bool intra_process, Prepared& out) {
  const std::string& name = info.name;
  out.app = std::make_unique<CLI::App>("ddsnav component " + name);
  CLI::App& app = *out.app;
  std::string dds, config, log_level = "info", ns;
  // The launcher names each process it starts; a process started by hand is named after its component.
  const char* launched_as = std::getenv("DDSNAV_COMPONENT_NAME");
  std::string instance = launched_as && *launched_as && !intra_process ? launched_as : name;
  std::optional<int> domain;
  std::vector<std::string> overrides, remaps;
  app.add_option("--dds", dds, "DDS vendor: fastdds | cyclonedds (default: $DDSNAV_DDS, else fastdds)");
  app.add_option("--domain", domain, "DDS domain id 0..232 (default: $DDSNAV_DOMAIN, else 0)");
  app.add_option("--config", config, "YAML parameter file")->check(CLI::ExistingFile);
  app.add_option("--param", overrides, "parameter override key=value (repeatable)");
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error | off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  app.add_option("--name", instance, "instance name in system/status (default: $DDSNAV_COMPONENT_NAME, else " + name + ")");
  std::optional<std::string> security;
  std::string network, peers;
  bool multicast = false;
  app.add_option("--security", security, "DDS Security directory from `ddsnav security init` (default: $DDSNAV_SECURITY, else off)");
  app.add_option("--network", network, "network interface to talk on (default: $DDSNAV_NETWORK, else loopback only)");
  app.add_option("--peers", peers, "with --network: peer hosts, comma-separated (default: $DDSNAV_PEERS)");
  app.add_flag("--multicast", multicast, "with --network: also discover by multicast");
  app.add_option("--namespace", ns, "prefix of every topic but system/...: NS/sensors/points");
  app.add_option("--remap", remaps, "use topic TO where the component uses FROM (FROM=TO, repeatable; TO=/name: no namespace)");
  // Like --help: before the other options' requirements are checked (a required file argument, say).
  app.add_flag_callback(
      "--describe",
      [&] {
        std::fputs(describeComponent(name, info.declare).c_str(), stdout);
        throw CLI::Success();
      },
      "print every parameter (default, range, unit, description) and exit");
  if (info.options) info.options(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int rc = app.exit(e);
    return rc == 0 ? kExitOk : kExitUsage;
  }

  // In a container every component logs through its own logger; spdlog's default one is the container's.
  if (spdlog::get(instance)) {
    spdlog::error("two components named '{}' in one process: give each its own --name", instance);
    return kExitUsage;
  }
  auto logger = spdlog::stderr_color_mt(instance);
  logger->set_level(spdlog::level::from_str(log_level));
  logger->set_pattern("[%H:%M:%S.%e] [%n] [%^%l%$] %v");
  if (!intra_process) spdlog::set_default_logger(logger);

  try {
    out.bus.vendor = dds.empty() ? bus::vendorFromEnvironment() : bus::parseVendor(dds);
    out.bus.domain_id = domain ? *domain : bus::domainFromEnvironment(0);
    if (out.bus.domain_id < 0 || out.bus.domain_id > bus::kMaxDomainId)
      throw bus::BusError("DDS domain id " + std::to_string(out.bus.domain_id) + " is out of range: expected 0.." +
                          std::to_string(bus::kMaxDomainId));
    out.bus.name = instance;
    out.bus.identity = name;  // the credentials are per component, whatever the instance is called
    out.bus.security_dir = security;
    out.bus.intra_process = intra_process;
    if (!network.empty())
      out.bus.network = bus::NetworkOptions{network, peers.empty() ? std::vector<std::string>{} : bus::parsePeers(peers), multicast};
    else if (!peers.empty() || multicast)
      throw bus::BusError("--peers / --multicast need --network INTERFACE");
    out.ctx = std::make_unique<ContextImpl>(instance, Parameters::load(config, overrides), logger);
    out.ctx->setComponent(name);
    out.ctx->setNames(ns, remaps);
  } catch (const std::exception& e) {
    logger->error("{}", e.what());
    spdlog::drop(instance);
    return kExitUsage;
  }
  out.instance = instance;
  return std::nullopt;
}

// The registry of component classes the container can load (DDSNAV_COMPONENT with DDSNAV_COMPONENT_REGISTRY).
std::map<std::string, ComponentFactory>& registry() {
  static std::map<std::string, ComponentFactory> factories;
  return factories;
}

}  // namespace

int runComponent(const ComponentInfo& info, int argc, char** argv, const std::function<void(Context&)>& body) {
  // Before any thread exists, so that every thread (DDS ones included) inherits the blocked mask.
  sigset_t signals = shutdownSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  Prepared prepared;
  if (const auto rc = prepare(info, argc, argv, false, prepared)) return *rc;
  auto& ctx = prepared.ctx;
  auto& logger = ctx->logger();

  int rc = kExitOk;
  try {
    ctx->start(prepared.bus);
    const double bound_s = ctx->runtimeParams().shutdown_timeout_s;
    SignalWatcher watcher([&ctx] { ctx->requestShutdown(); },
                          std::chrono::milliseconds(static_cast<long>(bound_s * 1000)));
    try {
      body(*ctx);
      ctx->finish(msg::LIFECYCLE_FINISHED, "");
    } catch (const ParameterError& e) {
      logger.error("{}", e.what());
      ctx->finish(msg::LIFECYCLE_FAILED, e.what());
      rc = kExitUsage;
    } catch (const std::exception& e) {
      logger.error("{}", e.what());
      ctx->finish(msg::LIFECYCLE_FAILED, e.what());
      rc = kExitError;
    }
  } catch (const ParameterError& e) {
    logger.error("{}", e.what());
    rc = kExitUsage;
  } catch (const std::exception& e) {
    logger.error("{}", e.what());
    rc = kExitError;
  }
  ctx.reset();
  spdlog::drop(prepared.instance);
  return rc;
}

bool registerComponent(ComponentFactory factory) {
  const std::string name = factory.name;
  return registry().emplace(name, std::move(factory)).second;
}

std::vector<std::string> registeredComponents() {
  std::vector<std::string> names;
  for (const auto& [name, f] : registry()) names.push_back(name);
  return names;
}

int runContainer(int argc, char** argv) {
  sigset_t signals = shutdownSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  auto container_log = spdlog::stderr_color_mt("container");
  container_log->set_pattern("[%H:%M:%S.%e] [%n] [%^%l%$] %v");
  spdlog::set_default_logger(container_log);

  std::string known;
  for (const auto& n : registeredComponents()) known += (known.empty() ? "" : ", ") + n;
  const std::string usage = std::string("usage: ") + argv[0] +
                            " -- COMPONENT [its options] [-- COMPONENT [its options] ...]\n  components: " + known + "\n";
  // Segments between "--": each a component's own command line, its kind first.
  std::vector<std::vector<char*>> segments;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h" || arg == "--list") {
      std::fputs(usage.c_str(), stdout);
      return kExitOk;
    }
    if (arg == "--") {
      segments.emplace_back();
      continue;
    }
    if (segments.empty()) {
      container_log->error("unexpected '{}' before the first '--'\n{}", arg, usage);
      return kExitUsage;
    }
    segments.back().push_back(argv[i]);
  }
  std::erase_if(segments, [](const auto& s) { return s.empty(); });
  if (segments.empty()) {
    container_log->error("no component given\n{}", usage);
    return kExitUsage;
  }

  struct Loaded {
    const ComponentFactory* factory = nullptr;
    Prepared prepared;
    std::unique_ptr<Component> component;
    std::thread thread;
    std::exception_ptr error;
  };
  std::vector<Loaded> loaded(segments.size());
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const std::string kind = segments[i][0];
    auto it = registry().find(kind);
    if (it == registry().end()) {
      container_log->error("unknown component '{}': this container holds {}", kind, known);
      return kExitUsage;
    }
    loaded[i].factory = &it->second;
    std::vector<char*> args = segments[i];  // args[0] (the kind) stands where a program name would
    if (const auto rc = prepare({kind, it->second.declare, {}}, static_cast<int>(args.size()), args.data(), true, loaded[i].prepared))
      return *rc;
  }

  std::mutex mutex;
  std::condition_variable changed;
  bool stopping = false;
  const auto stopAll = [&] {
    {
      std::lock_guard lock(mutex);
      stopping = true;
    }
    changed.notify_all();
    for (auto& l : loaded)
      if (l.prepared.ctx) l.prepared.ctx->requestShutdown();
  };

  int rc = kExitOk;
  double bound_s = 0;
  try {
    for (auto& l : loaded) {
      l.prepared.ctx->start(l.prepared.bus);
      bound_s = std::max(bound_s, l.prepared.ctx->runtimeParams().shutdown_timeout_s);
    }
  } catch (const std::exception& e) {
    container_log->error("{}", e.what());
    return kExitError;
  }
  SignalWatcher watcher(stopAll, std::chrono::milliseconds(static_cast<long>(bound_s * 1000)));
  // Constructed in the order given (a component's constructor may wait for what an earlier one offers),
  // each then runs on its own executor thread.
  for (auto& l : loaded) {
    ContextImpl& ctx = *l.prepared.ctx;
    try {
      l.component = l.factory->make(ctx);
      ctx.ready();
    } catch (const ParameterError& e) {
      ctx.logger().error("{}", e.what());
      ctx.finish(msg::LIFECYCLE_FAILED, e.what());
      rc = kExitUsage;
      break;
    } catch (const std::exception& e) {
      ctx.logger().error("{}", e.what());
      ctx.finish(msg::LIFECYCLE_FAILED, e.what());
      rc = kExitError;
      break;
    }
    l.thread = std::thread([&l, &ctx, &stopAll] {
      try {
        ctx.runExecutor();
      } catch (...) {
        l.error = std::current_exception();
      }
      stopAll();  // one component ending (the monitor's mission is over) or failing ends the container
    });
  }
  if (rc == kExitOk) {
    std::unique_lock lock(mutex);
    changed.wait(lock, [&] { return stopping; });
  } else {
    stopAll();
  }
  for (auto& l : loaded)
    if (l.thread.joinable()) l.thread.join();
  // Shut down in reverse order of construction: consumers before what they consume.
  for (auto it = loaded.rbegin(); it != loaded.rend(); ++it) {
    if (!it->component) continue;
    ContextImpl& ctx = *it->prepared.ctx;
    std::string failure;
    try {
      if (it->error) std::rethrow_exception(it->error);
      it->component->shutdown();
    } catch (const std::exception& e) {
      failure = e.what();
      ctx.logger().error("{}", e.what());
      rc = rc == kExitOk ? kExitError : rc;
    }
    it->component.reset();
    ctx.finish(failure.empty() ? msg::LIFECYCLE_FINISHED : msg::LIFECYCLE_FAILED, failure);
  }
  for (auto& l : loaded) {
    if (l.prepared.ctx) l.prepared.ctx->finish(msg::LIFECYCLE_FINISHED, "");
    l.prepared.ctx.reset();
    spdlog::drop(l.prepared.instance);
  }
  return rc;
}

}  // namespace ddsnav::runtime
