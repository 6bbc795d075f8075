// A component run with the topic clock follows a replayed recording's time: ddsnav-talker (runtime
// component, `--param clock=topic`, Fast DDS) stamps its vehicle states from system/clock, driven by
// `ddsnav play --clock` (Cyclone) of a recording whose time lies years in the past.
#include "child.hpp"

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/mcap.hpp>
#include <ddsnav/record/schemas.hpp>

#include <ddsnav/testing/domain.hpp>
#include <gtest/gtest.h>

#include <filesystem>

using namespace ddsnav;
namespace fs = std::filesystem;

namespace {

TEST(ClockFollowing, ComponentStampsFollowTheReplayedTime) {
  const ddsnav::testing::DomainLease domain_lease;  // the allocator's id, held for this test
  const int kDomain = domain_lease.id();
  const fs::path dir = fs::temp_directory_path() / ("ddsnav_record_clock_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path file = dir / "past.mcap";
  // 2.5 s of recorded time starting 2001-09-09 (1e18 ns): far from now, so no stamp can match by chance.
  constexpr std::int64_t kT0 = 1'000'000'000'000'000'000;
  constexpr std::int64_t kSpan = 2'500'000'000;
  {
    record::McapWriter w(file.string());
    const auto schema = w.addSchema("ddsnav::msg::VelocityCommand", "omgidl", *record::idlSchemaFor("ddsnav::msg::VelocityCommand"));
    const auto ch = w.addChannel(schema, "recorded/cmd", "cdr", {{"dds_type", "ddsnav::msg::VelocityCommand"}, {"keyed", "false"}});
    const auto& ts = msg::type_support<msg::VelocityCommand>();
    for (std::int64_t t = 0; t <= kSpan; t += 100'000'000) {
      msg::VelocityCommand c;
      c.stamp_ns(kT0 + t);
      std::vector<std::uint8_t> bytes(ts.serialized_size(&c));
      bytes.resize(ts.serialize(&c, bytes.data(), bytes.size()));
      w.write(ch, static_cast<std::uint64_t>(kT0 + t), static_cast<std::uint64_t>(kT0 + t), bytes);
    }
    w.close();
  }

  bus::Participant observer({.vendor = bus::Vendor::CycloneDDS, .domain_id = kDomain, .name = "clock-observer"});
  auto states = observer.inbox<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), 1000);
  record_test::Child talker({DDSNAV_TALKER_BIN, "--dds", "fastdds", "--domain", std::to_string(kDomain), "--param",
                             "clock=topic", "--param", "rate_hz=50"},
                            (dir / "talker.log").string());
  // The talker is up (and subscribed to system/clock) once it publishes.
  ASSERT_TRUE(states.wait(std::chrono::seconds(20))) << talker.log();
  record_test::Child player({DDSNAV_PLAY_BIN, file.string(), "--dds", "cyclonedds", "--domain", std::to_string(kDomain),
                             "--clock", "--wait-subscribers", "0", "--settle", "0"},
                            (dir / "play.log").string());
  std::int64_t last = 0, followed = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (last < kT0 + kSpan / 2 && std::chrono::steady_clock::now() < deadline) {
    auto s = states.wait(std::chrono::milliseconds(500));
    if (!s || s->header().stamp_ns() < kT0) continue;  // still on the talker's own start-up time
    // On the recording's clock: inside its span, never going back.
    EXPECT_LE(s->header().stamp_ns(), kT0 + kSpan);
    EXPECT_GE(s->header().stamp_ns(), last);
    last = s->header().stamp_ns();
    ++followed;
  }
  EXPECT_GE(last, kT0 + kSpan / 2) << "talker:\n" << talker.log() << "\nplayer:\n" << player.log();
  EXPECT_GT(followed, 10);
  EXPECT_TRUE(player.wait(std::chrono::seconds(20)));
  EXPECT_EQ(player.exitCode(), 0) << player.log();
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
