#include "ddsnav/launch/supervisor.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

using namespace ddsnav::launch;
namespace fs = std::filesystem;

namespace {

// Readiness through files: a test process "reports ready" by writing its pid to DIR/NAME.
class FileReadiness : public ReadinessSource {
 public:
  explicit FileReadiness(fs::path dir) : dir_(std::move(dir)) {}
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

  int run(LaunchConfig config) {
    FileReadiness readiness(dir_);
    SupervisorOptions options;
    options.bin_dir = dir_.string();
    options.log = [this](const std::string& line) { log_ += line + "\n"; };
    config.name = "test";
    config.shutdown_timeout_s = 2.0;
    return Supervisor(std::move(config), options, readiness).run();
  }

  fs::path dir_;
  std::string log_;
};

bool processExists(pid_t pid) { return ::kill(pid, 0) == 0; }

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
  std::ifstream runs(dir_ / "runs");
  int count = 0;
  for (std::string line; std::getline(runs, line);) ++count;
  EXPECT_EQ(count, 3) << "one start plus two restarts";
  EXPECT_NE(log_.find("reached max_restarts"), std::string::npos) << log_;
}

TEST_F(SupervisorTest, CleanExitIsNotRestartedUnderOnFailure) {
  LaunchConfig config;
  auto once = shell("once", "echo run >> " + (dir_ / "runs").string() + "; exit 0");
  once.wait_ready = false;
  once.restart = RestartPolicy::OnFailure;
  config.processes = {once};
  EXPECT_EQ(run(config), 0) << log_;
  std::ifstream runs(dir_ / "runs");
  int count = 0;
  for (std::string line; std::getline(runs, line);) ++count;
  EXPECT_EQ(count, 1);
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

TEST_F(SupervisorTest, MissingCommandIsReportedAsAFailedStart) {
  LaunchConfig config;
  auto ghost = shell("ghost", "");
  ghost.command = "ddsnav-no-such-command";
  ghost.args.clear();
  config.processes = {ghost};
  EXPECT_NE(run(config), 0);
  EXPECT_NE(log_.find("ended before it reported ready"), std::string::npos) << log_;
}
