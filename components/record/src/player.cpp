#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/recorder.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <thread>

namespace ddsnav::record {

namespace {

struct Output {
  bool enabled = false;
  bus::RawPublisher publisher;
  std::string topic;
};

bool chosen(const PlayerOptions& options, const std::string& topic) {
  if (!options.topics.empty()) return std::find(options.topics.begin(), options.topics.end(), topic) != options.topics.end();
  // Replayed heartbeats would make dead processes look alive; a recorded clock would fight --clock.
  if (topic == "system/status") return false;
  if (options.clock && topic == "system/clock") return false;
  return true;
}

// Why no message of `file` passes the player's filters (only called when none did).
std::string whyNothingPlays(const McapReader& file, const PlayerOptions& options, const std::map<std::uint16_t, Output>& outputs,
                            std::uint64_t begin) {
  const McapSummary& summary = file.summary();
  if (summary.message_count == 0) return "the recording holds no messages";
  std::uint64_t playable = 0;
  for (const auto& [id, out] : outputs) {
    const auto n = summary.channel_message_counts.find(id);
    if (out.enabled && n != summary.channel_message_counts.end()) playable += n->second;
  }
  if (playable == 0) {
    std::string topics;
    for (const auto& [id, out] : outputs)
      if (out.enabled) topics += (topics.empty() ? "" : ", ") + out.topic;
    return topics.empty() ? "no recorded topic can be replayed (chosen by --topics, publishable, see warnings above)"
                          : "the replayed topics (" + topics + ") have no messages in the recording";
  }
  if (begin > summary.message_end_time)
    return fmt::format("--start {:g} s is past the end of the recording ({:.3f} s long)", options.start_s,
                       static_cast<double>(summary.message_end_time - summary.message_start_time) * 1e-9);
  return fmt::format("no message of the replayed topics at or after --start {:g} s", options.start_s);
}

}  // namespace

PlaybackProgress play(bus::Participant& bus, const McapReader& file, const PlayerOptions& options,
                      const std::atomic<bool>& stop, const std::function<void(const PlaybackProgress&)>& progress) {
  if (!(options.rate > 0) || !std::isfinite(options.rate)) throw std::invalid_argument("--rate must be a positive number");
  if (!(options.start_s >= 0) || !std::isfinite(options.start_s)) throw std::invalid_argument("--start must be >= 0 s");
  if (options.clock && !(options.clock_hz > 0)) throw std::invalid_argument("clock rate must be positive");

  for (const std::string& t : options.topics) {
    const bool found = std::any_of(file.channels().begin(), file.channels().end(), [&](const auto& c) { return c.second.topic == t; });
    if (!found) throw std::invalid_argument(file.path() + ": topic '" + t + "' is not in the recording");
  }

  // One raw publisher per recorded channel, with the recorded type and QoS.
  std::map<std::uint16_t, Output> outputs;
  for (const auto& [id, channel] : file.channels()) {
    Output& out = outputs[id];
    out.topic = channel.topic;
    if (!chosen(options, channel.topic)) continue;
    auto meta = [&](const std::string& key) {
      const auto it = channel.metadata.find(key);
      return it == channel.metadata.end() ? std::string() : it->second;
    };
    std::string type = meta("dds_type");
    if (type.empty()) {
      const auto s = file.schemas().find(channel.schema_id);
      if (s != file.schemas().end()) type = s->second.name;
    }
    if (type.empty()) {
      spdlog::warn("play: {}: channel has no type name; skipped", channel.topic);
      continue;
    }
    const msg::TypeSupport* known = msg::find_type_support(type);
    const bool keyed = meta("keyed").empty() ? (known && known->keyed) : meta("keyed") == "true";
    try {
      out.publisher = bus.rawPublisher({channel.topic, type, keyed}, qosForProfile(meta("qos"), channel.topic).qos);
      out.enabled = true;
    } catch (const std::exception& e) {
      spdlog::warn("play: {} ({}): cannot publish: {}", channel.topic, type, e.what());
    }
  }
  bus::Publisher<msg::Clock> clock;
  if (options.clock) clock = bus.publisher<msg::Clock>("system/clock", bus::Qos::sensorData(1));

  // Subscribers that start with us need a moment to match; wait for each topic a little, not forever.
  bool any_matched = false;
  for (auto& [id, out] : outputs) {
    if (!out.enabled || stop.load()) continue;
    if (out.publisher.waitForSubscribers(1, options.wait_subscribers))
      any_matched = true;
    else
      spdlog::info("play: no subscriber on {} yet; publishing anyway", out.topic);
  }
  if (any_matched && !stop.load()) std::this_thread::sleep_for(options.settle);

  const auto& summary = file.summary();
  const std::uint64_t first = summary.message_start_time;
  const std::uint64_t begin = first + static_cast<std::uint64_t>(options.start_s * 1e9);
  PlaybackProgress p;
  p.duration_s = static_cast<double>(summary.message_end_time - first) * 1e-9;
  using Clock = std::chrono::steady_clock;
  auto last_report = Clock::now();
  const auto clock_period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / options.clock_hz));

  do {
    const auto wall_start = Clock::now();
    std::uint64_t attempted = 0;  // messages this pass reached the publish step
    // Recorded time -> wall time: offset from `begin`, divided by the rate.
    auto due = [&](std::uint64_t log_time) {
      return wall_start + std::chrono::nanoseconds(static_cast<std::int64_t>(static_cast<double>(log_time - begin) / options.rate));
    };
    auto recordedNow = [&] {
      const auto elapsed = std::chrono::duration<double>(Clock::now() - wall_start).count();
      return begin + static_cast<std::uint64_t>(elapsed * options.rate * 1e9);
    };
    auto publishClock = [&](std::uint64_t t) {
      msg::Clock c;
      c.stamp_ns(static_cast<std::int64_t>(t));
      clock.publish(c);
    };
    auto next_tick = Clock::now();
    file.forEachMessage([&](const MessageView& m) {
      if (stop.load()) return false;
      if (m.log_time < begin) return true;
      Output& out = outputs[m.channel->id];
      if (!out.enabled) return true;
      const auto when = due(m.log_time);
      // Sleep until the message is due, ticking the clock meanwhile.
      for (;;) {
        if (stop.load()) return false;
        const auto now = Clock::now();
        if (options.clock && now >= next_tick) {
          publishClock(std::min<std::uint64_t>(recordedNow(), m.log_time));
          next_tick = now + clock_period;
        }
        if (now >= when) break;
        auto wake = options.clock ? std::min(when, next_tick) : when;
        wake = std::min(wake, now + std::chrono::milliseconds(100));  // stay responsive to `stop`
        std::this_thread::sleep_until(wake);
      }
      // The clock reaches the message's time before the message is out.
      if (options.clock) publishClock(m.log_time);
      ++attempted;
      try {
        out.publisher.publish(m.data);
        ++p.published;
      } catch (const std::exception& e) {
        if (p.failed++ == 0) spdlog::warn("play: {}: {}", out.topic, e.what());
      }
      p.recorded_s = static_cast<double>(m.log_time - first) * 1e-9;
      if (progress && Clock::now() - last_report > std::chrono::milliseconds(500)) {
        progress(p);
        last_report = Clock::now();
      }
      return true;
    });
    // A pass with nothing to publish would repeat instantly forever under --loop; without it, it is still
    // a replay that did nothing. Either way the caller gets the reason.
    if (attempted == 0 && !stop.load()) throw std::runtime_error(file.path() + ": nothing to play: " + whyNothingPlays(file, options, outputs, begin));
  } while (options.loop && !stop.load());
  if (progress) progress(p);
  return p;
}

}  // namespace ddsnav::record
