#include "ddsnav/launch/status_readiness.hpp"

#include <ddsnav/msg/messages.hpp>

namespace ddsnav::launch {

StatusReadiness::StatusReadiness(bus::Participant& bus)
    : subscription_(bus.subscribe<msg::ComponentStatus>("system/status", bus::Qos::state(1), [this](const msg::ComponentStatus& s) {
        {
          std::lock_guard lock(mutex_);
          heard_[{s.name(), s.pid()}] = std::chrono::steady_clock::now();
          if (s.ready())
            ready_pid_[s.name()] = s.pid();
          else if (const auto it = ready_pid_.find(s.name()); it != ready_pid_.end() && it->second == s.pid())
            ready_pid_.erase(it);
        }
        changed_.notify_all();
      })) {}

bool StatusReadiness::waitUntilReady(const std::string& name, pid_t pid, std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  return changed_.wait_until(lock, deadline, [&] {
    const auto it = ready_pid_.find(name);
    return it != ready_pid_.end() && it->second == pid;
  });
}

std::optional<std::chrono::steady_clock::time_point> StatusReadiness::lastHeard(const std::string& name, pid_t pid) {
  std::lock_guard lock(mutex_);
  const auto it = heard_.find({name, pid});
  if (it == heard_.end()) return std::nullopt;
  return it->second;
}

}  // namespace ddsnav::launch
