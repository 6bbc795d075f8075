// Raw API: bytes taken from a typed publisher of one vendor are re-published raw and decoded by typed
// subscribers of both vendors; discovery reports topic, type name and keyed-ness.
#include "samples.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

namespace ddsnav::test {
namespace {

using bus::Vendor;

struct Captured {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<std::uint8_t> bytes;
  std::string type_name;
  bool done = false;
};

void captureAndReplay(Vendor typed_vendor, Vendor raw_vendor, int domain_offset) {
  bus::Participant typed(options(typed_vendor, domain_offset, "raw-typed"));
  bus::Participant raw(options(raw_vendor, domain_offset, "raw-recorder"));
  forEachMessageType([&](auto proto) {
    using T = decltype(proto);
    const msg::TypeSupport& ts = msg::type_support<T>();
    SCOPED_TRACE(shortName<T>());
    const std::string topic = "record/" + shortName<T>();
    const std::string replay_topic = "replay/" + shortName<T>();
    auto writer = typed.publisher<T>(topic, bus::Qos::state(1));
    const T sample = makeSample<T>(4);
    writer.publish(sample);

    std::optional<bus::TopicInfo> info = raw.waitForTopic(topic, kWait);
    ASSERT_TRUE(info.has_value()) << "publisher not discovered";
    EXPECT_EQ(info->type_name, ts.name);
    EXPECT_EQ(info->keyed, ts.keyed);

    Captured cap;
    auto recorder = raw.subscribeRaw(*info, bus::Qos::state(1), [&](const bus::RawSample& s) {
      std::lock_guard lock(cap.mutex);
      cap.bytes.assign(s.payload.begin(), s.payload.end());
      cap.type_name = s.type_name;
      cap.done = true;
      cap.cv.notify_all();
    });
    {
      std::unique_lock lock(cap.mutex);
      ASSERT_TRUE(cap.cv.wait_for(lock, kWait, [&] { return cap.done; })) << "no raw sample";
    }
    EXPECT_EQ(cap.type_name, ts.name);
    ASSERT_GE(cap.bytes.size(), 4u);

    bus::RawPublisher replay = raw.rawPublisher({replay_topic, info->type_name, info->keyed}, bus::Qos::state(1));
    replay.publish(cap.bytes);
    auto other_vendor = typed.inbox<T>(replay_topic, bus::Qos::state(1));
    auto same_vendor = raw.inbox<T>(replay_topic, bus::Qos::state(1));
    std::optional<T> got = other_vendor.wait(kWait);
    ASSERT_TRUE(got.has_value()) << "typed subscriber of the publisher's vendor got no replayed sample";
    EXPECT_EQ(*got, sample);
    got = same_vendor.wait(kWait);
    ASSERT_TRUE(got.has_value()) << "typed subscriber of the replaying vendor got nothing";
    EXPECT_EQ(*got, sample);
  });
}

TEST(BusRaw, FastCapturedReplayedByCyclone) { captureAndReplay(Vendor::FastDDS, Vendor::CycloneDDS, 11); }
TEST(BusRaw, CycloneCapturedReplayedByFast) { captureAndReplay(Vendor::CycloneDDS, Vendor::FastDDS, 12); }

// Fast DDS carries a type this build does not know as opaque bytes (unkeyed only).
TEST(BusRaw, FastCarriesUnknownUnkeyedType) {
  bus::Participant a(options(Vendor::FastDDS, 13, "opaque-a"));
  bus::Participant b(options(Vendor::FastDDS, 13, "opaque-b"));
  const bus::TopicInfo topic{"other/thing", "other::Thing", false};
  auto pub = a.rawPublisher(topic, bus::Qos::state(1));
  const std::vector<std::uint8_t> bytes = {0, 1, 0, 0, 9, 8, 7, 6, 5};
  pub.publish(bytes);
  std::optional<bus::TopicInfo> seen = b.waitForTopic("other/thing", kWait);
  ASSERT_TRUE(seen.has_value());
  EXPECT_EQ(*seen, topic);
  Captured cap;
  auto sub = b.subscribeRaw(*seen, bus::Qos::state(1), [&](const bus::RawSample& s) {
    std::lock_guard lock(cap.mutex);
    cap.bytes.assign(s.payload.begin(), s.payload.end());
    cap.done = true;
    cap.cv.notify_all();
  });
  std::unique_lock lock(cap.mutex);
  ASSERT_TRUE(cap.cv.wait_for(lock, kWait, [&] { return cap.done; }));
  EXPECT_EQ(cap.bytes, bytes);
}

// discoveredTopics lists remote publishers with the right type on both vendors, sorted, no duplicates.
TEST(BusRaw, DiscoveredTopicsListsPublishers) {
  for (Vendor observer_vendor : {Vendor::FastDDS, Vendor::CycloneDDS}) {
    SCOPED_TRACE(vendorTag(observer_vendor));
    bus::Participant pub(options(Vendor::CycloneDDS, 14, "disc-pub"));
    bus::Participant fast_pub(options(Vendor::FastDDS, 14, "disc-pub2"));
    bus::Participant observer(options(observer_vendor, 14, "disc-observer"));
    auto w1 = pub.publisher<msg::PointCloud>("sensors/points", bus::Qos::sensorData());
    auto w2 = fast_pub.publisher<msg::ComponentStatus>("system/status", bus::Qos::state());
    ASSERT_TRUE(observer.waitForTopic("sensors/points", kWait).has_value());
    ASSERT_TRUE(observer.waitForTopic("system/status", kWait).has_value());
    std::vector<bus::TopicInfo> topics = observer.discoveredTopics();
    std::vector<bus::TopicInfo> expected = {{"sensors/points", "ddsnav::msg::PointCloud", false},
                                            {"system/status", "ddsnav::msg::ComponentStatus", true}};
    EXPECT_EQ(topics, expected);
  }
}

}  // namespace
}  // namespace ddsnav::test
