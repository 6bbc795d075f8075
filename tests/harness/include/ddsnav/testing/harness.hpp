#pragma once
// The multi-process test harness (ddsnav::testing; docs/testing.md). A Harness owns a DDS domain id of its
// own (DomainLease: no two tests running at once share one), starts component processes or a whole launch
// file on it, waits for their readiness on system/status (event-driven, bounded), lets the test observe
// and assert on topics, and ends exactly the processes it started (by process group, SIGTERM then
// SIGKILL) when it goes out of scope. Meanwhile a recorder writes every topic of the domain to an MCAP
// file; when the test failed, that file and every process's log are kept and named in a failure message.
//
//   ddsnav::harness::Harness h;
//   h.startReady({.name = "sim", .command = "ddsnav-sim", .params = {{"scenario", path}}, .dds = "fastdds"});
//   EXPECT_TRUE(h.sampleWithin<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), 5s));
//   EXPECT_TRUE(h.rateWithin<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), 5.0, 50.0, 2s));
//
//   h.launch(share + "/launch/demo.yaml", {{"out", dir}});   // every process, readiness-gated
//   h.replay(file);                                           // ddsnav play --clock into the domain

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/launch/launch_config.hpp>
#include <ddsnav/launch/status_readiness.hpp>
#include <ddsnav/testing/domain.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace ddsnav::harness {

struct ProcessOptions {
  std::string name;                          // component name (system/status key)
  std::string command;                       // "ddsnav-sim" (from the stock bin/) or a path
  std::vector<std::string> args;
  std::map<std::string, std::string> params;  // --param key=value
  std::string dds = "fastdds";
};

struct HarnessOptions {
  bus::Vendor observer = bus::Vendor::FastDDS;  // vendor of the harness's own participant
  // Record every topic of the domain (ddsnav record) and keep the file when the test fails.
  bool record = true;
};

struct ReplayOptions {
  std::vector<std::string> topics;  // empty: every recorded topic but system/status
  double rate = 1.0;
  bool clock = true;                // publish system/clock on recorded time (components with clock=topic follow it)
  std::string dds = "fastdds";
  std::vector<std::string> args;    // more ddsnav-play options
};

class Harness {
 public:
  // A domain from the allocator (the way every test should get one).
  explicit Harness(HarnessOptions options = {});
  // A fixed domain id: only for tests that predate the allocator (ids 230-259, which it never hands out).
  explicit Harness(int domain, bus::Vendor observer = bus::Vendor::FastDDS);
  ~Harness();  // stops every process still running; keeps logs + recording when the test failed
  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  // Starts a process; its output goes to logPath(name).
  pid_t start(const ProcessOptions& options);
  // Waits until NAME (the pid started under it) reports ready; false on timeout or if it died first.
  bool waitReady(const std::string& name, std::chrono::milliseconds timeout);
  // start + waitReady; throws std::runtime_error with the process's log when it does not get ready.
  pid_t startReady(const ProcessOptions& options, std::chrono::milliseconds timeout = std::chrono::seconds(20));

  // Every process of a launch file (docs/launch.md), on this harness's domain: each starts once the
  // processes in its `after` list are ready, and launch() returns once all that report readiness are
  // ready (throws std::runtime_error naming the process, with its log, otherwise). `variables` override
  // the file's `variables:` block, like `ddsnav launch --set`. Restart policies are not applied: a test
  // sees a process that dies. Returns the process names, in start order.
  std::vector<std::string> launch(const std::string& file, const std::map<std::string, std::string>& variables = {},
                                  std::chrono::milliseconds timeout = std::chrono::seconds(30));

  // Plays an MCAP recording into the domain (ddsnav play, process name "play"); see waitExit().
  pid_t replay(const std::string& file, const ReplayOptions& options = {});

  // The wait status once NAME has exited (see <sys/wait.h>), nullopt if it still runs after `timeout`.
  std::optional<int> waitExit(const std::string& name, std::chrono::milliseconds timeout);
  // SIGTERM, wait up to `timeout`, then SIGKILL. Returns the raw wait status (see <sys/wait.h>).
  int stop(const std::string& name, std::chrono::milliseconds timeout = std::chrono::seconds(5));
  bool running(const std::string& name);
  pid_t pid(const std::string& name) const;

  bus::Participant& bus() { return *bus_; }
  int domain() const { return domain_; }
  std::string logDir() const { return log_dir_; }
  std::string logPath(const std::string& name) const;
  std::string log(const std::string& name) const;  // the whole output so far
  std::string recordingPath() const;                // the domain's MCAP (empty when not recording)
  void keepLogs() { keep_logs_ = true; }

  // The first sample on `topic` that satisfies `accept`, waiting up to `timeout`.
  template <class T>
  std::optional<T> waitFor(const std::string& topic, const bus::Qos& qos, std::chrono::milliseconds timeout,
                           const std::function<bool(const T&)>& accept = [](const T&) { return true; }) {
    std::size_t seen = 0;
    return waitCounting<T>(topic, qos, timeout, accept, seen);
  }

  // ---- Assertions on topics: EXPECT_TRUE(h.sampleWithin<...>(...)) prints what was seen instead. ----

  // A sample satisfying `accept` arrives within `timeout`.
  template <class T>
  ::testing::AssertionResult sampleWithin(const std::string& topic, const bus::Qos& qos, std::chrono::milliseconds timeout,
                                          const std::function<bool(const T&)>& accept = [](const T&) { return true; },
                                          const std::string& what = "any sample") {
    std::size_t seen = 0;
    if (waitCounting<T>(topic, qos, timeout, accept, seen)) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << topic << ": no sample with " << what << " within " << timeout.count()
                                         << " ms (" << seen << " other samples seen, domain " << domain_ << ")";
  }

  // Samples arrive at a rate within [min_hz, max_hz], counted over `window` after the first one (which must
  // come within `window` too).
  template <class T>
  ::testing::AssertionResult rateWithin(const std::string& topic, const bus::Qos& qos, double min_hz, double max_hz,
                                        std::chrono::milliseconds window) {
    auto inbox = bus_->inbox<T>(topic, qos, 4096);
    if (!inbox.wait(window))
      return ::testing::AssertionFailure() << topic << ": no sample at all within " << window.count() << " ms";
    const std::size_t first = inbox.received();
    std::this_thread::sleep_for(window);
    const double hz = static_cast<double>(inbox.received() - first) / (window.count() / 1000.0);
    if (hz >= min_hz && hz <= max_hz) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << topic << ": " << hz << " Hz over " << window.count() << " ms, expected "
                                         << min_hz << ".." << max_hz << " Hz";
  }

  // Not a single sample (satisfying `accept`) during `window`.
  template <class T>
  ::testing::AssertionResult noSampleDuring(const std::string& topic, const bus::Qos& qos, std::chrono::milliseconds window,
                                            const std::function<bool(const T&)>& accept = [](const T&) { return true; }) {
    std::size_t seen = 0;
    const auto start = std::chrono::steady_clock::now();
    if (!waitCounting<T>(topic, qos, window, accept, seen)) return ::testing::AssertionSuccess();
    const auto after = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start);
    return ::testing::AssertionFailure() << topic << ": a sample arrived after " << after.count() << " ms of a "
                                         << window.count() << " ms window that should have had none";
  }

  // The folder holding the stock ddsnav executables (beside this library: <prefix>/bin).
  static std::string binDir();

 private:
  struct Child {
    pid_t pid = -1;
    bool reaped = false;
    int status = 0;
  };
  bool reap(Child& child, bool block);
  pid_t spawn(const launch::ProcessSpec& spec);
  void startRecorder();
  template <class T>
  std::optional<T> waitCounting(const std::string& topic, const bus::Qos& qos, std::chrono::milliseconds timeout,
                                const std::function<bool(const T&)>& accept, std::size_t& rejected) {
    auto inbox = bus_->inbox<T>(topic, qos);
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left <= std::chrono::milliseconds::zero()) return std::nullopt;
      auto sample = inbox.wait(left);
      if (!sample) continue;
      if (accept(*sample)) return sample;
      ++rejected;
    }
  }

  std::optional<testing::DomainLease> lease_;
  int domain_;
  HarnessOptions options_;
  std::string log_dir_;
  bool keep_logs_ = false;
  std::unique_ptr<bus::Participant> bus_;
  std::unique_ptr<launch::StatusReadiness> readiness_;
  std::map<std::string, Child> children_;
  std::vector<std::string> order_;  // start order, for teardown in reverse
};

}  // namespace ddsnav::harness

namespace ddsnav::testing {
using harness::Harness;
using harness::HarnessOptions;
using harness::ProcessOptions;
using harness::ReplayOptions;
}  // namespace ddsnav::testing
