// ddsnav-bench-roundtrip: planning/request -> planning/path round trip of a real ddsnav-planner process,
// minus the solve time the planner reports (Path.statistics.time_s): what the component adds around the
// library (delivery both ways, executor, worker hand-over, world snapshot). Every vendor pair.
//   ddsnav-bench-roundtrip [--requests 200] [--domain 230] [--scenario configs/scenarios/demo_2d.yaml]
// Opens DDS participants: run it under the DDS test lock on a shared machine.
#include "bench_common.hpp"
#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>

#include <CLI/CLI.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

using namespace ddsnav;
using namespace std::chrono_literals;

using bench::binDir;
using bench::percentile;

namespace {

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"request -> path round trip of ddsnav-planner minus its solve time, every vendor pair"};
  int requests = 200, domain = 230;
  std::string scenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";
  app.add_option("--requests", requests, "requests per vendor pair")->check(CLI::Range(1, 100000));
  app.add_option("--domain", domain, "DDS domain id")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--scenario", scenario, "scenario the planner plans in (its exact geometry: world=scenario)")->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);

  std::printf("| requester -> planner | requests | round trip median / p99 (ms) | solve median / p99 (ms) | overhead median / p99 (ms) |\n|---|---|---|---|---|\n");
  for (const auto planner_vendor : {bus::Vendor::FastDDS, bus::Vendor::CycloneDDS})
    for (const auto requester_vendor : {bus::Vendor::FastDDS, bus::Vendor::CycloneDDS}) {
      const std::string planner = binDir() + "/ddsnav-planner";
      const std::string dds(bus::vendorName(planner_vendor));
      const pid_t pid = ::fork();
      if (pid == 0) {
        const std::string d = std::to_string(domain);
        ::execl(planner.c_str(), planner.c_str(), "--dds", dds.c_str(), "--domain", d.c_str(), "--log-level", "warn", "--param",
                ("scenario=" + scenario).c_str(), "--param", "world=scenario", static_cast<char*>(nullptr));
        ::_exit(127);
      }
      {
        bus::Participant bus({.vendor = requester_vendor, .domain_id = domain, .name = "bench-roundtrip"});
        auto pub = bus.publisher<msg::PlanRequest>("planning/request", bus::Qos::commands());
        auto paths = bus.inbox<msg::Path>("planning/path", bus::Qos::state(), 16);
        if (!pub.waitForSubscribers(1, 20s) || !paths.subscription().waitForPublishers(1, 20s)) {
          std::fprintf(stderr, "the planner did not come up\n");
          ::kill(pid, SIGKILL);
          return 1;
        }
        
        std::vector<double> total, solve, overhead;
        for (int i = 1; i <= requests; ++i) {
          msg::PlanRequest r;
          r.header().frame_id("map");
          r.request_id(static_cast<std::uint32_t>(i));
          r.start().x(3);
          r.start().y(3);
          r.goal().x(36);
          r.goal().y(35);
          r.goal_radius(1.5);
          r.planner("gart");
          r.time_budget_s(5);
          r.seed(static_cast<std::uint64_t>(i));
          const auto sent = std::chrono::steady_clock::now();
          pub.publish(r);
          std::optional<msg::Path> p;
          while ((p = paths.wait(10s)) && p->request_id() != static_cast<std::uint32_t>(i)) {
          }
          if (!p) {
            std::fprintf(stderr, "no answer to request %d\n", i);
            break;
          }
          const double t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - sent).count();
          const double s = p->statistics().time_s() * 1e3;
          total.push_back(t);
          solve.push_back(s);
          overhead.push_back(t - s);
        }
        std::printf("| %s -> %s | %zu | %.2f / %.2f | %.2f / %.2f | %.2f / %.2f |\n", std::string(bus::vendorName(requester_vendor)).c_str(),
                    dds.c_str(), total.size(), percentile(total, 0.5), percentile(total, 0.99), percentile(solve, 0.5), percentile(solve, 0.99),
                    percentile(overhead, 0.5), percentile(overhead, 0.99));
        std::fflush(stdout);
      }
      ::kill(pid, SIGTERM);
      int status = 0;
      ::waitpid(pid, &status, 0);
    }
  return 0;
}
