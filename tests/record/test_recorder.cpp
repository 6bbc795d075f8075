// The recorder in-process: schemas from the IDL, per-topic drop counts with a tiny queue and a slow
// "disk", and a killed recorder process leaving a readable file.
#include "child.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/info.hpp>
#include <ddsnav/record/recorder.hpp>
#include <ddsnav/record/schemas.hpp>

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <csignal>
#include <filesystem>

using namespace ddsnav;
namespace fs = std::filesystem;

namespace {

fs::path tempFile(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("ddsnav_record_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

// Calls recorder.poll() until it subscribed to `topics` topics (bounded).
bool pollUntilSubscribed(record::Recorder& recorder, std::size_t topics, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    recorder.poll();
    if (recorder.counts().size() >= topics) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

TEST(RecordSchemas, IdlTextOfTheTypeWithItsIncludes) {
  const auto path = record::idlSchemaFor("ddsnav::msg::Path");
  ASSERT_TRUE(path);
  EXPECT_NE(path->find("struct Path {"), std::string::npos);
  EXPECT_NE(path->find("struct PlannerStatistics {"), std::string::npos);
  EXPECT_NE(path->find("struct Header {"), std::string::npos);  // from common.idl
  EXPECT_LT(path->find("struct Header {"), path->find("struct Path {"));
  EXPECT_EQ(path->find("#include"), std::string::npos);
  EXPECT_TRUE(record::idlSchemaFor("ddsnav::msg::Clock"));
  EXPECT_FALSE(record::idlSchemaFor("ddsnav::msg::NoSuchType"));
  EXPECT_FALSE(record::idlSchemaFor("other::Path"));
}

TEST(RecordQos, TableFollowsTheTopicsIntent) {
  EXPECT_EQ(record::qosForTopic("sensors/points").qos.reliability, bus::Reliability::BestEffort);
  EXPECT_EQ(record::qosForTopic("map/octomap").qos.durability, bus::Durability::TransientLocal);
  EXPECT_EQ(record::qosForTopic("control/cmd_vel").profile, "commands");
  const auto unknown = record::qosForTopic("somebody/else");
  EXPECT_EQ(unknown.profile, "default");
  EXPECT_EQ(unknown.qos.reliability, bus::Reliability::Reliable);
  EXPECT_EQ(unknown.qos.durability, bus::Durability::Volatile);
}

TEST(Recorder, TinyQueueCountsDropsPerTopic) {
  constexpr int kDomain = 194;
  constexpr int kCount = 100;
  const fs::path file = tempFile("drops.mcap");
  bus::Participant pub_side({.vendor = bus::Vendor::FastDDS, .domain_id = kDomain, .name = "drops-pub"});
  bus::Participant rec_side({.vendor = bus::Vendor::FastDDS, .domain_id = kDomain, .name = "drops-rec"});
  auto pub = pub_side.publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands(kCount));
  record::RecorderOptions options;
  options.output = file.string();
  options.topics = {"control/cmd_vel"};
  options.queue_messages = 2;
  options.write_delay = std::chrono::milliseconds(5);  // a disk slower than the publisher
  {
    record::Recorder recorder(rec_side, options);
    ASSERT_TRUE(pollUntilSubscribed(recorder, 1, std::chrono::seconds(10)));
    ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(10)));
    for (int i = 0; i < kCount; ++i) {
      msg::VelocityCommand c;
      c.stamp_ns(i);
      c.v(0.1 * i);
      pub.publish(c);
    }
    // Reliable: every sample reaches the recorder; the queue decides what is written.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (recorder.counts()[0].received < kCount && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    recorder.stop();
    const auto c = recorder.counts().at(0);
    EXPECT_EQ(c.received, static_cast<std::uint64_t>(kCount));
    EXPECT_GT(c.dropped, 0u);
    EXPECT_GT(c.written, 0u);
    EXPECT_EQ(c.written + c.dropped, c.received);

    record::McapReader r(file.string());
    EXPECT_FALSE(r.truncated());
    EXPECT_EQ(r.summary().message_count, c.written);
    const auto info = record::describeRecording(r);
    ASSERT_EQ(info["topics"].size(), 1u);
    EXPECT_EQ(info["topics"][0]["dropped"].get<std::uint64_t>(), c.dropped);
    EXPECT_EQ(info["topics"][0]["received"].get<std::uint64_t>(), c.received);
    EXPECT_EQ(info["topics"][0]["qos"], "commands");
    // What was written decodes, in order.
    std::int64_t last = -1;
    r.forEachMessage([&](const record::MessageView& m) {
      msg::VelocityCommand v;
      EXPECT_TRUE(msg::type_support<msg::VelocityCommand>().deserialize(m.data.data(), m.data.size(), &v));
      EXPECT_GT(v.stamp_ns(), last);
      last = v.stamp_ns();
      // Source time from the writer, log time at reception: same host clock, so in that order.
      EXPECT_GT(m.publish_time, 0u);
      EXPECT_GE(m.log_time + 1'000'000, m.publish_time);
      return true;
    });
  }
}

TEST(Recorder, UnknownBestEffortTopicFallsBackToBestEffort) {
  constexpr int kDomain = 196;
  const fs::path file = tempFile("fallback.mcap");
  bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "fb-pub"});
  bus::Participant rec_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "fb-rec"});
  auto pub = pub_side.publisher<msg::Clock>("test/best_effort", bus::Qos::sensorData());
  record::RecorderOptions options;
  options.output = file.string();
  options.topics = {"test/best_effort"};
  record::Recorder recorder(rec_side, options);
  ASSERT_TRUE(pollUntilSubscribed(recorder, 1, std::chrono::seconds(10)));
  EXPECT_EQ(recorder.counts()[0].qos_profile, "default");  // reliable first: matches nothing here
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (recorder.counts()[0].qos_profile != "default-best-effort" && std::chrono::steady_clock::now() < deadline) {
    recorder.poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_EQ(recorder.counts()[0].qos_profile, "default-best-effort");
  ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(10)));
  // Best effort: publish until something arrives (bounded), rather than assume no loss.
  for (int i = 1; i <= 200 && recorder.counts()[0].received < 3; ++i) {
    msg::Clock c;
    c.stamp_ns(i);
    pub.publish(c);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_GE(recorder.counts()[0].received, 3u);
}

TEST(Recorder, FullDiskStopsWritingAndCountsTheRestAsDropped) {
  // A file size limit stands in for a full disk: writes past it fail with EFBIG (SIGXFSZ ignored).
  // Each test runs in its own process under ctest, so the limit touches nothing else.
  constexpr int kDomain = 198;
  const fs::path file = tempFile("full.mcap");
  ::signal(SIGXFSZ, SIG_IGN);
  rlimit old{};
  ::getrlimit(RLIMIT_FSIZE, &old);
  rlimit small = old;
  small.rlim_cur = 64 * 1024;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  {
    // Cyclone: Fast DDS's shared-memory segments are files too, and would hit the limit.
    bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "full-pub"});
    bus::Participant rec_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "full-rec"});
    auto pub = pub_side.publisher<msg::PointCloud>("sensors/points", bus::Qos::commands(50));
    record::RecorderOptions options;
    options.output = file.string();
    options.topics = {"sensors/points"};
    options.mcap.compression = record::Compression::None;
    options.mcap.chunk_size = 8 * 1024;
    record::Recorder recorder(rec_side, options);
    ASSERT_TRUE(pollUntilSubscribed(recorder, 1, std::chrono::seconds(10)));
    ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(10)));
    msg::PointCloud cloud;
    cloud.xyz().assign(3 * 400, 1.5f);  // ~4.8 KB: the limit is crossed after ~13 clouds
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    for (int i = 0; !recorder.failed() && std::chrono::steady_clock::now() < deadline; ++i) {
      cloud.header().stamp_ns(i);
      pub.publish(cloud);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_TRUE(recorder.failed());
    EXPECT_NE(recorder.error().find(file.string()), std::string::npos) << recorder.error();
    EXPECT_THROW(recorder.stop(), record::McapError);  // the summary cannot be written either
    const auto c = recorder.counts().at(0);
    EXPECT_GT(c.written, 0u);
    EXPECT_EQ(c.written + c.dropped, c.received);
  }
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  // What reached the disk reads back as a truncated recording.
  record::McapReader r(file.string());
  EXPECT_TRUE(r.truncated());
  EXPECT_GT(r.summary().message_count, 0u);
}

TEST(Recorder, KilledRecorderLeavesAReadableFile) {
  constexpr int kDomain = 195;
  const fs::path file = tempFile("killed.mcap");
  fs::remove(file);
  bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "killed-pub"});
  auto pub = pub_side.publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());
  record_test::Child recorder({DDSNAV_RECORD_BIN, "--dds", "cyclonedds", "--domain", std::to_string(kDomain), "--topics",
                               "vehicle/state", "--chunk-kb", "1", "-o", file.string()},
                              tempFile("killed.log").string());
  ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(15))) << recorder.log();
  // Publish until a few chunks are on disk, then kill -9: no chance to write a summary.
  std::int64_t sent = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while ((!fs::exists(file) || fs::file_size(file) < 6000) && std::chrono::steady_clock::now() < deadline) {
    msg::VehicleState s;
    s.header().stamp_ns(++sent);
    s.header().frame_id("map");
    s.position().x(static_cast<double>(sent));
    pub.publish(s);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_GE(fs::file_size(file), 6000u) << recorder.log();
  recorder.signal(SIGKILL);
  ASSERT_TRUE(recorder.wait(std::chrono::seconds(5)));

  record::McapReader r(file.string());
  EXPECT_TRUE(r.truncated());
  EXPECT_FALSE(r.hasSummary());
  ASSERT_EQ(r.channels().size(), 1u);
  EXPECT_EQ(r.channels().begin()->second.metadata.at("dds_type"), "ddsnav::msg::VehicleState");
  EXPECT_GT(r.summary().message_count, 5u);
  std::uint64_t decoded = 0;
  r.forEachMessage([&](const record::MessageView& m) {
    msg::VehicleState s;
    EXPECT_TRUE(msg::type_support<msg::VehicleState>().deserialize(m.data.data(), m.data.size(), &s));
    EXPECT_EQ(s.position().x(), static_cast<double>(s.header().stamp_ns()));
    ++decoded;
    return true;
  });
  EXPECT_EQ(decoded, r.summary().message_count);
  const auto info = record::describeRecording(r);
  EXPECT_TRUE(info["truncated"].get<bool>());
  EXPECT_FALSE(info["topic_counts_recorded"].get<bool>());
}

}  // namespace

// Removes this process's temporary files when the tests end.
namespace {
class TempCleanup : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(fs::temp_directory_path() / ("ddsnav_record_test_" + std::to_string(::getpid())), ec);
  }
};
[[maybe_unused]] ::testing::Environment* const kTempCleanup = ::testing::AddGlobalTestEnvironment(new TempCleanup);
}  // namespace
