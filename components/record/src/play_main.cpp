// ddsnav play: republishes a recording's raw payloads with the recorded timing; --clock drives
// system/clock so components run with `--clock topic` follow the recorded time.
#include <ddsnav/record/recorder.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <signal.h>
#include <unistd.h>

#include <thread>

using namespace ddsnav;

namespace {
std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop.store(true); }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Replay an MCAP recording onto DDS (docs/record.md)."};
  std::string path;
  record::PlayerOptions options;
  std::string dds;   // empty: DDSNAV_DDS, else fastdds
  int domain = -1;   // unset: DDSNAV_DOMAIN, else 0
  double wait_s = 2.0;
  double settle_s = 1.0;
  double linger_s = 1.0;
  app.add_option("file", path, "recording (.mcap)")->required();
  app.add_option("--rate", options.rate, "playback speed factor")->check(CLI::PositiveNumber);
  app.add_option("--topics", options.topics, "topics to replay (comma separated; default: all but system/status)")->delimiter(',');
  app.add_flag("--loop", options.loop, "start over at the end");
  app.add_flag("--clock", options.clock, "publish system/clock following the recorded time");
  app.add_option("--clock-hz", options.clock_hz, "system/clock publish rate")->check(CLI::PositiveNumber);
  app.add_option("--start", options.start_s, "skip the first S seconds")->check(CLI::NonNegativeNumber);
  app.add_option("--wait-subscribers", wait_s, "s to wait per topic for a subscriber before starting")->check(CLI::NonNegativeNumber);
  app.add_option("--settle", settle_s, "s to pause after subscribers matched, so they see us too")->check(CLI::NonNegativeNumber);
  app.add_option("--linger", linger_s, "s to keep the writers after the last message, for reliable resends")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--domain", domain, "DDS domain id (env DDSNAV_DOMAIN)")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--dds", dds, "DDS vendor: fastdds | cyclonedds (env DDSNAV_DDS)");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_pattern("[%H:%M:%S.%e] [play] [%^%l%$] %v");
  options.wait_subscribers = std::chrono::milliseconds(static_cast<long>(wait_s * 1000));
  options.settle = std::chrono::milliseconds(static_cast<long>(settle_s * 1000));

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  try {
    const bus::Vendor vendor = dds.empty() ? bus::vendorFromEnvironment() : bus::parseVendor(dds);
    if (domain < 0) domain = bus::domainFromEnvironment(0);
    record::McapReader file(path);
    if (file.truncated())
      spdlog::warn("{}: truncated at byte {} ({}); playing what is complete", path, file.truncatedAt(), file.truncationReason());
    bus::Participant participant({.vendor = vendor, .domain_id = domain, .name = "ddsnav-play"});
    const bool tty = ::isatty(STDERR_FILENO);
    const auto result = record::play(participant, file, options, g_stop, [&](const record::PlaybackProgress& p) {
      std::fprintf(stderr, "%s%.1f / %.1f s  published %llu%s", tty ? "\r" : "", p.recorded_s, p.duration_s,
                   static_cast<unsigned long long>(p.published), tty ? "   " : "\n");
    });
    if (tty) std::fprintf(stderr, "\n");
    spdlog::info("published {} messages{}", result.published,
                 result.failed ? " (" + std::to_string(result.failed) + " refused by the vendor)" : std::string());
    // Reliable samples not yet acknowledged are resent on the next heartbeat; the bus cannot wait for
    // acknowledgements, so keep the writers a while before they go away.
    for (int i = 0; i < static_cast<int>(linger_s * 10) && !g_stop.load(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return result.failed ? 1 : 0;
  } catch (const std::invalid_argument& e) {
    spdlog::error("{}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
