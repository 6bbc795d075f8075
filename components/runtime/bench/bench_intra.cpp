// ddsnav-bench-intra: one hop of a point cloud between two components' executors, intra-process (two
// participants with intra_process in one process, as in `ddsnav container`) against the same hop between
// two processes over DDS. Ping-pong: A publishes on bench/ping, B's executor callback republishes what it
// got on bench/pong, A's executor takes it; one hop is half the round trip. Intra-process, B republishes
// the very object it got (publish(shared_ptr)); between processes it is serialized each way.
//   ddsnav-bench-intra [--size 1048576] [--rounds 300] [--domain 231] [--vendors fastdds,cyclonedds]
// The second process is this executable again with --role echo. Opens DDS participants: run it under a
// domain lock on a shared machine.
#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/runtime/executor.hpp>

#include <CLI/CLI.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

using namespace ddsnav;
using namespace std::chrono_literals;

namespace {

const bus::Qos kQos = bus::Qos::sensorData(5);

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<std::size_t>(p * double(v.size() - 1) + 0.5))];
}

std::shared_ptr<msg::PointCloud> makeCloud(std::size_t bytes) {
  auto cloud = std::make_shared<msg::PointCloud>();
  cloud->header().frame_id("map");
  cloud->xyz().assign(bytes / sizeof(float), 1.5f);
  return cloud;
}

// B: republishes every ping as a pong, on its executor thread.
class Echo {
 public:
  explicit Echo(bus::Participant& p) : pong_(p.publisher<msg::PointCloud>("bench/pong", kQos)) {
    sub_ = executor_.subscribe<msg::PointCloud>(p, "bench/ping", kQos, [this](std::shared_ptr<const msg::PointCloud> c, const bus::SampleInfo&) {
      pong_.publish(std::move(c));  // intra-process: the same object; otherwise serialized once
    });
    thread_ = std::thread([this] { executor_.run(); });
  }
  ~Echo() {
    executor_.stop();
    thread_.join();
  }
  bus::Publisher<msg::PointCloud>& pong() { return pong_; }

 private:
  runtime::Executor executor_;
  bus::Publisher<msg::PointCloud> pong_;
  bus::Subscription sub_;
  std::thread thread_;
};

struct Result {
  std::vector<double> hop_us;
};

// A: ping-pong `rounds` times (after a warm-up), the pong taken on A's executor thread.
Result pingPong(bus::Participant& p, std::size_t bytes, int rounds, std::size_t expected_subscribers) {
  runtime::Executor executor;
  std::mutex mutex;
  std::condition_variable changed;
  int got = 0;
  auto sub = executor.subscribe<msg::PointCloud>(p, "bench/pong", kQos, [&](std::shared_ptr<const msg::PointCloud>, const bus::SampleInfo&) {
    {
      std::lock_guard lock(mutex);
      ++got;
    }
    changed.notify_all();
  });
  std::thread thread([&] { executor.run(); });
  auto ping = p.publisher<msg::PointCloud>("bench/ping", kQos);
  if (!ping.waitForSubscribers(expected_subscribers, 20s) || !sub.waitForPublishers(1, 20s)) {
    executor.stop();
    thread.join();
    throw std::runtime_error("the echo did not match");
  }
  std::this_thread::sleep_for(300ms);
  Result r;
  const int warmup = 20;
  for (int i = 0; i < warmup + rounds; ++i) {
    auto cloud = makeCloud(bytes);  // a fresh object each round, as a sensor would publish
    cloud->header().stamp_ns(i);
    std::unique_lock lock(mutex);
    const int before = got;
    lock.unlock();
    const auto sent = std::chrono::steady_clock::now();
    ping.publish(std::shared_ptr<const msg::PointCloud>(std::move(cloud)));
    lock.lock();
    if (!changed.wait_for(lock, 2s, [&] { return got > before; })) {
      lock.unlock();
      std::fprintf(stderr, "round %d: no pong within 2 s (best effort: lost), again\n", i);
      continue;
    }
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - sent).count();
    if (i >= warmup) r.hop_us.push_back(us / 2);
  }
  executor.stop();
  thread.join();
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"one hop of a point cloud between executors: intra-process vs between processes"};
  std::size_t size = 1 << 20;
  int rounds = 300, domain = 231;
  std::vector<std::string> vendors{"fastdds", "cyclonedds"};
  std::string role = "ping", echo_vendor;
  app.add_option("--size", size, "cloud size in bytes")->check(CLI::Range(std::size_t{12}, std::size_t{64} << 20));
  app.add_option("--rounds", rounds, "measured round trips per case")->check(CLI::Range(1, 100000));
  app.add_option("--domain", domain, "DDS domain id")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--vendors", vendors, "vendors to measure")->delimiter(',');
  app.add_option("--role", role, "internal: echo (the second process)");
  app.add_option("--dds", echo_vendor, "internal: the echo's vendor");
  CLI11_PARSE(app, argc, argv);

  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  if (role == "echo") {
    bus::Participant p({.vendor = bus::parseVendor(echo_vendor), .domain_id = domain, .name = "bench-intra-echo"});
    Echo echo(p);
    int sig = 0;
    sigwait(&signals, &sig);
    return 0;
  }

  std::printf("| vendor | hop | cloud | rounds | one hop median / p99 (us) |\n|---|---|---|---|---|\n");
  for (const std::string& v : vendors) {
    const bus::Vendor vendor = bus::parseVendor(v);
    double intra_median = 0;
    {
      // Intra-process: A and B in this process, each its own participant, as two components of a container.
      bus::ParticipantOptions a{.vendor = vendor, .domain_id = domain, .name = "bench-intra-a"};
      a.intra_process = true;
      bus::ParticipantOptions b = a;
      b.name = "bench-intra-b";
      bus::Participant pa(a), pb(b);
      Echo echo(pb);
      const auto r = pingPong(pa, size, rounds, 1);
      intra_median = percentile(r.hop_us, 0.5);
      std::printf("| %s | intra-process | %zu B | %zu | %.1f / %.1f |\n", v.c_str(), size, r.hop_us.size(), intra_median,
                  percentile(r.hop_us, 0.99));
      std::fflush(stdout);
    }
    {
      const std::string self = "/proc/self/exe";
      char path[4096];
      const ssize_t n = ::readlink(self.c_str(), path, sizeof path - 1);
      path[n > 0 ? n : 0] = '\0';
      const pid_t pid = ::fork();
      if (pid == 0) {
        const std::string d = std::to_string(domain);
        ::execl(path, path, "--role", "echo", "--dds", v.c_str(), "--domain", d.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
      }
      double inter_median = 0;
      {
        bus::Participant pa({.vendor = vendor, .domain_id = domain, .name = "bench-inter-a"});
        const auto r = pingPong(pa, size, rounds, 1);
        inter_median = percentile(r.hop_us, 0.5);
        std::printf("| %s | between processes | %zu B | %zu | %.1f / %.1f |\n", v.c_str(), size, r.hop_us.size(), inter_median,
                    percentile(r.hop_us, 0.99));
      }
      ::kill(pid, SIGTERM);
      int status = 0;
      ::waitpid(pid, &status, 0);
      std::printf("| %s | ratio (median) | | | %.0fx |\n", v.c_str(), intra_median > 0 ? inter_median / intra_median : 0.0);
      std::fflush(stdout);
    }
  }
  return 0;
}
