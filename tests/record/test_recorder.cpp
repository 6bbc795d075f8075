// The recorder in-process: schemas from the IDL, per-topic drop counts with a tiny queue and a slow
// "disk", and a killed recorder process leaving a readable file.
#include "child.hpp"
#include "recorder_waits.hpp"
#include "scratch_cleanup.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/info.hpp>
#include <ddsnav/record/recorder.hpp>
#include <ddsnav/record/schemas.hpp>

#include <ddsnav/testing/domain.hpp>
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <future>

using namespace ddsnav;
namespace fs = std::filesystem;

using record_test::pollUntilSubscribed;

namespace {

fs::path tempFile(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("ddsnav_record_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

// docs/record.md "Payload memory kept warm": whole 1 MB blocks are touched, a partial one is not; nothing in
// the sanitizer builds; the default follows the queue up to 1 GB.
TEST(RecordPayloadMemory, PrefaultsWholeBlocksAndTheDefaultFollowsTheQueue) {
#ifdef DDSNAV_SANITIZED
  EXPECT_EQ(record::prefaultPayloadMemory(std::size_t(3) << 20), 0u);
#else
  EXPECT_EQ(record::prefaultPayloadMemory(std::size_t(3) << 20), std::size_t(3) << 20);
  EXPECT_EQ(record::prefaultPayloadMemory((std::size_t(2) << 20) + 4096), std::size_t(2) << 20);
#endif
  EXPECT_EQ(record::prefaultPayloadMemory(0), 0u);
  EXPECT_EQ(record::prefaultPayloadMemory((1u << 20) - 1), 0u);
  EXPECT_EQ(record::defaultPayloadPreallocation(std::size_t(256) << 20), std::size_t(256) << 20);
  EXPECT_EQ(record::defaultPayloadPreallocation(std::size_t(64) << 30), std::size_t(1) << 30);
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
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
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
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
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
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
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
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
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

// The recorder asked for topics nobody publishes, and the player given nothing to play: each on a domain of
// its own from the allocator, where nothing else runs.

TEST(Recorder, RequestedTopicsNeverDiscoveredAreNamed) {
  const fs::path file = tempFile("partly.mcap");
  const ddsnav::testing::DomainLease nothing_domain;
  bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = nothing_domain.id(), .name = "nd-pub"});
  bus::Participant rec_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = nothing_domain.id(), .name = "nd-rec"});
  auto pub = pub_side.publisher<msg::Clock>("test/present", bus::Qos::commands());
  record::RecorderOptions options;
  options.output = file.string();
  options.topics = {"test/present", "test/presnet"};
  {
    record::Recorder recorder(rec_side, options);
    ASSERT_TRUE(pollUntilSubscribed(recorder, 1, std::chrono::seconds(10)));
    EXPECT_EQ(recorder.notDiscovered(), std::vector<std::string>{"test/presnet"});
    EXPECT_EQ(recorder.messagesWritten(), 0u);
    recorder.stop();
  }
  record::McapReader r(file.string());
  const auto end = std::find_if(r.metadata().begin(), r.metadata().end(), [](const auto& m) { return m.name == "ddsnav.recording_end"; });
  ASSERT_NE(end, r.metadata().end());
  EXPECT_EQ(end->values.at("not_discovered"), "test/presnet");
}

TEST(Recorder, RecordingNothingExitsNonZeroNamingTheMissingTopics) {
  const fs::path file = tempFile("nothing.mcap");
  const ddsnav::testing::DomainLease nothing_domain;
  record_test::Child recorder({DDSNAV_RECORD_BIN, "--dds", "cyclonedds", "--domain", nothing_domain.str(), "--topics",
                               "no/such_topic,control/cmd_vle", "--duration", "0.5", "-o", file.string()},
                              tempFile("nothing.log").string());
  ASSERT_TRUE(recorder.wait(std::chrono::seconds(30))) << recorder.log();
  EXPECT_EQ(recorder.exitCode(), 1) << recorder.log();
  const std::string log = recorder.log();
  EXPECT_NE(log.find("no/such_topic: no publisher discovered; nothing recorded"), std::string::npos) << log;
  EXPECT_NE(log.find("control/cmd_vle: no publisher discovered; nothing recorded"), std::string::npos) << log;
  EXPECT_NE(log.find("nothing was recorded"), std::string::npos) << log;
  record::McapReader r(file.string());  // still a valid, closed (empty) recording
  EXPECT_FALSE(r.truncated());
  EXPECT_EQ(r.summary().message_count, 0u);
}

TEST(Recorder, BadDomainInTheEnvironmentIsRefused) {
  // std::atoi read "19x" as domain 19: the recorder would have listened on the wrong domain, silently.
  const fs::path file = tempFile("baddomain.mcap");
  ::setenv("DDSNAV_DOMAIN", "19x", 1);
  record_test::Child recorder({DDSNAV_RECORD_BIN, "--dds", "cyclonedds", "--duration", "0.5", "-o", file.string()},
                              tempFile("baddomain.log").string());
  ::unsetenv("DDSNAV_DOMAIN");
  ASSERT_TRUE(recorder.wait(std::chrono::seconds(30))) << recorder.log();
  EXPECT_NE(recorder.exitCode(), 0) << recorder.log();
  EXPECT_NE(recorder.log().find("DDSNAV_DOMAIN='19x'"), std::string::npos) << recorder.log();
  EXPECT_FALSE(fs::exists(file));
}

// Two channels: vehicle/state with `count` messages 10 ms apart, control/cmd_vel with none.
void writeSparseRecording(const fs::path& path, int count) {
  record::McapWriter w(path.string());
  const auto state_schema = w.addSchema("ddsnav::msg::VehicleState", "omgidl", *record::idlSchemaFor("ddsnav::msg::VehicleState"));
  const auto cmd_schema = w.addSchema("ddsnav::msg::VelocityCommand", "omgidl", *record::idlSchemaFor("ddsnav::msg::VelocityCommand"));
  const auto state = w.addChannel(state_schema, "vehicle/state", "cdr",
                                  {{"dds_type", "ddsnav::msg::VehicleState"}, {"keyed", "false"}, {"qos", "sensorData"}});
  w.addChannel(cmd_schema, "control/cmd_vel", "cdr", {{"dds_type", "ddsnav::msg::VelocityCommand"}, {"keyed", "false"}, {"qos", "commands"}});
  const auto& ts = msg::type_support<msg::VehicleState>();
  for (int i = 0; i < count; ++i) {
    msg::VehicleState s;
    s.header().stamp_ns(i);
    std::vector<std::uint8_t> bytes(ts.serialized_size(&s));
    ASSERT_EQ(ts.serialize(&s, bytes.data(), bytes.size()), bytes.size());
    const std::uint64_t t = 1'000'000'000ull + 10'000'000ull * static_cast<std::uint64_t>(i);
    w.write(state, t, t, bytes);
  }
  w.close();
}

// play() with --loop on a file where nothing passes the filters: must end with an error, not spin.
std::string loopError(const fs::path& file, record::PlayerOptions options) {
  const ddsnav::testing::DomainLease nothing_domain;
  bus::Participant participant({.vendor = bus::Vendor::CycloneDDS, .domain_id = nothing_domain.id(), .name = "nd-play"});
  record::McapReader reader(file.string());
  options.loop = true;
  options.wait_subscribers = std::chrono::milliseconds(0);
  options.settle = std::chrono::milliseconds(0);
  std::atomic<bool> stop{false};
  auto result = std::async(std::launch::async, [&]() -> std::string {
    try {
      record::play(participant, reader, options, stop);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "(returned without an error)";
  });
  if (result.wait_for(std::chrono::seconds(20)) != std::future_status::ready) {
    stop.store(true);  // the old behaviour: looping over nothing until stopped
    result.wait();
    return "(still looping after 20 s)";
  }
  return result.get();
}

TEST(Player, LoopOverNothingPlayableFailsWithTheReason) {
  const fs::path sparse = tempFile("sparse.mcap");
  writeSparseRecording(sparse, 5);
  record::PlayerOptions options;
  options.topics = {"control/cmd_vel"};
  std::string e = loopError(sparse, options);
  EXPECT_NE(e.find(sparse.string() + ": nothing to play"), std::string::npos) << e;
  EXPECT_NE(e.find("(control/cmd_vel) have no messages"), std::string::npos) << e;

  options = {};
  options.start_s = 5.0;  // the recording is 40 ms long
  e = loopError(sparse, options);
  EXPECT_NE(e.find(sparse.string() + ": nothing to play"), std::string::npos) << e;
  EXPECT_NE(e.find("--start 5 s is past the end of the recording (0.040 s long)"), std::string::npos) << e;

  const fs::path empty = tempFile("empty.mcap");
  writeSparseRecording(empty, 0);
  e = loopError(empty, {});
  EXPECT_NE(e.find(empty.string() + ": nothing to play: the recording holds no messages"), std::string::npos) << e;
}

TEST(Player, PlayExitsNonZeroWhenNothingIsPlayable) {
  const fs::path sparse = tempFile("sparse_cli.mcap");
  writeSparseRecording(sparse, 3);
  const ddsnav::testing::DomainLease nothing_domain;
  record_test::Child player({DDSNAV_PLAY_BIN, sparse.string(), "--dds", "cyclonedds", "--domain", nothing_domain.str(),
                             "--loop", "--start", "60", "--wait-subscribers", "0", "--settle", "0", "--linger", "0"},
                            tempFile("sparse_cli.log").string());
  ASSERT_TRUE(player.wait(std::chrono::seconds(30))) << "still looping:\n" << player.log();
  EXPECT_EQ(player.exitCode(), 1) << player.log();
  EXPECT_NE(player.log().find("nothing to play: --start 60 s is past the end"), std::string::npos) << player.log();
}

}  // namespace

// Removes this process's temporary files when the tests end.
namespace {
[[maybe_unused]] const bool kScratchCleanup = ddsnav::record_test::removeScratchAtExit("ddsnav_record_test_");
}  // namespace
