// Intra-process delivery (ParticipantOptions::intra_process, what `ddsnav container` uses): the object
// itself reaches local subscriptions, never serialized; QoS rules and keep-last depth hold; DDS still
// carries the sample to readers outside the intra-process set (another participant in this process,
// another process), and a local reader never gets a sample twice.
#include "child_process.hpp"
#include "samples.hpp"
#include "test_support.hpp"

#include <ddsnav/runtime/executor.hpp>

#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <iostream>
#include <thread>

#ifndef BUS_TEST_PEER
#error "BUS_TEST_PEER must name the bus_test_peer executable"
#endif

namespace ddsnav::test {
namespace {

using bus::Vendor;

bus::ParticipantOptions intra(Vendor vendor, int key, const std::string& name) {
  auto o = options(vendor, key, name);
  o.intra_process = true;
  return o;
}

// This process's clouds carry its pid in frame_id. Once (CI, 2026-12-05) the Fast and Cyclone runs of
// QosRulesAndLateJoiners, started side by side, each got exactly the other's durable history: two test
// processes heard each other. What this file checks is this process's delivery, so clouds of another
// process are set aside and reported, never counted as duplicates.
std::string ownFrame() { return "map-pid-" + std::to_string(::getpid()); }

msg::PointCloud ownCloud(int variant, std::size_t points) {
  auto cloud = makeCloud(variant, points);
  cloud.header().frame_id(ownFrame());
  return cloud;
}

// What a shared subscription saw from this process's writers: the pointers, in order.
struct Seen {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::shared_ptr<const msg::PointCloud>> clouds;
  std::vector<std::uint64_t> writers;
  std::size_t foreign = 0;  // clouds of another process on the same domain

  auto callback() {
    return [this](std::shared_ptr<const msg::PointCloud> c, const bus::SampleInfo& info) {
      {
        std::lock_guard lock(mutex);
        if (c->header().frame_id() != ownFrame()) {
          if (++foreign == 1)
            std::cerr << "note: a cloud of another process ('" << c->header().frame_id()
                      << "') reached this test's domain; set aside\n";
          return;
        }
        clouds.push_back(std::move(c));
        writers.push_back(info.publication_handle);
      }
      changed.notify_all();
    };
  }
  bool waitFor(std::size_t n, std::chrono::milliseconds timeout = kWait) {
    std::unique_lock lock(mutex);
    return changed.wait_for(lock, timeout, [&] { return clouds.size() >= n; });
  }
  std::size_t size() {
    std::lock_guard lock(mutex);
    return clouds.size();
  }
};

class IntraProcess : public ::testing::TestWithParam<Vendor> {};

// The subscriber gets the publisher's own object; with nobody outside the process listening on a
// volatile topic, nothing is serialized at all.
TEST_P(IntraProcess, DeliversTheObjectWithoutSerialization) {
  const int key = GetParam() == Vendor::FastDDS ? 60 : 61;
  bus::Participant a(intra(GetParam(), key, "intra-a")), b(intra(GetParam(), key, "intra-b"));
  Seen seen;
  auto sub = b.subscribeShared<msg::PointCloud>("intra/points", bus::Qos::sensorData(), seen.callback());
  auto pub = a.publisher<msg::PointCloud>("intra/points", bus::Qos::sensorData());
  auto cloud = std::make_shared<const msg::PointCloud>(ownCloud(1, 1024 * 1024 / 12));
  pub.publish(cloud);
  ASSERT_TRUE(seen.waitFor(1));
  EXPECT_EQ(seen.clouds[0].get(), cloud.get()) << "the subscriber got a copy, not the published object";
  EXPECT_EQ(pub.ddsWrites(), 0u) << "serialized for DDS although no reader outside the process set exists";
  // publish(const T&) copies once, still without serialization.
  pub.publish(*cloud);
  ASSERT_TRUE(seen.waitFor(2));
  EXPECT_NE(seen.clouds[1].get(), cloud.get());
  EXPECT_TRUE(*seen.clouds[1] == *cloud);
  EXPECT_EQ(pub.ddsWrites(), 0u);
}

// A reader outside the intra-process set (a plain participant in this process) still gets the sample
// over DDS; the intra-process reader gets each sample once, not also its DDS copy.
TEST_P(IntraProcess, OutsideReadersStillGetDdsAndLocalReadersNoDuplicate) {
  const int key = GetParam() == Vendor::FastDDS ? 62 : 63;
  bus::Participant a(intra(GetParam(), key, "intra-a")), b(intra(GetParam(), key, "intra-b"));
  bus::Participant outside(options(GetParam(), key, "plain"));
  for (const bus::Qos qos : {bus::Qos::commands(), bus::Qos::state(3)}) {
    const std::string topic = qos.durability == bus::Durability::Volatile ? "intra/commands" : "intra/state";
    SCOPED_TRACE(topic);
    Seen local;
    auto sub = b.subscribeShared<msg::PointCloud>(topic, qos, local.callback());
    auto plain = outside.inbox<msg::PointCloud>(topic, qos);
    auto pub = a.publisher<msg::PointCloud>(topic, qos);
    ASSERT_TRUE(pub.waitForSubscribers(2, kWait));  // the local reader matches over DDS too
    ASSERT_TRUE(plain.subscription().waitForPublishers(1, kWait));
    for (int i = 0; i < 3; ++i) pub.publish(ownCloud(i, 50));
    for (int i = 0; i < 3; ++i) {
      auto got = plain.wait(kWait);
      ASSERT_TRUE(got.has_value()) << "the plain participant got no DDS sample " << i;
      EXPECT_TRUE(*got == ownCloud(i, 50));
    }
    EXPECT_EQ(pub.ddsWrites(), 3u);
    ASSERT_TRUE(local.waitFor(3));
    std::this_thread::sleep_for(300ms);  // a DDS duplicate would have come with the plain reader's copies
    EXPECT_EQ(local.size(), 3u) << "the intra-process reader also got DDS copies";
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(*local.clouds[static_cast<std::size_t>(i)] == ownCloud(i, 50));
  }
}

// Transient local: a local subscriber that joins late gets the last `depth` objects (the same ones), a
// volatile one nothing old; a reliable reader is not served by a best-effort writer (DDS's rule).
TEST_P(IntraProcess, QosRulesAndLateJoiners) {
  const int key = GetParam() == Vendor::FastDDS ? 64 : 65;
  bus::Participant a(intra(GetParam(), key, "intra-a")), b(intra(GetParam(), key, "intra-b"));
  auto pub = a.publisher<msg::PointCloud>("intra/latched", bus::Qos::state(2));
  std::vector<std::shared_ptr<const msg::PointCloud>> sent;
  for (int i = 0; i < 4; ++i) {
    sent.push_back(std::make_shared<const msg::PointCloud>(ownCloud(i, 10)));
    pub.publish(sent.back());
  }
  Seen late, late_depth1, volatile_reader;
  auto s1 = b.subscribeShared<msg::PointCloud>("intra/latched", bus::Qos::state(2), late.callback());
  auto s2 = b.subscribeShared<msg::PointCloud>("intra/latched", bus::Qos::state(1), late_depth1.callback());
  auto s3 = b.subscribeShared<msg::PointCloud>("intra/latched", bus::Qos::commands(2), volatile_reader.callback());
  ASSERT_TRUE(late.waitFor(2));
  EXPECT_EQ(late.clouds[0].get(), sent[2].get());
  EXPECT_EQ(late.clouds[1].get(), sent[3].get());
  ASSERT_TRUE(late_depth1.waitFor(1));
  EXPECT_EQ(late_depth1.clouds[0].get(), sent[3].get());
  pub.publish(sent[0]);
  ASSERT_TRUE(volatile_reader.waitFor(1));
  EXPECT_EQ(volatile_reader.clouds[0].get(), sent[0].get()) << "the volatile reader got history";
  std::this_thread::sleep_for(300ms);  // DDS's durable copies, were they not dropped, would be in by now
  EXPECT_EQ(late.size(), 3u);
  EXPECT_EQ(late_depth1.size(), 2u);
  EXPECT_EQ(volatile_reader.size(), 1u);

  auto best_effort = a.publisher<msg::PointCloud>("intra/mixed", bus::Qos::sensorData());
  Seen reliable;
  auto s4 = b.subscribeShared<msg::PointCloud>("intra/mixed", bus::Qos::commands(), reliable.callback());
  best_effort.publish(sent[0]);
  EXPECT_FALSE(reliable.waitFor(1, 300ms)) << "a reliable reader was served by a best-effort writer";
}

// Keep-last depth and overflow counting in an executor queue hold for objects delivered intra-process.
TEST_P(IntraProcess, ExecutorQueueKeepsLastDepth) {
  const int key = GetParam() == Vendor::FastDDS ? 66 : 67;
  bus::Participant a(intra(GetParam(), key, "intra-a")), b(intra(GetParam(), key, "intra-b"));
  runtime::Executor executor;
  std::vector<std::size_t> sizes;
  auto sub = executor.subscribe<msg::PointCloud>(b, "intra/queue", bus::Qos::sensorData(2), [&](const msg::PointCloud& c) {
    sizes.push_back(c.xyz().size() / 3);
    if (sizes.size() == 2) executor.stop();
  });
  auto pub = a.publisher<msg::PointCloud>("intra/queue", bus::Qos::sensorData(2));
  for (std::size_t i = 1; i <= 5; ++i) pub.publish(ownCloud(0, i));  // the executor is not running: they queue
  const auto stats = executor.queueStats();
  ASSERT_EQ(stats.size(), 1u);
  EXPECT_EQ(stats[0].received, 5u);
  EXPECT_EQ(stats[0].dropped, 3u);
  executor.run();
  EXPECT_EQ(sizes, (std::vector<std::size_t>{4, 5}));
}

// Another process still gets the topic over DDS (bus_test_peer echoes in/PointCloud to out/PointCloud),
// and the local subscriber gets the sample once.
TEST_P(IntraProcess, RemoteProcessStillReceives) {
  const int key = GetParam() == Vendor::FastDDS ? 68 : 69;
  ChildProcess peer({BUS_TEST_PEER, "--dds", std::string(bus::vendorName(GetParam())), "--domain", std::to_string(testDomain(key))});
  ASSERT_EQ(peer.readLine(kWait), std::optional<std::string>("READY"));
  bus::Participant a(intra(GetParam(), key, "intra-a")), b(intra(GetParam(), key, "intra-b"));
  Seen local;
  auto sub = b.subscribeShared<msg::PointCloud>("in/PointCloud", bus::Qos::state(2), local.callback());
  auto echo = a.inbox<msg::PointCloud>("out/PointCloud", bus::Qos::state(2));
  auto pub = a.publisher<msg::PointCloud>("in/PointCloud", bus::Qos::state(2));
  auto cloud = std::make_shared<const msg::PointCloud>(ownCloud(3, 1000));
  pub.publish(cloud);
  auto got = echo.wait(kWait);
  ASSERT_TRUE(got.has_value()) << "the other process did not get the sample";
  EXPECT_TRUE(*got == *cloud);
  ASSERT_TRUE(local.waitFor(1));
  EXPECT_EQ(local.clouds[0].get(), cloud.get());
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(local.size(), 1u) << "the local subscriber also got the DDS copy";
  EXPECT_EQ(peer.stop(std::chrono::seconds(5)), 0);
}

INSTANTIATE_TEST_SUITE_P(Vendors, IntraProcess, ::testing::Values(Vendor::FastDDS, Vendor::CycloneDDS),
                         [](const auto& info) { return vendorTag(info.param); });

}  // namespace
}  // namespace ddsnav::test
