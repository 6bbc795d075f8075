// Runs one benchmark run in a forked child with a hard deadline, so a planner that ignores its time limit
// (OMPL 1.5.2's SST can loop forever in selectNode) or aborts (Debian's OMPL keeps its assertions on)
// costs one failed run instead of the whole grid.
#include "bench_run.hpp"

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

namespace ddsnav::bench {

namespace {

nlohmann::json toJson(const RunRecord& r) {
  return {{"scenario", r.scenario},       {"planner", r.planner},
          {"seed", r.seed},               {"solved", r.solved},
          {"exact", r.exact},             {"kinodynamic", r.kinodynamic},
          {"valid", r.valid},             {"invalid_reason", r.invalid_reason},
          {"time_s", r.time_s},           {"time_to_first_s", r.time_to_first_s},
          {"iterations", r.iterations},   {"iterations_to_first", r.iterations_to_first},
          {"vertices", r.vertices},       {"cost", r.cost},
          {"pous", r.pous},               {"por", r.por},
          {"coverage", r.coverage},       {"growth", r.growth},
          {"validity_checks", r.validity_checks}, {"fdc", r.fdc},
          {"fgc", r.fgc}};
}

RunRecord fromJson(const nlohmann::json& j) {
  RunRecord r;
  r.scenario = j.at("scenario");
  r.planner = j.at("planner");
  r.seed = j.at("seed");
  r.solved = j.at("solved");
  r.exact = j.at("exact");
  r.kinodynamic = j.at("kinodynamic");
  r.valid = j.at("valid");
  r.invalid_reason = j.at("invalid_reason");
  r.time_s = j.at("time_s");
  r.time_to_first_s = j.at("time_to_first_s");
  r.iterations = j.at("iterations");
  r.iterations_to_first = j.at("iterations_to_first");
  r.vertices = j.at("vertices");
  r.cost = j.at("cost");
  r.pous = j.at("pous");
  r.por = j.at("por");
  r.coverage = j.at("coverage");
  r.growth = j.at("growth");
  r.validity_checks = j.at("validity_checks");
  r.fdc = j.at("fdc");
  r.fgc = j.at("fgc");
  return r;
}

RunRecord failed(RunRecord identity, const std::string& why) {
  spdlog::warn("{} on {} seed {}: {}", identity.planner, identity.scenario, identity.seed, why);
  identity.solved = false;
  identity.valid = false;
  identity.invalid_reason = why;
  return identity;
}

}  // namespace

RunRecord runIsolated(const std::function<RunRecord()>& run, double time_limit_s, const RunRecord& identity,
                      double slack_s) {
  // Room for the planner's own overrun past its limit, the path check and the reply.
  const double deadline_s = 2.0 * time_limit_s + slack_s;
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error(std::string("runIsolated: pipe: ") + std::strerror(errno));
  const pid_t child = fork();
  if (child < 0) {
    close(fds[0]);
    close(fds[1]);
    throw std::runtime_error(std::string("runIsolated: fork: ") + std::strerror(errno));
  }
  if (child == 0) {
    close(fds[0]);
    std::string out;
    try {
      out = toJson(run()).dump();
    } catch (const std::exception& e) {
      out = toJson(failed(identity, e.what())).dump();
    }
    const char* p = out.data();
    std::size_t left = out.size();
    while (left > 0) {
      const ssize_t n = write(fds[1], p, left);
      if (n <= 0) _exit(3);
      p += n;
      left -= static_cast<std::size_t>(n);
    }
    _exit(0);  // no destructors or atexit handlers of the parent's objects in the child
  }

  close(fds[1]);
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(deadline_s);
  bool timed_out = false;
  char buffer[65536];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    pollfd pfd{fds[0], POLLIN, 0};
    const int ready = poll(&pfd, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    const ssize_t n = read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // EOF: the child is done (or died)
    text.append(buffer, static_cast<std::size_t>(n));
  }
  close(fds[0]);
  if (timed_out) kill(child, SIGKILL);
  int status = 0;
  while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }

  char why[160];
  if (timed_out) {
    std::snprintf(why, sizeof why, "did not stop within %.1f s of its %.1f s time limit: killed", deadline_s,
                  time_limit_s);
    return failed(identity, why);
  }
  if (WIFSIGNALED(status)) {
    std::snprintf(why, sizeof why, "crashed: signal %d (%s)", WTERMSIG(status), strsignal(WTERMSIG(status)));
    return failed(identity, why);
  }
  try {
    return fromJson(nlohmann::json::parse(text));
  } catch (const std::exception& e) {
    std::snprintf(why, sizeof why, "no result from the run (exit status %d): %s",
                  WIFEXITED(status) ? WEXITSTATUS(status) : -1, e.what());
    return failed(identity, why);
  }
}

}  // namespace ddsnav::bench
