#include <ddsnav/record/recorder.hpp>
#include <ddsnav/record/schemas.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>

namespace ddsnav::record {

namespace {

std::uint64_t nowNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

}  // namespace

TopicQos qosForTopic(const std::string& topic) {
  // The profiles ddsnav's components publish with (idl/*.idl comments, docs/record.md). Readers must ask
  // no more than the writer offers: a transient-local reader does not match a volatile writer, a reliable
  // reader does not match a best-effort writer.
  static const std::map<std::string, std::string> table = {
      {"sensors/points", "sensorData"},        {"vehicle/state", "sensorData"},
      {"system/clock", "sensorData"},          {"control/tracking", "sensorData"},
      {"map/octomap", "state"},                {"perception/obstacles", "state"},
      {"planning/path", "state"},              {"control/trajectory", "state"},
      {"system/status", "state"},              {"planning/request", "commands"},
      {"control/cmd_vel", "commands"},
  };
  const auto it = table.find(topic);
  return qosForProfile(it == table.end() ? "default" : it->second, topic);
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

Recorder::Recorder(bus::Participant& bus, RecorderOptions options)
    : bus_(bus), options_(std::move(options)), writer_(options_.output, options_.mcap) {
  // First in the data section, so even a crashed recording says where it came from.
  writer_.addMetadata("ddsnav.recording", {{"vendor", options_.vendor_name},
                                           {"domain", std::to_string(options_.domain_id)},
                                           {"start_time_ns", std::to_string(nowNs())}});
  writer_thread_ = std::thread([this] { writerLoop(); });
}

Recorder::~Recorder() {
  try {
    stop();
  } catch (const std::exception& e) {
    spdlog::error("record: {}", e.what());
  }
}

bool Recorder::wanted(const std::string& topic) const {
  return options_.topics.empty() || std::find(options_.topics.begin(), options_.topics.end(), topic) != options_.topics.end();
}

std::uint16_t Recorder::schemaFor(const std::string& type_name) {
  if (auto it = schemas_.find(type_name); it != schemas_.end()) return it->second;
  const std::optional<std::string> idl = idlSchemaFor(type_name);
  // A type this build does not define gets no schema (id 0) rather than a made-up one.
  const std::uint16_t id = idl ? writer_.addSchema(type_name, "omgidl", *idl) : 0;
  schemas_[type_name] = id;
  return id;
}

void Recorder::fallBackToBestEffort(Topic& topic) {
  // A topic outside the table was subscribed reliable; a best-effort publisher never matches that. If
  // nothing matched after a while, try best effort, which matches publishers of either kind.
  topic.checked_match = true;
  if (topic.subscription.matchedPublishers() > 0) return;
  Topic* raw = &topic;
  topic.subscription = bus::Subscription();
  topic.qos = {bus::Qos::sensorData(10), "default-best-effort"};
  topic.subscription = bus_.subscribeRaw(topic.info, topic.qos.qos, [this, raw](const bus::RawSample& s) { onSample(*raw, s); });
  spdlog::info("record: {}: no reliable publisher matched in 2 s, subscribing best effort", topic.info.topic);
}

void Recorder::poll() {
  {
    std::lock_guard lock(writer_mutex_);
    if (stopped_) return;
  }
  {
    std::lock_guard lock(topics_mutex_);
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
    {
      std::lock_guard lock(writer_mutex_);
      if (stopped_) return;
      const std::uint16_t schema = schemaFor(info.type_name);
      topic->channel = writer_.addChannel(schema, info.topic, "cdr",
                                          {{"dds_type", info.type_name},
                                           {"keyed", info.keyed ? "true" : "false"},
                                           {"qos", topic->qos.profile}});
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
  // Runs on a DDS thread: copy, enqueue, return. Never waits for the disk.
  topic.received.fetch_add(1, std::memory_order_relaxed);
  const std::size_t size = sample.payload.size();
  bool was_empty = false;
  {
    std::lock_guard lock(queue_mutex_);
    if (stopping_ || queue_.size() >= options_.queue_messages ||
        (queued_bytes_ + size > options_.queue_bytes && !queue_.empty())) {
      topic.dropped.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    // Log time is the receive time, kept non-decreasing so the file is in log-time order.
    last_log_time_ = std::max(last_log_time_, nowNs());
    was_empty = queue_.empty();
    queue_.push_back(Item{&topic, last_log_time_, static_cast<std::uint64_t>(std::max<std::int64_t>(0, sample.source_timestamp_ns)),
                          std::vector<std::uint8_t>(sample.payload.begin(), sample.payload.end())});
    queued_bytes_ += size;
  }
  // The writer only sleeps on an empty queue: waking it once per batch saves a syscall per sample.
  if (was_empty) queue_changed_.notify_one();
}

void Recorder::writerLoop() {
  std::deque<Item> batch;
  for (;;) {
    {
      std::unique_lock lock(queue_mutex_);
      queue_changed_.wait_for(lock, std::chrono::milliseconds(100), [&] { return !queue_.empty() || stopping_; });
      batch.swap(queue_);
      queued_bytes_ = 0;
      if (batch.empty() && stopping_) return;
    }
    std::lock_guard lock(writer_mutex_);
    for (Item& item : batch) {
      if (!error_.empty()) {
        // The file cannot take more (disk full, I/O error): count the rest as dropped.
        item.topic->dropped.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      if (options_.write_delay.count() > 0) std::this_thread::sleep_for(options_.write_delay);
      try {
        writer_.write(item.topic->channel, item.log_time, item.publish_time, item.payload);
      } catch (const std::exception& e) {
        setError(e.what());
        item.topic->dropped.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      item.topic->written.fetch_add(1, std::memory_order_relaxed);
      bytes_written_.fetch_add(item.payload.size(), std::memory_order_relaxed);
      const std::uint64_t total = total_written_.fetch_add(1) + 1;
      if (options_.max_messages > 0 && total >= options_.max_messages) max_reached_.store(true);
    }
    batch.clear();
    // Bounded loss on a crash: a chunk never stays open longer than chunk_age.
    if (error_.empty()) {
      try {
        writer_.flushAged();
      } catch (const std::exception& e) {
        setError(e.what());
      }
    }
  }
}

void Recorder::setError(const std::string& what) {
  // Called with writer_mutex_ held.
  if (!error_.empty()) return;
  error_ = what;
  failed_.store(true);
  spdlog::error("record: {}; no more messages are written", what);
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
    for (auto& t : topics_) t->subscription = bus::Subscription();
  }
  {
    std::lock_guard lock(queue_mutex_);
    stopping_ = true;
  }
  queue_changed_.notify_all();
  if (writer_thread_.joinable()) writer_thread_.join();

  StringMap counts;
  for (const TopicCounts& c : this->counts()) {
    counts[c.topic + ":received"] = std::to_string(c.received);
    counts[c.topic + ":written"] = std::to_string(c.written);
    counts[c.topic + ":dropped"] = std::to_string(c.dropped);
  }
  std::string not_discovered;
  for (const std::string& topic : notDiscovered()) not_discovered += (not_discovered.empty() ? "" : ",") + topic;
  std::lock_guard lock(writer_mutex_);
  writer_.addMetadata("ddsnav.topic_counts", counts);
  writer_.addMetadata("ddsnav.recording_end",
                      {{"end_time_ns", std::to_string(nowNs())}, {"error", error_}, {"not_discovered", not_discovered}});
  writer_.close();
}

std::vector<TopicCounts> Recorder::counts() const {
  std::lock_guard lock(topics_mutex_);
  std::vector<TopicCounts> out;
  for (const auto& t : topics_)
    out.push_back({t->info.topic, t->info.type_name, t->qos.profile, t->received.load(), t->written.load(), t->dropped.load()});
  return out;
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
