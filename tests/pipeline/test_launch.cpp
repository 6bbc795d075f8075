// `ddsnav launch` with real components: readiness-gated start, restart on failure, teardown without orphans.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>

using namespace ddsnav;
using namespace std::chrono_literals;

namespace {

const std::string kScenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";

bool processExists(pid_t pid) { return ::kill(pid, 0) == 0; }

// The pids that have reported ready per component name, from system/status.
class ReadyPids {
 public:
  explicit ReadyPids(bus::Participant& bus)
      : sub_(bus.subscribe<msg::ComponentStatus>("system/status", bus::Qos::state(1), [this](const msg::ComponentStatus& s) {
          std::lock_guard lock(mutex_);
          if (s.ready()) pids_[s.name()].insert(s.pid());
        })) {}
  std::set<pid_t> of(const std::string& name) {
    std::lock_guard lock(mutex_);
    return pids_[name];
  }
  bool waitFor(const std::string& name, std::size_t count, std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      if (of(name).size() >= count) return true;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }

 private:
  std::mutex mutex_;
  std::map<std::string, std::set<pid_t>> pids_;
  bus::Subscription sub_;
};

std::string writeLaunchFile(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(path) << text;
  return path.string();
}

}  // namespace

TEST(Launch, StartsInOrderRestartsOnFailureAndTearsDownWithoutOrphans) {
  harness::Harness h(210);
  ReadyPids ready(h.bus());
  const auto file = writeLaunchFile("launch_restart", R"(
name: restart-test
processes:
  - name: sim
    command: ddsnav-sim
    params: {scenario: ")" + kScenario + R"("}
    dds: fastdds
  - name: perception
    command: ddsnav-perception
    dds: cyclonedds
    after: [sim]
    restart: on-failure
    max_restarts: 2
)");
  h.start({.name = "launcher", .command = "ddsnav-launch", .args = {file, "--domain", std::to_string(h.domain())}});
  ASSERT_TRUE(ready.waitFor("perception", 1, 30s)) << h.log("launcher");
  // The launcher saw sim ready before it started perception; this observer may discover sim's status
  // writer a little later (Fast DDS announces itself less often than Cyclone), so wait for it too.
  ASSERT_TRUE(ready.waitFor("sim", 1, 30s)) << h.log("launcher");
  ASSERT_EQ(ready.of("sim").size(), 1u);
  const pid_t sim = *ready.of("sim").begin();
  const pid_t first = *ready.of("perception").begin();

  // A crash of perception: the launcher starts a new one, which reports ready with a new pid.
  ASSERT_EQ(::kill(first, SIGKILL), 0);
  ASSERT_TRUE(ready.waitFor("perception", 2, 30s)) << h.log("launcher");
  pid_t second = -1;
  for (pid_t p : ready.of("perception"))
    if (p != first) second = p;
  ASSERT_GT(second, 0);
  EXPECT_NE(h.log("launcher").find("restarting perception (1/2)"), std::string::npos) << h.log("launcher");

  // SIGTERM to the launcher: everything it started is gone when it returns.
  const int status = h.stop("launcher", 15s);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << h.log("launcher");
  EXPECT_FALSE(processExists(sim));
  EXPECT_FALSE(processExists(second));
  std::filesystem::remove(file);
}

TEST(Launch, ABadLaunchFileIsRejectedBeforeAnythingStarts) {
  harness::Harness h(211);
  const auto file = writeLaunchFile("launch_bad", "processes:\n  - name: a\n    command: ddsnav-sim\n    restart: sometimes\n");
  h.start({.name = "launcher", .command = "ddsnav-launch", .args = {file}});
  int status = 0;
  for (int i = 0; i < 200 && h.running("launcher"); ++i) std::this_thread::sleep_for(50ms);
  status = h.stop("launcher");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status;
  EXPECT_NE(h.log("launcher").find(file + ":4: key 'restart'"), std::string::npos) << h.log("launcher");
  std::filesystem::remove(file);
}
