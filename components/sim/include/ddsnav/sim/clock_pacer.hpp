#pragma once
// Whether the simulator may advance its clock: `speed` is a ceiling, never a promise. A process that has fallen
// more than max_lag_s of simulated time behind the clock (system/progress: the clock time up to which it has
// handled its input) holds the clock until it catches up, so that a loaded machine or a speed-up the pipeline
// cannot keep makes a run slower in wall time, never different in kind: no component ever sees more simulated
// time pass during its work than max_lag_s (docs/simulator.md, "Pacing").
//
// Nothing can hold the clock for ever: a process that stops reporting (ended, killed) is forgotten after
// silence_s of wall time, and one that has held the clock for max_hold_s of wall time in a row is no longer
// waited for until it catches up (both logged by the caller through the returned events).
//
//   ClockPacer pacer({.max_lag_s = 0.3});
//   on system/progress: pacer.report(p.name(), p.stamp_ns(), steady_clock::now());
//   each step:          if (!pacer.mayAdvance(sim_now_ns, steady_clock::now())) return;  // held
//
// No DDS here: the simulator feeds it, the tests drive it with made-up times.

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace ddsnav::sim {

struct PacerParams {
  double max_lag_s = 0.3;   // simulated seconds a process may lag behind the clock before it is held
  double max_hold_s = 10.0;  // wall seconds one process may hold the clock in a row; then it is not waited for
  double silence_s = 1.0;   // wall seconds without a report after which a process is forgotten
  void validate() const;    // throws std::invalid_argument naming the bad parameter
};

class ClockPacer {
 public:
  using WallTime = std::chrono::steady_clock::time_point;

  // Something the caller should log, once per occurrence.
  struct Event {
    // LongHold: has held the clock for 1 s of wall time in a row (once per hold; GaveUp follows at max_hold_s).
    enum Kind { LongHold, GaveUp, CaughtUp, Forgotten } kind;
    std::string name;
    double lag_s;  // simulated seconds behind when it happened
  };

  explicit ClockPacer(const PacerParams& params = {});

  // A process reports that it has handled everything before stamp_ns (clock time).
  void report(const std::string& name, std::int64_t stamp_ns, WallTime now);
  // False while some process lags more than max_lag_s behind sim_now_ns (it is named by holder()).
  bool mayAdvance(std::int64_t sim_now_ns, WallTime now);

  // The process that held the clock at the last mayAdvance() that returned false.
  const std::string& holder() const { return holder_; }
  // Wall seconds each process has held the clock, in total.
  const std::map<std::string, double>& heldSeconds() const { return held_s_; }
  // Events since the last call (gave up on / caught up again / forgotten), oldest first.
  std::vector<Event> takeEvents();

 private:
  struct Process {
    std::int64_t stamp_ns = 0;
    WallTime reported{};
    WallTime holding_since{};
    bool holding = false;
    bool long_hold_told = false;
    bool given_up = false;
  };

  PacerParams params_;
  std::map<std::string, Process> processes_;
  std::map<std::string, double> held_s_;
  std::string holder_;
  WallTime last_held_{};
  bool was_held_ = false;
  std::vector<Event> events_;
};

}  // namespace ddsnav::sim
