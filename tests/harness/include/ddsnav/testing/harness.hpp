#pragma once
// A multi-process test harness: starts component processes on a DDS domain of the test's own, waits for
// their readiness on system/status (event-driven, bounded), lets the test observe and assert on topics,
// and ends exactly the processes it started (by pid, SIGTERM then SIGKILL) when it goes out of scope.
//
//   ddsnav::harness::Harness h(/*domain=*/61);
//   h.startReady({.name = "sim", .command = "ddsnav-sim", .params = {{"scenario", path}}, .dds = "fastdds"});
//   auto cloud = h.waitFor<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), std::chrono::seconds(5));
//   ASSERT_TRUE(cloud);

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/launch/launch_config.hpp>
#include <ddsnav/launch/status_readiness.hpp>

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace ddsnav::harness {

struct ProcessOptions {
  std::string name;                          // component name (system/status key)
  std::string command;                       // "ddsnav-sim" (from the build's bin/) or a path
  std::vector<std::string> args;
  std::map<std::string, std::string> params;  // --param key=value
  std::string dds = "fastdds";
};

class Harness {
 public:
  // `domain` must be unique among tests that may run at the same time (ctest -j).
  explicit Harness(int domain, bus::Vendor observer = bus::Vendor::FastDDS);
  ~Harness();  // stops every process still running, then removes the log folder unless keepLogs()
  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  // Starts a process; its output goes to logPath(name).
  pid_t start(const ProcessOptions& options);
  // Waits until NAME (the pid started under it) reports ready; false on timeout or if it died first.
  bool waitReady(const std::string& name, std::chrono::milliseconds timeout);
  // start + waitReady; throws std::runtime_error with the process's log when it does not get ready.
  pid_t startReady(const ProcessOptions& options, std::chrono::milliseconds timeout = std::chrono::seconds(20));

  // SIGTERM, wait up to `timeout`, then SIGKILL. Returns the raw wait status (see <sys/wait.h>).
  int stop(const std::string& name, std::chrono::milliseconds timeout = std::chrono::seconds(5));
  bool running(const std::string& name);
  pid_t pid(const std::string& name) const;

  bus::Participant& bus() { return *bus_; }
  int domain() const { return domain_; }
  std::string logPath(const std::string& name) const;
  std::string log(const std::string& name) const;  // the whole output so far
  void keepLogs() { keep_logs_ = true; }

  // The first sample on `topic` that satisfies `accept`, waiting up to `timeout`.
  template <class T>
  std::optional<T> waitFor(const std::string& topic, const bus::Qos& qos, std::chrono::milliseconds timeout,
                           const std::function<bool(const T&)>& accept = [](const T&) { return true; }) {
    auto inbox = bus_->inbox<T>(topic, qos);
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left <= std::chrono::milliseconds::zero()) return std::nullopt;
      auto sample = inbox.wait(left);
      if (sample && accept(*sample)) return sample;
    }
  }

  // The folder holding the ddsnav executables of this build.
  static std::string binDir();

 private:
  struct Child {
    pid_t pid = -1;
    bool reaped = false;
    int status = 0;
  };
  bool reap(Child& child, bool block);

  int domain_;
  std::string log_dir_;
  bool keep_logs_ = false;
  std::unique_ptr<bus::Participant> bus_;
  std::unique_ptr<launch::StatusReadiness> readiness_;
  std::map<std::string, Child> children_;
};

}  // namespace ddsnav::harness
