#include <ddsnav/record/recorder.hpp>
#include <ddsnav/record/schemas.hpp>
#include <ddsnav/runtime/topics.hpp>

#include <spdlog/spdlog.h>

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace ddsnav::record {

namespace fs = std::filesystem;

namespace {

std::uint64_t nowNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

}  // namespace

TopicQos qosForTopic(const std::string& topic) {
  // The profiles ddsnav's components publish with: the stock topic table (runtime/topics.hpp), a
  // namespaced name ("uav1/sensors/points") included. Readers must ask no more than the writer offers: a
  // transient-local reader does not match a volatile writer, a reliable reader does not match a
  // best-effort writer.
  const runtime::TopicRow* row = runtime::findStockTopic(topic);
  return qosForProfile(row ? row->profile : "default", topic);
}

TopicQos qosForProfile(const std::string& profile, const std::string& topic) {
  // Depths: the recorder's callbacks only enqueue, so a few samples of reader history are plenty; a
  // state reader keeps 10 so a burst of latched samples (system/status, one per component) all arrive.
  if (profile == "sensorData") return {bus::Qos::sensorData(10), profile};
  if (profile == "state") return {bus::Qos::state(10), profile};
  if (profile == "commands") return {bus::Qos::commands(10), profile};
  if (profile == "default") return {bus::Qos::commands(10), profile};
  return qosForTopic(topic);
}

void configureAllocatorForRecording() {
#ifdef __GLIBC__
  mallopt(M_ARENA_MAX, 1);
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest: bigger blocks still get their own mmap
  mallopt(M_TRIM_THRESHOLD, INT_MAX);
#endif
}

std::size_t defaultPayloadPreallocation(std::size_t queue_bytes) { return std::min<std::size_t>(queue_bytes, 1u << 30); }

std::size_t prefaultPayloadMemory(std::size_t bytes) {
#ifdef DDSNAV_SANITIZED  // ASan / TSan builds (top-level CMakeLists.txt)
  // The sanitizers bring their own allocator, which neither keeps these pages for payloads nor needs the
  // help; touching them would only cost the instrumented tests memory and time.
  (void)bytes;
  return 0;
#else
  constexpr std::size_t kBlock = 1 << 20;
  const long page = ::sysconf(_SC_PAGESIZE), available = ::sysconf(_SC_AVPHYS_PAGES);
  if (page > 0 && available > 0) bytes = std::min(bytes, static_cast<std::size_t>(page) * static_cast<std::size_t>(available) / 2);
  std::vector<void*> blocks;
  blocks.reserve(bytes / kBlock);
  for (std::size_t done = 0; done + kBlock <= bytes; done += kBlock) {
    void* block = std::malloc(kBlock);
    if (block == nullptr) break;
    for (std::size_t i = 0; i < kBlock; i += 4096) static_cast<volatile char*>(block)[i] = 0;
    blocks.push_back(block);
  }
  for (void* block : blocks) std::free(block);
  return blocks.size() * kBlock;
#endif
}

Recorder::Recorder(bus::Participant& bus, RecorderOptions options) : bus_(bus), options_(std::move(options)) {
  if (options_.snapshot && options_.snapshot_duration.count() <= 0 && options_.snapshot_bytes == 0)
    throw std::invalid_argument("snapshot mode needs a duration or a size to keep in memory");
  if (options_.compression_threads < 0)
    options_.compression_threads = static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 4u));
  options_.mcap.compression_threads = static_cast<unsigned>(options_.compression_threads);
  options_.mcap.worker_nice = options_.writer_nice;
  // Snapshot mode opens a file per snapshot; otherwise the first file now, so a bad path fails here.
  if (!options_.snapshot) openFile();
  writer_thread_ = std::thread([this] { writerLoop(); });
}

Recorder::~Recorder() {
  try {
    stop();
  } catch (const std::exception& e) {
    spdlog::error("record: {}", e.what());
  }
}

std::string Recorder::filePath(std::size_t index) const {
  if (!options_.snapshot && options_.max_file_bytes == 0 && options_.max_file_duration.count() == 0) return options_.output;
  const fs::path out(options_.output);
  const std::string ext = out.has_extension() ? out.extension().string() : std::string(".mcap");
  return (out.parent_path() / (out.stem().string() + "_" + std::to_string(index) + ext)).string();
}

void Recorder::openFile() {
  // Called with writer_mutex_ held (or before the writer thread exists).
  file_path_ = filePath(file_index_);
  writer_ = std::make_unique<McapWriter>(file_path_, options_.mcap);
  file_opened_ = std::chrono::steady_clock::now();
  // First in the data section, so even a crashed recording says where it came from.
  writer_->addMetadata("ddsnav.recording", {{"vendor", options_.vendor_name},
                                            {"domain", std::to_string(options_.domain_id)},
                                            {"start_time_ns", std::to_string(nowNs())},
                                            {"file_index", std::to_string(file_index_)},
                                            {"mode", options_.snapshot ? "snapshot" : "continuous"}});
  // Every channel known so far, with the same ids, so each file stands alone.
  schemas_.clear();
  for (const ChannelDef& ch : channels_)
    writer_->addChannel(schemaFor(*writer_, schemas_, ch.type_name), ch.topic, "cdr", ch.metadata);
  ++file_index_;
}

void Recorder::closeFile() {
  // Called with writer_mutex_ held. Counts so far (cumulative since the recording began) go in every file.
  if (!writer_) return;
  StringMap counts;
  for (const TopicCounts& c : this->counts()) {
    counts[c.topic + ":received"] = std::to_string(c.received);
    counts[c.topic + ":written"] = std::to_string(c.written);
    counts[c.topic + ":dropped"] = std::to_string(c.dropped);
    counts[c.topic + ":lost"] = std::to_string(c.lost);
  }
  std::string not_discovered;
  for (const std::string& topic : notDiscovered()) not_discovered += (not_discovered.empty() ? "" : ",") + topic;
  // On failure writer_ stays, so setError() can tell which messages never reached the file.
  writer_->addMetadata("ddsnav.topic_counts", counts);
  writer_->addMetadata("ddsnav.recording_end",
                       {{"end_time_ns", std::to_string(nowNs())}, {"error", error_}, {"not_discovered", not_discovered}});
  writer_->close();
  for (auto& buffer : writer_->takeReleasedBuffers()) recycle(std::move(buffer));
  writer_.reset();
  files_written_.push_back(file_path_);
}

bool Recorder::wanted(const std::string& topic) const {
  return options_.topics.empty() || std::find(options_.topics.begin(), options_.topics.end(), topic) != options_.topics.end();
}

std::uint16_t Recorder::schemaFor(McapWriter& writer, std::map<std::string, std::uint16_t>& schemas, const std::string& type_name) {
  if (auto it = schemas.find(type_name); it != schemas.end()) return it->second;
  const std::optional<std::string> idl = idlSchemaFor(type_name);
  // A type this build does not define gets no schema (id 0) rather than a made-up one.
  const std::uint16_t id = idl ? writer.addSchema(type_name, "omgidl", *idl) : 0;
  schemas[type_name] = id;
  return id;
}

void Recorder::fallBackToBestEffort(Topic& topic) {
  // A topic outside the table was subscribed reliable; a best-effort publisher never matches that. If
  // nothing matched after a while, try best effort, which matches publishers of either kind.
  topic.checked_match = true;
  if (topic.subscription.matchedPublishers() > 0) return;
  Topic* raw = &topic;
  topic.lost_before += topic.subscription.lostSamples();
  topic.subscription = bus::Subscription();
  topic.qos = {bus::Qos::sensorData(kRecorderReaderDepth), "default-best-effort"};
  topic.subscription = bus_.subscribeRaw(topic.info, topic.qos.qos, [this, raw](const bus::RawSample& s) { onSample(*raw, s); });
  spdlog::info("record: {}: no reliable publisher matched in 2 s, subscribing best effort", topic.info.topic);
}

void Recorder::updateLost() {
  // Called with topics_mutex_ held. The vendors count lost samples in the reader's status; read it here
  // (the main loop, every 100 ms) rather than in a vendor callback.
  for (auto& t : topics_)
    if (t->subscription) t->lost.store(t->lost_before + t->subscription.lostSamples(), std::memory_order_relaxed);
}

void Recorder::poll() {
  {
    std::lock_guard lock(writer_mutex_);
    if (stopped_) return;
  }
  {
    std::lock_guard lock(topics_mutex_);
    updateLost();
    for (auto& t : topics_)
      if (!t->checked_match && t->qos.profile == "default" &&
          std::chrono::steady_clock::now() - t->subscribed_at > std::chrono::seconds(2)) {
        try {
          fallBackToBestEffort(*t);
        } catch (const std::exception& e) {
          spdlog::warn("record: {}: {}", t->info.topic, e.what());
        }
      }
  }
  for (const bus::TopicInfo& info : bus_.discoveredTopics()) {
    if (!wanted(info.topic)) continue;
    {
      std::lock_guard lock(topics_mutex_);
      if (!seen_.emplace(info.topic, info.type_name).second) continue;
    }
    auto topic = std::make_unique<Topic>();
    topic->info = info;
    topic->qos = qosForTopic(info.topic);
    // The profile's reliability and durability, with a reader history deep enough for a burst.
    topic->qos.qos.depth = std::max(topic->qos.qos.depth, kRecorderReaderDepth);
    {
      std::lock_guard lock(writer_mutex_);
      if (stopped_) return;
      ChannelDef def{info.type_name, info.topic,
                     {{"dds_type", info.type_name}, {"keyed", info.keyed ? "true" : "false"}, {"qos", topic->qos.profile}}};
      topic->channel = static_cast<std::uint16_t>(channels_.size());
      if (writer_) {
        try {
          const std::uint16_t id = writer_->addChannel(schemaFor(*writer_, schemas_, info.type_name), info.topic, "cdr", def.metadata);
          if (id != topic->channel) throw McapError(file_path_ + ": channel ids out of step");
        } catch (const std::exception& e) {
          setError(e.what());
        }
      }
      channels_.push_back(std::move(def));
    }
    Topic* raw = topic.get();
    try {
      topic->subscribed_at = std::chrono::steady_clock::now();
      topic->subscription = bus_.subscribeRaw(info, topic->qos.qos, [this, raw](const bus::RawSample& s) { onSample(*raw, s); });
    } catch (const std::exception& e) {
      const std::string why = info.topic + " (" + info.type_name + "): " + e.what();
      spdlog::warn("record: not recording {}", why);
      std::lock_guard lock(topics_mutex_);
      skipped_.push_back(why);
      continue;
    }
    spdlog::info("record: {} ({}, {})", info.topic, info.type_name, topic->qos.profile);
    std::lock_guard lock(topics_mutex_);
    topics_.push_back(std::move(topic));
  }
}

void Recorder::onSample(Topic& topic, const bus::RawSample& sample) {
  // Runs on a DDS thread: take the bytes (or copy them into a reused buffer), enqueue, return. Never waits
  // for the disk.
  topic.received.fetch_add(1, std::memory_order_relaxed);
  const std::size_t size = sample.payload.size();
  const std::uint64_t publish_time = static_cast<std::uint64_t>(std::max<std::int64_t>(0, sample.source_timestamp_ns));
  bool was_empty = false;
  {
    std::lock_guard lock(queue_mutex_);
    if (stopping_ || queue_.size() >= options_.queue_messages ||
        (queued_bytes_ + size > options_.queue_bytes && !queue_.empty())) {
      topic.dropped.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    std::vector<std::uint8_t> buffer;
    if (!spare_.empty()) {
      buffer.swap(spare_.back());
      spare_.pop_back();
      spare_bytes_ -= buffer.capacity();
    }
    if (sample.owned_payload != nullptr) {
      // The vendor's own buffer changes hands; it gets ours, with its capacity, for the next sample.
      buffer.swap(*sample.owned_payload);
    } else {
      buffer.assign(sample.payload.begin(), sample.payload.end());
    }
    // Log time is the receive time, kept non-decreasing so the file is in log-time order.
    last_log_time_ = std::max(last_log_time_, nowNs());
    was_empty = queue_.empty();
    queue_.push_back(Item{&topic, last_log_time_, publish_time, std::move(buffer)});
    queued_bytes_ += size;
  }
  // The writer only sleeps on an empty queue: waking it once per batch saves a syscall per sample.
  if (was_empty) queue_changed_.notify_one();
}

void Recorder::recycle(std::vector<std::uint8_t>&& buffer) {
  // Writer thread only. Collected here and handed back in one go when the next batch is taken (under the
  // queue lock the writer takes anyway): the DDS threads never wait for a low-priority writer holding
  // the lock once per message.
  if (buffer.capacity() > 0) freed_.push_back(std::move(buffer));
}

void Recorder::returnFreedBuffers() {
  // Called with queue_mutex_ held. Keep up to a quarter of the queue's byte limit: enough for a steady
  // stream. The rest stay in freed_ and are released by the writer after it lets go of the lock (a
  // burst of small messages can free thousands of buffers: not while a DDS callback waits for it).
  std::size_t kept = 0;
  for (auto& buffer : freed_) {
    if (spare_bytes_ + buffer.capacity() > options_.queue_bytes / 4 || spare_.size() >= 1024) break;
    spare_bytes_ += buffer.capacity();
    spare_.push_back(std::move(buffer));
    ++kept;
  }
  freed_.erase(freed_.begin(), freed_.begin() + static_cast<std::ptrdiff_t>(kept));
}

void Recorder::rotateIfDue() {
  // Called with writer_mutex_ held, in continuous mode.
  if (options_.max_file_bytes == 0 && options_.max_file_duration.count() == 0) return;
  const bool full = options_.max_file_bytes > 0 && writer_->bytesWritten() + writer_->bytesBuffered() >= options_.max_file_bytes;
  const bool old = options_.max_file_duration.count() > 0 && std::chrono::steady_clock::now() - file_opened_ >= options_.max_file_duration;
  if ((!full && !old) || writer_->messageCount() == 0) return;
  closeFile();
  spdlog::info("record: {} complete; continuing in {}", files_written_.back(), filePath(file_index_));
  openFile();
}

void Recorder::remember(Item&& item) {
  // Snapshot mode: keep the newest messages within the limits, forget the oldest.
  snapshot_buffer_bytes_ += item.payload.size();
  snapshot_buffer_.push_back(std::move(item));
  const std::uint64_t newest = snapshot_buffer_.back().log_time;
  const auto window = static_cast<std::uint64_t>(std::chrono::nanoseconds(options_.snapshot_duration).count());
  while (snapshot_buffer_.size() > 1 &&
         ((options_.snapshot_bytes > 0 && snapshot_buffer_bytes_ > options_.snapshot_bytes) ||
          (window > 0 && newest - snapshot_buffer_.front().log_time > window))) {
    snapshot_buffer_bytes_ -= snapshot_buffer_.front().payload.size();
    recycle(std::move(snapshot_buffer_.front().payload));
    snapshot_buffer_.pop_front();
  }
  snapshot_messages_.store(snapshot_buffer_.size());
}

void Recorder::writeSnapshot() {
  // Called with writer_mutex_ held.
  if (snapshot_buffer_.empty()) {
    spdlog::warn("record: snapshot requested, but no message has arrived yet: no file written");
    return;
  }
  const std::size_t count = snapshot_buffer_.size();
  openFile();
  for (Item& item : snapshot_buffer_) {
    writer_->write(item.topic->channel, item.log_time, item.publish_time, item.payload);
    item.topic->written.fetch_add(1, std::memory_order_relaxed);
    bytes_written_.fetch_add(item.payload.size(), std::memory_order_relaxed);
    total_written_.fetch_add(1);
  }
  closeFile();
  spdlog::info("record: snapshot of {} messages ({:.1f} MB, {:.1f} s) written to {}", count, snapshot_buffer_bytes_ / 1e6,
               (snapshot_buffer_.back().log_time - snapshot_buffer_.front().log_time) * 1e-9, files_written_.back());
}

void Recorder::requestSnapshot() { snapshot_requested_.store(true); queue_changed_.notify_one(); }

void Recorder::writerLoop() {
  if (options_.writer_nice != 0) lowerThreadPriority(options_.writer_nice);
  std::deque<Item> batch;
  for (;;) {
    bool finishing = false;
    {
      std::unique_lock lock(queue_mutex_);
      queue_changed_.wait_for(lock, std::chrono::milliseconds(100),
                              [&] { return !queue_.empty() || stopping_ || snapshot_requested_.load(); });
      batch.swap(queue_);
      queued_bytes_ = 0;
      finishing = stopping_;
      returnFreedBuffers();
    }
    freed_.clear();  // what the spare pool had no room for, released outside the queue lock
    std::lock_guard lock(writer_mutex_);
    for (Item& item : batch) {
      if (options_.snapshot) {
        remember(std::move(item));
        continue;
      }
      if (!error_.empty()) {
        // The file cannot take more (disk full, I/O error): count the rest as dropped.
        item.topic->dropped.fetch_add(1, std::memory_order_relaxed);
        recycle(std::move(item.payload));
        continue;
      }
      if (options_.write_delay.count() > 0) std::this_thread::sleep_for(options_.write_delay);
      try {
        rotateIfDue();
      } catch (const std::exception& e) {
        setError(e.what());
        item.topic->dropped.fetch_add(1, std::memory_order_relaxed);
        recycle(std::move(item.payload));
        continue;
      }
      // Counted before the write: if a chunk fails later, setError() moves every message that never
      // reached the file (this one included) from written to dropped.
      item.topic->written.fetch_add(1, std::memory_order_relaxed);
      const std::uint64_t total = total_written_.fetch_add(1) + 1;
      try {
        // Large payloads are not copied: the chunk keeps the buffer until it is in the file, then
        // hands it back (takeReleasedBuffers) for the next samples.
        const std::size_t size = item.payload.size();
        writer_->write(item.topic->channel, item.log_time, item.publish_time, std::move(item.payload));
        bytes_written_.fetch_add(size, std::memory_order_relaxed);
      } catch (const std::exception& e) {
        setError(e.what());
      }
      recycle(std::move(item.payload));
      if (options_.max_messages > 0 && total >= options_.max_messages) max_reached_.store(true);
    }
    batch.clear();
    if (writer_)
      for (auto& buffer : writer_->takeReleasedBuffers()) recycle(std::move(buffer));
    if (options_.snapshot && snapshot_requested_.exchange(false)) {
      try {
        writeSnapshot();
      } catch (const std::exception& e) {
        // A snapshot that cannot be written (disk full, folder gone): say so; the buffer is kept for the next.
        spdlog::error("record: snapshot failed: {}", e.what());
        writer_.reset();
      }
    }
    // Bounded loss on a crash: a chunk never stays open longer than chunk_age.
    if (error_.empty() && writer_) {
      try {
        writer_->flushAged();
      } catch (const std::exception& e) {
        setError(e.what());
      }
    }
    if (finishing) {
      std::lock_guard q(queue_mutex_);
      if (queue_.empty()) return;
    }
  }
}

void Recorder::setError(const std::string& what) {
  // Called with writer_mutex_ held.
  if (!error_.empty()) return;
  error_ = what;
  failed_.store(true);
  spdlog::error("record: {}; no more messages are written", what);
  // Messages counted as written when they went into a chunk that never reached the file: dropped.
  if (!writer_) return;
  const auto unwritten = writer_->unwrittenMessages();
  std::lock_guard lock(topics_mutex_);
  for (auto& t : topics_) {
    const auto it = unwritten.find(t->channel);
    if (it == unwritten.end()) continue;
    t->written.fetch_sub(it->second, std::memory_order_relaxed);
    t->dropped.fetch_add(it->second, std::memory_order_relaxed);
    total_written_.fetch_sub(it->second);
  }
}

std::string Recorder::error() const {
  std::lock_guard lock(writer_mutex_);
  return error_;
}

void Recorder::stop() {
  {
    std::lock_guard lock(writer_mutex_);
    if (stopped_) return;
    stopped_ = true;
  }
  // No callback runs after its Subscription is gone; then drain what they queued.
  {
    std::lock_guard lock(topics_mutex_);
    updateLost();
    for (auto& t : topics_) t->subscription = bus::Subscription();
  }
  {
    std::lock_guard lock(queue_mutex_);
    stopping_ = true;
  }
  queue_changed_.notify_all();
  if (writer_thread_.joinable()) writer_thread_.join();
  std::lock_guard lock(writer_mutex_);
  try {
    closeFile();
  } catch (const std::exception& e) {
    setError(e.what());
    throw;
  }
}

std::vector<TopicCounts> Recorder::counts() const {
  std::lock_guard lock(topics_mutex_);
  std::vector<TopicCounts> out;
  for (const auto& t : topics_)
    out.push_back({t->info.topic, t->info.type_name, t->qos.profile, t->received.load(), t->written.load(), t->dropped.load(),
                   t->lost.load()});
  return out;
}

std::vector<std::string> Recorder::filesWritten() const {
  std::lock_guard lock(writer_mutex_);
  return files_written_;
}

std::vector<std::string> Recorder::notDiscovered() const {
  std::lock_guard lock(topics_mutex_);
  std::vector<std::string> out;
  for (const std::string& topic : options_.topics) {
    const bool seen = std::any_of(seen_.begin(), seen_.end(), [&](const auto& s) { return s.first == topic; });
    if (!seen && std::find(out.begin(), out.end(), topic) == out.end()) out.push_back(topic);
  }
  return out;
}

std::vector<std::string> Recorder::skipped() const {
  std::lock_guard lock(topics_mutex_);
  return skipped_;
}

}  // namespace ddsnav::record
