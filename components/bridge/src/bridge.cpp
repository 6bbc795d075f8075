#include <ddsnav/bridge/bridge.hpp>
#include <ddsnav/foxglove/schemas.hpp>
#include <ddsnav/record/recorder.hpp>
#include <ddsnav/record/schemas.hpp>

#include <spdlog/spdlog.h>

namespace ddsnav::bridge {
namespace {

std::uint64_t nowNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

// Clouds and transforms are streams; every other derived view is state a new subscriber needs at once.
bool latchedView(const std::string& schema_name) {
  return schema_name != "foxglove.PointCloud" && schema_name != "foxglove.FrameTransform";
}

ChannelSpec derivedSpec(const foxglove::DerivedChannel& c) {
  return {c.topic, std::string(foxglove::kMessageEncoding), c.schema_name, foxglove::jsonSchema(c.schema_name).dump(),
          std::string(foxglove::kSchemaEncoding), latchedView(c.schema_name)};
}

}  // namespace

Bridge::Bridge(bus::Participant& bus, BridgeOptions options)
    : bus_(bus), options_(std::move(options)), server_(options_.server) {
  worker_ = std::thread([this] { deriveLoop(); });
  // The scenario scene: published once, latched for every client.
  const foxglove::SceneDeriver standing(options_.derive);
  for (const auto& m : standing.standingMessages(static_cast<std::int64_t>(nowNs()))) {
    const auto id = derivedChannelId(m.channel.topic);
    server_.publish(id, m.stamp_ns, std::span(reinterpret_cast<const std::uint8_t*>(m.json.data()), m.json.size()));
  }
}

Bridge::~Bridge() {
  {
    std::lock_guard lock(queue_mutex_);
    stopping_ = true;
  }
  queue_changed_.notify_all();
  for (auto& t : topics_) t->subscription = {};  // no callback after this
  if (worker_.joinable()) worker_.join();
}

std::uint32_t Bridge::derivedChannelId(const std::string& derived_topic) {
  std::lock_guard lock(channels_mutex_);
  auto it = derived_channels_.find(derived_topic);
  if (it != derived_channels_.end()) return it->second.first;
  // Standing channels (the scenario) are advertised on first use and kept.
  for (const auto& c : foxglove::SceneDeriver(options_.derive).standingChannels())
    if (c.topic == derived_topic) return derived_channels_.emplace(c.topic, std::pair{server_.addChannel(derivedSpec(c)), 1}).first->second.first;
  return 0;
}

void Bridge::advertise(Topic& t) {
  const auto idl = record::idlSchemaFor(t.info.type_name);
  t.channel = server_.addChannel({t.info.topic, "cdr", t.info.type_name, idl.value_or(""), idl ? "omgidl" : "", t.latched});
  std::lock_guard lock(channels_mutex_);
  for (const auto& c : t.derived) {
    auto [it, added] = derived_channels_.try_emplace(c.topic, 0, 0);
    if (it->second.second++ == 0) it->second.first = server_.addChannel(derivedSpec(c));
  }
}

void Bridge::unadvertise(Topic& t) {
  server_.removeChannel(t.channel);
  t.channel = 0;
  std::lock_guard lock(channels_mutex_);
  for (const auto& c : t.derived) {
    auto it = derived_channels_.find(c.topic);
    if (it != derived_channels_.end() && --it->second.second == 0) {
      server_.removeChannel(it->second.first);
      derived_channels_.erase(it);
    }
  }
}

void Bridge::poll() {
  const auto now = std::chrono::steady_clock::now();
  for (const auto& info : bus_.discoveredTopics()) {
    if (!seen_.insert({info.topic, info.type_name}).second) continue;
    const auto qos = record::qosForTopic(info.topic);
    auto t = std::make_unique<Topic>();
    t->info = info;
    t->latched = qos.profile == "state";
    t->derived = foxglove::SceneDeriver::channelsFor(info.topic, info.type_name);
    t->last_matched = now;
    Topic& topic = *t;
    try {
      topic.subscription = bus_.subscribeRaw(info, qos.qos, [this, &topic](const bus::RawSample& s) { onSample(topic, s); });
    } catch (const bus::BusError& e) {
      spdlog::warn("bridge: {} ({}) not bridged: {}", info.topic, info.type_name, e.what());
      continue;
    }
    advertise(topic);
    spdlog::info("bridge: {} ({}, {}){}", info.topic, info.type_name, qos.profile,
                 topic.derived.empty() ? "" : " + " + std::to_string(topic.derived.size()) + " Foxglove view(s)");
    std::lock_guard lock(topics_mutex_);
    topics_.push_back(std::move(t));
  }
  for (auto& t : topics_) {
    if (t->subscription.matchedPublishers() > 0) {
      t->last_matched = now;
      if (t->channel == 0) {
        spdlog::info("bridge: {} is back", t->info.topic);
        advertise(*t);
      }
    } else if (t->channel != 0 && now - t->last_matched >= options_.gone_after) {
      spdlog::info("bridge: {} has no publisher any more; unadvertised", t->info.topic);
      unadvertise(*t);
    }
  }
}

void Bridge::onSample(Topic& topic, const bus::RawSample& sample) {
  // A DDS thread: copy once, hand over, return.
  ++received_;
  ++topic.received;
  auto payload = std::make_shared<const std::vector<std::uint8_t>>(sample.payload.begin(), sample.payload.end());
  const std::uint32_t channel = topic.channel;
  if (channel != 0) server_.publish(channel, nowNs(), payload);
  if (topic.derived.empty()) return;
  {
    std::lock_guard lock(queue_mutex_);
    if (queue_.size() >= options_.derive_queue) {
      queue_.pop_front();
      ++derive_dropped_;
    }
    queue_.push_back({&topic, std::move(payload)});
  }
  queue_changed_.notify_one();
}

void Bridge::deriveLoop() {
  foxglove::SceneDeriver derive(options_.derive);
  std::uint64_t failures_logged = 0;
  for (;;) {
    Work work;
    {
      std::unique_lock lock(queue_mutex_);
      queue_changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      work = std::move(queue_.front());
      queue_.pop_front();
    }
    try {
      for (const auto& m : derive.onSample(work.topic->info.topic, work.topic->info.type_name, *work.payload)) {
        std::uint32_t id = 0;
        {
          std::lock_guard lock(channels_mutex_);
          if (auto it = derived_channels_.find(m.channel.topic); it != derived_channels_.end()) id = it->second.first;
        }
        if (id == 0) continue;  // its source was unadvertised meanwhile
        server_.publish(id, static_cast<std::uint64_t>(m.stamp_ns),
                        std::make_shared<const std::vector<std::uint8_t>>(m.json.begin(), m.json.end()));
        ++derived_;
      }
    } catch (const foxglove::ConversionError& e) {
      // One bad message is not the end of the bridge; say so, but not thousands of times.
      if (derive_failed_++ < 10 || ++failures_logged % 1000 == 0) spdlog::warn("bridge: no Foxglove view: {}", e.what());
    }
  }
}

BridgeStats Bridge::stats() const {
  BridgeStats s;
  s.received = received_;
  s.derived = derived_;
  s.derive_dropped = derive_dropped_;
  s.derive_failed = derive_failed_;
  std::lock_guard lock(topics_mutex_);
  for (const auto& t : topics_) {
    s.received_by_topic[t->info.topic] = t->received;
    if (t->channel != 0) ++s.advertised_topics;
  }
  s.server = server_.stats();
  return s;
}

}  // namespace ddsnav::bridge
