// ddsnav record: raw DDS traffic into an MCAP file. SIGINT/SIGTERM (or --duration, --max-messages) end
// the recording cleanly: queued samples are written, per-topic counts stored, the summary added.
// --max-file-mb / --max-file-s split into numbered files; --snapshot keeps the last seconds/MB in memory and
// writes them on SIGUSR1 or a message on --snapshot-topic. --foxglove adds the Foxglove views
// (docs/visualize.md) to every file as soon as it is complete.
#include <ddsnav/foxglove/export.hpp>
#include <ddsnav/record/recorder.hpp>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <optional>

using namespace ddsnav;

namespace {

std::string defaultName() {
  const std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "ddsnav-%Y%m%d-%H%M%S.mcap", std::localtime(&t));
  return buf;
}

// Rewrites a completed recording with the derived Foxglove channels added (the same conversion as
// `ddsnav export --foxglove`), through a temporary file renamed over it, so the file is complete at every
// moment. The recorder's own writer never carries them: it keeps its hot path free of JSON encoding, and a
// file is rewritten only once it is closed (at each split, each snapshot, and at the end).
bool addFoxgloveViews(const std::string& path, const std::optional<planner::Scenario>& scenario) {
  const std::string tmp = path + ".foxglove.tmp";
  try {
    foxglove::ExportStats stats;
    {
      record::McapReader reader(path);
      record::McapWriterOptions mcap;
      mcap.library = "ddsnav-record --foxglove";
      record::McapWriter writer(tmp, mcap);
      foxglove::SceneDeriverOptions options;
      options.scenario = scenario;
      stats = foxglove::exportFoxglove(reader, writer, std::move(options));
      writer.close();
    }
    std::filesystem::rename(tmp, path);
    std::uint64_t derived = 0;
    for (const auto& entry : stats.derived) derived += entry.second;
    spdlog::info("{}: {} Foxglove messages added", path, derived);
    if (stats.failed > 0)
      spdlog::warn("{}: {} message(s) had no Foxglove view; first: {}", path, stats.failed, stats.first_errors.front());
    return true;
  } catch (const std::exception& e) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    spdlog::error("{}: adding the Foxglove views failed ({}); the recording itself is unchanged", path, e.what());
    return false;
  }
}

}  // namespace

int main(int argc, char** argv) {
  // Blocked before any thread exists: only the main loop's sigtimedwait sees them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGUSR1);  // snapshot
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
  app.add_option("--compression-threads", options.compression_threads, "chunk compression workers (default: one per core)")
      ->check(CLI::Range(0, 64));
  double max_file_mb = 0, max_file_s = 0;
  auto* max_file_mb_opt = app.add_option("--max-file-mb", max_file_mb, "start a new numbered file (NAME_0.mcap, NAME_1.mcap, ...) at this size");
  auto* max_file_s_opt = app.add_option("--max-file-s", max_file_s, "start a new numbered file after this many seconds");
  bool snapshot = false;
  double snapshot_s = 0, snapshot_mb = 0;
  std::string snapshot_topic;
  app.add_flag("--snapshot", snapshot, "keep the newest messages in memory; write them (NAME_N.mcap) on SIGUSR1 or --snapshot-topic");
  auto* snapshot_s_opt = app.add_option("--snapshot-s", snapshot_s, "snapshot mode: seconds of messages kept in memory");
  auto* snapshot_mb_opt = app.add_option("--snapshot-mb", snapshot_mb, "snapshot mode: MB of messages kept in memory");
  app.add_option("--snapshot-topic", snapshot_topic, "snapshot mode: any message on this topic (any type) writes a snapshot");
  bool with_foxglove = false;
  std::string scenario_file;
  app.add_flag("--foxglove", with_foxglove, "add the Foxglove views (foxglove/* channels, as `ddsnav export --foxglove`) to each file once complete");
  app.add_option("--scenario", scenario_file, "with --foxglove: scenario file whose true obstacles go on foxglove/scenario")
      ->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  if (!scenario_file.empty() && !with_foxglove) {
    std::fprintf(stderr, "ddsnav record: --scenario needs --foxglove\n");
    return 2;
  }
  // Limits from the command line: a positive finite number or the option is an error (0 would mean
  // "a new file for every message" or "keep nothing" -- never what was meant).
  auto positive = [](CLI::Option* opt, double value, const char* what) {
    if (opt->count() == 0 || (value > 0 && std::isfinite(value))) return true;
    std::fprintf(stderr, "ddsnav record: %s %g: expected a positive number of %s (leave the option out for no limit)\n",
                 opt->get_name().c_str(), value, what);
    return false;
  };
  if (!positive(max_file_mb_opt, max_file_mb, "MB") || !positive(max_file_s_opt, max_file_s, "seconds") ||
      !positive(snapshot_s_opt, snapshot_s, "seconds") || !positive(snapshot_mb_opt, snapshot_mb, "MB"))
    return 2;
  if (!snapshot && (snapshot_s_opt->count() || snapshot_mb_opt->count() || !snapshot_topic.empty())) {
    std::fprintf(stderr, "ddsnav record: --snapshot-s, --snapshot-mb and --snapshot-topic need --snapshot\n");
    return 2;
  }
  if (snapshot && (max_file_mb_opt->count() || max_file_s_opt->count())) {
    std::fprintf(stderr, "ddsnav record: --snapshot writes one file per snapshot; it does not combine with --max-file-mb/-s\n");
    return 2;
  }
  if (snapshot && snapshot_s_opt->count() == 0 && snapshot_mb_opt->count() == 0) snapshot_s = 10;  // default window
  options.max_file_bytes = static_cast<std::uint64_t>(max_file_mb * 1e6);
  options.max_file_duration = std::chrono::milliseconds(static_cast<std::int64_t>(max_file_s * 1000));
  options.snapshot = snapshot;
  options.snapshot_duration = std::chrono::milliseconds(static_cast<std::int64_t>(snapshot_s * 1000));
  options.snapshot_bytes = static_cast<std::uint64_t>(snapshot_mb * 1e6);
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
    // The folder first: one clear message instead of a failure deep inside (snapshot mode opens its files
    // only when triggered, so without this check a typo would show up at the first snapshot).
    {
      namespace fs = std::filesystem;
      const fs::path dir = fs::path(options.output).parent_path().empty() ? fs::path(".") : fs::path(options.output).parent_path();
      std::error_code ec;
      if (!fs::is_directory(dir, ec)) {
        spdlog::error("{}: the recording folder {} does not exist (or is not a folder)", options.output, dir.string());
        return 1;
      }
      if (::access(dir.c_str(), W_OK | X_OK) != 0) {
        spdlog::error("{}: the recording folder {} is not writable: {}", options.output, dir.string(), std::strerror(errno));
        return 1;
      }
    }
    std::optional<planner::Scenario> scenario;
    if (!scenario_file.empty()) scenario = planner::loadScenario(scenario_file);  // errors name the file, before recording starts
    bus::Participant participant({.vendor = vendor, .domain_id = domain, .name = "ddsnav-record"});
    options.vendor_name = std::string(bus::vendorName(participant.vendor()));
    record::Recorder recorder(participant, options);
    std::size_t files_with_views = 0;
    bool views_failed = false;
    auto addViewsToCompletedFiles = [&] {
      if (!with_foxglove) return;
      const auto files = recorder.filesWritten();
      for (; files_with_views < files.size(); ++files_with_views)
        views_failed |= !addFoxgloveViews(files[files_with_views], scenario);
    };
    spdlog::info("recording {} to {} (domain {}, {})", options.topics.empty() ? std::string("every topic") : fmt::format("{}", fmt::join(options.topics, ",")),
                 options.output, domain, options.vendor_name);

    if (snapshot)
      spdlog::info("snapshot mode: keeping the last {}{}{} in memory; kill -USR1 {}{} writes them", snapshot_s > 0 ? fmt::format("{:g} s", snapshot_s) : "",
                   snapshot_s > 0 && snapshot_mb > 0 ? " / " : "", snapshot_mb > 0 ? fmt::format("{:g} MB", snapshot_mb) : "", ::getpid(),
                   snapshot_topic.empty() ? "" : " (so does any message on " + snapshot_topic + ")");
    // The snapshot control topic: whatever type its publisher uses, any sample is a trigger.
    std::atomic<bool> snapshot_message{false};
    bus::Subscription snapshot_trigger;

    const bool tty = ::isatty(STDERR_FILENO);
    const auto start = std::chrono::steady_clock::now();
    auto last_line = start;
    auto progress = [&](bool final) {
      std::uint64_t received = 0, written = 0, dropped = 0, lost = 0;
      const auto counts = recorder.counts();
      for (const auto& c : counts) {
        received += c.received;
        written += c.written;
        dropped += c.dropped;
        lost += c.lost;
      }
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const std::string buffered = snapshot ? fmt::format("  buffered {}", recorder.snapshotMessages()) : std::string();
      std::fprintf(stderr, "%s%.1f s  %zu topics  received %llu  lost %llu  dropped %llu  written %llu  %.1f MB%s%s", tty ? "\r" : "", t,
                   counts.size(), static_cast<unsigned long long>(received), static_cast<unsigned long long>(lost),
                   static_cast<unsigned long long>(dropped), static_cast<unsigned long long>(written), recorder.bytesWritten() / 1e6,
                   buffered.c_str(), tty && !final ? "   " : "\n");
    };
    const timespec tick{0, 100'000'000};
    for (;;) {
      const int sig = ::sigtimedwait(&signals, nullptr, &tick);
      if (sig == SIGINT || sig == SIGTERM) {
        if (tty) std::fprintf(stderr, "\n");
        spdlog::info("{}: closing {}", strsignal(sig), options.output);
        break;
      }
      if (sig == SIGUSR1 || snapshot_message.exchange(false)) {
        if (snapshot)
          recorder.requestSnapshot();
        else
          spdlog::warn("{}: ignored: not in snapshot mode (--snapshot)", sig == SIGUSR1 ? "SIGUSR1" : "snapshot message");
      }
      recorder.poll();
      if (snapshot && !snapshot_topic.empty() && !snapshot_trigger) {
        for (const bus::TopicInfo& t : participant.discoveredTopics())
          if (t.topic == snapshot_topic) {
            try {
              // Best effort matches publishers of either reliability.
              snapshot_trigger = participant.subscribeRaw(t, bus::Qos::sensorData(10), [&](const bus::RawSample&) { snapshot_message = true; });
              spdlog::info("snapshot trigger: {} ({})", t.topic, t.type_name);
            } catch (const std::exception& e) {
              spdlog::warn("snapshot trigger {}: {}", t.topic, e.what());
            }
            break;
          }
      }
      const auto now = std::chrono::steady_clock::now();
      if (duration > 0 && now - start >= std::chrono::duration<double>(duration)) break;
      if (recorder.reachedMaxMessages()) break;
      if (recorder.failed()) break;
      addViewsToCompletedFiles();  // split files and snapshots, as each one closes
      if (now - last_line >= (tty ? std::chrono::milliseconds(500) : std::chrono::milliseconds(5000))) {
        progress(false);
        last_line = now;
      }
    }
    snapshot_trigger = bus::Subscription();
    try {
      recorder.stop();
    } catch (const std::exception& e) {
      // The counts below still say what reached the disk; failed() makes the exit status 1.
      spdlog::error("closing the recording: {}", e.what());
    }
    progress(true);
    addViewsToCompletedFiles();
    for (const auto& c : recorder.counts())
      spdlog::info("{}: received {} lost {} dropped {} written {}", c.topic, c.received, c.lost, c.dropped, c.written);
    const auto files = recorder.filesWritten();
    if (files.size() > 1 || snapshot)
      for (const auto& f : files) spdlog::info("file: {}", f);
    for (const auto& s : recorder.skipped()) spdlog::warn("not recorded: {}", s);
    // A topic asked for by name that never appeared is most often a typo: say so, by name.
    for (const auto& topic : recorder.notDiscovered()) spdlog::warn("{}: no publisher discovered; nothing recorded", topic);
    if (recorder.failed()) {
      spdlog::error("recording stopped early: {}", recorder.error());
      return 1;
    }
    if (views_failed) return 1;
    if (snapshot) {
      if (files.empty()) spdlog::warn("no snapshot was requested: nothing written");
      return 0;
    }
    if (recorder.messagesWritten() == 0) {
      spdlog::error("nothing was recorded: {} holds no messages", files.empty() ? options.output : files.back());
      return 1;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
