#pragma once
// Starts a LaunchConfig's processes in dependency order, each only once the ones it waits for report
// ready, restarts them by policy, and tears the whole set down (SIGTERM, then SIGKILL after the bound)
// so that no process it started outlives it.

#include "ddsnav/launch/launch_config.hpp"

#include <chrono>
#include <functional>
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
};

struct SupervisorOptions {
  std::string bin_dir;      // where "ddsnav-*" commands are looked up
  int domain = 0;
  std::string dds = "fastdds";
  std::function<void(const std::string&)> log;  // one line per event; defaults to stderr
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
// signalled together), dying with its parent (PR_SET_PDEATHSIG, so nothing is orphaned even when the
// parent is SIGKILLed), with DDSNAV_DDS / DDSNAV_DOMAIN / DDSNAV_COMPONENT_NAME set and params passed as
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

// Blocks SIGCHLD, SIGINT and SIGTERM for the calling thread and every thread it creates afterwards, so that
// Supervisor::run can wait for them synchronously. Call first thing in main().
void blockSupervisorSignals();

}  // namespace ddsnav::launch
