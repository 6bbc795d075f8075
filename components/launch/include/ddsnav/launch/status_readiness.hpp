#pragma once
// Readiness from the system/status topic: every component publishes a ComponentStatus (keyed by name,
// transient local) and sets `ready` once it serves. The pid must match, so a stale status from an
// earlier run of the same name never counts. Every status (heartbeats included, one per
// heartbeat_period_s) also counts as "heard from", which the launcher's liveness check reads.
// Used by `ddsnav launch` and by the multi-process test harness.

#include "ddsnav/launch/supervisor.hpp"

#include <ddsnav/bus/bus.hpp>

#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>
#include <utility>

namespace ddsnav::launch {

class StatusReadiness : public ReadinessSource {
 public:
  explicit StatusReadiness(bus::Participant& bus);
  bool waitUntilReady(const std::string& name, pid_t pid, std::chrono::steady_clock::time_point deadline) override;
  bool reportsLiveness() const override { return true; }
  std::optional<std::chrono::steady_clock::time_point> lastHeard(const std::string& name, pid_t pid) override;

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, pid_t> ready_pid_;
  std::map<std::pair<std::string, pid_t>, std::chrono::steady_clock::time_point> heard_;  // when received
  bus::Subscription subscription_;  // last: stops callbacks before the state above goes away
};

}  // namespace ddsnav::launch
