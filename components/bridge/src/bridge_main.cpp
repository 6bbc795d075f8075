// ddsnav bridge: a Foxglove WebSocket server for a running ddsnav system (docs/visualize.md).
#include <ddsnav/bridge/bridge.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <signal.h>

#include <chrono>
#include <cstdio>

using namespace ddsnav;

int main(int argc, char** argv) {
  sigset_t signals;  // blocked before any thread exists: only the main loop sees them
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  CLI::App app{"Serve a ddsnav DDS domain to Foxglove over WebSocket (foxglove.websocket.v1), raw topics plus Foxglove views."};
  bridge::BridgeOptions options;
  std::string dds;
  int domain = -1;
  std::string scenario;
  int port = 8765;
  double stats_s = 10;
  app.add_option("--address", options.server.address, "interface to listen on (default 127.0.0.1: this machine only)");
  app.add_option("--port", port, "TCP port (0: any free one, printed)")->check(CLI::Range(0, 65535));
  app.add_option("--domain", domain, "DDS domain id (env DDSNAV_DOMAIN)")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--dds", dds, "DDS vendor: fastdds | cyclonedds (env DDSNAV_DDS)");
  app.add_option("--scenario", scenario, "scenario file: its true obstacles on foxglove/scenario")->check(CLI::ExistingFile);
  app.add_option("--queue-mb", options.server.max_queue_bytes, "per-client data queue, bytes")->check(CLI::PositiveNumber);
  app.add_option("--stats-interval", stats_s, "log per-client counts every this many seconds (0: never)")->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  spdlog::set_pattern("[%H:%M:%S.%e] [bridge] [%^%l%$] %v");
  options.server.port = static_cast<std::uint16_t>(port);
  try {
    if (!scenario.empty()) options.derive.scenario = planner::loadScenario(scenario);
    const bus::Vendor vendor = dds.empty() ? bus::vendorFromEnvironment() : bus::parseVendor(dds);
    if (domain < 0) domain = bus::domainFromEnvironment(0);
    bus::Participant participant({.vendor = vendor, .domain_id = domain, .name = "ddsnav-bridge"});
    bridge::Bridge bridge(participant, options);
    // The one line tests and scripts wait for.
    std::printf("ddsnav bridge: listening on ws://%s:%u (domain %d, %s)\n", options.server.address.c_str(), bridge.port(), domain,
                std::string(bus::vendorName(vendor)).c_str());
    std::fflush(stdout);
    const timespec tick{0, 100'000'000};
    auto last_stats = std::chrono::steady_clock::now();
    for (;;) {
      const int sig = ::sigtimedwait(&signals, nullptr, &tick);
      if (sig == SIGINT || sig == SIGTERM) break;
      bridge.poll();
      const auto now = std::chrono::steady_clock::now();
      if (stats_s > 0 && now - last_stats >= std::chrono::duration<double>(stats_s)) {
        last_stats = now;
        const auto s = bridge.stats();
        spdlog::info("{} topics, {} samples from the bus, {} Foxglove views ({} not converted: queue full, {} bad), {} client(s)",
                     s.advertised_topics, s.received, s.derived, s.derive_dropped, s.derive_failed, s.server.clients.size());
        for (const auto& c : s.server.clients)
          spdlog::info("  client {}: {} subscriptions, sent {}, dropped {}", c.remote, c.subscriptions, c.sent, c.dropped);
      }
    }
    const auto s = bridge.stats();
    for (const auto& c : s.server.clients) spdlog::info("client {}: sent {}, dropped {}", c.remote, c.sent, c.dropped);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddsnav bridge: %s\n", e.what());
    return 1;
  }
  return 0;
}
