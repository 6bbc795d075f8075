// Record typed publishers of one vendor with a recorder of the other, replay with the first vendor to
// typed subscribers of the second, and compare every message field by field. Every hop crosses vendors.
#include "child.hpp"
#include "scratch_cleanup.hpp"

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/info.hpp>
#include <ddsnav/record/mcap.hpp>
#include <ddsnav/testing/domain.hpp>

#include <gtest/gtest.h>

#include <filesystem>

using namespace ddsnav;
namespace fs = std::filesystem;

namespace {

struct Case {
  bus::Vendor publisher;  // the typed publisher and the player
  bus::Vendor recorder;   // the recorder and the typed subscriber
};

std::string name(bus::Vendor v) { return std::string(bus::vendorName(v)); }

fs::path tempFile(const std::string& n) {
  fs::path dir = fs::temp_directory_path() / ("ddsnav_record_xv_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / n;
}

msg::Path makePath(int i) {
  msg::Path p;
  p.header().stamp_ns(1000 + i);
  p.header().frame_id("map");
  p.request_id(static_cast<std::uint32_t>(i));
  p.planner("rrtstar");
  p.solved(true);
  p.exact(i % 2 == 0);
  for (int k = 0; k <= i; ++k) {
    msg::PathState s;
    s.x(k * 0.5);
    s.y(-k * 0.25);
    s.z(0.125 * i);
    s.heading(0.1 * k);
    p.states().push_back(s);
  }
  p.cost(3.5 + i);
  p.statistics().iterations(100u + i);
  p.statistics().time_to_first_solution_s(-1.0);
  p.statistics().coverage(0.75);
  return p;
}

msg::VelocityCommand makeCommand(int i) {
  msg::VelocityCommand c;
  c.stamp_ns(5000 + i);
  c.v(0.1 * i);
  c.omega(-0.05 * i);
  c.vz(i % 3 == 0 ? 0.0 : 0.2);
  return c;
}

msg::PointCloud makeCloud(int i) {
  msg::PointCloud c;
  c.header().stamp_ns(9000 + i);
  c.header().frame_id("lidar");
  c.sensor_origin().x(i);
  for (int k = 0; k < 3000; ++k) c.xyz().push_back(static_cast<float>(k * 0.001 + i));
  if (i % 2) c.intensity().assign(1000, 0.5f * i);
  return c;
}

class CrossVendor : public ::testing::TestWithParam<Case> {};

TEST_P(CrossVendor, RecordThenReplayMatchesFieldByField) {
  const Case& c = GetParam();
  // Two ids from the allocator (one to record on, one to replay onto): a fixed pair here once met another
  // test's leased id and took its replayed clock for this one's.
  const ddsnav::testing::DomainLease record_lease, play_lease;
  const int record_domain = record_lease.id();
  const fs::path file = tempFile("xv_" + std::to_string(record_domain) + ".mcap");
  fs::remove(file);
  constexpr int kPaths = 4, kCommands = 10, kClouds = 3;

  // 1. Record. "test/points" is not a ddsnav topic: it is recorded with the default (reliable) QoS.
  {
    bus::Participant pub_side({.vendor = c.publisher, .domain_id = record_domain, .name = "xv-pub"});
    auto paths = pub_side.publisher<msg::Path>("planning/path", bus::Qos::state(kPaths));
    auto commands = pub_side.publisher<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands(kCommands));
    auto clouds = pub_side.publisher<msg::PointCloud>("test/points", bus::Qos::commands(kClouds));
    record_test::Child recorder({DDSNAV_RECORD_BIN, "--dds", name(c.recorder), "--domain", std::to_string(record_domain),
                                 "--topics", "planning/path,control/cmd_vel,test/points", "--max-messages",
                                 std::to_string(kPaths + kCommands + kClouds), "-o", file.string()},
                                tempFile("rec_" + std::to_string(record_domain) + ".log").string());
    ASSERT_TRUE(paths.waitForSubscribers(1, std::chrono::seconds(20))) << recorder.log();
    ASSERT_TRUE(commands.waitForSubscribers(1, std::chrono::seconds(20))) << recorder.log();
    ASSERT_TRUE(clouds.waitForSubscribers(1, std::chrono::seconds(20))) << recorder.log();
    for (int i = 0; i < kPaths; ++i) paths.publish(makePath(i));
    for (int i = 0; i < kCommands; ++i) commands.publish(makeCommand(i));
    for (int i = 0; i < kClouds; ++i) clouds.publish(makeCloud(i));
    ASSERT_TRUE(recorder.wait(std::chrono::seconds(30))) << "recorder did not get every message:\n" << recorder.log();
    ASSERT_EQ(recorder.exitCode(), 0) << recorder.log();
  }

  record::McapReader r(file.string());
  ASSERT_FALSE(r.truncated());
  const auto info = record::describeRecording(r);
  std::map<std::string, std::uint64_t> counts;
  for (const auto& t : info["topics"]) {
    counts[t["topic"]] = t["message_count"];
    EXPECT_EQ(t["dropped"].get<std::uint64_t>(), 0u) << t["topic"];
  }
  EXPECT_EQ(counts["planning/path"], static_cast<std::uint64_t>(kPaths));
  EXPECT_EQ(counts["control/cmd_vel"], static_cast<std::uint64_t>(kCommands));
  EXPECT_EQ(counts["test/points"], static_cast<std::uint64_t>(kClouds));

  // 2. Replay onto a fresh domain, to typed subscribers of the recorder's vendor, with --clock and --loop:
  // a reader may match the player's writers a few seconds late (a Cyclone reader learns about a Fast DDS
  // writer only from its next discovery resend), so each topic is checked on a complete, in-order pass.
  // The recording spans a few ms; --rate 0.02 stretches a pass to a fraction of a second.
  const int play_domain = play_lease.id();
  bus::Participant sub_side({.vendor = c.recorder, .domain_id = play_domain, .name = "xv-sub"});
  auto paths = sub_side.inbox<msg::Path>("planning/path", bus::Qos::state(kPaths), 256);
  auto commands = sub_side.inbox<msg::VelocityCommand>("control/cmd_vel", bus::Qos::commands(kCommands), 256);
  auto clouds = sub_side.inbox<msg::PointCloud>("test/points", bus::Qos::commands(kClouds), 256);
  auto clock = sub_side.inbox<msg::Clock>("system/clock", bus::Qos::sensorData(1), 4096);
  record_test::Child player({DDSNAV_PLAY_BIN, file.string(), "--dds", name(c.publisher), "--domain",
                             std::to_string(play_domain), "--rate", "0.02", "--clock", "--loop", "--wait-subscribers",
                             "20"},
                            tempFile("play_" + std::to_string(record_domain) + ".log").string());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  // The first run of messages with keys 0, 1, ..., n-1 in a row.
  auto completePass = [&](auto& inbox, int n, auto key) {
    using T = typename std::decay_t<decltype(*inbox.tryTake())>;
    std::vector<T> run;
    while (std::chrono::steady_clock::now() < deadline) {
      auto got = inbox.wait(std::chrono::milliseconds(200));
      if (!got) continue;
      const std::int64_t k = key(*got);
      if (k == 0) run.clear();
      if (k == static_cast<std::int64_t>(run.size())) run.push_back(*got);
      else run.clear();
      if (static_cast<int>(run.size()) == n) break;
    }
    return run;
  };
  const auto got_paths = completePass(paths, kPaths, [](const msg::Path& p) { return std::int64_t(p.request_id()); });
  ASSERT_EQ(got_paths.size(), static_cast<std::size_t>(kPaths)) << player.log();
  for (int i = 0; i < kPaths; ++i) {
    const msg::Path want = makePath(i);
    const msg::Path& got = got_paths[i];
    EXPECT_EQ(got.request_id(), want.request_id());
    EXPECT_EQ(got.header().frame_id(), want.header().frame_id());
    EXPECT_EQ(got.states().size(), want.states().size());
    EXPECT_EQ(got.statistics().iterations(), want.statistics().iterations());
    EXPECT_TRUE(got == want) << "path " << i << " differs";
  }
  const auto got_commands =
      completePass(commands, kCommands, [](const msg::VelocityCommand& v) { return v.stamp_ns() - 5000; });
  ASSERT_EQ(got_commands.size(), static_cast<std::size_t>(kCommands)) << player.log();
  for (int i = 0; i < kCommands; ++i) {
    const msg::VelocityCommand want = makeCommand(i);
    EXPECT_EQ(got_commands[i].stamp_ns(), want.stamp_ns());
    EXPECT_EQ(got_commands[i].v(), want.v());
    EXPECT_EQ(got_commands[i].omega(), want.omega());
    EXPECT_EQ(got_commands[i].vz(), want.vz());
  }
  const auto got_clouds =
      completePass(clouds, kClouds, [](const msg::PointCloud& p) { return p.header().stamp_ns() - 9000; });
  ASSERT_EQ(got_clouds.size(), static_cast<std::size_t>(kClouds)) << player.log();
  for (int i = 0; i < kClouds; ++i) {
    const msg::PointCloud want = makeCloud(i);
    EXPECT_EQ(got_clouds[i].header().stamp_ns(), want.header().stamp_ns());
    EXPECT_EQ(got_clouds[i].xyz(), want.xyz());
    EXPECT_EQ(got_clouds[i].intensity(), want.intensity());
  }
  player.signal(SIGTERM);
  ASSERT_TRUE(player.wait(std::chrono::seconds(10))) << player.log();
  EXPECT_EQ(player.exitCode(), 0) << player.log();

  // The clock followed the recorded time: always inside the recording's span (it starts over with each
  // pass of --loop; monotonic time within a pass is checked by record_clock_tests).
  std::size_t ticks = 0;
  while (auto t = clock.tryTake()) {
    EXPECT_GE(t->stamp_ns(), static_cast<std::int64_t>(r.summary().message_start_time));
    EXPECT_LE(t->stamp_ns(), static_cast<std::int64_t>(r.summary().message_end_time));
    ++ticks;
  }
  // Best effort (as components subscribe to it): some ticks may be lost, but not all.
  EXPECT_GT(ticks, 0u);
}

INSTANTIATE_TEST_SUITE_P(Vendors, CrossVendor,
                         ::testing::Values(Case{bus::Vendor::FastDDS, bus::Vendor::CycloneDDS},
                                           Case{bus::Vendor::CycloneDDS, bus::Vendor::FastDDS}),
                         [](const auto& info) {
                           return info.param.publisher == bus::Vendor::FastDDS ? "FastToCyclone" : "CycloneToFast";
                         });

}  // namespace

// Removes this process's temporary files when the tests end.
namespace {
[[maybe_unused]] const bool kScratchCleanup = ddsnav::record_test::removeScratchAtExit("ddsnav_record_xv_");
}  // namespace
