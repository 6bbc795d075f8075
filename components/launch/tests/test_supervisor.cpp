#include "ddsnav/launch/supervisor.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

using namespace ddsnav::launch;
namespace fs = std::filesystem;

namespace {

// Readiness through files: a test process "reports ready" by writing its pid to DIR/NAME, and beats
// (heartbeats) by rewriting its pid to DIR/NAME.beat; the file's modification time is when it was heard.
class FileReadiness : public ReadinessSource {
 public:
  explicit FileReadiness(fs::path dir) : dir_(std::move(dir)) {}
  bool reportsLiveness() const override { return true; }
  std::optional<std::chrono::steady_clock::time_point> lastHeard(const std::string& name, pid_t pid) override {
    const auto beat = dir_ / (name + ".beat");
    std::error_code error;
    const auto written = fs::last_write_time(beat, error);
    std::ifstream in(beat);
    pid_t reported = -1;
    if (error || !(in >> reported) || reported != pid) return std::nullopt;
    const auto age = fs::file_time_type::clock::now() - written;
    return std::chrono::steady_clock::now() - std::chrono::duration_cast<std::chrono::steady_clock::duration>(age);
  }
  bool waitUntilReady(const std::string& name, pid_t pid, std::chrono::steady_clock::time_point deadline) override {
    do {
      std::ifstream in(dir_ / name);
      pid_t reported = -1;
      if (in >> reported && reported == pid) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    } while (std::chrono::steady_clock::now() < deadline);
    return false;
  }

 private:
  fs::path dir_;
};

class SupervisorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    blockSupervisorSignals();
    dir_ = fs::temp_directory_path() / ("ddsnav_launch_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  ProcessSpec shell(const std::string& name, const std::string& script) {
    ProcessSpec spec;
    spec.name = name;
    spec.command = "/bin/sh";
    spec.args = {"-c", script, name};
    return spec;
  }
  std::string readyCommand(const std::string& name) { return "echo $$ > " + (dir_ / name).string() + "; "; }

  std::string beatCommand(const std::string& name) {
    return "while true; do echo $$ > " + (dir_ / (name + ".beat")).string() + "; sleep 0.1; done";
  }

  int run(LaunchConfig config, bool watchdog = true) {
    FileReadiness readiness(dir_);
    SupervisorOptions options;
    options.bin_dir = dir_.string();
    options.watchdog = watchdog;
    options.log = [this](const std::string& line) {
      std::lock_guard lock(log_mutex_);
      log_ += line + "\n";
    };
    options.on_event = [this](const SupervisionEvent& event) { events_.push_back(event); };
    config.name = "test";
    config.shutdown_timeout_s = 2.0;
    return Supervisor(std::move(config), options, readiness).run();
  }

  pid_t waitForPidFile(const std::string& file, std::chrono::seconds timeout = std::chrono::seconds(10)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      std::ifstream in(dir_ / file);
      pid_t pid = -1;
      if (in >> pid && pid > 0) return pid;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }

  int lines(const std::string& file) {
    std::ifstream in(dir_ / file);
    int count = 0;
    for (std::string line; std::getline(in, line);) ++count;
    return count;
  }

  fs::path dir_;
  std::mutex log_mutex_;
  std::string log_;
  std::vector<SupervisionEvent> events_;
};

bool processExists(pid_t pid) { return ::kill(pid, 0) == 0; }

// Gone, or a zombie nobody has reaped yet (an orphan's new parent may be this test process, a subreaper).
bool processGone(pid_t pid) {
  int status = 0;
  if (::waitpid(pid, &status, WNOHANG) == pid) return true;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return true;
  const auto close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'Z';
}

bool waitGone(pid_t pid, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!processGone(pid)) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

}  // namespace

TEST_F(SupervisorTest, RequiredProcessEndsTheSetAndTearsDownTheRest) {
  LaunchConfig config;
  auto server = shell("server", readyCommand("server") + "echo $$ > " + (dir_ / "server.pid").string() + "; exec sleep 60");
  auto client = shell("client", readyCommand("client") + "exit 3");
  client.after = {"server"};
  client.required = true;
  config.processes = {server, client};
  EXPECT_EQ(run(config), 3) << log_;
  pid_t server_pid = -1;
  std::ifstream(dir_ / "server.pid") >> server_pid;
  ASSERT_GT(server_pid, 0);
  EXPECT_FALSE(processExists(server_pid)) << "the long-running server must have been torn down";
  EXPECT_NE(log_.find("server is ready"), std::string::npos) << log_;
}

TEST_F(SupervisorTest, DependentStartsOnlyAfterItsDependencyIsReady) {
  LaunchConfig config;
  // The first process becomes ready only after a delay; the second records whether it was ready then.
  auto slow = shell("slow", "sleep 0.3; " + readyCommand("slow") + "exec sleep 60");
  auto checker = shell("checker", readyCommand("checker") + "test -f " + (dir_ / "slow").string() + "; exit $?");
  checker.after = {"slow"};
  checker.required = true;
  config.processes = {slow, checker};
  EXPECT_EQ(run(config), 0) << log_;
}

TEST_F(SupervisorTest, OnFailureRestartsUpToTheLimitThenFails) {
  LaunchConfig config;
  auto flaky = shell("flaky", "echo run >> " + (dir_ / "runs").string() + "; exit 1");
  flaky.wait_ready = false;
  flaky.restart = RestartPolicy::OnFailure;
  flaky.max_restarts = 2;
  config.processes = {flaky};
  EXPECT_NE(run(config), 0) << log_;
  EXPECT_EQ(lines("runs"), 3) << "one start plus two restarts";
  EXPECT_NE(log_.find("reached max_restarts"), std::string::npos) << log_;
}

TEST_F(SupervisorTest, CleanExitIsNotRestartedUnderOnFailure) {
  LaunchConfig config;
  auto once = shell("once", "echo run >> " + (dir_ / "runs").string() + "; exit 0");
  once.wait_ready = false;
  once.restart = RestartPolicy::OnFailure;
  config.processes = {once};
  EXPECT_EQ(run(config), 0) << log_;
  EXPECT_EQ(lines("runs"), 1);
}

TEST_F(SupervisorTest, ReadinessTimeoutFailsAndKillsTheStarter) {
  LaunchConfig config;
  auto mute = shell("mute", "echo $$ > " + (dir_ / "mute.pid").string() + "; exec sleep 60");
  mute.ready_timeout_s = 0.3;
  config.processes = {mute};
  EXPECT_EQ(run(config), 1);
  EXPECT_NE(log_.find("did not report ready within"), std::string::npos) << log_;
  pid_t pid = -1;
  std::ifstream(dir_ / "mute.pid") >> pid;
  ASSERT_GT(pid, 0);
  EXPECT_FALSE(processExists(pid));
}

TEST_F(SupervisorTest, ProcessThatIgnoresSigtermIsKilledAfterTheBound) {
  LaunchConfig config;
  auto stubborn = shell("stubborn", "trap '' TERM; " + readyCommand("stubborn") + "while true; do sleep 0.05; done");
  auto quitter = shell("quitter", readyCommand("quitter") + "exit 0");
  quitter.after = {"stubborn"};
  quitter.required = true;
  config.processes = {stubborn, quitter};
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(run(config), 0) << log_;
  EXPECT_NE(log_.find("stubborn did not stop within"), std::string::npos) << log_;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
}

// Issue 13 row 13: a missing command or a directory as command is a failed start (exit 1, as docs/launch.md
// says), found before anything starts -- not a child exiting 127.
TEST_F(SupervisorTest, MissingCommandOrDirectoryIsAFailedStartBeforeAnythingRuns) {
  LaunchConfig config;
  auto first = shell("first", "echo run >> " + (dir_ / "runs").string() + "; exec sleep 60");
  first.wait_ready = false;
  auto ghost = shell("ghost", "");
  ghost.command = "ddsnav-no-such-command";
  ghost.args.clear();
  config.processes = {first, ghost};
  EXPECT_EQ(run(config), 1);
  EXPECT_NE(log_.find("cannot start ghost: command 'ddsnav-no-such-command' not found"), std::string::npos) << log_;
  EXPECT_EQ(lines("runs"), 0) << "nothing starts when a command is unusable";

  log_.clear();
  auto folder = shell("folder", "");
  folder.command = "/tmp";
  folder.args.clear();
  config.processes = {folder};
  EXPECT_EQ(run(config), 1);
  EXPECT_NE(log_.find("cannot start folder: command '/tmp' is a directory"), std::string::npos) << log_;
}

// Issue 13 row 10: `restart: always` on a program that exits at once made ~1,000 fork+exec per second.
// Now each restart waits restart_delay_s, doubled per restart up to max_restart_delay_s, and the budget
// (max_restarts within restart_window_s) ends it.
TEST_F(SupervisorTest, CrashLoopBacksOffExponentiallyAndStopsAtTheBudget) {
  LaunchConfig config;
  auto quick = shell("quick", "date +%s%N >> " + (dir_ / "runs").string() + "; exit 0");
  quick.wait_ready = false;
  quick.restart = RestartPolicy::Always;
  quick.max_restarts = 4;
  quick.restart_delay_s = 0.1;
  quick.max_restart_delay_s = 0.3;
  config.processes = {quick};
  EXPECT_EQ(run(config), 1) << log_;
  std::ifstream in(dir_ / "runs");
  std::vector<double> starts;
  for (long long ns = 0; in >> ns;) starts.push_back(static_cast<double>(ns) * 1e-9);
  ASSERT_EQ(starts.size(), 5u) << "one start plus max_restarts restarts, then the budget is spent\n" << log_;
  const double expected_delay[] = {0.1, 0.2, 0.3, 0.3};  // doubled, capped at max_restart_delay_s
  for (size_t i = 0; i < 4; ++i)
    EXPECT_GE(starts[i + 1] - starts[i], expected_delay[i] * 0.95) << "restart " << i + 1 << "\n" << log_;
  EXPECT_NE(log_.find("restarting quick (1/4) in 0.1 s"), std::string::npos) << log_;
  EXPECT_NE(log_.find("restarting quick (3/4) in 0.3 s"), std::string::npos) << log_;
  EXPECT_NE(log_.find("quick reached max_restarts (4 within restart_window_s 60.0 s): tearing down"), std::string::npos) << log_;
  ASSERT_EQ(events_.size(), 5u);
  EXPECT_TRUE(events_[0].restarting);
  EXPECT_FALSE(events_[4].restarting);
  EXPECT_NE(events_[4].detail.find("reached max_restarts"), std::string::npos) << events_[4].detail;
}

TEST_F(SupervisorTest, RestartBudgetIsPerWindow) {
  LaunchConfig config;
  // Exits 1 every 1.1 s; with one restart allowed per 1 s window it keeps running until the required
  // timer process ends the set.
  auto flaky = shell("flaky", "echo run >> " + (dir_ / "runs").string() + "; sleep 1.1; exit 1");
  flaky.wait_ready = false;
  flaky.restart = RestartPolicy::OnFailure;
  flaky.max_restarts = 1;
  flaky.restart_window_s = 1.0;
  flaky.restart_delay_s = 0.0;
  flaky.max_restart_delay_s = 0.0;
  auto timer = shell("timer", "sleep 3.5; exit 0");
  timer.wait_ready = false;
  timer.required = true;
  config.processes = {flaky, timer};
  EXPECT_EQ(run(config), 0) << log_;
  EXPECT_GE(lines("runs"), 3) << "restarts spread over several windows are not counted together\n" << log_;
  EXPECT_EQ(log_.find("reached max_restarts"), std::string::npos) << log_;
}

// Issue 13 row 4: a stopped (SIGSTOP) process kept counting as running. Silent for liveness_timeout_s,
// it is now named, killed and handled by its restart policy, and the rest of the system is told.
TEST_F(SupervisorTest, SilentProcessIsNamedKilledAndRestarted) {
  LaunchConfig config;
  // Heard once before it reports ready (as a component's STARTING status is), then beating.
  auto beater = shell("beater", "echo $$ >> " + (dir_ / "runs").string() + "; echo $$ > " + (dir_ / "beater.beat").string() + "; " +
                                    readyCommand("beater") + beatCommand("beater"));
  beater.restart = RestartPolicy::OnFailure;
  beater.liveness_timeout_s = 0.5;
  beater.restart_delay_s = 0.1;
  // The judge ends the set once the beater has run twice (bounded: exit 9 after ~10 s).
  auto judge = shell("judge", "i=0; while [ \"$(wc -l < " + (dir_ / "runs").string() + ")\" -lt 2 ] && [ $i -lt 200 ]; do "
                              "i=$((i+1)); sleep 0.05; done; [ $i -lt 200 ]");
  judge.wait_ready = false;
  judge.required = true;
  judge.after = {"beater"};
  config.processes = {beater, judge};
  pid_t stopped = -1;
  std::thread stopper([&] {
    stopped = waitForPidFile("beater");
    if (stopped > 0) ::kill(stopped, SIGSTOP);
  });
  const int status = run(config);
  stopper.join();
  ASSERT_GT(stopped, 0);
  EXPECT_EQ(status, 0) << log_;
  EXPECT_TRUE(waitGone(stopped, std::chrono::seconds(5)));
  const std::string named = "beater (pid " + std::to_string(stopped) + ") silent on system/status for ";
  EXPECT_NE(log_.find(named), std::string::npos) << log_;
  EXPECT_NE(log_.find("s (liveness_timeout_s 0.5): killing it"), std::string::npos) << log_;
  EXPECT_NE(log_.find("restarting beater (1/3) in 0.1 s"), std::string::npos) << log_;
  ASSERT_FALSE(events_.empty()) << log_;
  EXPECT_EQ(events_[0].name, "beater");
  EXPECT_EQ(events_[0].pid, stopped);
  EXPECT_TRUE(events_[0].restarting);
  EXPECT_NE(events_[0].detail.find("silent on system/status"), std::string::npos) << events_[0].detail;
}

// A restarted instance that never says a word within ready_timeout_s is killed too.
TEST_F(SupervisorTest, RestartedInstanceThatNeverSpeaksIsKilledAfterReadyTimeout) {
  LaunchConfig config;
  // First run: ready and beating, then exits 1. Later runs: never beat.
  auto once = shell("once", "if [ ! -f " + (dir_ / "first").string() + " ]; then touch " + (dir_ / "first").string() + "; " +
                                readyCommand("once") + "echo $$ > " + (dir_ / "once.beat").string() + "; sleep 0.2; exit 1; fi; " +
                                "echo $$ >> " + (dir_ / "mute").string() + "; exec sleep 60");
  once.restart = RestartPolicy::OnFailure;
  once.max_restarts = 1;
  once.restart_delay_s = 0.0;
  once.ready_timeout_s = 0.5;
  config.processes = {once};
  EXPECT_NE(run(config), 0) << log_;
  EXPECT_NE(log_.find("no status on system/status within ready_timeout_s 0.5 s: killing it"), std::string::npos) << log_;
  EXPECT_NE(log_.find("once reached max_restarts"), std::string::npos) << log_;
}

// Issue 13 row 6: grandchildren (a shell's `sleep`) must go with the set.
TEST_F(SupervisorTest, TeardownReachesGrandchildren) {
  LaunchConfig config;
  auto parent = shell("parent", "sleep 301 & echo $! > " + (dir_ / "grandchild").string() + "; " + readyCommand("parent") + "wait");
  auto quitter = shell("quitter", "sleep 0.2; exit 0");
  quitter.wait_ready = false;
  quitter.required = true;
  quitter.after = {"parent"};
  config.processes = {parent, quitter};
  EXPECT_EQ(run(config), 0) << log_;
  const pid_t grandchild = waitForPidFile("grandchild");
  ASSERT_GT(grandchild, 0);
  EXPECT_TRUE(processGone(grandchild)) << log_;
}

// A process that ends leaving children behind in its group: they are killed before it is restarted.
TEST_F(SupervisorTest, LeftoversOfAnEndedProcessAreKilledBeforeItsRestart) {
  LaunchConfig config;
  auto leaky = shell("leaky", "sleep 301 & echo $! >> " + (dir_ / "leftovers").string() + "; exit 1");
  leaky.wait_ready = false;
  leaky.restart = RestartPolicy::OnFailure;
  leaky.max_restarts = 1;
  leaky.restart_delay_s = 0.0;
  config.processes = {leaky};
  EXPECT_NE(run(config), 0) << log_;
  std::ifstream in(dir_ / "leftovers");
  int count = 0;
  for (pid_t pid = -1; in >> pid; ++count) EXPECT_TRUE(waitGone(pid, std::chrono::seconds(5))) << pid;
  EXPECT_EQ(count, 2);
}

// Issue 13 row 6: the launcher killed with SIGKILL. PDEATHSIG reaches only its direct children; the
// TeardownWatchdog ends the whole tree. Without it (the control run) the grandchild survives.
TEST_F(SupervisorTest, SigkilledLauncherLeavesNoGrandchildrenBehind) {
  for (const bool watchdog : {true, false}) {
    SCOPED_TRACE(watchdog ? "with the watchdog" : "without the watchdog (control)");
    fs::remove(dir_ / "grandchild");
    LaunchConfig config;
    auto parent = shell("parent", "trap 'exit 0' TERM; sleep 301 & echo $! > " + (dir_ / "grandchild").string() + "; wait");
    parent.wait_ready = false;
    config.processes = {parent};
    const pid_t launcher = ::fork();
    ASSERT_GE(launcher, 0);
    if (launcher == 0) {
      ::setpgid(0, 0);
      run(config, watchdog);
      ::_exit(0);
    }
    const pid_t grandchild = waitForPidFile("grandchild");
    ASSERT_GT(grandchild, 0);
    ASSERT_EQ(::kill(launcher, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(launcher, &status, 0), launcher);
    if (watchdog) {
      EXPECT_TRUE(waitGone(grandchild, std::chrono::seconds(5))) << "the watchdog must end the launcher's grandchildren";
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      EXPECT_FALSE(processGone(grandchild)) << "control: PDEATHSIG alone does not reach grandchildren";
      ::kill(grandchild, SIGKILL);  // ours: the test started it
      waitGone(grandchild, std::chrono::seconds(5));
    }
  }
}
