// Subscriptions through the executor over real DDS (both vendors, domain 230): every callback runs on the
// executor's thread, never on a vendor thread, and a busy executor's queue keeps the newest samples.
// Opens DDS participants: run under the DDS test lock (label bus).
#include <ddsnav/runtime/executor.hpp>
#include <ddsnav/runtime/topics.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <mutex>
#include <set>

namespace ddsnav::runtime {
namespace {

using namespace std::chrono_literals;

constexpr int kDomain = 230;

msg::VehicleState state(double x) {
  msg::VehicleState s;
  msg::Vec3 p;
  p.x(x);
  s.position(p);
  return s;
}

class ExecutorOverDds : public ::testing::TestWithParam<bus::Vendor> {};

TEST_P(ExecutorOverDds, CallbacksRunOnTheExecutorThreadNeverOnAVendorThread) {
  bus::Participant participant({.vendor = GetParam(), .domain_id = kDomain, .name = "executor-test"});
  const std::string topic = "test/executor_threads";
  Executor executor;
  std::mutex mutex;
  std::set<std::thread::id> callback_threads, vendor_threads;
  std::atomic<int> received{0};
  // The plain bus callback shows which threads the vendor delivers on.
  bus::Subscription plain = participant.subscribe<msg::VehicleState>(topic, bus::Qos::commands(100), [&](const msg::VehicleState&) {
    std::lock_guard lock(mutex);
    vendor_threads.insert(std::this_thread::get_id());
  });
  bus::Subscription queued = executor.subscribe<msg::VehicleState>(participant, topic, bus::Qos::commands(100), [&](const msg::VehicleState&) {
    {
      std::lock_guard lock(mutex);
      callback_threads.insert(std::this_thread::get_id());
    }
    if (++received == 50) executor.stop();
  });
  auto pub = participant.publisher<msg::VehicleState>(topic, bus::Qos::commands(100));
  ASSERT_TRUE(pub.waitForSubscribers(2, 10s));
  std::thread runner([&] { executor.run(); });
  const auto runner_id = runner.get_id();
  for (int i = 0; i < 50; ++i) pub.publish(state(i));
  auto done = std::async(std::launch::async, [&] { runner.join(); });
  if (done.wait_for(20s) != std::future_status::ready) {
    executor.stop();
    done.wait();
    FAIL() << "only " << received.load() << " of 50 samples reached the executor";
  }
  std::lock_guard lock(mutex);
  ASSERT_EQ(callback_threads.size(), 1u);
  EXPECT_EQ(*callback_threads.begin(), runner_id);
  ASSERT_FALSE(vendor_threads.empty());
  EXPECT_EQ(vendor_threads.count(runner_id), 0u);
}

TEST_P(ExecutorOverDds, ABusyExecutorKeepsTheNewestSamplesAndCountsTheDropped) {
  bus::Participant participant({.vendor = GetParam(), .domain_id = kDomain, .name = "executor-overflow"});
  const std::string topic = "test/executor_overflow";
  Executor executor;
  std::vector<double> seen;
  // Depth 4: while the executor is not running, only the four newest of 20 stay queued.
  bus::Subscription queued = executor.subscribe<msg::VehicleState>(participant, topic, bus::Qos::commands(4), [&](const msg::VehicleState& s) {
    seen.push_back(s.position().x());
  });
  auto pub = participant.publisher<msg::VehicleState>(topic, bus::Qos::commands(20));
  ASSERT_TRUE(pub.waitForSubscribers(1, 10s));
  for (int i = 0; i < 20; ++i) pub.publish(state(i));
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (executor.queueStats().at(0).received < 20 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(5ms);
  const auto stats = executor.queueStats().at(0);
  EXPECT_EQ(stats.topic, topic);
  EXPECT_EQ(stats.received, 20u);
  EXPECT_EQ(stats.dropped, 16u);
  executor.post([&] { executor.stop(); });  // after the queued samples
  Timer guard = executor.every(5s, [&] { executor.stop(); });
  executor.run();
  EXPECT_EQ(seen, (std::vector<double>{16, 17, 18, 19}));
}

INSTANTIATE_TEST_SUITE_P(Vendors, ExecutorOverDds, ::testing::Values(bus::Vendor::FastDDS, bus::Vendor::CycloneDDS),
                         [](const auto& info) { return std::string(info.param == bus::Vendor::FastDDS ? "Fast" : "Cyclone"); });

}  // namespace
}  // namespace ddsnav::runtime
