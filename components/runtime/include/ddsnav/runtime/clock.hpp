// Where a component gets "now" from: the system clock, or a time source on the bus (system/clock,
// published by a simulator or a replayed recording) so the same code runs on recorded time.
#pragma once

#include <ddsnav/bus/bus.hpp>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>

namespace ddsnav::runtime {

class Clock {
 public:
  virtual ~Clock() = default;
  // Nanoseconds since the Unix epoch on this clock (the unit of every stamp_ns in the messages).
  virtual std::int64_t nowNs() const = 0;
  // False while a followed time source has not said anything yet.
  virtual bool valid() const { return true; }
};

class SystemClock : public Clock {
 public:
  std::int64_t nowNs() const override;
};

// Follows msg::Clock samples on a topic. Between samples time stands still (a paused replay stays
// paused); nowNs() is the newest stamp received, 0 before the first one.
class TopicClock : public Clock {
 public:
  TopicClock(bus::Participant& participant, const std::string& topic = "system/clock");
  std::int64_t nowNs() const override { return latest_->load(); }
  bool valid() const override { return latest_->load() != 0; }

 private:
  std::shared_ptr<std::atomic<std::int64_t>> latest_;
  bus::Subscription subscription_;
};

}  // namespace ddsnav::runtime
