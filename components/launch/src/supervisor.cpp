#include "ddsnav/launch/supervisor.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <map>
#include <vector>

namespace ddsnav::launch {
namespace {

using Clock = std::chrono::steady_clock;

sigset_t supervisorSignals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGCHLD);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

std::string describeStatus(int status) {
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return std::string("killed by signal ") + strsignal(WTERMSIG(status));
  return "ended";
}

int exitCodeOf(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

}  // namespace

pid_t spawnComponent(const ProcessSpec& spec, const SpawnOptions& options) {
  std::string program = spec.command;
  if (program.find('/') == std::string::npos && ::access((options.bin_dir + "/" + program).c_str(), X_OK) == 0)
    program = options.bin_dir + "/" + program;
  std::vector<std::string> argv_strings{program};
  argv_strings.insert(argv_strings.end(), spec.args.begin(), spec.args.end());
  for (const auto& [key, value] : spec.params) {
    argv_strings.push_back("--param");
    argv_strings.push_back(key + "=" + value);
  }
  // Everything the child needs is prepared before fork: after it, only async-signal-safe calls.
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  const std::string dds = spec.dds.value_or(options.dds);
  const std::string domain = std::to_string(options.domain);
  const pid_t parent = ::getpid();
  const sigset_t signals = supervisorSignals();

  const pid_t pid = ::fork();
  if (pid != 0) {
    if (pid > 0) ::setpgid(pid, pid);  // also from the parent, so the group exists before we signal it
    return pid;
  }
  ::setpgid(0, 0);
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  if (::getppid() != parent) ::_exit(127);  // the parent died between fork and prctl
  pthread_sigmask(SIG_UNBLOCK, &signals, nullptr);
  if (!options.output_file.empty()) {
    const int fd = ::open(options.output_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
  }
  ::setenv("DDSNAV_DDS", dds.c_str(), 1);
  ::setenv("DDSNAV_DOMAIN", domain.c_str(), 1);
  ::setenv("DDSNAV_COMPONENT_NAME", spec.name.c_str(), 1);
  ::execvp(argv[0], argv.data());
  std::fprintf(stderr, "[launch] cannot run '%s' for process '%s': %s\n", argv[0], spec.name.c_str(), std::strerror(errno));
  ::_exit(127);
}

void blockSupervisorSignals() {
  const sigset_t set = supervisorSignals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
}

struct Supervisor::Impl {
  struct Running {
    const ProcessSpec* spec = nullptr;
    pid_t pid = -1;
    int restarts = 0;
    bool ended = false;
    int last_status = 0;
  };

  LaunchConfig config;
  SupervisorOptions options;
  ReadinessSource& readiness;
  std::vector<Running> running;  // same order as config.processes
  bool stop_requested = false;  // SIGINT/SIGTERM arrived
  bool tearing_down = false;    // exits from now on are expected, not failures
  int final_status = 0;

  Impl(LaunchConfig c, SupervisorOptions o, ReadinessSource& r) : config(std::move(c)), options(std::move(o)), readiness(r) {
    if (!options.log) options.log = [](const std::string& line) { std::cerr << line << std::endl; };
    running.resize(config.processes.size());
    for (size_t i = 0; i < running.size(); ++i) running[i].spec = &config.processes[i];
  }

  void log(const std::string& line) const { options.log("[launch " + config.name + "] " + line); }

  pid_t spawn(const ProcessSpec& spec) {
    const pid_t pid = spawnComponent(spec, {options.bin_dir, options.domain, options.dds, ""});
    if (pid < 0) {
      log("cannot fork for '" + spec.name + "': " + std::strerror(errno));
      return -1;
    }
    log("started " + spec.name + " (pid " + std::to_string(pid) + ", " + spec.dds.value_or(options.dds) + ")");
    return pid;
  }

  Running* findByPid(pid_t pid) {
    for (auto& r : running)
      if (r.pid == pid && !r.ended) return &r;
    return nullptr;
  }

  // Reaps every child that has ended; returns false when a required process ended or a restart failed.
  bool reapChildren() {
    bool keep_running = true;
    for (;;) {
      int status = 0;
      const pid_t pid = ::waitpid(-1, &status, WNOHANG);
      if (pid <= 0) break;
      Running* r = findByPid(pid);
      if (!r) continue;
      r->ended = true;
      r->last_status = status;
      const bool failed = !(WIFEXITED(status) && WEXITSTATUS(status) == 0);
      log(r->spec->name + " (pid " + std::to_string(pid) + ") " + describeStatus(status));
      if (stop_requested || tearing_down) continue;
      if (r->spec->required) {
        final_status = exitCodeOf(status);
        log(r->spec->name + " is required: tearing down");
        keep_running = false;
        continue;
      }
      const bool wants_restart = r->spec->restart == RestartPolicy::Always ||
                                 (r->spec->restart == RestartPolicy::OnFailure && failed);
      if (!wants_restart) {
        if (failed) final_status = final_status ? final_status : exitCodeOf(status);
        continue;
      }
      if (r->restarts >= r->spec->max_restarts) {
        log(r->spec->name + " reached max_restarts (" + std::to_string(r->spec->max_restarts) + "): tearing down");
        final_status = exitCodeOf(status) ? exitCodeOf(status) : 1;
        keep_running = false;
        continue;
      }
      ++r->restarts;
      log("restarting " + r->spec->name + " (" + std::to_string(r->restarts) + "/" + std::to_string(r->spec->max_restarts) + ")");
      r->pid = spawn(*r->spec);
      r->ended = r->pid < 0;
      if (r->pid < 0) keep_running = false;
    }
    return keep_running;
  }

  // Handles pending signals without blocking; returns false on SIGINT/SIGTERM.
  bool pollSignals(std::chrono::milliseconds wait) {
    const sigset_t set = supervisorSignals();
    timespec timeout{static_cast<time_t>(wait.count() / 1000), static_cast<long>((wait.count() % 1000) * 1000000)};
    const int sig = ::sigtimedwait(&set, nullptr, &timeout);
    if (sig == SIGINT || sig == SIGTERM) {
      log(std::string("received ") + strsignal(sig) + ": tearing down");
      stop_requested = true;
      return false;
    }
    return true;
  }

  bool allEnded() const {
    for (const auto& r : running)
      if (r.pid > 0 && !r.ended) return false;
    return true;
  }

  bool startAll() {
    for (auto& r : running) {
      for (const auto& dep : r.spec->after) {
        for (const auto& other : running)
          if (other.spec->name == dep && (other.pid <= 0 || other.ended)) {
            log("cannot start " + r.spec->name + ": '" + dep + "' is not running");
            final_status = 1;
            return false;
          }
      }
      r.pid = spawn(*r.spec);
      if (r.pid < 0) {
        final_status = 1;
        return false;
      }
      if (!r.spec->wait_ready) continue;
      const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                               std::chrono::duration<double>(r.spec->ready_timeout_s));
      // Wait in short slices so that a crash of the starting process or a Ctrl-C ends the wait at once.
      bool ready = false;
      while (!ready && Clock::now() < deadline) {
        ready = readiness.waitUntilReady(r.spec->name, r.pid, std::min(deadline, Clock::now() + std::chrono::milliseconds(100)));
        if (!pollSignals(std::chrono::milliseconds(0))) return false;
        if (!reapChildren()) return false;
        if (r.ended) {
          log("'" + r.spec->name + "' ended before it reported ready");
          final_status = final_status ? final_status : 1;
          return false;
        }
      }
      if (!ready) {
        log("'" + r.spec->name + "' did not report ready within " + std::to_string(r.spec->ready_timeout_s) + " s");
        final_status = 1;
        return false;
      }
      log(r.spec->name + " is ready");
    }
    return true;
  }

  void teardown() {
    tearing_down = true;
    // Reverse start order: consumers go before their producers, so nobody logs a lost peer needlessly.
    for (auto it = running.rbegin(); it != running.rend(); ++it)
      if (it->pid > 0 && !it->ended) ::kill(-it->pid, SIGTERM);
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(config.shutdown_timeout_s));
    while (!allEnded() && Clock::now() < deadline) {
      pollSignals(std::chrono::milliseconds(20));
      reapChildren();
    }
    for (auto& r : running) {
      if (r.pid > 0 && !r.ended) {
        log(r.spec->name + " did not stop within " + std::to_string(config.shutdown_timeout_s) + " s: SIGKILL");
        ::kill(-r.pid, SIGKILL);
        int status = 0;
        ::waitpid(r.pid, &status, 0);
        r.ended = true;
      }
    }
  }

  int run() {
    if (startAll()) {
      log("all " + std::to_string(running.size()) + " processes started");
      for (;;) {
        if (!pollSignals(std::chrono::milliseconds(200))) break;
        if (!reapChildren()) break;
        if (allEnded()) break;
      }
    }
    teardown();
    if (stop_requested && final_status == 0) return 0;
    return final_status;
  }
};

Supervisor::Supervisor(LaunchConfig config, SupervisorOptions options, ReadinessSource& readiness)
    : impl_(new Impl(std::move(config), std::move(options), readiness)) {}

Supervisor::~Supervisor() { delete impl_; }

int Supervisor::run() { return impl_->run(); }

}  // namespace ddsnav::launch
