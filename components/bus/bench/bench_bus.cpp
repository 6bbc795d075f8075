// ddsnav-bench-bus: ping-pong round-trip time and one-way stream throughput between two processes, for
// 1 KB / 1 MB / 8 MB samples, over Fast DDS (shared memory and UDP), Cyclone DDS and across vendors,
// each through the ddsnav bus AND through the vendor's own API in the same run, so that the bus's cost
// is a ratio. The second process is this executable started again with --role pong.
//
//   ddsnav-bench-bus                                  # everything, 3 alternating repeats per case
//   ddsnav-bench-bus --pairs cyclone --sizes 1k --impls bus,native
//   ddsnav-bench-bus --impls bus,secure               # DDS Security's cost: the bus with and without it
#include "link.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <ddsnav/security/security.hpp>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

using namespace ddsnav::bench;
using Clock = std::chrono::steady_clock;  // CLOCK_MONOTONIC: comparable between processes on one host

namespace {

std::int64_t monoNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

// The credentials of the "secure" impl: made once per run, in a folder both processes read.
std::string& securityDir() {
  static std::string dir;
  return dir;
}

std::unique_ptr<Link> makeLink(const std::string& impl, const LinkOptions& o) {
  if (impl == "bus") return makeBusLink(o);
  if (impl == "secure") {
    LinkOptions secured = o;
    secured.security_dir = securityDir();
    return makeBusLink(secured);
  }
  return o.cyclone ? makeNativeCycloneLink(o) : makeNativeFastLink(o);
}

// ---- the second process -------------------------------------------------------------------------

int runPong(const std::string& impl, bool cyclone, bool shm, std::size_t size, int domain, long stream_count) {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  std::mutex m;
  std::condition_variable cv;
  long received = 0;
  std::int64_t bytes = 0, last_ns = 0;
  std::atomic<Link*> self{nullptr};
  LinkOptions o;
  o.cyclone = cyclone;
  o.shared_memory = shm;
  o.domain = domain;
  o.payload = size;
  o.pinger = false;
  o.on_receive = [&](int topic, std::int64_t seq, std::size_t payload) {
    if (topic == kPing) {
      if (Link* l = self.load()) while (!l->send(kPong, seq)) std::this_thread::yield();
      return;
    }
    std::lock_guard lock(m);
    ++received;
    bytes += static_cast<std::int64_t>(payload);
    last_ns = monoNs();
    cv.notify_all();
  };
  std::unique_ptr<Link> link = makeLink(impl, o);
  self = link.get();
  std::cout << "READY" << std::endl;
  {
    // The stream ends when every sample arrived, or 2 s after the last one (keep-last may drop some).
    std::unique_lock lock(m);
    cv.wait_for(lock, std::chrono::seconds(120), [&] { return received > 0; });
    while (received < stream_count) {
      long before = received;
      cv.wait_for(lock, std::chrono::seconds(2), [&] { return received >= stream_count; });
      if (received == before) break;
    }
    std::cout << "STREAM " << received << " " << bytes << " " << last_ns << std::endl;
  }
  int sig = 0;
  sigwait(&signals, &sig);
  self = nullptr;
  return 0;
}

// ---- the measuring process ----------------------------------------------------------------------

class Child {
 public:
  explicit Child(const std::vector<std::string>& args) {
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      std::vector<char*> argv;
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv("/proc/self/exe", argv.data());
      _exit(127);
    }
    close(fds[1]);
    fd_ = fds[0];
  }
  ~Child() {
    kill(pid_, SIGTERM);
    for (int i = 0; i < 500 && waitpid(pid_, nullptr, WNOHANG) == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (waitpid(pid_, nullptr, WNOHANG) == 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    close(fd_);
  }
  std::optional<std::string> line(std::chrono::milliseconds timeout) {
    auto deadline = Clock::now() + timeout;
    while (true) {
      if (auto nl = buf_.find('\n'); nl != std::string::npos) {
        std::string l = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        return l;
      }
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char c[256];
      ssize_t n = read(fd_, c, sizeof(c));
      if (n <= 0) return std::nullopt;
      buf_.append(c, static_cast<std::size_t>(n));
    }
  }

 private:
  pid_t pid_ = -1;
  int fd_ = -1;
  std::string buf_;
};

struct Pair {
  std::string name;
  bool ping_cyclone, pong_cyclone, shm;
};

struct Result {
  std::string pair, impl;
  std::size_t size = 0;
  double rtt_median_us = NAN, rtt_p99_us = NAN;
  int rtt_lost = 0;
  double stream_mb_s = NAN;
  double delivered = NAN;  // fraction of stream samples received
  std::string error;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  std::size_t i = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - 1;
  return v[std::min(i, v.size() - 1)];
}

struct Plan {
  int warmup, rounds;
  long stream;
};

Plan planFor(std::size_t size, double scale) {
  Plan p = size <= 64 * 1024 ? Plan{200, 2000, 20000} : size <= 2 * 1024 * 1024 ? Plan{20, 300, 400} : Plan{5, 50, 60};
  p.rounds = std::max(10, static_cast<int>(p.rounds * scale));
  p.stream = std::max(10L, static_cast<long>(static_cast<double>(p.stream) * scale));
  return p;
}

Result measure(const std::string& impl, const Pair& pair, std::size_t size, int domain, double scale) {
  Result r;
  r.pair = pair.name;
  r.impl = impl;
  r.size = size;
  const Plan plan = planFor(size, scale);
  Child child({"ddsnav-bench-bus", "--role", "pong", "--impls", impl, "--pong-cyclone", pair.pong_cyclone ? "1" : "0",
               "--shm", pair.shm ? "1" : "0", "--size", std::to_string(size), "--domain", std::to_string(domain),
               "--stream-count", std::to_string(plan.stream), "--security-dir", securityDir()});
  if (child.line(std::chrono::seconds(20)) != std::optional<std::string>("READY")) {
    r.error = "pong process did not start";
    return r;
  }
  // Like ddsperf: the next ping is sent from the callback that received the pong, so a round trip
  // is two deliveries and no extra thread wake-up.
  std::mutex m;
  std::condition_variable cv;
  const int total = plan.warmup + plan.rounds;
  std::vector<double> rtts;
  rtts.reserve(static_cast<std::size_t>(total));
  std::atomic<std::int64_t> expected{0};
  std::atomic<std::int64_t> sent_at{0};
  std::atomic<Link*> self{nullptr};
  LinkOptions o;
  o.cyclone = pair.ping_cyclone;
  o.shared_memory = pair.shm;
  o.domain = domain;
  o.payload = size;
  o.pinger = true;
  o.on_receive = [&](int, std::int64_t seq, std::size_t) {
    const std::int64_t now = monoNs();
    if (seq != expected.load()) return;  // a duplicate after a resend
    if (seq >= plan.warmup) rtts.push_back(static_cast<double>(now - sent_at.load()) * 1e-3);
    if (seq + 1 < total) {
      expected = seq + 1;
      sent_at = monoNs();
      if (Link* l = self.load()) while (!l->send(kPing, seq + 1)) std::this_thread::yield();
    } else {
      std::lock_guard lock(m);
      expected = total;
      cv.notify_all();
    }
  };
  std::unique_ptr<Link> link = makeLink(impl, o);
  self = link.get();
  auto deadline = Clock::now() + std::chrono::seconds(20);
  while (link->matchedReaders() < 2 && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  if (link->matchedReaders() < 2) {
    r.error = "no match";
    self = nullptr;
    return r;
  }
  sent_at = monoNs();
  link->send(kPing, 0);
  {
    // A ping sent before the pong side's writer matched us is answered into the void: resend the
    // awaited one when nothing moves for a while.
    std::unique_lock lock(m);
    std::int64_t seen = -1;
    while (expected.load() < total) {
      if (cv.wait_for(lock, std::chrono::seconds(3), [&] { return expected.load() >= total; })) break;
      std::int64_t now_expected = expected.load();
      if (now_expected == seen) {
        if (++r.rtt_lost > 5) {
          r.error = "pongs lost";
          break;
        }
        lock.unlock();
        sent_at = monoNs();
        link->send(kPing, now_expected);
        lock.lock();
      }
      seen = now_expected;
    }
  }
  self = nullptr;
  {
    std::lock_guard lock(m);
    r.rtt_median_us = percentile(rtts, 0.5);
    r.rtt_p99_us = percentile(rtts, 0.99);
  }

  const std::int64_t start_ns = monoNs();
  for (long i = 0; i < plan.stream; ++i)
    while (!link->send(kStream, i)) std::this_thread::sleep_for(std::chrono::microseconds(50));
  std::optional<std::string> line = child.line(std::chrono::seconds(150));
  long received = 0;
  std::int64_t bytes = 0, last_ns = 0;
  std::string tag;
  if (line && (std::istringstream(*line) >> tag >> received >> bytes >> last_ns) && tag == "STREAM" && received > 0) {
    r.stream_mb_s = static_cast<double>(bytes) / (static_cast<double>(last_ns - start_ns) * 1e-9) / 1e6;
    r.delivered = static_cast<double>(received) / static_cast<double>(plan.stream);
  } else if (r.error.empty()) {
    r.error = "no stream result";
  }
  return r;
}

std::string sizeName(std::size_t s) {
  if (s >= 1024 * 1024) return fmt::format("{} MB", s / (1024 * 1024));
  return fmt::format("{} KB", s / 1024);
}

std::size_t parseSize(const std::string& s) {
  std::size_t n = std::stoul(s);
  char unit = s.empty() ? ' ' : static_cast<char>(std::tolower(s.back()));
  if (unit == 'k') return n * 1024;
  if (unit == 'm') return n * 1024 * 1024;
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ddsnav bus benchmark: RTT and throughput, bus vs. native vendor APIs"};
  std::string role = "ping", json_path;
  std::vector<std::string> impls = {"bus", "native"};
  std::vector<std::string> pair_names = {"fast-shm", "fast-udp", "cyclone", "fast-cyclone", "cyclone-fast"};
  std::vector<std::string> size_names = {"1k", "1m", "8m"};
  int domain = 200;
  double scale = 1.0;
  int repeat = 3;
  bool pong_cyclone = false, shm = true;
  std::size_t size = 1024;
  long stream_count = 0;
  app.add_option("--impls", impls, "bus and/or native")->delimiter(',');
  app.add_option("--pairs", pair_names, "fast-shm fast-udp cyclone fast-cyclone cyclone-fast")->delimiter(',');
  app.add_option("--sizes", size_names, "payload sizes, e.g. 1k,1m,8m")->delimiter(',');
  app.add_option("--domain", domain, "first DDS domain id (one per case, counting up)");
  app.add_option("--scale", scale, "multiplies round and stream counts");
  app.add_option("--repeat", repeat, "runs per case, alternating API order; medians are reported")
      ->check(CLI::PositiveNumber);
  app.add_option("--json", json_path, "also write the results as JSON");
  app.add_option("--role", role)->group("");  // internal: the second process
  app.add_option("--pong-cyclone", pong_cyclone)->group("");
  app.add_option("--shm", shm)->group("");
  app.add_option("--size", size)->group("");
  app.add_option("--stream-count", stream_count)->group("");
  app.add_option("--security-dir", securityDir())->group("");
  CLI11_PARSE(app, argc, argv);
  for (const std::string& impl : impls)
    if (impl != "bus" && impl != "native" && impl != "secure") {
      std::cerr << "unknown impl '" << impl << "': expected bus, native or secure\n";
      return 2;
    }

  if (role == "pong") return runPong(impls.at(0), pong_cyclone, shm, size, domain, stream_count);
  // Authentication + access control + AES-GCM on everything (docs/security.md), one identity for both ends.
  std::filesystem::path credentials;
  if (std::find(impls.begin(), impls.end(), "secure") != impls.end()) {
    credentials = std::filesystem::temp_directory_path() / ("ddsnav_bench_security_" + std::to_string(getpid()));
    std::filesystem::remove_all(credentials);
    ddsnav::security::initDirectory(credentials.string(), {.grants = {{"bench-bus", {"bench/*", "system/status", "ddsnav_internal/*"},
                                                                       {"bench/*", "ddsnav_internal/*"}}}});
    securityDir() = credentials.string();
  }

  const std::map<std::string, Pair> known = {{"fast-shm", {"Fast SHM ↔ Fast SHM", false, false, true}},
                                             {"fast-udp", {"Fast UDP ↔ Fast UDP", false, false, false}},
                                             {"cyclone", {"Cyclone ↔ Cyclone", true, true, true}},
                                             {"fast-cyclone", {"Fast → Cyclone", false, true, true}},
                                             {"cyclone-fast", {"Cyclone → Fast", true, false, true}}};
  std::vector<Result> results;
  int case_domain = domain;
  std::cout << "| pair | API | size | RTT median µs | RTT p99 µs | stream MB/s | delivered |\n|---|---|---|---|---|---|---|\n";
  for (const std::string& sz : size_names) {
    for (const std::string& pn : pair_names) {
      auto it = known.find(pn);
      if (it == known.end()) {
        std::cerr << "unknown pair '" << pn << "'\n";
        return 2;
      }
      // Repeats alternate the order of the APIs so that load drifts on a shared machine hit both alike;
      // each figure reported is the median over the repeats.
      std::map<std::string, std::vector<Result>> runs;
      const bool impls_secure = std::find(impls.begin(), impls.end(), "secure") != impls.end();
      for (int rep = 0; rep < repeat; ++rep) {
        std::vector<std::string> order = impls;
        if (rep % 2 == 1) std::reverse(order.begin(), order.end());
        for (const std::string& impl : order) {
          runs[impl].push_back(measure(impl, it->second, parseSize(sz), case_domain, scale));
          // Secured participants live on 0..security::kMaxDomain (230), the others up to 232.
          const int last_domain = impls_secure ? ddsnav::security::kMaxDomain : 232;  // bus::kMaxDomainId (this file uses the vendors directly)
          case_domain = case_domain >= last_domain ? domain : case_domain + 1;
        }
      }
      for (const std::string& impl : impls) {
        const std::vector<Result>& rs = runs[impl];
        Result r = rs.front();
        auto med = [&](double Result::*field) {
          std::vector<double> v;
          for (const Result& x : rs)
            if (!std::isnan(x.*field)) v.push_back(x.*field);
          return percentile(v, 0.5);
        };
        r.rtt_median_us = med(&Result::rtt_median_us);
        r.rtt_p99_us = med(&Result::rtt_p99_us);
        r.stream_mb_s = med(&Result::stream_mb_s);
        r.delivered = med(&Result::delivered);
        for (const Result& x : rs)
          if (!x.error.empty()) r.error = x.error;
        std::cout << fmt::format("| {} | {} | {} | {:.0f} | {:.0f} | {:.1f} | {:.0f}% |{}\n", r.pair, r.impl,
                                 sizeName(r.size), r.rtt_median_us, r.rtt_p99_us, r.stream_mb_s, 100 * r.delivered,
                                 r.error.empty() ? "" : " " + r.error)
                  << std::flush;
        results.push_back(r);
      }
    }
  }
  // Bus cost as a ratio to the native API of the same pair and size.
  std::cout << "\n| pair | size | RTT median bus/native | RTT p99 bus/native | throughput bus/native |\n|---|---|---|---|---|\n";
  for (const Result& b : results) {
    if (b.impl != "bus") continue;
    for (const Result& n : results)
      if (n.impl == "native" && n.pair == b.pair && n.size == b.size)
        std::cout << fmt::format("| {} | {} | {:.3f} | {:.3f} | {:.3f} |\n", b.pair, sizeName(b.size),
                                 b.rtt_median_us / n.rtt_median_us, b.rtt_p99_us / n.rtt_p99_us,
                                 b.stream_mb_s / n.stream_mb_s);
  }
  // DDS Security's cost as a ratio to the plain bus of the same pair and size.
  if (!credentials.empty()) {
    std::cout << "\n| pair | size | RTT median secure/plain | RTT p99 secure/plain | throughput secure/plain |\n|---|---|---|---|---|\n";
    for (const Result& s : results) {
      if (s.impl != "secure") continue;
      for (const Result& b : results)
        if (b.impl == "bus" && b.pair == s.pair && b.size == s.size)
          std::cout << fmt::format("| {} | {} | {:.3f} | {:.3f} | {:.3f} |\n", s.pair, sizeName(s.size),
                                   s.rtt_median_us / b.rtt_median_us, s.rtt_p99_us / b.rtt_p99_us,
                                   s.stream_mb_s / b.stream_mb_s);
    }
    std::filesystem::remove_all(credentials);
  }
  if (!json_path.empty()) {
    nlohmann::json j = nlohmann::json::array();
    for (const Result& r : results)
      j.push_back({{"pair", r.pair}, {"api", r.impl}, {"size", r.size}, {"rtt_median_us", r.rtt_median_us},
                   {"rtt_p99_us", r.rtt_p99_us}, {"stream_mb_s", r.stream_mb_s}, {"delivered", r.delivered},
                   {"error", r.error}});
    std::ofstream(json_path) << j.dump(2) << "\n";
  }
  return 0;
}
