// `ddsnav launch` with real components: readiness-gated start, restart on failure, teardown without orphans.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
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

// Waits until the launcher's log contains `text`.
bool launcherSaw(harness::Harness& h, const std::string& text, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (h.log("launcher").find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(20ms);
  }
  return false;
}

std::string writeLaunchFile(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(path) << text;
  return path.string();
}

}  // namespace

TEST(Launch, StartsInOrderRestartsOnFailureAndTearsDownWithoutOrphans) {
  harness::Harness h;
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
  ASSERT_TRUE(launcherSaw(h, "perception is ready", 30s)) << h.log("launcher");

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
  harness::Harness h;
  const auto file = writeLaunchFile("launch_bad", "processes:\n  - name: a\n    command: ddsnav-sim\n    restart: sometimes\n");
  h.start({.name = "launcher", .command = "ddsnav-launch", .args = {file}});
  int status = 0;
  for (int i = 0; i < 200 && h.running("launcher"); ++i) std::this_thread::sleep_for(50ms);
  status = h.stop("launcher");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status;
  EXPECT_NE(h.log("launcher").find(file + ":4: key 'restart'"), std::string::npos) << h.log("launcher");
  std::filesystem::remove(file);
}

namespace {

// Every ComponentStatus seen, with when it arrived.
class StatusLog {
 public:
  struct Entry {
    msg::ComponentStatus status;
    std::chrono::steady_clock::time_point received;
  };
  explicit StatusLog(bus::Participant& bus)
      : sub_(bus.subscribe<msg::ComponentStatus>("system/status", bus::Qos::state(1), [this](const msg::ComponentStatus& s) {
          std::lock_guard lock(mutex_);
          entries_.push_back({s, std::chrono::steady_clock::now()});
        })) {}
  // The first entry accepted by `match`, waiting up to `timeout`.
  std::optional<Entry> waitFor(const std::function<bool(const msg::ComponentStatus&)>& match, std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      {
        std::lock_guard lock(mutex_);
        for (const auto& e : entries_)
          if (match(e.status)) return e;
      }
      std::this_thread::sleep_for(10ms);
    }
    return std::nullopt;
  }

 private:
  std::mutex mutex_;
  std::vector<Entry> entries_;
  bus::Subscription sub_;
};

bool waitGone(pid_t pid, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(stat, line)) return true;
    const auto close = line.rfind(')');
    if (close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'Z') return true;  // unreaped orphan
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(20ms);
  }
}

pid_t readPid(const std::string& path, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    std::ifstream in(path);
    pid_t pid = -1;
    if (in >> pid && pid > 0) return pid;
    std::this_thread::sleep_for(20ms);
  }
  return -1;
}

}  // namespace

// Issue 13 row 4: SIGSTOP a component mid-run. The launcher notices its silence within
// liveness_timeout_s, names it, kills it, restarts it by policy, and tells the system on system/status.
TEST(Launch, StoppedComponentIsNamedKilledRestartedAndAnnounced) {
  harness::Harness h;
  ReadyPids ready(h.bus());
  StatusLog statuses(h.bus());
  const auto file = writeLaunchFile("launch_liveness", R"(
name: liveness-test
processes:
  - name: sim
    command: ddsnav-sim
    params: {scenario: ")" + kScenario + R"(", heartbeat_period_s: "0.25"}
    dds: fastdds
  - name: perception
    command: ddsnav-perception
    params: {heartbeat_period_s: "0.25"}
    dds: cyclonedds
    after: [sim]
    restart: on-failure
    liveness_timeout_s: 2
    restart_delay_s: 0.2
)");
  h.start({.name = "launcher", .command = "ddsnav-launch", .args = {file, "--domain", std::to_string(h.domain())}});
  ASSERT_TRUE(ready.waitFor("perception", 1, 30s)) << h.log("launcher");
  const pid_t first = *ready.of("perception").begin();
  // Stop it only once the launcher has its READY: a stopped process cannot retransmit a lost sample.
  ASSERT_TRUE(launcherSaw(h, "perception is ready", 30s)) << h.log("launcher");

  const auto stopped_at = std::chrono::steady_clock::now();
  ASSERT_EQ(::kill(first, SIGSTOP), 0);
  // The status event: perception's key, the stopped pid, not ready, SHUTTING_DOWN, the reason.
  const auto event = statuses.waitFor(
      [&](const msg::ComponentStatus& s) {
        return s.name() == "perception" && s.pid() == first && s.state() == msg::LIFECYCLE_SHUTTING_DOWN && !s.ready() &&
               s.detail().rfind("launch: ", 0) == 0;
      },
      20s);
  ASSERT_TRUE(event.has_value()) << h.log("launcher");
  const double detected_s = std::chrono::duration<double>(event->received - stopped_at).count();
  std::printf("[ measured ] SIGSTOP of perception announced after %.2f s (liveness_timeout_s 2)\n", detected_s);
  EXPECT_NE(event->status.detail().find("silent on system/status for"), std::string::npos) << event->status.detail();
  EXPECT_NE(event->status.detail().find("restart 1/3 in 0.2 s"), std::string::npos) << event->status.detail();
  EXPECT_NE(h.log("launcher").find("perception (pid " + std::to_string(first) + ") silent on system/status for"), std::string::npos)
      << h.log("launcher");
  EXPECT_TRUE(waitGone(first, 10s)) << "the stopped instance is killed";

  // Handled by policy: a new instance reports ready with a new pid.
  ASSERT_TRUE(ready.waitFor("perception", 2, 30s)) << h.log("launcher");
  const int status = h.stop("launcher", 15s);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << h.log("launcher");
  std::filesystem::remove(file);
}

// Issue 13 row 6: kill -9 the launcher. Its components shut down cleanly (one SIGTERM's worth: FINISHED,
// not exit 3) and a grandchild (`sh -c "sleep 301 & ..."`) goes too.
TEST(Launch, SigkilledLauncherTakesTheWholeTreeDownCleanly) {
  harness::Harness h;
  ReadyPids ready(h.bus());
  StatusLog statuses(h.bus());
  const auto pid_file = (std::filesystem::temp_directory_path() / ("launch_grandchild_" + std::to_string(::getpid()))).string();
  std::filesystem::remove(pid_file);
  const auto file = writeLaunchFile("launch_sigkill", R"(
name: sigkill-test
shutdown_timeout_s: 5
processes:
  - name: sim
    command: ddsnav-sim
    params: {scenario: ")" + kScenario + R"("}
    dds: cyclonedds
  - name: forker
    command: /bin/sh
    args: [-c, "sleep 301 & echo $! > )" + pid_file + R"(; wait"]
    wait_ready: false
    after: [sim]
)");
  h.start({.name = "launcher", .command = "ddsnav-launch", .args = {file, "--domain", std::to_string(h.domain())}});
  ASSERT_TRUE(ready.waitFor("sim", 1, 30s)) << h.log("launcher");
  const pid_t sim = *ready.of("sim").begin();
  const pid_t grandchild = readPid(pid_file, 20s);
  ASSERT_GT(grandchild, 0) << h.log("launcher");

  ASSERT_EQ(::kill(h.pid("launcher"), SIGKILL), 0);
  h.stop("launcher");  // reaps it
  EXPECT_TRUE(waitGone(grandchild, 10s)) << "the grandchild outlived a SIGKILLed launcher";
  EXPECT_TRUE(waitGone(sim, 10s));
  const auto finished = statuses.waitFor(
      [&](const msg::ComponentStatus& s) { return s.name() == "sim" && s.pid() == sim && s.state() == msg::LIFECYCLE_FINISHED; }, 10s);
  EXPECT_TRUE(finished.has_value()) << "sim did not shut down cleanly (a second SIGTERM used to make it exit 3)";
  if (!waitGone(grandchild, 0s)) ::kill(grandchild, SIGKILL);  // never leave it behind, even when failing
  std::filesystem::remove(pid_file);
  std::filesystem::remove(file);
}

// Issue 13 row 13: exit statuses as docs/launch.md gives them.
TEST(Launch, UsageAndStartErrorsExitAsDocumented) {
  harness::Harness h;
  auto exitOf = [&](const std::string& name, const std::vector<std::string>& args) {
    h.start({.name = name, .command = "ddsnav-launch", .args = args});
    for (int i = 0; i < 400 && h.running(name); ++i) std::this_thread::sleep_for(50ms);
    const int status = h.stop(name);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  const auto good = writeLaunchFile("launch_usage", "processes:\n  - {name: a, command: /bin/true, wait_ready: false}\n");
  EXPECT_EQ(exitOf("domain", {good, "--domain", "233"}), 2) << h.log("domain");
  EXPECT_NE(h.log("domain").find("--domain"), std::string::npos) << h.log("domain");
  const auto folder = writeLaunchFile("launch_folder", "processes:\n  - {name: a, command: /tmp, wait_ready: false}\n");
  EXPECT_EQ(exitOf("folder", {folder, "--domain", std::to_string(h.domain())}), 1) << h.log("folder");
  EXPECT_NE(h.log("folder").find("cannot start a: command '/tmp' is a directory"), std::string::npos) << h.log("folder");
  const auto nul = writeLaunchFile("launch_nul", "processes:\n  - {name: \"pl\\0anner\", command: /bin/true}\n");
  EXPECT_EQ(exitOf("nul", {nul, "--domain", std::to_string(h.domain())}), 2) << h.log("nul");
  EXPECT_NE(h.log("nul").find(nul + ":2: key 'name': control character (byte 0)"), std::string::npos) << h.log("nul");
  for (const auto& f : {good, folder, nul}) std::filesystem::remove(f);
}
