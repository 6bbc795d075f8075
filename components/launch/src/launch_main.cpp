// ddsnav launch FILE [--set name=value]... [--domain N] [--dds VENDOR]
// Starts a component set from a YAML launch file and supervises it (see docs/launch.md).

#include "ddsnav/launch/launch_config.hpp"
#include "ddsnav/launch/status_readiness.hpp"
#include "ddsnav/launch/supervisor.hpp"

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <climits>
#include <filesystem>
#include <map>

namespace {

using namespace ddsnav;

std::string executableDirectory() {
  char buffer[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", buffer, sizeof(buffer) - 1);
  if (n <= 0) return ".";
  std::string path(buffer, static_cast<size_t>(n));
  return path.substr(0, path.rfind('/'));
}

}  // namespace

int main(int argc, char** argv) {
  // Before any thread exists, so DDS threads inherit the mask and the supervisor gets every signal.
  launch::blockSupervisorSignals();

  CLI::App app{"Start a set of ddsnav components from a YAML launch file and supervise it."};
  std::string file;
  std::vector<std::string> sets;
  int domain = -1;
  std::string dds;
  app.add_option("file", file, "launch file (YAML, see docs/launch.md)")->required();
  app.add_option("--set", sets, "override a variable of the launch file: name=value")->take_all();
  app.add_option("--domain", domain, "DDS domain id for every process (default: the file's, else DDSNAV_DOMAIN, else 0)")
      ->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--dds", dds, "default vendor for processes that do not name one: fastdds | cyclonedds");
  std::string security, network, peers;
  bool multicast = false;
  app.add_option("--security", security, "DDS Security directory for every process (overrides the file's `security:`)");
  app.add_option("--network", network, "network interface for every process (overrides the file's `network:`)");
  app.add_option("--peers", peers, "with --network: peer hosts, comma-separated");
  app.add_flag("--multicast", multicast, "with --network: also discover by multicast");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Usage errors (a bad --domain, an unknown option) are exit status 2, like a bad launch file;
    // CLI11's own codes (105 for a failed check) mean nothing to a caller. --help is 0.
    return app.exit(e) == 0 ? 0 : 2;
  }

  try {
    std::map<std::string, std::string> overrides;
    for (const auto& s : sets) {
      const auto eq = s.find('=');
      if (eq == std::string::npos || eq == 0) throw launch::LaunchError("--set '" + s + "': expected name=value");
      overrides[s.substr(0, eq)] = s.substr(eq + 1);
    }
    auto config = launch::loadLaunchConfig(file, overrides);
    if (!dds.empty()) config.dds = dds;
    if (domain < 0) domain = config.domain.value_or(-1);
    if (domain < 0) domain = bus::domainFromEnvironment(0);
    const auto vendor = bus::parseVendor(config.dds);
    if (!security.empty()) config.security = std::filesystem::absolute(security).lexically_normal().string();
    if (!network.empty()) config.network = launch::NetworkSpec{network, peers.empty() ? std::vector<std::string>{} : bus::parsePeers(peers), multicast};
    else if (!peers.empty() || multicast) throw launch::LaunchError("--peers / --multicast need --network");
    // Through the environment: every process started below inherits it, and so does this one's participant.
    if (config.security) ::setenv("DDSNAV_SECURITY", config.security->c_str(), 1);
    if (config.network) {
      std::string list;
      for (const auto& p : config.network->peers) list += (list.empty() ? "" : ",") + p;
      ::setenv("DDSNAV_NETWORK", config.network->interface.c_str(), 1);
      ::setenv("DDSNAV_PEERS", list.c_str(), 1);
      ::setenv("DDSNAV_MULTICAST", config.network->multicast ? "1" : "0", 1);
    }
    for (const auto& p : config.processes)
      if (p.dds) bus::parseVendor(*p.dds);  // reject a typo before anything starts

    bus::Participant participant({.vendor = vendor, .domain_id = domain, .name = "launch"});
    launch::StatusReadiness readiness(participant);
    launch::SupervisorOptions options;
    options.bin_dir = executableDirectory();
    options.domain = domain;
    options.dds = std::string(bus::vendorName(vendor));
    options.log = [](const std::string& line) { spdlog::info("{}", line); };
    // The status event dependents see when an instance ends unexpectedly: a ComponentStatus under the
    // component's own name, with the ended instance's pid and ready = false; SHUTTING_DOWN when a new
    // instance follows (it then reports STARTING ... READY with a new pid), FAILED when it is gone for good.
    auto events = participant.publisher<msg::ComponentStatus>("system/status", bus::Qos::state(1));
    options.on_event = [&events](const launch::SupervisionEvent& event) {
      msg::ComponentStatus status;
      status.name(event.name);
      status.pid(static_cast<std::int32_t>(event.pid));
      status.ready(false);
      status.state(event.restarting ? msg::LIFECYCLE_SHUTTING_DOWN : msg::LIFECYCLE_FAILED);
      status.detail("launch: " + event.detail);
      status.stamp_ns(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
      try {
        events.publish(status);
      } catch (const std::exception& e) {
        spdlog::warn("could not publish the status event for {}: {}", event.name, e.what());
      }
    };
    return launch::Supervisor(std::move(config), options, readiness).run();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
}
