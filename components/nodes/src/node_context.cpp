#include "ddsnav/nodes/node_context.hpp"

#include <CLI/CLI.hpp>
#include <ddsnav/msg/messages.hpp>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <condition_variable>
#include <map>
#include <mutex>
#include <set>
#include <thread>

namespace ddsnav::nodes {
namespace {

// A bad parameter or option: reported as a configuration error (exit status 2).
class ConfigError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Flattens a YAML mapping into "a.b.c" -> scalar text.
void flatten(const YAML::Node& node, const std::string& prefix, const std::string& file,
             std::map<std::string, std::string>& out) {
  if (node.IsMap()) {
    for (const auto& entry : node) flatten(entry.second, prefix.empty() ? entry.first.as<std::string>() : prefix + "." + entry.first.as<std::string>(), file, out);
  } else if (node.IsScalar()) {
    out[prefix] = node.Scalar();
  } else if (!node.IsNull()) {
    throw ConfigError(file + ":" + std::to_string(node.Mark().line + 1) + ": parameter '" + prefix + "': expected a scalar value");
  }
}

std::string envOr(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value && *value ? value : fallback;
}

class Context : public NodeContext {
 public:
  Context(std::string name, std::map<std::string, std::string> params, std::string clock_source)
      : name_(std::move(name)), params_(std::move(params)), clock_source_(std::move(clock_source)) {}

  void start(const bus::ParticipantOptions& options) {
    bus_ = std::make_unique<bus::Participant>(options);
    status_ = bus_->publisher<msg::ComponentStatus>("system/status", bus::Qos::state(1));
    publishStatus(msg::LifecycleState::LIFECYCLE_CONFIGURING, "");
    if (clock_source_ == "topic") {
      clock_ = bus_->subscribe<msg::Clock>("system/clock", bus::Qos::sensorData(1),
                                           [this](const msg::Clock& c) { followed_ns_.store(c.stamp_ns()); });
    }
    heartbeat_ = std::thread([this] { heartbeatLoop(); });
  }

  // Stops the heartbeat and publishes the final state; only the first call counts.
  void finish(msg::LifecycleState state, const std::string& detail) {
    {
      std::lock_guard lock(mutex_);
      if (finished_) return;
      finished_ = true;
    }
    wake_.notify_all();
    if (heartbeat_.joinable()) heartbeat_.join();
    if (bus_) publishStatus(state, detail);
  }

  ~Context() override {
    finish(msg::LifecycleState::LIFECYCLE_FINISHED, "");
    clock_ = bus::Subscription();
    status_ = {};
    bus_.reset();
  }

  bus::Participant& bus() override { return *bus_; }
  const std::string& name() const override { return name_; }

  std::string paramString(const std::string& key, const std::string& fallback) override {
    const auto* v = lookup(key);
    return v ? *v : fallback;
  }
  std::string requiredString(const std::string& key) override {
    const auto* v = lookup(key);
    if (!v || v->empty()) throw ConfigError("parameter '" + key + "' is required (give --param " + key + "=VALUE)");
    return *v;
  }
  double paramDouble(const std::string& key, double fallback) override {
    const auto* v = lookup(key);
    if (!v) return fallback;
    double value = 0;
    const auto [end, ec] = std::from_chars(v->data(), v->data() + v->size(), value);
    if (ec != std::errc() || end != v->data() + v->size() || !std::isfinite(value))
      throw ConfigError("parameter '" + key + "': expected a finite number, got '" + *v + "'");
    return value;
  }
  std::int64_t paramInt(const std::string& key, std::int64_t fallback) override {
    const auto* v = lookup(key);
    if (!v) return fallback;
    std::int64_t value = 0;
    const auto [end, ec] = std::from_chars(v->data(), v->data() + v->size(), value);
    if (ec != std::errc() || end != v->data() + v->size())
      throw ConfigError("parameter '" + key + "': expected an integer, got '" + *v + "'");
    return value;
  }
  bool paramBool(const std::string& key, bool fallback) override {
    const auto* v = lookup(key);
    if (!v) return fallback;
    if (*v == "true" || *v == "1" || *v == "yes" || *v == "on") return true;
    if (*v == "false" || *v == "0" || *v == "no" || *v == "off") return false;
    throw ConfigError("parameter '" + key + "': expected true or false, got '" + *v + "'");
  }

  void ready() override {
    // Every parameter given must have been asked for by now: a typo is an error, not a silent default.
    std::vector<std::string> unknown;
    {
      std::lock_guard lock(mutex_);
      for (const auto& [key, value] : params_)
        if (!read_.count(key)) unknown.push_back(key);
    }
    if (!unknown.empty()) {
      std::string list;
      for (const auto& k : unknown) list += (list.empty() ? "'" : ", '") + k + "'";
      throw ConfigError("unknown parameter " + list + " for component '" + name_ + "'");
    }
    publishStatus(msg::LifecycleState::LIFECYCLE_READY, "");
    spdlog::info("ready");
  }

  bool running() const override { return !shutdown_.load(); }
  void requestShutdown() override {
    shutdown_.store(true);
    wake_.notify_all();
  }
  bool sleepFor(std::chrono::nanoseconds duration) override {
    std::unique_lock lock(mutex_);
    wake_.wait_for(lock, duration, [this] { return shutdown_.load(); });
    return !shutdown_.load();
  }
  std::int64_t nowNs() const override {
    if (clock_source_ == "topic") return followed_ns_.load();
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  }

  void publishStatus(msg::LifecycleState state, const std::string& detail) {
    msg::ComponentStatus status;
    status.name(name_);
    status.stamp_ns(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
    status.state(state);
    status.ready(state == msg::LifecycleState::LIFECYCLE_READY);
    status.pid(static_cast<std::int32_t>(::getpid()));
    status.detail(detail);
    std::lock_guard lock(status_mutex_);
    last_state_ = state;
    try {
      status_.publish(status);
    } catch (const std::exception& e) {
      spdlog::warn("system/status: {}", e.what());
    }
  }

 private:
  const std::string* lookup(const std::string& key) {
    std::lock_guard lock(mutex_);
    read_.insert(key);
    const auto it = params_.find(key);
    return it == params_.end() ? nullptr : &it->second;
  }

  // Republishes the current state every second, so a status reader can tell a live process from a
  // hung one by the stamp.
  void heartbeatLoop() {
    std::unique_lock lock(mutex_);
    while (!wake_.wait_for(lock, std::chrono::seconds(1), [this] { return finished_; })) {
      lock.unlock();
      msg::LifecycleState state;
      {
        std::lock_guard status_lock(status_mutex_);
        state = last_state_;
      }
      publishStatus(shutdown_.load() ? msg::LifecycleState::LIFECYCLE_SHUTTING_DOWN : state, "");
      lock.lock();
    }
  }

  std::string name_;
  std::map<std::string, std::string> params_;
  std::set<std::string> read_;
  std::string clock_source_;
  std::unique_ptr<bus::Participant> bus_;
  bus::Publisher<msg::ComponentStatus> status_;
  bus::Subscription clock_;
  std::atomic<std::int64_t> followed_ns_{0};
  std::atomic<bool> shutdown_{false};
  mutable std::mutex mutex_;
  std::mutex status_mutex_;
  msg::LifecycleState last_state_ = msg::LifecycleState::LIFECYCLE_STARTING;
  std::condition_variable wake_;
  bool finished_ = false;
  std::thread heartbeat_;
};

// Waits for SIGINT/SIGTERM on a thread of its own (they are blocked everywhere else), asks the node to
// shut down, and ends the process if the node has not returned within the bound.
class SignalWatcher {
 public:
  SignalWatcher(Context& context, double shutdown_timeout_s) : thread_([this, &context, shutdown_timeout_s] {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    const timespec slice{0, 100'000'000};
    std::chrono::steady_clock::time_point deadline{};
    while (!done_.load()) {
      const int sig = ::sigtimedwait(&set, nullptr, &slice);
      if ((sig == SIGINT || sig == SIGTERM) && deadline == std::chrono::steady_clock::time_point{}) {
        spdlog::info("{}: shutting down", strsignal(sig));
        context.requestShutdown();
        deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                          std::chrono::duration<double>(shutdown_timeout_s));
      }
      if (deadline != std::chrono::steady_clock::time_point{} && std::chrono::steady_clock::now() > deadline) {
        spdlog::error("did not shut down within {} s: exiting", shutdown_timeout_s);
        std::fflush(nullptr);
        ::_exit(1);
      }
    }
  }) {}
  ~SignalWatcher() {
    done_.store(true);
    thread_.join();
  }

 private:
  std::atomic<bool> done_{false};
  std::thread thread_;
};

}  // namespace

int runNode(int argc, char** argv, const std::string& default_name, const std::string& description,
            const std::function<int(NodeContext&)>& body) {
  // Blocked before any thread exists, so only the signal watcher ever receives them.
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);

  CLI::App app{description};
  std::string dds = envOr("DDSNAV_DDS", "fastdds");
  int domain = std::atoi(envOr("DDSNAV_DOMAIN", "0").c_str());
  std::string name = envOr("DDSNAV_COMPONENT_NAME", default_name);
  std::string config_file;
  std::vector<std::string> param_args;
  std::string log_level = "info";
  std::string clock_source = "system";
  double shutdown_timeout = 5.0;
  app.add_option("--dds", dds, "DDS vendor: fastdds | cyclonedds (env DDSNAV_DDS)");
  app.add_option("--domain", domain, "DDS domain id, 0..232 (env DDSNAV_DOMAIN)");
  app.add_option("--name", name, "component name on system/status (env DDSNAV_COMPONENT_NAME)");
  app.add_option("--config", config_file, "YAML file of parameters");
  app.add_option("--param", param_args, "parameter override key=value (repeatable)")->take_all();
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  app.add_option("--clock", clock_source, "system, or topic: follow system/clock (recorded or simulated time)")
      ->check(CLI::IsMember({"system", "topic"}));
  app.add_option("--shutdown-timeout", shutdown_timeout, "s allowed between SIGTERM and exit")->check(CLI::PositiveNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  spdlog::set_pattern("[%H:%M:%S.%e] [" + name + "] [%^%l%$] %v");
  spdlog::set_level(spdlog::level::from_str(log_level));

  std::unique_ptr<Context> context;
  try {
    std::map<std::string, std::string> params;
    if (!config_file.empty()) {
      YAML::Node root;
      try {
        root = YAML::LoadFile(config_file);
      } catch (const YAML::BadFile&) {
        throw ConfigError(config_file + ": cannot open parameter file");
      } catch (const YAML::ParserException& e) {
        throw ConfigError(config_file + ":" + std::to_string(e.mark.line + 1) + ": invalid YAML: " + e.msg);
      }
      if (!root.IsMap() && !root.IsNull()) throw ConfigError(config_file + ": expected a mapping of parameter: value");
      flatten(root, "", config_file, params);
    }
    for (const auto& p : param_args) {
      const auto eq = p.find('=');
      if (eq == std::string::npos || eq == 0) throw ConfigError("--param '" + p + "': expected key=value");
      params[p.substr(0, eq)] = p.substr(eq + 1);
    }
    bus::ParticipantOptions options;
    options.vendor = bus::parseVendor(dds);
    options.domain_id = domain;
    options.name = name;
    context = std::make_unique<Context>(name, std::move(params), clock_source);
    context->start(options);
  } catch (const std::exception& e) {
    spdlog::error("configuration error: {}", e.what());
    return 2;
  }

  SignalWatcher watcher(*context, shutdown_timeout);
  int status = 1;
  try {
    status = body(*context);
    context->finish(status == 0 ? msg::LifecycleState::LIFECYCLE_FINISHED : msg::LifecycleState::LIFECYCLE_FAILED, "");
  } catch (const std::invalid_argument& e) {
    spdlog::error("configuration error: {}", e.what());
    context->finish(msg::LifecycleState::LIFECYCLE_FAILED, e.what());
    status = 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    context->finish(msg::LifecycleState::LIFECYCLE_FAILED, e.what());
    status = 1;
  }
  return status;
}

}  // namespace ddsnav::nodes
