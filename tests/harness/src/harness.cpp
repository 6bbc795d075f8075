#include "ddsnav/testing/harness.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/msg/registry.hpp>

#include <dlfcn.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

namespace ddsnav::harness {

namespace fs = std::filesystem;

namespace {
constexpr const char* kRecorder = "__record";  // the domain recorder's process name (not a component)
}

std::string Harness::binDir() {
  // This library lives in <dir>/lib (build tree or install prefix); the executables in <dir>/bin.
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&Harness::binDir), &info) == 0 || info.dli_fname == nullptr)
    throw std::runtime_error("harness: cannot tell where libddsnav_test_harness is (dladdr failed)");
  return (fs::weakly_canonical(info.dli_fname).parent_path().parent_path() / "bin").string();
}

Harness::Harness(HarnessOptions options) : options_(options) {
  lease_.emplace();
  domain_ = lease_->id();
  log_dir_ = (fs::temp_directory_path() / ("ddsnav_test_" + std::to_string(::getpid()) + "_d" + std::to_string(domain_))).string();
  fs::create_directories(log_dir_);
  bus_ = std::make_unique<bus::Participant>(bus::ParticipantOptions{.vendor = options_.observer, .domain_id = domain_, .name = "test-harness"});
  readiness_ = std::make_unique<launch::StatusReadiness>(*bus_);
  if (options_.record) startRecorder();
}

Harness::Harness(int domain, bus::Vendor observer) : domain_(domain), options_{.observer = observer, .record = true} {
  log_dir_ = (fs::temp_directory_path() / ("ddsnav_test_" + std::to_string(::getpid()) + "_d" + std::to_string(domain))).string();
  fs::create_directories(log_dir_);
  bus_ = std::make_unique<bus::Participant>(bus::ParticipantOptions{.vendor = observer, .domain_id = domain, .name = "test-harness"});
  readiness_ = std::make_unique<launch::StatusReadiness>(*bus_);
  startRecorder();
}

namespace {
// The message libraries (ddsnav_add_messages) this test process has loaded go into DDSNAV_MESSAGE_LIBRARIES,
// so the stock processes it starts (the recorder, ddsnav play/echo) know the same types.
void shareMessageLibraries() {
  Dl_info stock{};
  ::dladdr(static_cast<const void*>(&msg::type_support<msg::Header>()), &stock);
  const char* current = std::getenv(msg::kMessageLibrariesVariable);
  std::string list = current ? current : "";
  for (const msg::TypeSupport* type : msg::all_type_supports()) {
    Dl_info info{};
    if (::dladdr(static_cast<const void*>(type), &info) == 0 || !info.dli_fname) continue;
    const std::string file = info.dli_fname;
    if (stock.dli_fname && file == stock.dli_fname) continue;
    if (fs::path(file).extension() != ".so" && file.find(".so.") == std::string::npos) continue;  // linked statically
    if ((":" + list + ":").find(":" + file + ":") != std::string::npos) continue;
    list += (list.empty() ? "" : ":") + file;
  }
  if (!list.empty()) ::setenv(msg::kMessageLibrariesVariable, list.c_str(), 1);
}
}  // namespace

void Harness::startRecorder() {
  shareMessageLibraries();
  launch::ProcessSpec spec;
  spec.name = kRecorder;
  spec.command = "ddsnav-record";
  spec.args = {"--all", "-o", recordingPath(), "--compression", "none"};
  spec.dds = "fastdds";
  spawn(spec);
}

std::string Harness::recordingPath() const {
  return options_.record ? log_dir_ + "/domain-" + std::to_string(domain_) + ".mcap" : std::string();
}

Harness::~Harness() {
  const bool failed = ::testing::Test::HasFailure();
  // The recorder first, so that it closes its file while the components still publish.
  if (children_.count(kRecorder)) stop(kRecorder);
  for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
    if (!children_.at(*it).reaped) stop(*it);
  }
  readiness_.reset();
  bus_.reset();
  if (failed) {
    std::string kept = "harness: the test failed; the logs of every process it started are kept in " + log_dir_;
    if (options_.record) kept += ", with a recording of every topic of domain " + std::to_string(domain_) + ": " +
                                 recordingPath() + " (ddsnav info / ddsnav play it)";
    ADD_FAILURE() << kept;
  } else if (!keep_logs_) {
    std::error_code ignored;
    fs::remove_all(log_dir_, ignored);
  }
}

std::string Harness::logPath(const std::string& name) const { return log_dir_ + "/" + name + ".log"; }

std::string Harness::log(const std::string& name) const {
  std::ifstream in(logPath(name));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

pid_t Harness::spawn(const launch::ProcessSpec& spec) {
  if (children_.count(spec.name) && !children_[spec.name].reaped)
    throw std::logic_error("harness: a process named '" + spec.name + "' is already running");
  const std::string dds = spec.dds.value_or("fastdds");
  const pid_t pid = launch::spawnComponent(spec, {binDir(), domain_, dds, logPath(spec.name)});
  if (pid < 0) throw std::runtime_error("harness: cannot fork for '" + spec.name + "'");
  if (!children_.count(spec.name) && spec.name != kRecorder) order_.push_back(spec.name);
  children_[spec.name] = Child{pid};
  return pid;
}

pid_t Harness::start(const ProcessOptions& options) {
  launch::ProcessSpec spec;
  spec.name = options.name;
  spec.command = options.command;
  spec.args = options.args;
  spec.params = options.params;
  spec.dds = options.dds;
  return spawn(spec);
}

bool Harness::reap(Child& child, bool block) {
  if (child.reaped) return true;
  int status = 0;
  const pid_t r = ::waitpid(child.pid, &status, block ? 0 : WNOHANG);
  if (r == child.pid) {
    child.reaped = true;
    child.status = status;
  }
  return child.reaped;
}

bool Harness::waitReady(const std::string& name, std::chrono::milliseconds timeout) {
  auto& child = children_.at(name);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    const auto slice = std::min(deadline, std::chrono::steady_clock::now() + std::chrono::milliseconds(100));
    if (readiness_->waitUntilReady(name, child.pid, slice)) return true;
    if (reap(child, false)) return false;  // died before it was ready
  }
  return false;
}

pid_t Harness::startReady(const ProcessOptions& options, std::chrono::milliseconds timeout) {
  const pid_t pid = start(options);
  if (!waitReady(options.name, timeout))
    throw std::runtime_error("harness: '" + options.name + "' did not report ready within " + std::to_string(timeout.count()) +
                             " ms; its output:\n" + log(options.name));
  return pid;
}

std::vector<std::string> Harness::launch(const std::string& file, const std::map<std::string, std::string>& variables,
                                         std::chrono::milliseconds timeout) {
  const launch::LaunchConfig config = launch::loadLaunchConfig(file, variables);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::set<std::string> ready;
  auto gate = [&](const std::string& name) {
    if (ready.count(name)) return;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (!waitReady(name, std::max(left, std::chrono::milliseconds(1))))
      throw std::runtime_error("harness: " + file + ": '" + name + "' did not report ready within " +
                               std::to_string(timeout.count()) + " ms of the launch; its output:\n" + log(name));
    ready.insert(name);
  };
  std::vector<std::string> names;
  for (launch::ProcessSpec spec : config.processes) {  // in an order where every `after` comes first
    for (const std::string& before : spec.after) gate(before);
    if (!spec.dds) spec.dds = config.dds;
    spawn(spec);
    names.push_back(spec.name);
  }
  for (const launch::ProcessSpec& spec : config.processes)
    if (spec.wait_ready) gate(spec.name);
  return names;
}

pid_t Harness::replay(const std::string& file, const ReplayOptions& options) {
  ProcessOptions play{.name = "play", .command = "ddsnav-play", .args = {file}, .dds = options.dds};
  if (options.clock) play.args.push_back("--clock");
  play.args.insert(play.args.end(), {"--rate", std::to_string(options.rate)});
  if (!options.topics.empty()) {
    std::string list;
    for (const std::string& t : options.topics) list += (list.empty() ? "" : ",") + t;
    play.args.insert(play.args.end(), {"--topics", list});
  }
  play.args.insert(play.args.end(), options.args.begin(), options.args.end());
  return start(play);
}

std::optional<int> Harness::waitExit(const std::string& name, std::chrono::milliseconds timeout) {
  auto& child = children_.at(name);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!reap(child, false)) {
    if (std::chrono::steady_clock::now() > deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return child.status;
}

int Harness::stop(const std::string& name, std::chrono::milliseconds timeout) {
  auto& child = children_.at(name);
  if (reap(child, false)) return child.status;
  ::kill(-child.pid, SIGTERM);  // the child leads its own process group: only what we started
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!reap(child, false)) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(-child.pid, SIGKILL);
      reap(child, true);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return child.status;
}

bool Harness::running(const std::string& name) { return !reap(children_.at(name), false); }

pid_t Harness::pid(const std::string& name) const { return children_.at(name).pid; }

}  // namespace ddsnav::harness
