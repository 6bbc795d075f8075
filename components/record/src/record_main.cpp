// ddsnav record: raw DDS traffic into an MCAP file. SIGINT/SIGTERM (or --duration, --max-messages) end
// the recording cleanly: queued samples are written, per-topic counts stored, the summary added.
// --max-file-mb / --max-file-s split into numbered files; --snapshot keeps the last seconds/MB in memory and
// writes them on SIGUSR1 or a message on --snapshot-topic. --foxglove adds the Foxglove views
// (docs/visualize.md) to every file as soon as it is complete.
#include <ddsnav/foxglove/export.hpp>
#include <ddsnav/record/recorder.hpp>
#include <ddsnav/runtime/component.hpp>

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

// The command line beyond the runtime's options (--dds, --domain, --namespace, --remap, ...).
struct RecordOptions {
  record::RecorderOptions options;
  bool all = false;
  double duration = 0;
  std::string compression = "zstd";
  double queue_mb = 256;
  double preallocate_mb = -1;  // -1: record::defaultPayloadPreallocation
  std::size_t chunk_kb = 1024;
  long write_delay_us = 0;
  double max_file_mb = 0, max_file_s = 0;
  CLI::Option *max_file_mb_opt = nullptr, *max_file_s_opt = nullptr, *snapshot_s_opt = nullptr, *snapshot_mb_opt = nullptr;
  bool snapshot = false;
  double snapshot_s = 0, snapshot_mb = 0;
  std::string snapshot_topic;
  bool with_foxglove = false;
  std::string scenario_file;

  void add(CLI::App& app) {
    options.output = defaultName();
    app.add_option("-o,--output", options.output, "MCAP file to write");
    app.add_option("--topics", options.topics, "topics to record (comma separated)")->delimiter(',');
    app.add_flag("--all", all, "record every topic discovered (the default when --topics is not given)");
    app.add_option("--duration", duration, "stop after this many seconds (0: until SIGINT/SIGTERM)")->check(CLI::NonNegativeNumber);
    app.add_option("--max-messages", options.max_messages, "stop after writing this many messages (0: no limit)");
    app.add_option("--compression", compression, "chunk compression: zstd (smaller files), lz4 (faster), none")
        ->check(CLI::IsMember({"zstd", "lz4", "none"}));
    app.add_option("--chunk-kb", chunk_kb, "close a chunk at this many KB of messages (also after 1 s)")->check(CLI::Range(1, 1 << 20));
    app.add_option("--queue-mb", queue_mb, "writer queue limit in MB; samples beyond it are dropped and counted")
        ->check(CLI::PositiveNumber);
    app.add_option("--preallocate-mb", preallocate_mb,
                   "payload memory made resident at start, so a flood's samples never wait for page faults "
                   "(default: the queue size, at most 1024; 0: none)")
        ->check(CLI::Range(0.0, 1048576.0));
    app.add_option("--queue-messages", options.queue_messages, "writer queue limit in samples")->check(CLI::PositiveNumber);
    app.add_option("--write-delay-us", write_delay_us, "pause after each write (simulates a slow disk; tests)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--compression-threads", options.compression_threads, "chunk compression workers (default: one per core)")
        ->check(CLI::Range(0, 64));
    max_file_mb_opt = app.add_option("--max-file-mb", max_file_mb, "start a new numbered file (NAME_0.mcap, NAME_1.mcap, ...) at this size");
    max_file_s_opt = app.add_option("--max-file-s", max_file_s, "start a new numbered file after this many seconds");
    app.add_flag("--snapshot", snapshot, "keep the newest messages in memory; write them (NAME_N.mcap) on SIGUSR1 or --snapshot-topic");
    snapshot_s_opt = app.add_option("--snapshot-s", snapshot_s, "snapshot mode: seconds of messages kept in memory");
    snapshot_mb_opt = app.add_option("--snapshot-mb", snapshot_mb, "snapshot mode: MB of messages kept in memory");
    app.add_option("--snapshot-topic", snapshot_topic, "snapshot mode: any message on this topic (any type) writes a snapshot");
    app.add_flag("--foxglove", with_foxglove, "add the Foxglove views (foxglove/* channels, as `ddsnav export --foxglove`) to each file once complete");
    app.add_option("--scenario", scenario_file, "with --foxglove: scenario file whose true obstacles go on foxglove/scenario")
        ->check(CLI::ExistingFile);
  }
};

// Bad combinations of options: exit status 2 with the message (runtime::ParameterError).
void usageError(const std::string& message) { throw runtime::ParameterError("ddsnav record: " + message); }

void runRecording(runtime::Context& ctx, RecordOptions& o, sigset_t snapshot_signal) {
  auto& options = o.options;
  const auto& snapshot = o.snapshot;
  auto& snapshot_s = o.snapshot_s;
  const auto& snapshot_mb = o.snapshot_mb;
  const auto& snapshot_topic = o.snapshot_topic;
  const auto& duration = o.duration;
  if (!o.scenario_file.empty() && !o.with_foxglove) usageError("--scenario needs --foxglove");
  // Limits from the command line: a positive finite number or the option is an error (0 would mean
  // "a new file for every message" or "keep nothing" -- never what was meant).
  auto positive = [](CLI::Option* opt, double value, const char* what) {
    if (opt->count() == 0 || (value > 0 && std::isfinite(value))) return;
    usageError(fmt::format("{} {:g}: expected a positive number of {} (leave the option out for no limit)", opt->get_name(), value, what));
  };
  positive(o.max_file_mb_opt, o.max_file_mb, "MB");
  positive(o.max_file_s_opt, o.max_file_s, "seconds");
  positive(o.snapshot_s_opt, o.snapshot_s, "seconds");
  positive(o.snapshot_mb_opt, o.snapshot_mb, "MB");
  if (!snapshot && (o.snapshot_s_opt->count() || o.snapshot_mb_opt->count() || !snapshot_topic.empty()))
    usageError("--snapshot-s, --snapshot-mb and --snapshot-topic need --snapshot");
  if (snapshot && (o.max_file_mb_opt->count() || o.max_file_s_opt->count()))
    usageError("--snapshot writes one file per snapshot; it does not combine with --max-file-mb/-s");
  if (snapshot && o.snapshot_s_opt->count() == 0 && o.snapshot_mb_opt->count() == 0) snapshot_s = 10;  // default window
  options.max_file_bytes = static_cast<std::uint64_t>(o.max_file_mb * 1e6);
  options.max_file_duration = std::chrono::milliseconds(static_cast<std::int64_t>(o.max_file_s * 1000));
  options.snapshot = snapshot;
  options.snapshot_duration = std::chrono::milliseconds(static_cast<std::int64_t>(snapshot_s * 1000));
  options.snapshot_bytes = static_cast<std::uint64_t>(snapshot_mb * 1e6);
  if (o.all && !options.topics.empty()) usageError("give either --topics or --all, not both");
  // The names asked for are the component's topics: --namespace and --remap apply to them.
  for (auto& topic : options.topics) topic = ctx.topic(topic);

  const int domain = ctx.bus().domainId();
  options.mcap.compression = o.compression == "zstd"  ? record::Compression::Zstd
                             : o.compression == "lz4" ? record::Compression::Lz4
                                                      : record::Compression::None;
  options.mcap.chunk_size = o.chunk_kb * 1024;
  options.queue_bytes = static_cast<std::size_t>(o.queue_mb * (1 << 20));
  options.write_delay = std::chrono::microseconds(o.write_delay_us);
  options.domain_id = domain;
  // The folder first: one clear message instead of a failure deep inside (snapshot mode opens its files
  // only when triggered, so without this check a typo would show up at the first snapshot).
  {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(options.output).parent_path().empty() ? fs::path(".") : fs::path(options.output).parent_path();
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
      throw std::runtime_error(fmt::format("{}: the recording folder {} does not exist (or is not a folder)", options.output, dir.string()));
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
      throw std::runtime_error(fmt::format("{}: the recording folder {} is not writable: {}", options.output, dir.string(), std::strerror(errno)));
  }
  std::optional<planner::Scenario> scenario;
  if (!o.scenario_file.empty()) scenario = planner::loadScenario(o.scenario_file);  // errors name the file, before recording starts
  {
    const std::size_t bytes = o.preallocate_mb >= 0 ? static_cast<std::size_t>(o.preallocate_mb * (1 << 20))
                                                    : record::defaultPayloadPreallocation(options.queue_bytes);
    const std::size_t touched = record::prefaultPayloadMemory(bytes);
    spdlog::debug("record: {} MB of payload memory resident", touched >> 20);
  }
  bus::Participant& participant = ctx.bus();
  options.vendor_name = std::string(bus::vendorName(participant.vendor()));
  record::Recorder recorder(participant, options);
  std::size_t files_with_views = 0;
  bool views_failed = false;
  auto addViewsToCompletedFiles = [&] {
    if (!o.with_foxglove) return;
    const auto files = recorder.filesWritten();
    for (; files_with_views < files.size(); ++files_with_views)
      views_failed |= !addFoxgloveViews(files[files_with_views], scenario);
  };
  spdlog::info("recording {} to {} (domain {}, {})", options.topics.empty() ? std::string("every topic") : fmt::format("{}", fmt::join(options.topics, ",")),
               options.output, domain, options.vendor_name);
  if (participant.vendor() == bus::Vendor::CycloneDDS)
    spdlog::warn("record: with Cyclone DDS the lost counts are a lower bound (its readers expose no sequence numbers, and its "
                 "status misses samples a reliable writer overwrote); --dds fastdds counts every loss");

  if (snapshot)
    spdlog::info("snapshot mode: keeping the last {}{}{} in memory; kill -USR1 {}{} writes them", snapshot_s > 0 ? fmt::format("{:g} s", snapshot_s) : "",
                 snapshot_s > 0 && snapshot_mb > 0 ? " / " : "", snapshot_mb > 0 ? fmt::format("{:g} MB", snapshot_mb) : "", ::getpid(),
                 snapshot_topic.empty() ? "" : " (so does any message on " + snapshot_topic + ")");
  // The snapshot control topic: whatever type its publisher uses, any sample is a trigger.
  std::atomic<bool> snapshot_message{false};
  bus::Subscription snapshot_trigger;
  ctx.ready();  // recording (what is discovered from now on): READY on system/status like every component

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
    // SIGINT/SIGTERM are the runtime's (shutdownRequested); SIGUSR1, blocked in every thread, is ours.
    const int sig = ::sigtimedwait(&snapshot_signal, nullptr, &tick);
    if (ctx.shutdownRequested()) {
      if (tty) std::fprintf(stderr, "\n");
      spdlog::info("closing {}", options.output);
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
  if (recorder.failed()) throw std::runtime_error("recording stopped early: " + recorder.error());
  if (views_failed) throw std::runtime_error("adding the Foxglove views failed");
  if (snapshot) {
    if (files.empty()) spdlog::warn("no snapshot was requested: nothing written");
    return;
  }
  if (recorder.messagesWritten() == 0)
    throw std::runtime_error(fmt::format("nothing was recorded: {} holds no messages", files.empty() ? options.output : files.back()));
}

}  // namespace

int main(int argc, char** argv) {
  record::configureAllocatorForRecording();  // before any thread exists (recorder.hpp)
  // Blocked before any thread exists: only the recording loop's sigtimedwait sees it.
  sigset_t snapshot_signal;
  sigemptyset(&snapshot_signal);
  sigaddset(&snapshot_signal, SIGUSR1);
  pthread_sigmask(SIG_BLOCK, &snapshot_signal, nullptr);
  RecordOptions options;
  return runtime::runComponent(
      runtime::ComponentInfo{"record", {}, [&](CLI::App& app) { options.add(app); }}, argc, argv,
      [&](runtime::Context& ctx) { runRecording(ctx, options, snapshot_signal); });
}
