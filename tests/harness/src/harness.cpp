#include "ddsnav/testing/harness.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace ddsnav::harness {

namespace fs = std::filesystem;

std::string Harness::binDir() { return DDSNAV_BIN_DIR; }

Harness::Harness(int domain, bus::Vendor observer) : domain_(domain) {
  log_dir_ = (fs::temp_directory_path() / ("ddsnav_test_" + std::to_string(::getpid()) + "_d" + std::to_string(domain))).string();
  fs::create_directories(log_dir_);
  bus_ = std::make_unique<bus::Participant>(bus::ParticipantOptions{.vendor = observer, .domain_id = domain, .name = "test-harness"});
  readiness_ = std::make_unique<launch::StatusReadiness>(*bus_);
}

Harness::~Harness() {
  for (auto& [name, child] : children_) {
    if (!child.reaped) stop(name);
  }
  readiness_.reset();
  bus_.reset();
  if (!keep_logs_) {
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

pid_t Harness::start(const ProcessOptions& options) {
  if (children_.count(options.name) && !children_[options.name].reaped)
    throw std::logic_error("harness: a process named '" + options.name + "' is already running");
  launch::ProcessSpec spec;
  spec.name = options.name;
  spec.command = options.command;
  spec.args = options.args;
  spec.params = options.params;
  spec.dds = options.dds;
  const pid_t pid = launch::spawnComponent(spec, {binDir(), domain_, options.dds, logPath(options.name)});
  if (pid < 0) throw std::runtime_error("harness: cannot fork for '" + options.name + "'");
  children_[options.name] = Child{pid};
  return pid;
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
