// Bounded waits shared by the record tests: a recorder polled until it subscribed, a condition polled.
#pragma once

#include <ddsnav/record/recorder.hpp>

#include <chrono>
#include <cstddef>
#include <thread>

namespace ddsnav::record_test {

// Calls recorder.poll() until it subscribed to `topics` topics (bounded).
inline bool pollUntilSubscribed(record::Recorder& recorder, std::size_t topics, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    recorder.poll();
    if (recorder.counts().size() >= topics) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

template <class Pred>
bool waitFor(Pred pred, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace ddsnav::record_test
