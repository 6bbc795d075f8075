#pragma once
// Readiness from the system/status topic: every component publishes a ComponentStatus (keyed by name,
// transient local) and sets `ready` once it serves. The pid must match, so a stale status from an
// earlier run of the same name never counts. Used by `ddsnav launch` and by the multi-process test harness.

#include "ddsnav/launch/supervisor.hpp"

#include <ddsnav/bus/bus.hpp>

#include <condition_variable>
#include <map>
#include <mutex>

namespace ddsnav::launch {

class StatusReadiness : public ReadinessSource {
 public:
  explicit StatusReadiness(bus::Participant& bus);
  bool waitUntilReady(const std::string& name, pid_t pid, std::chrono::steady_clock::time_point deadline) override;

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, pid_t> ready_pid_;
  bus::Subscription subscription_;  // last: stops callbacks before the state above goes away
};

}  // namespace ddsnav::launch
