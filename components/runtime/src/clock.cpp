#include <ddsnav/runtime/clock.hpp>

#include <ddsnav/msg/messages.hpp>

namespace ddsnav::runtime {

std::int64_t SystemClock::nowNs() const {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

TopicClock::TopicClock(bus::Participant& participant, const std::string& topic)
    : latest_(std::make_shared<std::atomic<std::int64_t>>(0)) {
  subscription_ = participant.subscribe<msg::Clock>(topic, bus::Qos::sensorData(1), [latest = latest_](const msg::Clock& c) {
    // Never step backwards on a reordered/duplicated sample.
    std::int64_t prev = latest->load();
    while (c.stamp_ns() > prev && !latest->compare_exchange_weak(prev, c.stamp_ns())) {
    }
  });
}

}  // namespace ddsnav::runtime
