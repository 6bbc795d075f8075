#include "ddsnav/launch/supervisor.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
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

std::string seconds(double s) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.1f", s);
  return buffer;
}

Clock::duration toDuration(double s) {
  // Every duration entering here was bounded by the launch-file reader; the clamp only guards callers
  // that build a LaunchConfig in code.
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::clamp(s, 0.0, 86400.0 * 365)));
}

bool groupExists(pid_t group) { return group > 0 && (::kill(-group, 0) == 0 || errno == EPERM); }

int exitCodeOf(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

}  // namespace

std::string resolveCommand(const std::string& command, const std::string& bin_dir) {
  if (command.empty()) throw LaunchError("the command is empty");
  auto check = [&](const std::string& path) -> std::string {  // "" when usable, else why not
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return std::strerror(errno);
    if (S_ISDIR(st.st_mode)) return "is a directory";
    if (!S_ISREG(st.st_mode)) return "is not a regular file";
    if (::access(path.c_str(), X_OK) != 0) return "is not executable";
    return "";
  };
  if (command.find('/') != std::string::npos) {
    const auto why = check(command);
    if (!why.empty()) throw LaunchError("command '" + command + "' " + (why.rfind("is ", 0) == 0 ? why : "cannot be run: " + why));
    return command;
  }
  std::vector<std::string> dirs;
  if (!bin_dir.empty()) dirs.push_back(bin_dir);
  const char* path_env = std::getenv("PATH");
  std::stringstream path_list(path_env ? path_env : "/usr/local/bin:/usr/bin:/bin");
  for (std::string dir; std::getline(path_list, dir, ':');) dirs.push_back(dir.empty() ? "." : dir);
  std::string first_problem;
  for (const auto& dir : dirs) {
    const std::string candidate = dir + "/" + command;
    const auto why = check(candidate);
    if (why.empty()) return candidate;
    if (first_problem.empty() && why.rfind("is ", 0) == 0) first_problem = "'" + candidate + "' " + why;
  }
  throw LaunchError("command '" + command + "' not found beside ddsnav (" + bin_dir + ") or on PATH" +
                    (first_problem.empty() ? "" : " (" + first_problem + ")"));
}

pid_t spawnComponent(const ProcessSpec& spec, const SpawnOptions& options) {
  std::string program = spec.command;
  try {
    program = resolveCommand(spec.command, options.bin_dir);
  } catch (const LaunchError&) {
    // Left to execvp, whose failure the child reports (exit 127): callers that care resolve first.
  }
  std::vector<std::string> argv_strings{program};
  argv_strings.insert(argv_strings.end(), spec.args.begin(), spec.args.end());
  const auto addNames = [&](const std::map<std::string, std::string>& params, const std::string& ns,
                            const std::map<std::string, std::string>& remap) {
    for (const auto& [key, value] : params) {
      argv_strings.push_back("--param");
      argv_strings.push_back(key + "=" + value);
    }
    if (!ns.empty()) argv_strings.insert(argv_strings.end(), {"--namespace", ns});
    for (const auto& [from, to] : remap) argv_strings.insert(argv_strings.end(), {"--remap", from + "=" + to});
  };
  addNames(spec.params, spec.ns, spec.remap);
  // A container: one "-- KIND --name NAME ..." segment per component (runtime::runContainer).
  for (const auto& c : spec.components) {
    argv_strings.insert(argv_strings.end(), {"--", c.component, "--name", c.name});
    argv_strings.insert(argv_strings.end(), c.args.begin(), c.args.end());
    addNames(c.params, c.ns, c.remap);
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

// ---- TeardownWatchdog ---------------------------------------------------------------------------
//
// Protocol on the pipe: one int32 per message; +g tracks process group g, -g forgets it, 0 disarms.
// The child only calls async-signal-safe functions (read, kill, clock_gettime, nanosleep, close, _exit)
// and touches no memory it would have to allocate: the table is allocated before fork.
namespace {

constexpr std::size_t kWatchdogGroups = 4096;

void watchdogMain(int fd, double timeout_s, pid_t* groups) {
  ::setpgid(0, 0);  // out of the launcher's group: a Ctrl-C or `kill -- -PGID` meant for it must not stop us
  std::size_t count = 0;
  for (;;) {
    std::int32_t message = 0;
    const ssize_t n = ::read(fd, &message, sizeof(message));
    if (n < 0 && errno == EINTR) continue;
    if (n != static_cast<ssize_t>(sizeof(message))) break;  // EOF: the launcher is gone without disarming us
    if (message == 0) ::_exit(0);
    if (message > 0) {
      if (count < kWatchdogGroups) groups[count++] = message;
    } else {
      for (std::size_t i = 0; i < count; ++i)
        if (groups[i] == -message) groups[i] = groups[--count];
    }
  }
  for (std::size_t i = 0; i < count; ++i) {
    ::kill(-groups[i], SIGTERM);
    ::kill(-groups[i], SIGCONT);  // a stopped member would otherwise never see the SIGTERM
  }
  timespec start{};
  ::clock_gettime(CLOCK_MONOTONIC, &start);
  for (;;) {
    bool any = false;
    for (std::size_t i = 0; i < count; ++i) any = any || ::kill(-groups[i], 0) == 0;
    if (!any) ::_exit(0);
    timespec now{};
    ::clock_gettime(CLOCK_MONOTONIC, &now);
    if (static_cast<double>(now.tv_sec - start.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec - start.tv_nsec) > timeout_s) break;
    const timespec tick{0, 20'000'000};
    ::nanosleep(&tick, nullptr);
  }
  for (std::size_t i = 0; i < count; ++i) ::kill(-groups[i], SIGKILL);
  ::_exit(0);
}

}  // namespace

TeardownWatchdog::TeardownWatchdog(std::chrono::duration<double> shutdown_timeout) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return;  // no watchdog: PDEATHSIG still ends the direct children
  auto* groups = new pid_t[kWatchdogGroups];  // for the child; the parent frees its copy below
  const double timeout_s = shutdown_timeout.count();
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[1]);
    // Hold nothing of the launcher's (sockets, files) beyond our pipe.
    for (int fd = 3; fd < 1024; ++fd)
      if (fd != fds[0]) ::close(fd);
    watchdogMain(fds[0], timeout_s, groups);
  }
  delete[] groups;
  ::close(fds[0]);
  if (pid < 0) {
    ::close(fds[1]);
    return;
  }
  pid_ = pid;
  pipe_ = fds[1];
}

TeardownWatchdog::~TeardownWatchdog() {
  if (pipe_ < 0) return;
  const std::int32_t disarm = 0;
  [[maybe_unused]] const ssize_t n = ::write(pipe_, &disarm, sizeof(disarm));
  ::close(pipe_);
  int status = 0;
  ::waitpid(pid_, &status, 0);
}

void TeardownWatchdog::track(pid_t process_group) {
  const std::int32_t message = process_group;
  if (pipe_ >= 0 && process_group > 0) [[maybe_unused]] const ssize_t n = ::write(pipe_, &message, sizeof(message));
}

void TeardownWatchdog::forget(pid_t process_group) {
  const std::int32_t message = -process_group;
  if (pipe_ >= 0 && process_group > 0) [[maybe_unused]] const ssize_t n = ::write(pipe_, &message, sizeof(message));
}

// ---- Supervisor ---------------------------------------------------------------------------------

struct Supervisor::Impl {
  struct Running {
    const ProcessSpec* spec = nullptr;
    pid_t pid = -1;
    bool ended = false;
    int last_status = 0;
    Clock::time_point started_at{};
    bool watched = false;                     // liveness applies (it was ready once, or is a restart)
    std::string kill_reason;                  // set when the supervisor killed it for silence
    std::deque<Clock::time_point> restarts;   // restarts within the current restart_window_s
    std::optional<Clock::time_point> restart_due;
  };

  LaunchConfig config;
  SupervisorOptions options;
  ReadinessSource& readiness;
  std::vector<Running> running;  // same order as config.processes
  std::set<pid_t> groups;        // process groups created and possibly not empty yet
  std::unique_ptr<TeardownWatchdog> watchdog;
  bool stop_requested = false;  // SIGINT/SIGTERM arrived
  bool tearing_down = false;    // exits from now on are expected, not failures
  int final_status = 0;

  Impl(LaunchConfig c, SupervisorOptions o, ReadinessSource& r) : config(std::move(c)), options(std::move(o)), readiness(r) {
    if (!options.log) options.log = [](const std::string& line) { std::cerr << line << std::endl; };
    running.resize(config.processes.size());
    for (size_t i = 0; i < running.size(); ++i) running[i].spec = &config.processes[i];
  }

  void log(const std::string& line) const { options.log("[launch " + config.name + "] " + line); }

  void announce(const Running& r, pid_t pid, bool restarting, const std::string& detail) const {
    if (options.on_event) options.on_event({r.spec->name, pid, restarting, detail});
  }

  pid_t spawn(Running& r) {
    const ProcessSpec& spec = *r.spec;
    const pid_t pid = spawnComponent(spec, {options.bin_dir, options.domain, options.dds, ""});
    if (pid < 0) {
      log("cannot fork for '" + spec.name + "': " + std::strerror(errno));
      return -1;
    }
    groups.insert(pid);
    if (watchdog) watchdog->track(pid);
    r.pid = pid;
    r.ended = false;
    r.kill_reason.clear();
    r.started_at = Clock::now();
    log("started " + spec.name + " (pid " + std::to_string(pid) + ", " + spec.dds.value_or(options.dds) + ")");
    return pid;
  }

  Running* findByPid(pid_t pid) {
    for (auto& r : running)
      if (r.pid == pid && !r.ended) return &r;
    return nullptr;
  }

  // Groups whose last member has been reaped are dropped (and the watchdog told), so a pid reused
  // later by an unrelated process group is never signalled.
  void forgetEmptyGroups() {
    for (auto it = groups.begin(); it != groups.end();) {
      if (groupExists(*it)) {
        ++it;
        continue;
      }
      if (watchdog) watchdog->forget(*it);
      it = groups.erase(it);
    }
  }

  // Decides what happens after R ended unexpectedly; returns false when the set must be torn down.
  bool applyRestartPolicy(Running& r, int status, const std::string& why) {
    const ProcessSpec& spec = *r.spec;
    const bool failed = !(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    if (spec.required) {
      // Several required processes (one monitor per vehicle): the set ends when the last one has ended
      // cleanly, or at once when one fails.
      if (!failed)
        for (const auto& other : running)
          if (&other != &r && !other.ended && other.spec->required) {
            log(spec.name + " (required) ended cleanly; waiting for the other required processes");
            return true;
          }
      final_status = exitCodeOf(status);
      log(spec.name + " is required: tearing down");
      if (failed) announce(r, r.pid, false, why + "; required: tearing the set down");
      return false;
    }
    const bool wants_restart = spec.restart == RestartPolicy::Always || (spec.restart == RestartPolicy::OnFailure && failed);
    if (!wants_restart) {
      if (failed) {
        final_status = final_status ? final_status : exitCodeOf(status);
        announce(r, r.pid, false, why + "; restart: " + toString(spec.restart) + ", not restarted");
      }
      return true;
    }
    const auto now = Clock::now();
    while (!r.restarts.empty() && now - r.restarts.front() > toDuration(spec.restart_window_s)) r.restarts.pop_front();
    if (static_cast<int>(r.restarts.size()) >= spec.max_restarts) {
      const std::string budget = "reached max_restarts (" + std::to_string(spec.max_restarts) + " within restart_window_s " +
                                 seconds(spec.restart_window_s) + " s)";
      log(spec.name + " " + budget + ": tearing down");
      announce(r, r.pid, false, why + "; " + budget + ": tearing the set down");
      final_status = exitCodeOf(status) ? exitCodeOf(status) : 1;
      return false;
    }
    // Exponential backoff over the restarts of this window: delay, 2 delay, 4 delay, ... up to the cap.
    const double delay_s = std::min(spec.max_restart_delay_s,
                                    spec.restart_delay_s * std::ldexp(1.0, static_cast<int>(std::min<std::size_t>(r.restarts.size(), 60))));
    r.restarts.push_back(now);
    r.restart_due = now + toDuration(delay_s);
    const std::string plan = "restart " + std::to_string(r.restarts.size()) + "/" + std::to_string(spec.max_restarts) + " in " +
                             seconds(delay_s) + " s";
    log("restarting " + spec.name + " (" + std::to_string(r.restarts.size()) + "/" + std::to_string(spec.max_restarts) + ") in " +
        seconds(delay_s) + " s");
    announce(r, r.pid, true, why + "; " + plan);
    return true;
  }

  // Reaps every child that has ended (grandchildren too: the launcher is their subreaper); returns false
  // when a required process ended or the restart budget ran out.
  bool reapChildren() {
    bool keep_running = true;
    for (;;) {
      int status = 0;
      const pid_t pid = ::waitpid(-1, &status, WNOHANG);
      if (pid <= 0) break;
      Running* r = findByPid(pid);
      if (!r) continue;  // an orphaned grandchild, or a watchdog
      r->ended = true;
      r->last_status = status;
      const std::string why = r->spec->name + " (pid " + std::to_string(pid) + ") " +
                              (r->kill_reason.empty() ? describeStatus(status) : "was killed: " + r->kill_reason);
      log(why);
      if (stop_requested || tearing_down) continue;
      // Whatever it left in its group (a shell's children) goes with it, so a restart never doubles them.
      if (groupExists(pid)) ::kill(-pid, SIGKILL);
      if (!applyRestartPolicy(*r, status, why)) keep_running = false;
    }
    forgetEmptyGroups();
    return keep_running;
  }

  bool startDueRestarts() {
    const auto now = Clock::now();
    for (auto& r : running) {
      if (!r.restart_due || now < *r.restart_due) continue;
      r.restart_due.reset();
      if (spawn(r) < 0) {
        final_status = final_status ? final_status : 1;
        return false;
      }
      r.watched = r.spec->wait_ready;
    }
    return true;
  }

  // A watched process silent for its liveness_timeout_s (or a restarted one that never spoke within
  // ready_timeout_s) is killed; the reaper then applies its restart policy.
  void checkLiveness() {
    if (!readiness.reportsLiveness()) return;
    const auto now = Clock::now();
    for (auto& r : running) {
      if (!r.watched || r.pid <= 0 || r.ended || !r.kill_reason.empty()) continue;
      // A container is as alive as its quietest component.
      std::optional<Clock::time_point> heard;
      bool all_heard = true;
      for (const auto& name : r.spec->reportingNames()) {
        const auto h = readiness.lastHeard(name, r.pid);
        if (!h) all_heard = false;
        else if (!heard || *h < *heard) heard = h;
      }
      if (!all_heard) heard.reset();
      const auto deadline = heard ? std::max(*heard, r.started_at) + toDuration(r.spec->liveness_timeout_s)
                                  : r.started_at + toDuration(r.spec->ready_timeout_s);
      if (now <= deadline) continue;
      const double silent_s = std::chrono::duration<double>(now - (heard ? std::max(*heard, r.started_at) : r.started_at)).count();
      r.kill_reason = heard ? "silent on system/status for " + seconds(silent_s) + " s (liveness_timeout_s " +
                                  seconds(r.spec->liveness_timeout_s) + ")"
                            : "no status on system/status within ready_timeout_s " + seconds(r.spec->ready_timeout_s) + " s";
      log(r.spec->name + " (pid " + std::to_string(r.pid) + ") " + r.kill_reason + ": killing it");
      ::kill(-r.pid, SIGKILL);  // a silent process (stopped, hung) cannot be trusted to shut down
    }
  }

  // Handles pending signals, waiting up to `wait`; returns false on SIGINT/SIGTERM.
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

  // One supervision step while running or starting: signals, exits, silence, due restarts.
  bool step(std::chrono::milliseconds wait) {
    if (!pollSignals(wait)) return false;
    if (!reapChildren()) return false;
    checkLiveness();
    return startDueRestarts();
  }

  bool allEnded() const {
    for (const auto& r : running)
      if ((r.pid > 0 && !r.ended) || r.restart_due) return false;
    return true;
  }

  bool startAll() {
    // Every command is checked before anything starts: a typo or a directory fails the launch at once.
    for (auto& r : running) {
      try {
        resolveCommand(r.spec->command, options.bin_dir);
      } catch (const LaunchError& e) {
        log("cannot start " + r.spec->name + ": " + e.what());
        final_status = 1;
        return false;
      }
    }
    for (auto& r : running) {
      for (const auto& dep : r.spec->after) {
        for (const auto& other : running)
          if (other.spec->name == dep && (other.pid <= 0 || other.ended) && !other.restart_due) {
            log("cannot start " + r.spec->name + ": '" + dep + "' is not running");
            final_status = 1;
            return false;
          }
      }
      if (spawn(r) < 0) {
        final_status = 1;
        return false;
      }
      if (!r.spec->wait_ready) continue;
      auto deadline = Clock::now() + toDuration(r.spec->ready_timeout_s);
      // Wait in short slices so that a crash of the starting process or a Ctrl-C ends the wait at once.
      // One that fails while starting is handled by its restart policy like any other failure; each new
      // instance gets its own ready_timeout_s.
      bool ready = false;
      pid_t pid = r.pid;
      while (!ready && Clock::now() < deadline) {
        if (r.ended) {  // waiting out a restart's backoff
          if (!step(std::chrono::milliseconds(50))) return false;
        } else {
          ready = true;  // a container: every component, with the container's pid
          for (const auto& name : r.spec->reportingNames())
            ready = ready && readiness.waitUntilReady(name, pid, std::min(deadline, Clock::now() + std::chrono::milliseconds(100)));
          if (!step(std::chrono::milliseconds(0))) return false;
        }
        if (r.ended && !r.restart_due) {
          log("'" + r.spec->name + "' ended before it reported ready");
          if (!r.spec->required) final_status = final_status ? final_status : 1;  // a required process's own status is ours
          return false;
        }
        if (r.restart_due) deadline = std::max(deadline, *r.restart_due + toDuration(r.spec->ready_timeout_s));
        if (!r.ended && r.pid != pid) {
          pid = r.pid;
          ready = false;
          deadline = Clock::now() + toDuration(r.spec->ready_timeout_s);
        }
      }
      if (!ready) {
        log("'" + r.spec->name + "' did not report ready within " + seconds(r.spec->ready_timeout_s) + " s (ready_timeout_s)");
        final_status = 1;
        return false;
      }
      r.watched = true;
      log(r.spec->name + " is ready");
    }
    return true;
  }

  // SIGTERM once to every group still alive (SIGCONT too, or a stopped member never sees it), wait
  // up to shutdown_timeout_s for the groups to empty, then SIGKILL the rest.
  void teardown() {
    tearing_down = true;
    for (auto& r : running) r.restart_due.reset();
    forgetEmptyGroups();
    // Reverse start order: consumers go before their producers, so nobody logs a lost peer needlessly.
    std::vector<pid_t> order;
    for (auto it = running.rbegin(); it != running.rend(); ++it)
      if (it->pid > 0 && groups.count(it->pid)) order.push_back(it->pid);
    for (pid_t g : groups)
      if (std::find(order.begin(), order.end(), g) == order.end()) order.push_back(g);
    for (pid_t g : order) {
      ::kill(-g, SIGTERM);
      ::kill(-g, SIGCONT);
    }
    const auto deadline = Clock::now() + toDuration(config.shutdown_timeout_s);
    while (!groups.empty() && Clock::now() < deadline) {
      pollSignals(std::chrono::milliseconds(20));
      reapChildren();
    }
    for (auto& r : running)
      if (r.pid > 0 && !r.ended && groups.count(r.pid))
        log(r.spec->name + " did not stop within " + seconds(config.shutdown_timeout_s) + " s (shutdown_timeout_s): SIGKILL");
    for (pid_t g : groups) ::kill(-g, SIGKILL);
    // SIGKILL is not ignorable; the members end promptly and are reaped here (we are their subreaper).
    const auto reap_deadline = Clock::now() + std::chrono::seconds(2);
    while (!groups.empty() && Clock::now() < reap_deadline) {
      pollSignals(std::chrono::milliseconds(10));
      reapChildren();
    }
    for (auto& r : running) r.ended = true;
  }

  int run() {
    // Orphaned grandchildren (a shell's `sleep` after the shell died) become our children, so teardown
    // can reap them and a process group never outlives the set unnoticed.
    ::prctl(PR_SET_CHILD_SUBREAPER, 1);
    if (options.watchdog) watchdog = std::make_unique<TeardownWatchdog>(std::chrono::duration<double>(config.shutdown_timeout_s));
    if (startAll()) {
      log("all " + std::to_string(running.size()) + " processes started");
      for (;;) {
        if (!step(std::chrono::milliseconds(100))) break;
        if (allEnded()) break;
      }
    }
    teardown();
    watchdog.reset();  // disarm: everything it knew about is gone
    if (stop_requested && final_status == 0) return 0;
    return final_status;
  }
};

Supervisor::Supervisor(LaunchConfig config, SupervisorOptions options, ReadinessSource& readiness)
    : impl_(new Impl(std::move(config), std::move(options), readiness)) {}

Supervisor::~Supervisor() { delete impl_; }

int Supervisor::run() { return impl_->run(); }

}  // namespace ddsnav::launch
