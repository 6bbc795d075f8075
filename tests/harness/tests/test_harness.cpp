// The harness against real processes: its topic assertions pass and fail when they should, a launch file
// starts readiness-gated, a replay drives components on recorded time, and a failed test keeps a
// recording of its domain.
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/mcap.hpp>
#include <ddsnav/record/schemas.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <chrono>
#include <fstream>
#include <thread>
#include <regex>

using namespace ddsnav;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

harness::ProcessOptions talker(const std::string& name, double rate_hz) {
  return {.name = name, .command = "ddsnav-talker", .params = {{"rate_hz", std::to_string(rate_hz)}}};
}

TEST(HarnessAssertions, PassAndFailOnALiveTopic) {
  harness::Harness h;
  h.startReady(talker("talker", 20));
  const auto qos = bus::Qos::sensorData();
  EXPECT_TRUE(h.sampleWithin<msg::VehicleState>("vehicle/state", qos, 10s));
  const auto never = h.sampleWithin<msg::VehicleState>("vehicle/state", qos, 500ms,
                                                       [](const msg::VehicleState& s) { return s.position().z() > 1e9; },
                                                       "z above 1e9 m");
  EXPECT_FALSE(never);
  EXPECT_NE(std::string(never.message()).find("z above 1e9 m"), std::string::npos) << never.message();
  EXPECT_TRUE(h.rateWithin<msg::VehicleState>("vehicle/state", qos, 10.0, 40.0, 2s));
  const auto too_fast = h.rateWithin<msg::VehicleState>("vehicle/state", qos, 100.0, 200.0, 1s);
  EXPECT_FALSE(too_fast);
  EXPECT_FALSE(h.noSampleDuring<msg::VehicleState>("vehicle/state", qos, 1s));
  EXPECT_TRUE(h.noSampleDuring<msg::VehicleState>("nobody/publishes/this", qos, 500ms));
}

TEST(HarnessLaunch, StartsEveryProcessOfTheFileGatedOnReadiness) {
  harness::Harness h;
  const fs::path file = fs::path(h.logDir()) / "two.yaml";
  std::ofstream(file) << "name: two\nvariables: {rate: \"25\"}\nprocesses:\n"
                         "  - {name: first, command: ddsnav-talker, params: {rate_hz: \"${rate}\"}}\n"
                         "  - {name: second, command: ddsnav-talker, after: [first], dds: cyclonedds,\n"
                         "     args: [--log-level, info], params: {rate_hz: \"5\"}}\n";
  const auto names = h.launch(file.string(), {{"rate", "30"}});
  EXPECT_EQ(names, (std::vector<std::string>{"first", "second"}));
  EXPECT_TRUE(h.running("first"));
  EXPECT_TRUE(h.running("second"));
  // Readiness comes over system/status; the process's "ready on cyclonedds" log line may reach its file a moment
  // later, so the log is read until it holds the line (bounded).
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (h.log("second").find("cyclonedds") == std::string::npos && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(50ms);
  EXPECT_NE(h.log("second").find("cyclonedds"), std::string::npos) << h.log("second");
  EXPECT_TRUE(h.rateWithin<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), 20.0, 50.0, 2s));
}

TEST(HarnessLaunch, AProcessThatNeverGetsReadyIsAnErrorNamingIt) {
  harness::Harness h;
  const fs::path file = fs::path(h.logDir()) / "broken.yaml";
  std::ofstream(file) << "name: broken\nprocesses:\n"
                         "  - {name: sim, command: ddsnav-sim, params: {scenario: /no/such/scenario.yaml}}\n"
                         "  - {name: after_sim, command: ddsnav-talker, after: [sim]}\n";
  try {
    h.launch(file.string(), {}, 15s);
    ADD_FAILURE() << "launch of a broken set succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'sim' did not report ready"), std::string::npos) << e.what();
  }
  EXPECT_THROW(h.pid("after_sim"), std::out_of_range);  // never started
}

TEST(HarnessReplay, ComponentsUnderTestRunOnTheRecordedTime) {
  harness::Harness h;
  const fs::path file = fs::path(h.logDir()) / "past.mcap";
  constexpr std::int64_t kT0 = 1'000'000'000'000'000'000;  // 2001: no live stamp is near it
  constexpr std::int64_t kSpan = 3'000'000'000;
  {
    record::McapWriter w(file.string());
    const auto schema = w.addSchema("ddsnav::msg::VelocityCommand", "omgidl", *record::idlSchemaFor("ddsnav::msg::VelocityCommand"));
    const auto ch = w.addChannel(schema, "recorded/cmd", "cdr", {{"dds_type", "ddsnav::msg::VelocityCommand"}, {"keyed", "false"}});
    for (std::int64_t t = 0; t <= kSpan; t += 100'000'000) {
      msg::VelocityCommand c;
      c.stamp_ns(kT0 + t);
      w.write(ch, kT0 + t, kT0 + t, msg::serializeToBytes(c));
    }
    w.close();
  }
  auto opts = talker("talker", 50);
  opts.params["clock"] = "topic";
  h.startReady(opts);
  h.replay(file.string(), {.args = {"--wait-subscribers", "0", "--settle", "0"}});
  EXPECT_TRUE(h.sampleWithin<msg::VelocityCommand>("recorded/cmd", bus::Qos::commands(), 10s));
  EXPECT_TRUE(h.sampleWithin<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), 10s,
      [](const msg::VehicleState& s) { return s.header().stamp_ns() >= kT0 && s.header().stamp_ns() <= kT0 + kSpan; },
      "a stamp inside the recording's time"));
  const auto status = h.waitExit("play", 20s);
  ASSERT_TRUE(status);
  EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 0) << h.log("play");
}

// Fails on purpose; run only by the next test, in a child process.
TEST(HarnessFailure, DISABLED_FailsWithATalkerRunning) {
  harness::Harness h;
  h.startReady(talker("talker", 20));
  ASSERT_TRUE(h.sampleWithin<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(), 10s));
  std::this_thread::sleep_for(1s);  // a second of traffic in the recording
  ADD_FAILURE() << "failing on purpose";
}

TEST(HarnessFailure, AFailedTestKeepsARecordingOfItsDomainAndNamesIt) {
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  const std::string command = self + " --gtest_also_run_disabled_tests --gtest_filter=HarnessFailure.DISABLED_FailsWithATalkerRunning 2>&1";
  std::string output;
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
  const int status = ::pclose(pipe);
  EXPECT_NE(status, 0) << output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(output, m, std::regex(R"(recording of every topic of domain \d+: (\S+\.mcap))"))) << output;
  const std::string kept = m[1];
  ASSERT_TRUE(fs::exists(kept)) << kept;
  record::McapReader reader(kept);
  bool has_state = false;
  for (const auto& [id, channel] : reader.channels()) has_state |= channel.topic == "vehicle/state";
  EXPECT_TRUE(has_state) << "no vehicle/state channel in " << kept;
  std::error_code ignored;
  fs::remove_all(fs::path(kept).parent_path(), ignored);
}

}  // namespace
