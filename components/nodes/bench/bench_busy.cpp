// ddsnav-bench-busy: does a planner busy with a long solve delay perception in the same container? Starts
// `ddsnav-container -- perception -- planner` (world: obstacles, so the planner takes in every obstacle
// update while it solves), sends a point cloud every 100 ms and times each one from publishing to
// perception/obstacles carrying its stamp: first with the planner idle, then while it solves a request
// that runs its whole 5 s budget (rrtstar without goal bias towards a 1 um goal region: never reached).
//   ddsnav-bench-busy [--clouds 40] [--domain 232] [--dds fastdds] [--scenario configs/scenarios/demo_2d.yaml]
// Opens DDS participants: run it under a domain lock on a shared machine.
#include "bench_common.hpp"
#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>

#include <CLI/CLI.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

using namespace ddsnav;
using namespace std::chrono_literals;

using bench::binDir;
using bench::percentile;

namespace {

// Two round obstacles seen from (3, 3): a planar scan's worth of points on their near sides.
msg::PointCloud makeCloud(std::int64_t stamp) {
  msg::PointCloud c;
  c.header().frame_id("map");
  c.header().stamp_ns(stamp);
  c.sensor_origin().x(3);
  c.sensor_origin().y(3);
  for (const auto [cx, cy] : {std::pair{12.0, 10.0}, std::pair{20.0, 24.0}})
    for (int i = 0; i < 200; ++i) {
      const double a = 2 * M_PI * i / 200.0;
      c.xyz().push_back(static_cast<float>(cx + 0.6 * std::cos(a)));
      c.xyz().push_back(static_cast<float>(cy + 0.6 * std::sin(a)));
      c.xyz().push_back(0.0f);
    }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"perception latency in a container while the planner in it solves a 5 s problem"};
  int clouds = 40, domain = 232;
  std::string dds = "fastdds", scenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";
  app.add_option("--clouds", clouds, "clouds per phase (idle, busy)")->check(CLI::Range(1, 45));
  app.add_option("--domain", domain, "DDS domain id")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--dds", dds, "vendor of the container and of this process")->check(CLI::IsMember({"fastdds", "cyclonedds"}));
  app.add_option("--scenario", scenario, "scenario the planner plans in")->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);

  const std::string container = binDir() + "/ddsnav-container";
  const pid_t pid = ::fork();
  if (pid == 0) {
    const std::string d = std::to_string(domain);
    ::execl(container.c_str(), container.c_str(), "--", "perception", "--dds", dds.c_str(), "--domain", d.c_str(), "--log-level", "warn",
            "--", "planner", "--dds", dds.c_str(), "--domain", d.c_str(), "--log-level", "warn", "--param", ("scenario=" + scenario).c_str(),
            "--param", "world=obstacles", "--param", "planner_options=[rrtstar.goal_bias=0]", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int rc = 0;
  {
    bus::Participant bus({.vendor = bus::parseVendor(dds), .domain_id = domain, .name = "bench-busy"});
    auto points = bus.publisher<msg::PointCloud>("sensors/points", bus::Qos::sensorData());
    auto requests = bus.publisher<msg::PlanRequest>("planning/request", bus::Qos::commands());
    auto paths = bus.inbox<msg::Path>("planning/path", bus::Qos::state(), 4);
    std::mutex mutex;
    std::map<std::int64_t, std::chrono::steady_clock::time_point> sent, received;
    auto obstacles = bus.subscribe<msg::ObstacleArray>("perception/obstacles", bus::Qos::state(), [&](const msg::ObstacleArray& a) {
      const auto now = std::chrono::steady_clock::now();
      std::lock_guard lock(mutex);
      received.emplace(a.header().stamp_ns(), now);
    });
    if (!points.waitForSubscribers(1, 20s) || !requests.waitForSubscribers(1, 20s) || !obstacles.waitForPublishers(1, 20s)) {
      std::fprintf(stderr, "the container did not come up\n");
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
      return 1;
    }
    std::this_thread::sleep_for(1s);
    std::int64_t stamp = 1000;
    // Sends `n` clouds 100 ms apart; returns their publish -> obstacles latencies (ms).
    const auto phase = [&](int n) {
      std::vector<std::int64_t> stamps;
      for (int i = 0; i < n; ++i) {
        const auto cloud = makeCloud(++stamp);
        {
          std::lock_guard lock(mutex);
          sent[stamp] = std::chrono::steady_clock::now();
        }
        points.publish(cloud);
        stamps.push_back(stamp);
        std::this_thread::sleep_for(100ms);
      }
      std::this_thread::sleep_for(300ms);
      std::vector<double> ms;
      std::lock_guard lock(mutex);
      for (const auto s : stamps)
        if (auto r = received.find(s); r != received.end()) ms.push_back(std::chrono::duration<double, std::milli>(r->second - sent[s]).count());
      return ms;
    };
    std::printf("| planner | clouds answered | cloud -> obstacles median / p99 / max (ms) |\n|---|---|---|\n");
    const auto idle = phase(clouds);
    std::printf("| idle | %zu of %d | %.2f / %.2f / %.2f |\n", idle.size(), clouds, percentile(idle, 0.5), percentile(idle, 0.99),
                percentile(idle, 1.0));
    std::fflush(stdout);
    msg::PlanRequest r;
    r.header().frame_id("map");
    r.request_id(1);
    r.start().x(3);
    r.start().y(3);
    r.goal().x(36);
    r.goal().y(35);
    r.goal_radius(1e-6);
    r.planner("rrtstar");
    r.time_budget_s(5);
    const auto asked = std::chrono::steady_clock::now();
    requests.publish(r);
    std::this_thread::sleep_for(200ms);  // the solve has begun
    const auto busy = phase(clouds);
    const auto path = paths.wait(10s);
    const double solve_s = path ? path->statistics().time_s() : 0.0;
    const double answered_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - asked).count();
    std::printf("| solving (%.2f s solve, answered after %.2f s) | %zu of %d | %.2f / %.2f / %.2f |\n", solve_s, answered_s, busy.size(), clouds,
                percentile(busy, 0.5), percentile(busy, 0.99), percentile(busy, 1.0));
    if (!path || solve_s < 0.2 + 0.1 * clouds) {
      std::fprintf(stderr, "the solve did not span the busy phase (%.2f s): the numbers are not under load\n", solve_s);
      rc = 1;
    }
  }
  ::kill(pid, SIGTERM);
  ::waitpid(pid, nullptr, 0);
  return rc;
}
