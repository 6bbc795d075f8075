#pragma once
// Work that runs neither on the executor nor on a runtime::Worker (a std::async, a thread of one's own) but that
// the process's progress report (system/progress, docs/simulator.md "Pacing") must wait for: hold a PendingWork
// while it runs. It is stamped with the work clock when made (setWorkClock in executor.hpp; no stamp without one),
// and the report stays at or before that stamp until it is gone.
//
//   auto token = std::make_shared<runtime::PendingWork>();
//   future = std::async(std::launch::async, [token]() mutable { ...; token.reset(); return result; });

#include <cstdint>

namespace ddsnav::runtime {

class PendingWork {
 public:
  PendingWork();
  ~PendingWork();
  PendingWork(const PendingWork&) = delete;
  PendingWork& operator=(const PendingWork&) = delete;

 private:
  std::uint64_t id_ = 0;  // 0: not registered (no work clock)
};

}  // namespace ddsnav::runtime
