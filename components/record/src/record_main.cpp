// ddsnav record: raw DDS traffic into an MCAP file. SIGINT/SIGTERM (or --duration, --max-messages) end
// the recording cleanly: queued samples are written, per-topic counts stored, the summary added.
#include <ddsnav/record/recorder.hpp>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <signal.h>
#include <unistd.h>

#include <ctime>

using namespace ddsnav;

namespace {

std::string defaultName() {
  const std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "ddsnav-%Y%m%d-%H%M%S.mcap", std::localtime(&t));
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  // Blocked before any thread exists: only the main loop's sigtimedwait sees them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  CLI::App app{"Record DDS topics as raw payloads into an MCAP file (docs/record.md)."};
  record::RecorderOptions options;
  options.output = defaultName();
  std::string dds;   // empty: DDSNAV_DDS, else fastdds
  int domain = -1;   // unset: DDSNAV_DOMAIN, else 0
  bool all = false;
  double duration = 0;
  std::string compression = "zstd";
  double queue_mb = 256;
  std::size_t chunk_kb = 1024;
  long write_delay_us = 0;
  app.add_option("-o,--output", options.output, "MCAP file to write");
  app.add_option("--topics", options.topics, "topics to record (comma separated)")->delimiter(',');
  app.add_flag("--all", all, "record every topic discovered (the default when --topics is not given)");
  app.add_option("--duration", duration, "stop after this many seconds (0: until SIGINT/SIGTERM)")->check(CLI::NonNegativeNumber);
  app.add_option("--max-messages", options.max_messages, "stop after writing this many messages (0: no limit)");
  app.add_option("--domain", domain, "DDS domain id (env DDSNAV_DOMAIN)")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--dds", dds, "DDS vendor: fastdds | cyclonedds (env DDSNAV_DDS)");
  app.add_option("--compression", compression, "chunk compression")->check(CLI::IsMember({"zstd", "none"}));
  app.add_option("--chunk-kb", chunk_kb, "close a chunk at this many KB of messages (also after 1 s)")->check(CLI::Range(1, 1 << 20));
  app.add_option("--queue-mb", queue_mb, "writer queue limit in MB; samples beyond it are dropped and counted")
      ->check(CLI::PositiveNumber);
  app.add_option("--queue-messages", options.queue_messages, "writer queue limit in samples")->check(CLI::PositiveNumber);
  app.add_option("--write-delay-us", write_delay_us, "pause after each write (simulates a slow disk; tests)")
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  if (all && !options.topics.empty()) {
    std::fprintf(stderr, "ddsnav record: give either --topics or --all, not both\n");
    return 2;
  }
  spdlog::set_pattern("[%H:%M:%S.%e] [record] [%^%l%$] %v");

  try {
    const bus::Vendor vendor = dds.empty() ? bus::vendorFromEnvironment() : bus::parseVendor(dds);
    if (domain < 0) domain = bus::domainFromEnvironment(0);
    options.mcap.compression = compression == "zstd" ? record::Compression::Zstd : record::Compression::None;
    options.mcap.chunk_size = chunk_kb * 1024;
    options.queue_bytes = static_cast<std::size_t>(queue_mb * (1 << 20));
    options.write_delay = std::chrono::microseconds(write_delay_us);
    options.domain_id = domain;
    bus::Participant participant({.vendor = vendor, .domain_id = domain, .name = "ddsnav-record"});
    options.vendor_name = std::string(bus::vendorName(participant.vendor()));
    record::Recorder recorder(participant, options);
    spdlog::info("recording {} to {} (domain {}, {})", options.topics.empty() ? std::string("every topic") : fmt::format("{}", fmt::join(options.topics, ",")),
                 options.output, domain, options.vendor_name);

    const bool tty = ::isatty(STDERR_FILENO);
    const auto start = std::chrono::steady_clock::now();
    auto last_line = start;
    auto progress = [&](bool final) {
      std::uint64_t received = 0, written = 0, dropped = 0;
      const auto counts = recorder.counts();
      for (const auto& c : counts) {
        received += c.received;
        written += c.written;
        dropped += c.dropped;
      }
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::fprintf(stderr, "%s%.1f s  %zu topics  received %llu  written %llu  dropped %llu  %.1f MB%s", tty ? "\r" : "", t,
                   counts.size(), static_cast<unsigned long long>(received), static_cast<unsigned long long>(written),
                   static_cast<unsigned long long>(dropped), recorder.bytesWritten() / 1e6, tty && !final ? "   " : "\n");
    };
    const timespec tick{0, 100'000'000};
    for (;;) {
      const int sig = ::sigtimedwait(&signals, nullptr, &tick);
      if (sig == SIGINT || sig == SIGTERM) {
        if (tty) std::fprintf(stderr, "\n");
        spdlog::info("{}: closing {}", strsignal(sig), options.output);
        break;
      }
      recorder.poll();
      const auto now = std::chrono::steady_clock::now();
      if (duration > 0 && now - start >= std::chrono::duration<double>(duration)) break;
      if (recorder.reachedMaxMessages()) break;
      if (recorder.failed()) break;
      if (now - last_line >= (tty ? std::chrono::milliseconds(500) : std::chrono::milliseconds(5000))) {
        progress(false);
        last_line = now;
      }
    }
    recorder.stop();
    progress(true);
    for (const auto& c : recorder.counts())
      spdlog::info("{}: received {} written {} dropped {}", c.topic, c.received, c.written, c.dropped);
    for (const auto& s : recorder.skipped()) spdlog::warn("not recorded: {}", s);
    // A topic asked for by name that never appeared is most often a typo: say so, by name.
    for (const auto& topic : recorder.notDiscovered()) spdlog::warn("{}: no publisher discovered; nothing recorded", topic);
    if (recorder.failed()) {
      spdlog::error("recording stopped early: {}", recorder.error());
      return 1;
    }
    if (recorder.messagesWritten() == 0) {
      spdlog::error("nothing was recorded: {} holds no messages", options.output);
      return 1;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
