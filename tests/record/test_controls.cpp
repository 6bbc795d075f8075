// The recorder's and player's controls: split by size and duration, snapshot mode (in-process and by
// SIGUSR1 / control topic), play --start/--end/--remap, a looped one-message file, damaged chunks skipped
// on play, and bad input to `ddsnav record` (folder missing, --max-file-mb 0, disk full mid-split).
// DDS domains come from the allocator (ddsnav::testing::DomainLease), never fixed ids.
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
#include <fstream>
#include <future>
#include <map>

using namespace ddsnav;
namespace fs = std::filesystem;

using record_test::pollUntilSubscribed;
using record_test::waitFor;

namespace {

fs::path scratch(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("ddsnav_record_ctl_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

msg::VelocityCommand command(int i) {
  msg::VelocityCommand c;
  c.stamp_ns(i);
  c.v(0.5 * i);
  return c;
}

// Stamps of the VelocityCommand messages in a file, in file order.
std::vector<std::int64_t> stamps(const record::McapReader& r) {
  std::vector<std::int64_t> out;
  r.forEachMessage([&](const record::MessageView& m) {
    msg::VelocityCommand c;
    EXPECT_TRUE(msg::type_support<msg::VelocityCommand>().deserialize(m.data.data(), m.data.size(), &c));
    out.push_back(c.stamp_ns());
    return true;
  });
  return out;
}

TEST(RecorderSplit, BySizeAndByDurationIntoCompleteNumberedFiles) {
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
  bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "split-pub"});
  bus::Participant rec_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "split-rec"});
  auto pub = pub_side.publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands(100));
  for (const bool by_size : {true, false}) {
    SCOPED_TRACE(by_size ? "by size" : "by duration");
    const fs::path base = scratch(by_size ? "size.mcap" : "duration.mcap");
    record::RecorderOptions options;
    options.output = base.string();
    options.topics = {"control/cmd_vel"};
    options.mcap.chunk_size = 1024;
    if (by_size)
      options.max_file_bytes = 4096;
    else
      options.max_file_duration = std::chrono::milliseconds(300);
    constexpr int kCount = 150;
    std::vector<std::string> files;
    {
      record::Recorder recorder(rec_side, options);
      ASSERT_TRUE(pollUntilSubscribed(recorder, 1, std::chrono::seconds(10)));
      ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(10)));
      for (int i = 0; i < kCount; ++i) {
        pub.publish(command(i));
        std::this_thread::sleep_for(std::chrono::milliseconds(10));  // 1.5 s in all
      }
      ASSERT_TRUE(waitFor([&] { return recorder.counts()[0].received == kCount; }, std::chrono::seconds(10)));
      recorder.stop();
      EXPECT_EQ(recorder.counts()[0].written, static_cast<std::uint64_t>(kCount));
      files = recorder.filesWritten();
    }
    ASSERT_GE(files.size(), 3u);
    EXPECT_FALSE(fs::exists(base));  // numbered files only
    std::vector<std::int64_t> all;
    for (std::size_t i = 0; i < files.size(); ++i) {
      EXPECT_EQ(files[i], (base.parent_path() / (base.stem().string() + "_" + std::to_string(i) + ".mcap")).string());
      record::McapReader r(files[i]);
      EXPECT_FALSE(r.truncated()) << files[i];
      EXPECT_TRUE(r.hasSummary()) << files[i];
      ASSERT_EQ(r.channels().size(), 1u) << files[i];
      EXPECT_EQ(r.channels().begin()->second.metadata.at("dds_type"), "ddsnav::msg::VelocityCommand");
      EXPECT_FALSE(r.schemas().empty());
      const auto s = stamps(r);
      EXPECT_FALSE(s.empty()) << files[i];
      all.insert(all.end(), s.begin(), s.end());
      if (by_size && i + 1 < files.size()) {
        // The file's data (header, schema, channel, chunks) ends at the limit, give or take the last
        // chunk (1 KB + a message); the counts metadata and the summary follow. The limit counts message
        // records before compression, so zstd chunks end a little short of it.
        const auto& last = r.chunks().back();
        const std::uint64_t data_end = last.offset + last.record_length + last.message_index_length;
        EXPECT_GE(data_end, 3000u) << files[i];  // compressed: a little under what was counted
        EXPECT_LT(data_end, 4096u + 1300u) << files[i];
      }
      if (!by_size) {
        EXPECT_LT(r.summary().message_end_time - r.summary().message_start_time, 400'000'000u) << files[i];
      }
    }
    // Together the files hold every message once, in order.
    ASSERT_EQ(all.size(), static_cast<std::size_t>(kCount));
    for (int i = 0; i < kCount; ++i) EXPECT_EQ(all[i], i);
    // Counts in the last file are the recording's totals.
    const auto info = record::describeRecording(*std::make_unique<record::McapReader>(files.back()));
    EXPECT_EQ(info["topics"][0]["received"].get<std::uint64_t>(), static_cast<std::uint64_t>(kCount));
    EXPECT_EQ(info["topics"][0]["lost"].get<std::uint64_t>(), 0u);
  }
}

TEST(RecorderSnapshot, KeepsTheLastSecondsAndWritesThemOnRequest) {
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
  bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "snap-pub"});
  bus::Participant rec_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "snap-rec"});
  auto pub = pub_side.publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands(100));
  const fs::path base = scratch("snap.mcap");
  record::RecorderOptions options;
  options.output = base.string();
  options.topics = {"control/cmd_vel"};
  options.snapshot = true;
  options.snapshot_duration = std::chrono::milliseconds(500);
  record::Recorder recorder(rec_side, options);
  ASSERT_TRUE(pollUntilSubscribed(recorder, 1, std::chrono::seconds(10)));
  // Before any data: nothing to write, no file, and the recorder carries on.
  recorder.requestSnapshot();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_TRUE(recorder.filesWritten().empty());
  EXPECT_FALSE(recorder.failed());
  ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(10)));
  constexpr int kCount = 150;  // 10 ms apart: 1.5 s, three times the window
  for (int i = 0; i < kCount; ++i) {
    pub.publish(command(i));
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(waitFor([&] { return recorder.counts()[0].received == kCount; }, std::chrono::seconds(10)));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // into the writer's buffer
  recorder.requestSnapshot();
  ASSERT_TRUE(waitFor([&] { return recorder.filesWritten().size() == 1; }, std::chrono::seconds(10)));
  const std::string file = recorder.filesWritten()[0];
  EXPECT_EQ(file, (base.parent_path() / "snap_0.mcap").string());
  record::McapReader r(file);
  EXPECT_FALSE(r.truncated());
  const auto s = stamps(r);
  ASSERT_FALSE(s.empty());
  EXPECT_EQ(s.back(), kCount - 1);  // the newest message is in
  // Only the last ~0.5 s: about 50 messages (scheduling on a busy machine stretches the 10 ms gaps).
  EXPECT_LE(s.size(), 60u);
  EXPECT_GE(s.size(), 10u);
  EXPECT_LE(r.summary().message_end_time - r.summary().message_start_time, 500'000'000u);
  for (std::size_t i = 1; i < s.size(); ++i) EXPECT_EQ(s[i], s[i - 1] + 1);
  recorder.stop();
  EXPECT_EQ(recorder.filesWritten().size(), 1u);  // stopping writes no snapshot by itself
}

TEST(RecorderSnapshot, SigusrAndControlTopicTriggerSnapshotsFromTheCommandLine) {
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
  const fs::path base = scratch("cli_snap.mcap");
  bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "clisnap-pub"});
  auto pub = pub_side.publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands(100));
  auto trigger = pub_side.publisher<msg::Clock>("record/snapshot", bus::Qos::commands());
  record_test::Child recorder({DDSNAV_RECORD_BIN, "--dds", "cyclonedds", "--domain", std::to_string(kDomain), "--topics",
                               "control/cmd_vel", "--snapshot", "--snapshot-s", "5", "--snapshot-topic", "record/snapshot", "-o",
                               base.string()},
                              scratch("cli_snap.log").string());
  ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(15))) << recorder.log();
  for (int i = 0; i < 20; ++i) {
    pub.publish(command(i));
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const fs::path first = base.parent_path() / "cli_snap_0.mcap", second = base.parent_path() / "cli_snap_1.mcap";
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  recorder.signal(SIGUSR1);
  ASSERT_TRUE(waitFor([&] { return recorder.log().find("snapshot of") != std::string::npos; }, std::chrono::seconds(10)))
      << recorder.log();
  ASSERT_TRUE(trigger.waitForSubscribers(1, std::chrono::seconds(15))) << recorder.log();
  for (int i = 20; i < 30; ++i) pub.publish(command(i));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  msg::Clock any;
  trigger.publish(any);
  ASSERT_TRUE(waitFor([&] { return fs::exists(second) && recorder.log().find(second.string()) != std::string::npos; },
                      std::chrono::seconds(10)))
      << recorder.log();
  recorder.signal(SIGINT);
  ASSERT_TRUE(recorder.wait(std::chrono::seconds(20))) << recorder.log();
  EXPECT_EQ(recorder.exitCode(), 0) << recorder.log();
  record::McapReader a(first.string()), b(second.string());
  EXPECT_EQ(stamps(a).size(), 20u);
  EXPECT_EQ(stamps(b).size(), 30u);  // the window (5 s) holds everything so far
}

TEST(RecordCommandLine, BadFolderAndZeroLimitsAreRefusedWithAClearMessage) {
  // No DDS participant is created for these: the checks come first.
  struct Case {
    std::vector<std::string> args;
    int exit_code;
    std::string message;
  };
  const std::string missing = (scratch("x").parent_path() / "no_such_folder" / "run.mcap").string();
  const std::vector<Case> cases = {
      {{"-o", missing}, 1, "the recording folder " + fs::path(missing).parent_path().string() + " does not exist"},
      // Not writable even for root (tests run as root in CI, where a chmod 555 folder would still be writable).
      {{"-o", "/proc/self/run.mcap"}, 1, "the recording folder /proc/self is not writable"},
      {{"-o", scratch("zero.mcap").string(), "--max-file-mb", "0"}, 2, "--max-file-mb 0: expected a positive number of MB"},
      {{"-o", scratch("zero.mcap").string(), "--max-file-s", "-1"}, 2, "--max-file-s -1: expected a positive number of seconds"},
      {{"-o", scratch("zero.mcap").string(), "--snapshot", "--snapshot-mb", "0"}, 2, "--snapshot-mb 0: expected a positive"},
      {{"-o", scratch("zero.mcap").string(), "--snapshot-s", "3"}, 2, "need --snapshot"},
  };
  const ddsnav::testing::DomainLease domain_lease;  // a recorder that does start must not join another test's domain
  int n = 0;
  for (const Case& c : cases) {
    std::vector<std::string> argv = {DDSNAV_RECORD_BIN, "--dds", "cyclonedds", "--domain", domain_lease.str(), "--duration", "1"};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    record_test::Child child(argv, scratch("badinput_" + std::to_string(n++) + ".log").string());
    ASSERT_TRUE(child.wait(std::chrono::seconds(20))) << child.log();
    EXPECT_EQ(child.exitCode(), c.exit_code) << child.log();
    EXPECT_NE(child.log().find(c.message), std::string::npos) << child.log();
  }
  EXPECT_FALSE(fs::exists(scratch("zero.mcap")));
}

TEST(RecorderSplit, DiskFullMidSplitKeepsTheEarlierFilesComplete) {
  // A file size limit stands in for a full disk (SIGXFSZ ignored); this test runs in its own process.
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
  const fs::path base = scratch("fullsplit.mcap");
  ::signal(SIGXFSZ, SIG_IGN);
  rlimit old{};
  ::getrlimit(RLIMIT_FSIZE, &old);
  std::vector<std::string> files;
  std::string error;
  {
    bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "fs-pub"});
    bus::Participant rec_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "fs-rec"});
    auto pub = pub_side.publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands(100));
    record::RecorderOptions options;
    options.output = base.string();
    options.topics = {"control/cmd_vel"};
    options.mcap.chunk_size = 512;
    options.max_file_bytes = 3000;
    record::Recorder recorder(rec_side, options);
    ASSERT_TRUE(pollUntilSubscribed(recorder, 1, std::chrono::seconds(10)));
    ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(10)));
    int i = 0;
    // Two complete files first, then the "disk" fills: every file may now hold 2 KB only.
    for (; recorder.filesWritten().size() < 2 && i < 2000; ++i) {
      pub.publish(command(i));
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ASSERT_EQ(recorder.filesWritten().size(), 2u);
    rlimit small = old;
    small.rlim_cur = 2000;
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
    for (int k = 0; !recorder.failed() && k < 2000; ++k, ++i) {
      pub.publish(command(i));
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ASSERT_TRUE(recorder.failed());
    error = recorder.error();
    EXPECT_THROW(recorder.stop(), record::McapError);
    const auto c = recorder.counts().at(0);
    EXPECT_EQ(c.written + c.dropped, c.received);
    EXPECT_GT(c.dropped, 0u);
    files = recorder.filesWritten();
  }
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  EXPECT_NE(error.find(base.stem().string() + "_2.mcap"), std::string::npos) << error;
  ASSERT_EQ(files.size(), 2u);
  for (const auto& f : files) {
    record::McapReader r(f);
    EXPECT_FALSE(r.truncated()) << f;
    EXPECT_GT(r.summary().message_count, 0u);
  }
  // The file that was open when the disk filled reads back as a truncated recording.
  record::McapReader last((base.parent_path() / (base.stem().string() + "_2.mcap")).string());
  EXPECT_TRUE(last.truncated());
}

// vehicle/state, `count` messages `gap_ms` apart, in chunks of `chunk_size` bytes.
fs::path stateRecording(const std::string& name, int count, int gap_ms, std::size_t chunk_size = 1 << 20) {
  const fs::path path = scratch(name);
  record::McapWriterOptions o;
  o.chunk_size = chunk_size;
  record::McapWriter w(path.string(), o);
  const auto schema = w.addSchema("ddsnav::msg::VehicleState", "omgidl", *record::idlSchemaFor("ddsnav::msg::VehicleState"));
  const auto ch = w.addChannel(schema, "vehicle/state", "cdr",
                               {{"dds_type", "ddsnav::msg::VehicleState"}, {"keyed", "false"}, {"qos", "sensorData"}});
  for (int i = 0; i < count; ++i) {
    msg::VehicleState s;
    s.header().stamp_ns(i);
    const std::vector<std::uint8_t> bytes = msg::serializeToBytes(s);
    const std::uint64_t t = 1'000'000'000ull + static_cast<std::uint64_t>(gap_ms) * 1'000'000ull * static_cast<std::uint64_t>(i);
    w.write(ch, t, t, bytes);
  }
  w.close();
  return path;
}

record::PlayerOptions quickStart() {
  record::PlayerOptions o;
  o.wait_subscribers = std::chrono::milliseconds(0);
  o.settle = std::chrono::milliseconds(0);
  return o;
}

TEST(Player, LoopOfOneMessageKeepsAMinimumPeriod) {
  // Used to republish a one-message file as fast as the CPU allowed (64,000/s).
  const fs::path file = stateRecording("one.mcap", 1, 10);
  const ddsnav::testing::DomainLease domain_lease;
  bus::Participant participant({.vendor = bus::Vendor::CycloneDDS, .domain_id = domain_lease.id(), .name = "loop-play"});
  record::McapReader reader(file.string());
  record::PlayerOptions options = quickStart();
  options.loop = true;
  std::atomic<bool> stop{false};
  auto result = std::async(std::launch::async, [&] { return record::play(participant, reader, options, stop); });
  std::this_thread::sleep_for(std::chrono::seconds(1));
  stop.store(true);
  ASSERT_EQ(result.wait_for(std::chrono::seconds(5)), std::future_status::ready);
  const auto p = result.get();
  // kMinLoopPass = 100 ms: about 10 in one second.
  EXPECT_GE(p.published, 5u);
  EXPECT_LE(p.published, 12u);
}

TEST(Player, LoopKeepsTheRecordedRhythmAcrossPasses) {
  // 5 messages 50 ms apart: one pass spans 200 ms, the next starts one interval (50 ms) after the last.
  const fs::path file = stateRecording("five.mcap", 5, 50);
  const ddsnav::testing::DomainLease domain_lease;
  bus::Participant participant({.vendor = bus::Vendor::CycloneDDS, .domain_id = domain_lease.id(), .name = "loop-play2"});
  record::McapReader reader(file.string());
  record::PlayerOptions options = quickStart();
  options.loop = true;
  std::atomic<bool> stop{false};
  auto result = std::async(std::launch::async, [&] { return record::play(participant, reader, options, stop); });
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  stop.store(true);
  const auto p = result.get();
  EXPECT_GE(p.published, 15u);  // 1 s at 20 messages/s, minus scheduling
  EXPECT_LE(p.published, 22u);
}

TEST(Player, DamagedChunkIsSkippedWithAWarningAndPlayContinues) {
  const fs::path file = stateRecording("damaged_play.mcap", 60, 1, 1024);
  std::uint64_t at = 0, in_chunk = 0, total = 0;
  {
    record::McapReader r(file.string());
    ASSERT_GT(r.chunks().size(), 4u);
    const auto& c = r.chunks()[2];
    at = c.offset;
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(c.offset + c.record_length - c.compressed_size / 2));
    char b = 0;
    f.read(&b, 1);
    f.seekp(static_cast<std::streamoff>(c.offset + c.record_length - c.compressed_size / 2));
    b = static_cast<char>(b ^ 0x5A);
    f.write(&b, 1);
    total = r.summary().message_count;
    r.forEachMessage([&](const record::MessageView& m) { return in_chunk += m.log_time >= c.message_start_time && m.log_time <= c.message_end_time, true; });
  }
  const ddsnav::testing::DomainLease domain_lease;
  bus::Participant participant({.vendor = bus::Vendor::CycloneDDS, .domain_id = domain_lease.id(), .name = "dmg-play"});
  record::McapReader reader(file.string());
  std::atomic<bool> stop{false};
  record::PlayerOptions options = quickStart();
  options.rate = 10;
  const auto p = record::play(participant, reader, options, stop);
  EXPECT_EQ(p.damaged_chunks, 1u);
  EXPECT_GT(in_chunk, 0u);
  EXPECT_EQ(p.published, total - in_chunk) << "chunk at byte " << at;
}

TEST(Player, StartEndAndRemapSelectWhatIsPublishedWhere) {
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
  const fs::path file = stateRecording("window.mcap", 100, 10);  // 0 .. 0.99 s
  bus::Participant sub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "remap-sub"});
  bus::Participant play_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "remap-play"});
  // vehicle/state is recorded as sensorData (best effort): subscribe alike.
  auto original = sub_side.inbox<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(200), 200);
  auto be = sub_side.inbox<msg::VehicleState>("replay/state", bus::Qos::sensorData(200), 200);
  record::McapReader reader(file.string());
  record::PlayerOptions options;
  options.wait_subscribers = std::chrono::milliseconds(5000);
  options.settle = std::chrono::milliseconds(500);
  options.start_s = 0.3;
  options.end_s = 0.6;
  options.remap = {{"vehicle/state", "replay/state"}};
  std::atomic<bool> stop{false};
  const auto p = record::play(play_side, reader, options, stop);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<std::int64_t> got;
  while (auto s = be.tryTake()) got.push_back(s->header().stamp_ns());
  EXPECT_EQ(original.received(), 0u);  // nothing on the recorded name
  ASSERT_FALSE(got.empty());
  // Best effort on one host: all 31 normally arrive; never anything outside [0.3, 0.6] s.
  EXPECT_GE(got.size(), 25u);
  for (const auto s : got) {
    EXPECT_GE(s, 30);
    EXPECT_LE(s, 60);
  }
  EXPECT_EQ(p.published, 31u);
  // Bad options name what is wrong.
  options.remap = {{"no/such", "x"}};
  EXPECT_THROW(record::play(play_side, reader, options, stop), std::invalid_argument);
  options.remap = {};
  options.start_s = 0.8;
  options.end_s = 0.5;
  EXPECT_THROW(record::play(play_side, reader, options, stop), std::invalid_argument);
}

}  // namespace

namespace {
[[maybe_unused]] const bool kScratchCleanup = ddsnav::record_test::removeScratchAtExit("ddsnav_record_ctl_");
}  // namespace

TEST(RecordCommandLine, FoxgloveAddsTheDerivedViewsToTheFinishedFile) {
  // `ddsnav record --foxglove`: the file holds the recorded vehicle/state unchanged and, beside it, the
  // Foxglove views of it (foxglove/tf: one FrameTransform per sample; foxglove/vehicle/state: the scene).
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
  const fs::path file = scratch("foxglove.mcap");
  bus::Participant pub_side({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "fox-pub"});
  auto pub = pub_side.publisher<msg::VehicleState>("vehicle/state", bus::Qos::commands(100));
  record_test::Child recorder({DDSNAV_RECORD_BIN, "--dds", "cyclonedds", "--domain", std::to_string(kDomain), "--topics",
                               "vehicle/state", "--foxglove", "-o", file.string()},
                              scratch("foxglove.log").string());
  ASSERT_TRUE(pub.waitForSubscribers(1, std::chrono::seconds(15))) << recorder.log();
  constexpr int kCount = 20;
  for (int i = 0; i < kCount; ++i) {
    msg::VehicleState s;
    s.header().stamp_ns(1'000'000'000LL + i * 200'000'000LL);
    s.header().frame_id("map");
    s.position().x(0.5 * i);
    s.position().y(1.0);
    s.heading(0.1 * i);
    pub.publish(s);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  recorder.signal(SIGINT);
  ASSERT_TRUE(recorder.wait(std::chrono::seconds(30))) << recorder.log();
  ASSERT_EQ(recorder.exitCode(), 0) << recorder.log();
  EXPECT_FALSE(fs::exists(file.string() + ".foxglove.tmp"));
  record::McapReader r(file.string());
  EXPECT_FALSE(r.truncated());
  std::map<std::string, int> per_topic;
  std::map<std::string, std::string> schema_of;
  for (const auto& [id, channel] : r.channels()) {
    auto s = r.schemas().find(channel.schema_id);
    if (s != r.schemas().end()) schema_of[channel.topic] = s->second.name;
  }
  std::string first_transform;
  r.forEachMessage([&](const record::MessageView& m) {
    ++per_topic[m.channel->topic];
    if (m.channel->topic == "foxglove/tf" && first_transform.empty()) first_transform.assign(m.data.begin(), m.data.end());
    return true;
  });
  EXPECT_EQ(per_topic["vehicle/state"], kCount) << recorder.log();
  EXPECT_EQ(per_topic["foxglove/tf"], kCount) << recorder.log();
  EXPECT_GE(per_topic["foxglove/vehicle/state"], 1) << recorder.log();
  EXPECT_EQ(schema_of["foxglove/tf"], "foxglove.FrameTransform");
  EXPECT_EQ(schema_of["foxglove/vehicle/state"], "foxglove.SceneUpdate");
  // A FrameTransform as Foxglove reads it: JSON naming the frames.
  EXPECT_NE(first_transform.find("\"parent_frame_id\""), std::string::npos) << first_transform;
  EXPECT_NE(first_transform.find("\"child_frame_id\""), std::string::npos) << first_transform;
}
