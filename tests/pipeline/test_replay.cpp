// "Any stage can be swapped for a replay": record the simulator's sensor topics, then run
// perception and the mapper on that recording instead of the simulator with
// configs/launch/replay_perception.yaml (each phase on a domain of its own), following the recording's clock.

#include <chrono>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/scenario.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <thread>

using namespace ddsnav;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

const std::string kSource = DDSNAV_SOURCE_DIR;
const std::string kScenario = kSource + "/configs/scenarios/demo_2d.yaml";
const std::string kLaunchFile = kSource + "/configs/launch/replay_perception.yaml";

// Waits (bounded) for a process the harness started to end by itself; returns its wait status, or -1
// when it was still running at the deadline (the harness then stops it).
int waitForExit(harness::Harness& h, const std::string& name, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (h.running(name)) {
    if (std::chrono::steady_clock::now() > deadline) return -1;
    std::this_thread::sleep_for(50ms);
  }
  return h.stop(name);
}

bool exitedWith(int status, int code) { return status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) == code; }

// `ddsnav-info FILE --json`: what the recording holds, read back by the record library.
nlohmann::json recordingInfo(const std::string& file) {
  const std::string command = harness::Harness::binDir() + "/ddsnav-info '" + file + "' --json";
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return {};
  std::string text;
  std::array<char, 4096> buffer{};
  for (std::size_t n; (n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0;) text.append(buffer.data(), n);
  ::pclose(pipe);
  return nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
}

std::uint64_t messagesOn(const nlohmann::json& info, const std::string& topic) {
  for (const auto& t : info.value("topics", nlohmann::json::array()))
    if (t.value("topic", "") == topic) return t.value("message_count", std::uint64_t{0});
  return 0;
}

// Distance from p to the nearest true obstacle of configs/scenarios/demo_2d.yaml, in the plane. The
// rotated ellipse (33,22; 5 x 2 m; yaw 1.2) is taken as its 5 m bounding circle: lenient, still far
// from the empty parts of the yard.
// Distance from (x, y) to the nearest obstacle of the recorded scenario (0 inside one), from the scenario file
// itself through the planner's exact geometry, so an edit of demo_2d.yaml cannot leave this test behind.
double distanceToScenarioObstacle(const planner::CollisionWorld& world, double x, double y) {
  return std::max(world.clearance(planner::Vec3(x, y, 0.0)) + world.robotRadius(), 0.0);
}

// What the test sees while the replay runs.
struct Observed {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<msg::ObstacleArray> obstacles;
  std::size_t maps = 0;
  std::vector<std::pair<std::string, std::int64_t>> heartbeat_stamps;  // (component, stamp) of perception/mapper
};

}  // namespace

TEST(Replay, PerceptionAndMapperRunOnARecordingOfTheSimulatorOnItsClock) {
  const fs::path dir = fs::temp_directory_path() / ("ddsnav_replay_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string recording = (dir / "run.mcap").string();
  const auto world = planner::makeScenarioWorld(planner::loadScenario(kScenario));

  // Phase 1: record the simulator's lidar clouds and vehicle states (Fast DDS sim, Cyclone recorder).
  {
    harness::Harness h;
    h.startReady({.name = "sim", .command = "ddsnav-sim", .params = {{"scenario", kScenario}}, .dds = "fastdds"});
    h.start({.name = "record",
             .command = "ddsnav-record",
             .args = {"-o", recording, "--topics", "sensors/points,vehicle/state", "--duration", "4", "--compression", "none",
                      "--domain", std::to_string(h.domain())},
             .dds = "cyclonedds"});
    const int status = waitForExit(h, "record", 20s);
    ASSERT_TRUE(exitedWith(status, 0)) << status << "\n" << h.log("record");
    h.stop("sim");
  }
  const auto info = recordingInfo(recording);
  ASSERT_TRUE(info.is_object()) << "ddsnav-info gave no JSON for " << recording;
  ASSERT_FALSE(info.value("truncated", true));
  ASSERT_GE(messagesOn(info, "sensors/points"), 5u) << info.dump(2);
  ASSERT_GE(messagesOn(info, "vehicle/state"), 20u) << info.dump(2);
  const auto recorded_from = info.value("start_time_ns", std::int64_t{0});
  const auto recorded_to = info.value("end_time_ns", std::int64_t{0});
  ASSERT_GT(recorded_to, recorded_from);
  // The simulator's own clock (system/clock, simulated time) may run up to a step or so ahead of the
  // receipt times the recording's end is measured in; a wall-clock stamp would lie after the replay's start.
  const std::int64_t sim_clock_lead_ns = 2'000'000'000;
  const std::int64_t replay_started = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();

  // Phase 2: the launch file replays it into perception and the mapper; nothing simulates anything.
  harness::Harness h;
  Observed seen;
  auto obstacles = h.bus().subscribe<msg::ObstacleArray>("perception/obstacles", bus::Qos::state(), [&](const msg::ObstacleArray& a) {
    std::lock_guard lock(seen.mutex);
    seen.obstacles.push_back(a);
    seen.changed.notify_all();
  });
  auto maps = h.bus().subscribe<msg::OccupancyMap>("map/octomap", bus::Qos::state(), [&](const msg::OccupancyMap& m) {
    std::lock_guard lock(seen.mutex);
    if (!m.octree().empty()) ++seen.maps;
    seen.changed.notify_all();
  });
  auto statuses = h.bus().subscribe<msg::ComponentStatus>("system/status", bus::Qos::state(1), [&](const msg::ComponentStatus& s) {
    std::lock_guard lock(seen.mutex);
    if (s.name() == "perception" || s.name() == "mapper") seen.heartbeat_stamps.emplace_back(s.name(), s.stamp_ns());
  });

  const std::string out = (dir / "out").string();
  h.start({.name = "launcher",
           .command = "ddsnav-launch",
           .args = {kLaunchFile, "--set", "recording=" + recording, "--set", "out=" + out, "--domain", std::to_string(h.domain())}});
  {
    std::unique_lock lock(seen.mutex);
    const bool both = seen.changed.wait_for(lock, 30s, [&] {
      const bool any_obstacle = std::any_of(seen.obstacles.begin(), seen.obstacles.end(),
                                            [](const msg::ObstacleArray& a) { return !a.obstacles().empty(); });
      return any_obstacle && seen.maps > 0;
    });
    ASSERT_TRUE(both) << "obstacle arrays " << seen.obstacles.size() << ", maps " << seen.maps << "\n" << h.log("launcher");
  }

  // Playback ends -> the required play process exits 0 -> the launcher tears down and returns 0.
  const int status = waitForExit(h, "launcher", 30s);
  EXPECT_TRUE(exitedWith(status, 0)) << status << "\n" << h.log("launcher");
  EXPECT_NE(h.log("launcher").find("play is required: tearing down"), std::string::npos) << h.log("launcher");
  EXPECT_TRUE(fs::exists(out + "/map.bt") && fs::file_size(out + "/map.bt") > 0) << h.log("launcher");

  std::lock_guard lock(seen.mutex);
  // The obstacles come from the recorded clouds: their stamps are the recording's, and every ellipse lies
  // on one of the scenario's true obstacles.
  std::size_t ellipses = 0;
  for (const auto& array : seen.obstacles) {
    EXPECT_EQ(array.header().frame_id(), "map");
    EXPECT_TRUE(array.planar());
    EXPECT_GE(array.header().stamp_ns(), recorded_from - 100'000'000);  // a cloud's stamp precedes its receipt slightly
    EXPECT_LE(array.header().stamp_ns(), recorded_to + sim_clock_lead_ns);
    EXPECT_LT(array.header().stamp_ns(), replay_started);
    for (const auto& o : array.obstacles()) {
      ++ellipses;
      EXPECT_LT(distanceToScenarioObstacle(*world, o.centre().x(), o.centre().y()), 1.0) << "ellipse at " << o.centre().x() << ", " << o.centre().y();
    }
  }
  EXPECT_GE(ellipses, 3u);

  // clock: topic — the components' own time (their heartbeat stamps) is the recording's time, which ended
  // seconds before this replay; a wall-clock stamp would lie after recorded_to. 0 = no clock sample yet.
  std::size_t on_recorded_clock = 0;
  for (const auto& [name, stamp] : seen.heartbeat_stamps) {
    if (stamp == 0) continue;
    ++on_recorded_clock;
    EXPECT_GE(stamp, recorded_from) << name;
    EXPECT_LE(stamp, recorded_to + sim_clock_lead_ns) << name;
    EXPECT_LT(stamp, replay_started) << name;
  }
  EXPECT_GE(on_recorded_clock, 2u) << "perception/mapper never published a status stamped by system/clock";

  fs::remove_all(dir);
}
