#include <ddsnav/sim/clock_pacer.hpp>

#include <cmath>
#include <stdexcept>

namespace ddsnav::sim {
namespace {
constexpr double kLongHoldS = 1.0;  // wall seconds of holding in a row worth a log line
constexpr std::size_t kMaxProcesses = 1024;
}  // namespace

void PacerParams::validate() const {
  const auto positive = [](double v, const char* name) {
    if (!(std::isfinite(v) && v > 0)) throw std::invalid_argument(std::string(name) + ": expected a finite value > 0");
  };
  positive(max_lag_s, "max_lag_s");
  positive(max_hold_s, "max_hold_s");
  positive(silence_s, "silence_s");
}

ClockPacer::ClockPacer(const PacerParams& params) : params_(params) { params_.validate(); }

void ClockPacer::report(const std::string& name, std::int64_t stamp_ns, WallTime now) {
  // A clock time is positive (ns since the epoch); anything else is no report (and would overflow the lag).
  if (stamp_ns <= 0) return;
  // Bounded: a flood of names (no system has this many processes) cannot grow it; silent ones are forgotten.
  if (processes_.size() >= kMaxProcesses && processes_.find(name) == processes_.end()) return;
  Process& p = processes_[name];
  // Reports may arrive reordered (best effort); progress never goes back.
  if (stamp_ns > p.stamp_ns) p.stamp_ns = stamp_ns;
  p.reported = now;
}

bool ClockPacer::mayAdvance(std::int64_t sim_now_ns, WallTime now) {
  using Seconds = std::chrono::duration<double>;
  if (was_held_) held_s_[holder_] += Seconds(now - last_held_).count();
  was_held_ = false;

  double worst_lag = 0;
  std::string worst;
  for (auto it = processes_.begin(); it != processes_.end();) {
    Process& p = it->second;
    const double lag = static_cast<double>(sim_now_ns - p.stamp_ns) * 1e-9;
    if (Seconds(now - p.reported).count() > params_.silence_s) {
      events_.push_back({Event::Forgotten, it->first, lag});
      it = processes_.erase(it);
      continue;
    }
    if (lag <= params_.max_lag_s) {
      if (p.given_up) events_.push_back({Event::CaughtUp, it->first, lag});
      p.holding = p.given_up = false;
    } else if (!p.given_up) {
      if (!p.holding) {
        p.holding = true;
        p.long_hold_told = false;
        p.holding_since = now;
      }
      const double holding_s = Seconds(now - p.holding_since).count();
      if (holding_s >= kLongHoldS && holding_s <= params_.max_hold_s && !p.long_hold_told) {
        p.long_hold_told = true;
        events_.push_back({Event::LongHold, it->first, lag});
      }
      if (holding_s > params_.max_hold_s) {
        p.given_up = true;
        p.holding = false;
        events_.push_back({Event::GaveUp, it->first, lag});
      } else if (lag > worst_lag) {
        worst_lag = lag;
        worst = it->first;
      }
    }
    ++it;
  }
  if (worst.empty()) return true;
  holder_ = worst;
  was_held_ = true;
  last_held_ = now;
  return false;
}

std::vector<ClockPacer::Event> ClockPacer::takeEvents() {
  std::vector<Event> out;
  out.swap(events_);
  return out;
}

}  // namespace ddsnav::sim
