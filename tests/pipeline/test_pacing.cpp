// The simulator's pacing across processes (docs/simulator.md, "Pacing"): a component on `clock: topic`
// reports on system/progress how far it has caught up with the clock; a process that lags more than
// pace_max_lag_s holds the simulator's clock, and one that falls silent stops holding it.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <map>
#include <mutex>
#include <thread>

using namespace ddsnav;
using namespace std::chrono_literals;

namespace {

const std::string kScenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";

}  // namespace

TEST(Pacing, ALaggingProcessHoldsTheSimulatorsClockAndASilentOneNoLonger) {
  harness::Harness h;
  std::atomic<std::int64_t> clock_ns{0};
  auto clock_sub = h.bus().subscribe<msg::Clock>("system/clock", bus::Qos::sensorData(1), [&](const msg::Clock& c) {
    std::int64_t prev = clock_ns.load();
    while (c.stamp_ns() > prev && !clock_ns.compare_exchange_weak(prev, c.stamp_ns())) {
    }
  });
  std::mutex mutex;
  std::map<std::string, std::int64_t> progress;
  auto progress_sub = h.bus().subscribe<msg::Progress>("system/progress", bus::Qos::sensorData(1), [&](const msg::Progress& p) {
    std::lock_guard lock(mutex);
    progress[p.name()] = p.stamp_ns();
  });
  h.startReady({.name = "sim", .command = "ddsnav-sim", .params = {{"scenario", kScenario}, {"speed", "4"}, {"pace_max_lag_s", "0.3"}}});
  h.startReady({.name = "planner", .command = "ddsnav-planner", .params = {{"scenario", kScenario}, {"clock", "topic"}}});

  // 1. The planner, idle on `clock: topic`, reports progress that keeps up with the clock.
  std::int64_t planner_progress = 0;
  for (auto deadline = std::chrono::steady_clock::now() + 10s; std::chrono::steady_clock::now() < deadline;) {
    {
      std::lock_guard lock(mutex);
      if (progress.count("planner")) planner_progress = progress["planner"];
    }
    if (planner_progress > 0) break;
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_GT(planner_progress, 0) << h.log("planner");
  std::this_thread::sleep_for(500ms);
  {
    std::lock_guard lock(mutex);
    EXPECT_LT(static_cast<double>(clock_ns.load() - progress["planner"]) * 1e-9, 1.0) << "an idle planner lags";
  }

  // 2. A process reporting the same progress for 2 s of wall time holds the clock within the lag (plus the
  //    steps between two reports) of it.
  auto reports = h.bus().publisher<msg::Progress>("system/progress", bus::Qos::sensorData(1));
  const std::int64_t held_at = clock_ns.load();
  ASSERT_GT(held_at, 0);
  msg::Progress stuck;
  stuck.name("stuck-test-process");
  stuck.stamp_ns(held_at);
  for (int i = 0; i < 40; ++i) {
    reports.publish(stuck);
    std::this_thread::sleep_for(50ms);
  }
  const double ran_on_s = static_cast<double>(clock_ns.load() - held_at) * 1e-9;
  EXPECT_LT(ran_on_s, 0.3 + 0.5) << "2 s of wall time at speed 4 would be 8 s of simulated time";
  EXPECT_GE(ran_on_s, 0.0);
  EXPECT_NE(h.log("sim").find("stuck-test-process"), std::string::npos) << "nothing said who held the clock (logged every 10 s)\n"
                                                                        << h.log("sim");

  // 3. Silent for 1 s of wall time: forgotten, the clock runs again at about the speed asked for.
  const std::int64_t before = clock_ns.load();
  std::this_thread::sleep_for(3s);
  EXPECT_GT(static_cast<double>(clock_ns.load() - before) * 1e-9, 2.0) << h.log("sim");
  EXPECT_NE(h.log("sim").find("pacing: stuck-test-process stopped reporting its progress"), std::string::npos) << h.log("sim");
  EXPECT_TRUE(h.running("sim"));
  EXPECT_TRUE(h.running("planner"));
}
