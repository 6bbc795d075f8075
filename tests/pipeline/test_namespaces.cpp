// Remapping and namespaces across processes (DDS domains 231 and 232: the components range 230..239 ends
// at the largest valid id, 232; the two tests on 231 publish nothing the other looks for): a
// remapped stage is heard only under its new name; bad names are refused at start naming what is wrong;
// two namespaced pipelines in one domain (configs/launch/two_vehicles.yaml) both reach their goals
// without hearing each other.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

using namespace ddsnav;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

const std::string kScenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";

}  // namespace

TEST(Namespaces, ARemappedStageIsHeardOnlyUnderItsNewName) {
  harness::Harness h(231);
  // Subscribed before the sim starts, so that a cloud on the old name could not be missed.
  auto old_name = h.bus().inbox<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), 4);
  auto new_name = h.bus().inbox<msg::PointCloud>("front/points", bus::Qos::sensorData(), 4);
  auto namespaced_state = h.bus().inbox<msg::VehicleState>("uav7/vehicle/state", bus::Qos::sensorData(), 4);
  h.startReady({.name = "sim",
                .command = "ddsnav-sim",
                .args = {"--namespace", "uav7", "--remap", "sensors/points=/front/points"},
                .params = {{"scenario", kScenario}}});
  ASSERT_TRUE(new_name.wait(10s)) << h.log("sim");
  ASSERT_TRUE(namespaced_state.wait(10s)) << h.log("sim");
  // Several clouds went out under the new name meanwhile; none under the old one.
  while (new_name.received() < 5) ASSERT_TRUE(new_name.wait(5s));
  EXPECT_EQ(old_name.received(), 0u);
  for (const auto& t : h.bus().discoveredTopics()) EXPECT_NE(t.topic, "sensors/points");
}

TEST(Namespaces, BadNamesAreRefusedAtStartNamingWhatIsWrong) {
  harness::Harness h(231);
  struct Case {
    std::vector<std::string> args;
    std::string named;
  };
  const std::vector<Case> cases = {
      {{"--remap", "sensors/pionts=lidar/points"}, "uses no topic 'sensors/pionts'; it uses: "},
      {{"--namespace", "uav-1"}, "contains '-', which a DDS topic name cannot carry"},
      {{"--remap", "system/status=x"}, "system/status is never remapped"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.named);
    h.start({.name = "perception", .command = "ddsnav-perception", .args = c.args});
    EXPECT_FALSE(h.waitReady("perception", 10s));
    const int status = h.stop("perception");
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status << "\n" << h.log("perception");
    EXPECT_NE(h.log("perception").find(c.named), std::string::npos) << h.log("perception");
  }
}

TEST(Namespaces, TwoNamespacedPipelinesInOneDomainBothReachTheirGoals) {
  harness::Harness h(232);
  const fs::path out = fs::temp_directory_path() / ("ddsnav_two_vehicles_" + std::to_string(::getpid()));
  fs::remove_all(out);
  // Nothing may appear on an un-namespaced pipeline topic while both run.
  auto plain_paths = h.bus().inbox<msg::Path>("planning/path", bus::Qos::state(), 4);
  auto plain_clouds = h.bus().inbox<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), 4);
  h.start({.name = "launcher",
           .command = "ddsnav-launch",
           .args = {std::string(DDSNAV_SOURCE_DIR) + "/configs/launch/two_vehicles.yaml", "--domain", std::to_string(h.domain()), "--set",
                    "out=" + out.string()}});
  const auto deadline = std::chrono::steady_clock::now() + 280s;
  while (h.running("launcher") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(200ms);
  ASSERT_FALSE(h.running("launcher")) << "the two pipelines did not end within 280 s\n" << h.log("launcher");
  const int status = h.stop("launcher");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << h.log("launcher");
  for (const char* vehicle : {"uav1", "uav2"}) {
    SCOPED_TRACE(vehicle);
    std::ifstream file(out / vehicle / "summary.json");
    ASSERT_TRUE(file.good()) << "no summary.json for " << vehicle << "\n" << h.log("launcher");
    const auto summary = nlohmann::json::parse(file, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(summary.is_object());
    EXPECT_TRUE(summary.value("goal_reached", false)) << summary.dump(2);
    EXPECT_EQ(summary.value("scenario", std::string()), std::string(vehicle) == "uav1" ? "demo_2d" : "demo_2d_crossing") << summary.dump(2);
    EXPECT_GT(summary.value("clouds", 0), 0) << summary.dump(2);
  }
  EXPECT_EQ(plain_paths.received(), 0u);
  EXPECT_EQ(plain_clouds.received(), 0u);
  fs::remove_all(out);
}
