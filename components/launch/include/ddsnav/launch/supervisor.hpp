#pragma once
// Starts a LaunchConfig's processes in dependency order, each only once the ones it waits for report
// ready; watches their heartbeats (a process silent for liveness_timeout_s is named and killed);
// restarts them by policy with exponential backoff and a budget per window; and tears the whole tree
// down (SIGTERM, then SIGKILL after the bound) so that no process it started, nor any process those
// started, outlives it -- also when the launcher itself is killed with SIGKILL (see TeardownWatchdog).

#include "ddsnav/launch/launch_config.hpp"

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <sys/types.h>

namespace ddsnav::launch {

// Answers "has component NAME (running as PID) said it is ready?". The launcher implements it on the
// system/status topic; tests can use a fake.
class ReadinessSource {
 public:
  virtual ~ReadinessSource() = default;
  // Waits at most until `deadline`; returns true once NAME with PID has reported ready.
  virtual bool waitUntilReady(const std::string& name, pid_t pid, std::chrono::steady_clock::time_point deadline) = 0;
  // Whether lastHeard() is meaningful; a source without heartbeats turns liveness supervision off.
  virtual bool reportsLiveness() const { return false; }
  // When NAME running as PID was last heard from (any status, heartbeats included); nullopt if never.
  virtual std::optional<std::chrono::steady_clock::time_point> lastHeard(const std::string& name, pid_t pid) {
    (void)name;
    (void)pid;
    return std::nullopt;
  }
};

// What the supervisor tells the rest of the system when an instance ends unexpectedly (the launcher
// publishes it on system/status under the component's name; see docs/launch.md).
struct SupervisionEvent {
  std::string name;
  pid_t pid = -1;           // the instance that ended (or was killed)
  bool restarting = false;  // true: a new instance follows; false: gone for good
  std::string detail;       // why, and what happens next, e.g. "silent for 5.2 s ...; restart 1/3 in 0.5 s"
};

struct SupervisorOptions {
  std::string bin_dir;      // where "ddsnav-*" commands are looked up
  int domain = 0;
  std::string dds = "fastdds";
  std::function<void(const std::string&)> log;  // one line per event; defaults to stderr
  std::function<void(const SupervisionEvent&)> on_event;  // optional
  bool watchdog = true;     // fork a TeardownWatchdog so that a SIGKILLed launcher still tears the tree down
};

class Supervisor {
 public:
  Supervisor(LaunchConfig config, SupervisorOptions options, ReadinessSource& readiness);
  ~Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Runs until a required process exits, every process has ended for good, a start fails, or SIGINT /
  // SIGTERM arrives; then tears down. Returns the exit status for the launcher: the required process's
  // status, 0 when everything ended cleanly, non-zero on any failure.
  // The caller must have blocked SIGCHLD, SIGINT and SIGTERM in every thread (see blockSupervisorSignals).
  int run();

 private:
  struct Impl;
  Impl* impl_;
};

// How one component process is started: in a process group of its own (so it and its children can be
// signalled together), getting SIGTERM when its parent dies (PR_SET_PDEATHSIG: a second line behind
// the TeardownWatchdog, which also reaches grandchildren), with DDSNAV_DDS / DDSNAV_DOMAIN / DDSNAV_COMPONENT_NAME set and params passed as
// --param key=value. `output_file`, when not empty, receives the process's stdout and stderr.
struct SpawnOptions {
  std::string bin_dir;  // where "ddsnav-*" commands are looked up first
  int domain = 0;
  std::string dds = "fastdds";  // used when the spec names no vendor
  std::string output_file;
};
// Returns the pid (also the process group id), or -1 with errno set when fork failed. A command that
// cannot be executed makes the child exit with status 127 after saying why on stderr.
pid_t spawnComponent(const ProcessSpec& spec, const SpawnOptions& options);

// Where `command` would be executed from: a path as given, else bin_dir/command, else the first match
// on PATH. Throws LaunchError saying why when that is not an executable regular file (missing, a
// directory, not executable), so a start fails with a clear message instead of a child exiting 127.
std::string resolveCommand(const std::string& command, const std::string& bin_dir);

// A helper process that outlives a launcher killed with SIGKILL: the launcher tells it every process
// group it creates; when the launcher dies without disarming it (its pipe closes), it sends SIGTERM
// (and SIGCONT, for stopped members) to each group still alive, waits up to `shutdown_timeout`, then
// SIGKILLs what is left. It runs in a process group of its own, so Ctrl-C or a signal to the launcher's
// group does not reach it. Safe to start from a multi-threaded process (the child only makes
// async-signal-safe calls).
class TeardownWatchdog {
 public:
  explicit TeardownWatchdog(std::chrono::duration<double> shutdown_timeout);
  ~TeardownWatchdog();  // disarms: the launcher ended normally and has reaped what it started
  TeardownWatchdog(const TeardownWatchdog&) = delete;
  TeardownWatchdog& operator=(const TeardownWatchdog&) = delete;
  void track(pid_t process_group);
  void forget(pid_t process_group);
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int pipe_ = -1;
};

// Blocks SIGCHLD, SIGINT and SIGTERM for the calling thread and every thread it creates afterwards, so that
// Supervisor::run can wait for them synchronously. Call first thing in main().
void blockSupervisorSignals();

}  // namespace ddsnav::launch
