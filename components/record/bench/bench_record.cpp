// ddsnav-bench-record: what recording costs (docs/benchmarks/record.md).
//
// 1. Over DDS, two processes: a child publishes N messages (1 MB point clouds or ~100 B vehicle states) as
//    fast as reliable delivery allows; this process takes them either with a raw subscription that
//    discards them (the ceiling) or with the Recorder writing an MCAP file (zstd or none). Reported:
//    msgs/s, MB/s, received vs. sent, queue drops, and recorder / discard ratios.
// 2. On disk only: McapWriter throughput and file size for the same payloads, none vs. zstd levels.
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/recorder.hpp>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <tuple>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <random>
#include <thread>

using namespace ddsnav;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

// A lidar-like cloud: rings of points on a ground plane and walls, with centimetre noise, so compression
// sees realistic float data rather than zeros or white noise.
msg::PointCloud makeCloud(std::size_t points, int index, std::mt19937& rng) {
  msg::PointCloud c;
  c.header().stamp_ns(index);
  c.header().frame_id("map");
  std::normal_distribution<float> noise(0.f, 0.01f);
  std::vector<float> xyz;
  xyz.reserve(points * 3);
  for (std::size_t i = 0; i < points; ++i) {
    const float azimuth = static_cast<float>(i % 1800) * (2.f * static_cast<float>(M_PI) / 1800.f);
    const float ring = static_cast<float>(i / 1800);
    const float range = ring < 24 ? 2.f + ring * 0.8f : 20.f;  // ground rings, then a wall
    xyz.push_back(range * std::cos(azimuth) + noise(rng));
    xyz.push_back(range * std::sin(azimuth) + noise(rng));
    xyz.push_back(ring < 24 ? noise(rng) : (ring - 24) * 0.1f + noise(rng));
  }
  c.xyz(std::move(xyz));
  return c;
}

msg::VehicleState makeState(int index) {
  msg::VehicleState s;
  s.header().stamp_ns(index);
  s.header().frame_id("map");
  s.position().x(std::cos(index * 0.01));
  s.position().y(std::sin(index * 0.01));
  s.heading(index * 0.01);
  s.velocity().x(1.0);
  return s;
}

constexpr std::size_t kCloudPoints = 87'000;  // 12 B per point: ~1.04 MB

bus::Qos publisherQos(const std::string& qos, int depth) {
  return qos == "best-effort" ? bus::Qos::sensorData(depth) : bus::Qos::commands(depth);
}

int runPublisher(const std::string& dds, int domain, const std::string& kind, int count, double rate, const std::string& qos) {
  bus::Participant p({.vendor = bus::parseVendor(dds), .domain_id = domain, .name = "bench-record-pub"});
  std::mt19937 rng(1);
  auto publishAll = [&](auto& pub, auto make) {
    if (!pub.waitForSubscribers(1, std::chrono::seconds(20))) return 1;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    // Paced (rate > 0): a stream the subscriber side should keep up with, so CPU per message compares
    // like with like; rate 0 is a flood, where reliable KEEP_LAST overwrites what a slow reader missed.
    const auto start = Clock::now();
    int refused = 0;
    for (int i = 0; i < count; ++i) {
      if (rate > 0) std::this_thread::sleep_until(start + std::chrono::nanoseconds(static_cast<std::int64_t>(i * 1e9 / rate)));
      try {
        pub.publish(make(i));
      } catch (const bus::BusError&) {
        ++refused;  // a full reliable history: this sample was never sent
      }
    }
    if (refused > 0) std::fprintf(stderr, "publisher: %d of %d samples refused by the writer\n", refused, count);
    // The writer stays until the sink has stopped making progress (it sends SIGTERM): a reliable writer
    // that left earlier would take its unacknowledged samples with it, neither delivered nor reported lost.
    sigset_t term;
    sigemptyset(&term);
    sigaddset(&term, SIGTERM);
    const timespec limit{120, 0};
    ::sigtimedwait(&term, nullptr, &limit);
    return 0;
  };
  // Reliable volatile, deep enough that the writer does not overwrite what the reader has not acked.
  if (kind == "cloud") {
    auto pub = p.publisher<msg::PointCloud>("bench/points", publisherQos(qos, 32));
    // Build a few clouds up front: the publisher should measure the bus, not cloud generation.
    std::vector<msg::PointCloud> clouds;
    for (int i = 0; i < 4; ++i) clouds.push_back(makeCloud(kCloudPoints, i, rng));
    return publishAll(pub, [&](int i) {
      auto& c = clouds[i % clouds.size()];
      c.header().stamp_ns(i);
      return c;
    });
  }
  auto pub = p.publisher<msg::VehicleState>("bench/small", publisherQos(qos, 1000));
  return publishAll(pub, makeState);
}

struct Result {
  std::string sink;
  std::uint64_t sent = 0, received = 0, written = 0, dropped = 0, lost = 0, bytes = 0;
  double seconds = 0;       // first to last sample received
  double close_s = 0;       // recorder stop (drain + summary)
  std::uint64_t file_bytes = 0;
  double cpu_s = 0;         // CPU time of this (subscribing/recording) process during the run
  double cpu_us_per_msg() const { return delivered() ? cpu_s * 1e6 / delivered() : 0; }
  // Samples that reached the sink: received for discard, written to the file for the recorder.
  std::uint64_t delivered() const { return sink == "discard" ? received : written; }
  // Every sample sent is delivered, or counted as lost (DDS) or dropped (recorder): the rest is unexplained.
  std::int64_t unaccounted() const {
    return static_cast<std::int64_t>(sent) - static_cast<std::int64_t>(delivered() + lost + dropped);
  }
  double msgs_per_s() const { return seconds > 0 && delivered() > 1 ? (delivered() - 1) / seconds : 0; }
  double mb_per_s() const { return seconds > 0 ? bytes / 1e6 / seconds : 0; }
};

// Runs the publisher child against one sink: "discard", "record-none" or "record-zstd".
double cpuSeconds() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

struct RunSpec {
  std::string dds, pub_dds, kind, qos;
  int domain = 199, count = 0, compression_threads = -1, writer_nice = 10;
  std::size_t queue_mb = 256;
  double rate = 0;
  std::size_t chunk_kb = 1024;
  int zstd_level = 1;
  int lz4_level = 0;
  std::size_t resident_bytes = 0;  // payload memory touched before each run (as ddsnav record does at start)
};

Result runSink(const std::string& self, const RunSpec& spec, const std::string& sink, const fs::path& file) {
  const std::string& dds = spec.dds;
  const int domain = spec.domain, count = spec.count;
  const std::string& kind = spec.kind;
  double cpu0 = cpuSeconds();
  bus::Participant p({.vendor = bus::parseVendor(dds), .domain_id = domain, .name = "bench-record-sub"});
  const std::string topic = kind == "cloud" ? "bench/points" : "bench/small";
  std::atomic<std::uint64_t> received{0}, bytes{0};
  std::atomic<std::int64_t> first_ns{0}, last_ns{0};
  auto stamp = [] { return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count(); };

  // Blocked before the fork: the child waits for it with sigtimedwait (its mask survives exec).
  sigset_t term;
  sigemptyset(&term);
  sigaddset(&term, SIGTERM);
  sigset_t old_mask;
  ::pthread_sigmask(SIG_BLOCK, &term, &old_mask);
  const pid_t child = ::fork();
  if (child == 0) {
    const std::string c = std::to_string(count), d = std::to_string(domain), r = std::to_string(spec.rate);
    ::execl(self.c_str(), self.c_str(), "--role", "publish", "--dds", spec.pub_dds.c_str(), "--domain", d.c_str(), "--kind",
            kind.c_str(), "--count", c.c_str(), "--rate", r.c_str(), "--qos", spec.qos.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // After the fork, not before: a fork write-protects every page of this process, and the first write to
  // each would fault again. (ddsnav record forks nothing.)
  {
    const double before = cpuSeconds();
    record::prefaultPayloadMemory(spec.resident_bytes);
    cpu0 += cpuSeconds() - before;  // the set-up is not the sink's cost per message
  }
  std::unique_ptr<record::Recorder> recorder;
  bus::Subscription discard;
  if (sink == "discard") {
    const auto info = p.waitForTopic(topic, std::chrono::seconds(20));
    if (!info) throw std::runtime_error("publisher not discovered");
    // The recorder's reader QoS for this topic, so both sinks ask DDS for the same thing.
    bus::Qos qos = spec.qos == "best-effort" ? bus::Qos::sensorData() : record::qosForTopic(topic).qos;
    qos.depth = record::kRecorderReaderDepth;
    discard = p.subscribeRaw(*info, qos, [&](const bus::RawSample& s) {
      const auto now = stamp();
      if (received.fetch_add(1) == 0) first_ns = now;
      last_ns = now;
      bytes += s.payload.size();
    });
  } else {
    record::RecorderOptions o;
    o.output = file.string();
    o.topics = {topic};
    o.mcap.compression = sink == "record-zstd"  ? record::Compression::Zstd
                         : sink == "record-lz4" ? record::Compression::Lz4
                                                : record::Compression::None;
    o.mcap.lz4_level = spec.lz4_level;
    o.mcap.chunk_size = spec.chunk_kb * 1024;
    o.mcap.zstd_level = spec.zstd_level;
    o.compression_threads = spec.compression_threads;
    o.writer_nice = spec.writer_nice;
    o.queue_bytes = spec.queue_mb << 20;
    recorder = std::make_unique<record::Recorder>(p, o);
  }
  // Until the child is done (it lingers 2 s after its last write).
  int status = 0;
  std::uint64_t last_written = 0;
  ::pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
  std::uint64_t last_received = 0;
  // Ends the publisher once received + lost has not moved for 3 s (or nothing came in 60 s).
  std::uint64_t progress = 0;
  auto last_progress = Clock::now();
  bool told_to_stop = false;
  while (::waitpid(child, &status, WNOHANG) == 0) {
    const std::uint64_t now_progress =
        recorder ? [&] {
          const auto c = recorder->counts();
          return c.empty() ? std::uint64_t{0} : c[0].received + c[0].lost;
        }()
                 : received.load() + discard.lostSamples();
    if (now_progress != progress) {
      progress = now_progress;
      last_progress = Clock::now();
    }
    const auto quiet = Clock::now() - last_progress;
    if (!told_to_stop && ((progress > 0 && quiet > std::chrono::seconds(3)) || quiet > std::chrono::seconds(60))) {
      ::kill(child, SIGTERM);
      told_to_stop = true;
    }
    if (recorder) {
      recorder->poll();
      const auto c = recorder->counts();
      // The recorder's time: from its first sample received to its last written (or, below, to the end
      // of stop(), which drains the queue), sampled here every 5 ms.
      if (!c.empty() && c[0].received != 0 && last_received == 0) first_ns = stamp();
      if (!c.empty()) last_received = c[0].received;
      if (!c.empty() && c[0].written != last_written) {
        last_ns = stamp();
        last_written = c[0].written;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  Result r;
  r.sink = sink;
  r.sent = count;
  if (recorder) {
    const auto t0 = Clock::now();
    const std::uint64_t written_before_stop = recorder->counts().empty() ? 0 : recorder->counts()[0].written;
    recorder->stop();
    r.close_s = std::chrono::duration<double>(Clock::now() - t0).count();
    if (!recorder->counts().empty() && recorder->counts()[0].written != written_before_stop) last_ns = stamp();
    const auto counts = recorder->counts();
    if (counts.empty()) throw std::runtime_error("the recorder never subscribed to " + topic);
    const auto& c = counts.at(0);
    r.received = c.received;
    r.written = c.written;
    r.dropped = c.dropped;
    r.lost = c.lost;
    r.bytes = recorder->bytesWritten();
    r.file_bytes = fs::file_size(file);
  } else {
    r.lost = discard.lostSamples();
    discard = bus::Subscription();
    r.received = received;
    r.bytes = bytes;
  }
  r.seconds = (last_ns - first_ns) * 1e-9;
  r.cpu_s = cpuSeconds() - cpu0;
  if (WIFEXITED(status) && WEXITSTATUS(status) != 0) spdlog::warn("publisher exited with {}", WEXITSTATUS(status));
  return r;
}

struct DiskResult {
  std::string compression;
  double seconds = 0;
  std::uint64_t input_bytes = 0, file_bytes = 0;
};

// The payloads of the disk-only runs: the benchmark's own messages, or those of one topic of a recording.
std::vector<std::vector<std::uint8_t>> diskPayloads(const std::string& kind, const std::string& from_file,
                                                    const std::string& from_topic) {
  std::vector<std::vector<std::uint8_t>> payloads;
  if (!from_file.empty()) {
    record::McapReader r(from_file);
    r.forEachMessage([&](const record::MessageView& m) {
      if (m.channel->topic == from_topic) payloads.emplace_back(m.data.begin(), m.data.end());
      return payloads.size() < 2000;
    });
    if (payloads.empty()) throw std::runtime_error(from_file + ": no message on topic " + from_topic);
    return payloads;
  }
  std::mt19937 rng(1);
  for (int i = 0; i < 4; ++i) {
    std::vector<std::uint8_t> b;
    if (kind == "cloud") {
      const auto c = makeCloud(kCloudPoints, i, rng);
      const auto& ts = msg::type_support<msg::PointCloud>();
      b.resize(ts.serialized_size(&c));
      b.resize(ts.serialize(&c, b.data(), b.size()));
    } else {
      const auto s = makeState(i);
      const auto& ts = msg::type_support<msg::VehicleState>();
      b.resize(ts.serialized_size(&s));
      b.resize(ts.serialize(&s, b.data(), b.size()));
    }
    payloads.push_back(std::move(b));
  }
  return payloads;
}

// McapWriter as the recorder drives it: each payload arrives in a buffer of its own (the recorder's queue
// item) and is handed over; buffers come back from the writer and are refilled for the next messages.
// The refill stands for the DDS side's copy and is not counted in the writer's time.
DiskResult diskOnly(const std::vector<std::vector<std::uint8_t>>& payloads, int count, record::Compression compression,
                    int level, unsigned threads, std::size_t chunk_kb, const fs::path& file) {
  DiskResult r;
  r.compression = (compression == record::Compression::Zstd  ? "zstd" + std::to_string(level)
                   : compression == record::Compression::Lz4 ? "lz4" + std::to_string(level)
                                                             : std::string("none")) +
                  "/" + std::to_string(threads) + "t";
  std::vector<std::vector<std::uint8_t>> spare;
  double refill_s = 0;
  const auto t0 = Clock::now();
  {
    record::McapWriterOptions options;
    options.compression = compression;
    options.zstd_level = level;
    options.lz4_level = level;
    options.compression_threads = threads;
    options.chunk_size = chunk_kb * 1024;
    record::McapWriter w(file.string(), options);
    const auto ch = w.addChannel(0, "bench", "cdr");
    for (int i = 0; i < count; ++i) {
      const auto& p = payloads[i % payloads.size()];
      const auto f0 = Clock::now();
      std::vector<std::uint8_t> buffer;
      if (!spare.empty()) {
        buffer.swap(spare.back());
        spare.pop_back();
      }
      buffer.assign(p.begin(), p.end());
      refill_s += std::chrono::duration<double>(Clock::now() - f0).count();
      w.write(ch, i, i, std::move(buffer));
      for (auto& b : w.takeReleasedBuffers()) spare.push_back(std::move(b));
      r.input_bytes += p.size();
    }
    w.close();
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count() - refill_s;
  r.file_bytes = fs::file_size(file);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Recording throughput: recorder vs. a discarding raw subscription, and MCAP write cost."};
  std::string role = "bench";
  RunSpec spec;
  spec.dds = "fastdds";
  spec.kind = "cloud";
  spec.qos = "reliable";
  int repeats = 1, disk_count = 0;
  double rate = -1;
  std::string out_dir = fs::temp_directory_path().string();
  std::vector<std::string> sinks = {"discard", "record-none", "record-zstd", "record-lz4"};
  std::vector<int> levels = {1, 3};
  std::vector<int> lz4_levels = {0};
  bool json = false, no_disk = false, no_dds = false;
  std::string disk_from, disk_topic = "sensors/points";
  app.add_option("--role", role)->check(CLI::IsMember({"bench", "publish"}));
  app.add_option("--dds", spec.dds, "vendor of the receiving process (discard / recorder)");
  app.add_option("--pub-dds", spec.pub_dds, "vendor of the publishing process (default: --dds)");
  app.add_option("--domain", spec.domain)->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--kind", spec.kind, "cloud (1 MB) | small (~100 B)")->check(CLI::IsMember({"cloud", "small"}));
  app.add_option("--qos", spec.qos, "publisher reliability")->check(CLI::IsMember({"reliable", "best-effort"}));
  app.add_option("--count", spec.count, "messages per run (default: 300 clouds, 50000 small)")->check(CLI::PositiveNumber);
  app.add_option("--rate", rate, "publisher msgs/s, 0 = flood (default: 100 clouds/s, 20000 small/s)")->check(CLI::NonNegativeNumber);
  app.add_option("--repeats", repeats, "runs per sink")->check(CLI::PositiveNumber);
  app.add_option("--sinks", sinks, "comma separated: discard, record-none, record-zstd, record-lz4")->delimiter(',')
      ->check(CLI::IsMember({"discard", "record-none", "record-zstd", "record-lz4"}));
  app.add_option("--chunk-kb", spec.chunk_kb, "recorder / disk chunk size")->check(CLI::Range(1, 1 << 20));
  app.add_option("--zstd-level", spec.zstd_level, "recorder zstd level (negative: zstd's fast levels)")->check(CLI::Range(-50, 19));
  app.add_option("--lz4-level", spec.lz4_level, "recorder lz4 level (0 default, negative: faster)")->check(CLI::Range(-65537, 12));
  app.add_option("--compression-threads", spec.compression_threads, "recorder compression workers (-1: one per core)")
      ->check(CLI::Range(-1, 64));
  app.add_option("--writer-nice", spec.writer_nice, "recorder writer/worker nice increment")->check(CLI::Range(0, 19));
  app.add_option("--queue-mb", spec.queue_mb, "recorder queue limit")->check(CLI::Range(1, 1 << 16));
  double preallocate_mb = -1;
  app.add_option("--preallocate-mb", preallocate_mb, "as ddsnav record's (default: the queue size, at most 1024; 0: none)")
      ->check(CLI::Range(0.0, 1048576.0));
  app.add_option("--disk-count", disk_count, "messages for the disk-only runs (default: 1000 clouds, 1000000 small)")
      ->check(CLI::PositiveNumber);
  app.add_option("--disk-levels", levels, "zstd levels for the disk-only runs")->delimiter(',');
  app.add_option("--disk-lz4-levels", lz4_levels, "lz4 levels for the disk-only runs")->delimiter(',');
  app.add_option("--disk-from", disk_from, "disk-only runs: payloads of --disk-topic from this recording (real data)")
      ->check(CLI::ExistingFile);
  app.add_option("--disk-topic", disk_topic, "topic of --disk-from");
  app.add_flag("--no-disk", no_disk, "skip the disk-only runs");
  app.add_flag("--no-dds", no_dds, "only the disk-only runs");
  app.add_option("--dir", out_dir, "where the recordings are written (and removed)");
  app.add_flag("--json", json, "one JSON document instead of a table");
  CLI11_PARSE(app, argc, argv);
  if (spec.count <= 0) spec.count = spec.kind == "cloud" ? 300 : 50000;
  spec.rate = rate >= 0 ? rate : spec.kind == "cloud" ? 100 : 20000;
  if (spec.pub_dds.empty()) spec.pub_dds = spec.dds;
  try {
    bus::parseVendor(spec.dds);
    bus::parseVendor(spec.pub_dds);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddsnav-bench-record: %s\n", e.what());
    return 2;
  }
  if (role == "publish") return runPublisher(spec.pub_dds, spec.domain, spec.kind, spec.count, spec.rate, spec.qos);
  // The sinks run in this process, on the allocator settings and resident payload memory `ddsnav record`
  // has (recorder.hpp); no thread exists yet. The discarding sink gets them too: one process, one allocator.
  record::configureAllocatorForRecording();
  spec.resident_bytes = preallocate_mb >= 0 ? static_cast<std::size_t>(preallocate_mb * (1 << 20))
                                            : record::defaultPayloadPreallocation(spec.queue_mb << 20);

  // A bad --dir is a usage error, said once, before any process starts.
  {
    std::error_code ec;
    if (!fs::is_directory(out_dir, ec)) {
      std::fprintf(stderr, "ddsnav-bench-record: --dir %s: not an existing folder\n", out_dir.c_str());
      return 2;
    }
    if (::access(out_dir.c_str(), W_OK | X_OK) != 0) {
      std::fprintf(stderr, "ddsnav-bench-record: --dir %s: not writable: %s\n", out_dir.c_str(), std::strerror(errno));
      return 2;
    }
  }

  spdlog::set_level(spdlog::level::warn);
  const std::string self = fs::canonical("/proc/self/exe").string();
  const fs::path file = fs::path(out_dir) / ("ddsnav-bench-record-" + std::to_string(::getpid()) + ".mcap");
  nlohmann::json report;
  report["kind"] = spec.kind;
  report["dds"] = spec.dds;
  report["pub_dds"] = spec.pub_dds;
  report["qos"] = spec.qos;
  report["count"] = spec.count;
  report["rate"] = spec.rate;
  report["resident_payload_mb"] = spec.resident_bytes >> 20;
  std::map<std::string, std::vector<double>> delivered_fraction, cpu_per_msg;
  bool all_accounted = true;
  if (!json && !no_dds)
    std::printf("%s -> %s, %s %s, %d sent at %s\n", spec.pub_dds.c_str(), spec.dds.c_str(), spec.qos.c_str(), spec.kind.c_str(),
                spec.count, spec.rate > 0 ? (std::to_string(static_cast<long>(spec.rate)) + "/s").c_str() : "flood");
  if (!json && !no_dds) std::printf("payload memory made resident before each run: %zu MB\n", spec.resident_bytes >> 20);
  for (int rep = 0; rep < repeats && !no_dds; ++rep) {
    for (const std::string& sink : sinks) {
      Result r;
      try {
        r = runSink(self, spec, sink, file);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "ddsnav-bench-record: %s run failed: %s\n", sink.c_str(), e.what());
        fs::remove(file);
        return 1;
      }
      fs::remove(file);
      all_accounted = all_accounted && r.unaccounted() == 0;
      report["dds_runs"].push_back({{"sink", r.sink}, {"sent", r.sent}, {"received", r.received}, {"written", r.written},
                                    {"lost", r.lost}, {"queue_dropped", r.dropped}, {"unaccounted", r.unaccounted()},
                                    {"seconds", r.seconds}, {"msgs_per_s", r.msgs_per_s()},
                                    {"mb_per_s", r.mb_per_s()}, {"close_s", r.close_s}, {"file_bytes", r.file_bytes},
                                    {"cpu_s", r.cpu_s}, {"cpu_us_per_msg", r.cpu_us_per_msg()}});
      cpu_per_msg[sink].push_back(r.cpu_us_per_msg());
      delivered_fraction[sink].push_back(static_cast<double>(r.delivered()) / static_cast<double>(r.sent));
      if (!json)
        std::printf("%-12s sent %7llu received %7llu lost %6llu dropped %6llu written %7llu unaccounted %5lld  %9.1f msg/s %7.1f MB/s  cpu %7.1f us/msg  close %.3f s\n",
                    r.sink.c_str(), static_cast<unsigned long long>(r.sent), static_cast<unsigned long long>(r.received),
                    static_cast<unsigned long long>(r.lost), static_cast<unsigned long long>(r.dropped),
                    static_cast<unsigned long long>(r.written), static_cast<long long>(r.unaccounted()), r.msgs_per_s(), r.mb_per_s(),
                    r.cpu_us_per_msg(), r.close_s);
    }
  }
  // Worst run of each sink against the worst discard run: the figure the targets are stated in.
  auto worst = [](const std::vector<double>& v) { return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end()); };
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
  };
  for (const char* s : {"record-none", "record-zstd", "record-lz4"}) {
    if (delivered_fraction.count(s) == 0) continue;
    const double base = worst(delivered_fraction["discard"]);
    report["worst_delivered_fraction"][s] = worst(delivered_fraction[s]);
    if (!json) {
      std::printf("%s: worst delivered %.3f of sent", s, worst(delivered_fraction[s]));
      if (base > 0) std::printf(" = %.3f of the worst discard run", worst(delivered_fraction[s]) / base);
      if (!cpu_per_msg["discard"].empty())
        std::printf("; median CPU/msg %.2fx discard", median(cpu_per_msg[s]) / std::max(1e-9, median(cpu_per_msg["discard"])));
      std::printf("\n");
    }
  }
  if (!no_dds) {
    report["all_accounted"] = all_accounted;
    if (!json) std::printf("received + lost + dropped = sent in every run: %s\n", all_accounted ? "yes" : "NO");
  }
  // Disk only: same payloads straight into McapWriter, one thread and with the recorder's worker pool.
  if (!no_disk) {
    if (disk_count <= 0) disk_count = spec.kind == "cloud" ? 1000 : 1000000;
    const unsigned workers = std::clamp(std::thread::hardware_concurrency(), 1u, 4u);
    std::vector<std::tuple<record::Compression, int, unsigned>> runs = {{record::Compression::None, 0, 0},
                                                                         {record::Compression::None, 0, 1}};
    for (int level : levels) {
      runs.emplace_back(record::Compression::Zstd, level, 0);
      runs.emplace_back(record::Compression::Zstd, level, workers);
    }
    for (int level : lz4_levels) {
      runs.emplace_back(record::Compression::Lz4, level, 0);
      runs.emplace_back(record::Compression::Lz4, level, workers);
    }
    std::vector<std::vector<std::uint8_t>> payloads;
    try {
      payloads = diskPayloads(spec.kind, disk_from, disk_topic);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "ddsnav-bench-record: --disk-from: %s\n", e.what());
      return 2;
    }
    if (!json && !disk_from.empty()) {
      std::size_t total = 0;
      for (const auto& p : payloads) total += p.size();
      std::printf("disk payloads: %zu messages of %s from %s, mean %.1f KB\n", payloads.size(), disk_topic.c_str(), disk_from.c_str(),
                  total / 1e3 / payloads.size());
    }
    for (const auto& [compression, level, threads] : runs) {
      const DiskResult d = diskOnly(payloads, disk_count, compression, level, threads, spec.chunk_kb, file);
      fs::remove(file);
      report["disk_runs"].push_back({{"compression", d.compression}, {"messages", disk_count}, {"seconds", d.seconds},
                                     {"input_mb_per_s", d.input_bytes / 1e6 / d.seconds},
                                     {"file_bytes", d.file_bytes}, {"input_bytes", d.input_bytes},
                                     {"ratio", static_cast<double>(d.input_bytes) / d.file_bytes}});
      if (!json)
        std::printf("disk %-11s chunk %5zu KB %8d msgs  %7.3f s  %8.1f MB/s in  file %8.1f MB  ratio %.2f\n", d.compression.c_str(),
                    spec.chunk_kb, disk_count, d.seconds, d.input_bytes / 1e6 / d.seconds, d.file_bytes / 1e6,
                    static_cast<double>(d.input_bytes) / d.file_bytes);
    }
  }
  if (json) std::cout << report.dump(2) << '\n';
  return 0;
}
