// Typed round trips of every message type inside one process: same vendor and across vendors, with a
// transient-local late joiner, keyed instances and an 8 MB point cloud.
#include "samples.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

namespace ddsnav::test {
namespace {

using bus::Vendor;

// Publishes sample 1 before the subscriber exists (served to it as a late joiner), then sample 2 live.
void roundTripEveryType(Vendor pub_vendor, Vendor sub_vendor, int domain_offset) {
  bus::Participant pub(options(pub_vendor, domain_offset, "rt-pub"));
  bus::Participant sub(options(sub_vendor, domain_offset, "rt-sub"));
  forEachMessageType([&](auto proto) {
    using T = decltype(proto);
    SCOPED_TRACE(shortName<T>());
    const std::string topic = "test/" + shortName<T>();
    auto writer = pub.publisher<T>(topic, bus::Qos::state(2));
    const T first = makeSample<T>(1);
    writer.publish(first);
    auto inbox = sub.inbox<T>(topic, bus::Qos::state(2));
    std::optional<T> got = inbox.wait(kWait);
    ASSERT_TRUE(got.has_value()) << "late joiner got nothing";
    EXPECT_EQ(*got, first);
    const T second = makeSample<T>(2);
    writer.publish(second);
    got = inbox.wait(kWait);
    ASSERT_TRUE(got.has_value()) << "live sample did not arrive";
    EXPECT_EQ(*got, second);
  });
}

TEST(BusInProcess, FastToFastEveryType) { roundTripEveryType(Vendor::FastDDS, Vendor::FastDDS, 0); }
TEST(BusInProcess, CycloneToCycloneEveryType) { roundTripEveryType(Vendor::CycloneDDS, Vendor::CycloneDDS, 1); }
TEST(BusInProcess, FastToCycloneEveryType) { roundTripEveryType(Vendor::FastDDS, Vendor::CycloneDDS, 2); }
TEST(BusInProcess, CycloneToFastEveryType) { roundTripEveryType(Vendor::CycloneDDS, Vendor::FastDDS, 3); }

// 8 MB of xyz (699051 points) plus intensities: several hundred fragments across vendors.
void largeCloud(Vendor pub_vendor, Vendor sub_vendor, int domain_offset) {
  bus::Participant pub(options(pub_vendor, domain_offset, "cloud-pub"));
  bus::Participant sub(options(sub_vendor, domain_offset, "cloud-sub"));
  auto writer = pub.publisher<msg::PointCloud>("sensors/points", bus::Qos::state(1));
  auto inbox = sub.inbox<msg::PointCloud>("sensors/points", bus::Qos::state(1));
  ASSERT_TRUE(writer.waitForSubscribers(1, kWait));
  const msg::PointCloud cloud = makeCloud(3, 8 * 1024 * 1024 / 12);
  ASSERT_GE(cloud.xyz().size() * sizeof(float), 8u * 1024 * 1024 - 12);
  writer.publish(cloud);
  std::optional<msg::PointCloud> got = inbox.wait(kWait);
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->xyz().size(), cloud.xyz().size());
  EXPECT_TRUE(*got == cloud);  // EXPECT_EQ would print 8 MB on failure
}

TEST(BusInProcess, LargeCloudFastToCyclone) { largeCloud(Vendor::FastDDS, Vendor::CycloneDDS, 4); }
TEST(BusInProcess, LargeCloudCycloneToFast) { largeCloud(Vendor::CycloneDDS, Vendor::FastDDS, 5); }
TEST(BusInProcess, LargeCloudFastToFast) { largeCloud(Vendor::FastDDS, Vendor::FastDDS, 6); }
TEST(BusInProcess, LargeCloudCycloneToCyclone) { largeCloud(Vendor::CycloneDDS, Vendor::CycloneDDS, 7); }

// Keyed: with depth 1 per instance a late joiner still gets one status per component name.
void keyedLateJoiner(Vendor pub_vendor, Vendor sub_vendor, int domain_offset) {
  bus::Participant pub(options(pub_vendor, domain_offset, "status-pub"));
  bus::Participant sub(options(sub_vendor, domain_offset, "status-sub"));
  auto writer = pub.publisher<msg::ComponentStatus>("system/status", bus::Qos::state(1));
  msg::ComponentStatus a = makeSample<msg::ComponentStatus>(1);
  msg::ComponentStatus b = makeSample<msg::ComponentStatus>(2);
  msg::ComponentStatus a_newer = a;
  a_newer.detail("newer");
  writer.publish(a);
  writer.publish(b);
  writer.publish(a_newer);  // replaces a: same key
  auto inbox = sub.inbox<msg::ComponentStatus>("system/status", bus::Qos::state(1));
  std::map<std::string, msg::ComponentStatus> latest;
  while (latest.size() < 2) {
    std::optional<msg::ComponentStatus> got = inbox.wait(kWait);
    ASSERT_TRUE(got.has_value()) << "got " << latest.size() << " of 2 instances";
    latest[got->name()] = *got;
  }
  EXPECT_EQ(latest[a.name()], a_newer);
  EXPECT_EQ(latest[b.name()], b);
  EXPECT_FALSE(inbox.wait(200ms).has_value()) << "the replaced sample of the first key was delivered";
}

TEST(BusInProcess, KeyedLateJoinerFastToCyclone) { keyedLateJoiner(Vendor::FastDDS, Vendor::CycloneDDS, 8); }
TEST(BusInProcess, KeyedLateJoinerCycloneToFast) { keyedLateJoiner(Vendor::CycloneDDS, Vendor::FastDDS, 9); }

// SampleInfo carries the writer's source timestamp on both vendors.
TEST(BusInProcess, SampleInfoHasSourceTimestamp) {
  for (Vendor v : {Vendor::FastDDS, Vendor::CycloneDDS}) {
    SCOPED_TRACE(vendorTag(v));
    bus::Participant p(options(v, 10, "info"));
    std::mutex m;
    std::condition_variable cv;
    std::int64_t stamp = 0;
    auto sub = p.subscribe<msg::Clock>("system/clock", bus::Qos::commands(),
                                       [&](const msg::Clock&, const bus::SampleInfo& info) {
                                         std::lock_guard lock(m);
                                         stamp = info.source_timestamp_ns;
                                         cv.notify_all();
                                       });
    auto pub = p.publisher<msg::Clock>("system/clock", bus::Qos::commands());
    ASSERT_TRUE(pub.waitForSubscribers(1, kWait));
    auto before = std::chrono::system_clock::now().time_since_epoch();
    pub.publish(makeSample<msg::Clock>(1));
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, kWait, [&] { return stamp != 0; }));
    EXPECT_GE(stamp, std::chrono::duration_cast<std::chrono::nanoseconds>(before).count() - 1'000'000);
  }
}

}  // namespace
}  // namespace ddsnav::test

namespace ddsnav::test {
namespace {

// Destroying a Subscription while its callback runs waits for the callback to finish.
TEST(BusInProcess, SubscriptionDestructionWaitsForCallback) {
  for (Vendor v : {Vendor::FastDDS, Vendor::CycloneDDS}) {
    SCOPED_TRACE(vendorTag(v));
    bus::Participant p(options(v, 18, "teardown"));
    auto pub = p.publisher<msg::Clock>("teardown/clock", bus::Qos::commands());
    std::atomic<bool> inside{false}, entered{false}, after_destroy{false};
    std::atomic<bool> destroyed{false};
    auto sub = std::make_unique<bus::Subscription>(
        p.subscribe<msg::Clock>("teardown/clock", bus::Qos::commands(), [&](const msg::Clock&) {
          if (destroyed) after_destroy = true;
          inside = true;
          entered = true;
          std::this_thread::sleep_for(std::chrono::milliseconds(100));
          inside = false;
        }));
    ASSERT_TRUE(pub.waitForSubscribers(1, kWait));
    pub.publish(makeSample<msg::Clock>(1));
    auto deadline = std::chrono::steady_clock::now() + kWait;
    while (!entered && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
    ASSERT_TRUE(entered.load());
    sub.reset();
    destroyed = true;
    EXPECT_FALSE(inside.load()) << "Subscription destructor returned while its callback was running";
    EXPECT_FALSE(after_destroy.load());
  }
}

}  // namespace
}  // namespace ddsnav::test

namespace ddsnav::test {
namespace {

// Every QoS profile matches itself across vendors and carries live samples.
TEST(BusInProcess, QosProfilesAcrossVendors) {
  const std::vector<std::pair<std::string, bus::Qos>> profiles = {
      {"sensorData", bus::Qos::sensorData()}, {"commands", bus::Qos::commands()}, {"state", bus::Qos::state(3)}};
  for (auto [pub_vendor, sub_vendor] : {std::pair{Vendor::FastDDS, Vendor::CycloneDDS},
                                        std::pair{Vendor::CycloneDDS, Vendor::FastDDS}}) {
    bus::Participant pub(options(pub_vendor, 19, "qos-pub"));
    bus::Participant sub(options(sub_vendor, 19, "qos-sub"));
    for (const auto& [name, qos] : profiles) {
      SCOPED_TRACE(vendorTag(pub_vendor) + "->" + vendorTag(sub_vendor) + " " + name);
      const std::string topic = "qos/" + name;
      auto writer = pub.publisher<msg::VehicleState>(topic, qos);
      auto inbox = sub.inbox<msg::VehicleState>(topic, qos);
      ASSERT_TRUE(writer.waitForSubscribers(1, kWait));
      ASSERT_TRUE(inbox.subscription().waitForPublishers(1, kWait));
      const msg::VehicleState s = makeSample<msg::VehicleState>(7);
      // Best effort may drop a sample right after matching; keep publishing until one arrives.
      std::optional<msg::VehicleState> got;
      for (int i = 0; i < 50 && !got; ++i) {
        writer.publish(s);
        got = inbox.wait(std::chrono::milliseconds(200));
      }
      ASSERT_TRUE(got.has_value());
      EXPECT_EQ(*got, s);
    }
  }
}

// waitForSubscribers means matched both ways: the one sample published right after it reaches a volatile
// subscriber of the other vendor. Every round is a fresh discovery: before the bus waited for a foreign
// reader to settle, a Cyclone subscriber learnt of a Fast DDS publisher up to a second after the publisher
// had matched it, and the sample was lost in about half of the rounds (docs/bus.md, "Matched is not matched
// both ways").
void publishOnceAfterWaiting(Vendor pub_vendor, Vendor sub_vendor, int domain_offset) {
  for (std::uint32_t round = 1; round <= 4; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    bus::Participant pub(options(pub_vendor, domain_offset, "once-pub"));
    auto writer = pub.publisher<msg::PlanRequest>("test/once", bus::Qos::commands());
    bus::Participant sub(options(sub_vendor, domain_offset, "once-sub"));
    auto inbox = sub.inbox<msg::PlanRequest>("test/once", bus::Qos::commands());
    ASSERT_TRUE(writer.waitForSubscribers(1, kWait));
    msg::PlanRequest request;
    request.request_id(round);
    writer.publish(request);
    const auto got = inbox.wait(std::chrono::seconds(3));
    ASSERT_TRUE(got.has_value()) << "the sample published once after waitForSubscribers never arrived";
    EXPECT_EQ(got->request_id(), round);
  }
}

TEST(BusInProcess, OneSampleAfterWaitingArrivesFastToCyclone) {
  publishOnceAfterWaiting(Vendor::FastDDS, Vendor::CycloneDDS, 30);
}
TEST(BusInProcess, OneSampleAfterWaitingArrivesCycloneToFast) {
  publishOnceAfterWaiting(Vendor::CycloneDDS, Vendor::FastDDS, 31);
}

}  // namespace
}  // namespace ddsnav::test
