// The README's main job, exactly as `scripts/demo` runs it: `ddsnav launch configs/launch/demo.yaml`
// (sim, perception, mapper, planner, tracker and the monitor across both vendors) must end by itself with
// status 0, the goal reached, and the report, summary and map written. The same test runs the same
// pipeline composed in one container (demo_composed.yaml, intra-process delivery).

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

class DemoLaunch : public ::testing::TestWithParam<std::string> {};

TEST_P(DemoLaunch, TheReadmeDemoReachesTheGoalAndWritesItsReport) {
  harness::Harness h;
  const fs::path out = fs::temp_directory_path() / ("ddsnav_demo_launch_" + GetParam() + "_" + std::to_string(::getpid()));
  fs::remove_all(out);
  h.start({.name = "launcher",
           .command = "ddsnav-launch",
           .args = {std::string(DDSNAV_SOURCE_DIR) + "/configs/launch/" + GetParam() + ".yaml", "--domain", std::to_string(h.domain()),
                    "--set", "out=" + out.string()}});

  // The monitor (required) ends the set when the vehicle reaches the goal or its own timeout passes
  // (demo.yaml: 120 s); this bound only guards against a launcher that never returns.
  const auto deadline = std::chrono::steady_clock::now() + 200s;
  while (h.running("launcher") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(200ms);
  ASSERT_FALSE(h.running("launcher")) << "the demo did not end within 200 s\n" << h.log("launcher");
  const int status = h.stop("launcher");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << h.log("launcher");

  std::ifstream summary_file(out / "summary.json");
  ASSERT_TRUE(summary_file.good()) << "no summary.json in " << out << "\n" << h.log("launcher");
  const auto summary = nlohmann::json::parse(summary_file, nullptr, /*allow_exceptions=*/false);
  ASSERT_TRUE(summary.is_object()) << "summary.json is not JSON";
  EXPECT_TRUE(summary.value("goal_reached", false)) << summary.dump(2);
  EXPECT_GT(summary.value("clouds", 0), 0) << summary.dump(2);
  EXPECT_GT(summary.value("obstacles", 0), 0) << summary.dump(2);
  for (const char* file : {"report.html", "report.svg", "map.bt"}) {
    EXPECT_GT(fs::exists(out / file) ? fs::file_size(out / file) : 0u, 0u) << file << " missing or empty in " << out;
  }
  fs::remove_all(out);
}

INSTANTIATE_TEST_SUITE_P(SeparateAndComposed, DemoLaunch, ::testing::Values("demo", "demo_composed"),
                         [](const auto& info) { return info.param == "demo" ? std::string("Separate") : std::string("Composed"); });
