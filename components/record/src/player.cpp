#include <ddsnav/msg/messages.hpp>
#include <ddsnav/msg/registry.hpp>
#include <ddsnav/record/recorder.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
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
  // Replayed heartbeats would make dead processes look alive, replayed progress reports would make a live
  // simulator wait for processes of the recording (its pacing); a recorded clock would fight --clock.
  if (topic == "system/status" || topic == "system/progress") return false;
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
  if (!std::isfinite(options.end_s)) throw std::invalid_argument("--end must be a finite number of seconds");
  if (options.end_s >= 0 && options.end_s < options.start_s)
    throw std::invalid_argument(fmt::format("--end {:g} s is before --start {:g} s", options.end_s, options.start_s));
  if (options.clock && !(options.clock_hz > 0)) throw std::invalid_argument("clock rate must be positive");

  auto inFile = [&](const std::string& t) {
    return std::any_of(file.channels().begin(), file.channels().end(), [&](const auto& c) { return c.second.topic == t; });
  };
  for (const std::string& t : options.topics)
    if (!inFile(t)) throw std::invalid_argument(file.path() + ": topic '" + t + "' is not in the recording");
  for (const auto& [from, to] : options.remap) {
    if (!inFile(from)) throw std::invalid_argument(file.path() + ": --remap " + from + "=" + to + ": topic '" + from + "' is not in the recording");
    if (to.empty()) throw std::invalid_argument("--remap " + from + "=: the new topic name is empty");
  }

  // One raw publisher per recorded channel, with the recorded type and QoS.
  std::map<std::uint16_t, Output> outputs;
  for (const auto& entry : file.channels()) {
    // Not a structured binding: the lambda below captures the channel, which clang before 16 refuses for one.
    const auto& channel = entry.second;
    Output& out = outputs[entry.first];
    const auto remapped = options.remap.find(channel.topic);
    out.topic = remapped == options.remap.end() ? channel.topic : remapped->second;
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
    if (!known)
      throw std::invalid_argument(file.path() + ": topic " + channel.topic + " carries type " + type +
                               ", which this build does not know; if it is a ddsnav_add_messages() type, list its "
                               "library in " + msg::kMessageLibrariesVariable +
                               " (e.g. " + msg::kMessageLibrariesVariable + "=/path/libmy_msgs.so), or leave the "
                               "topic out with --topics");
    const bool keyed = meta("keyed").empty() ? (known && known->keyed) : meta("keyed") == "true";
    try {
      // QoS by the recorded topic's profile: a remapped topic keeps the QoS it was recorded with.
      out.publisher = bus.rawPublisher({out.topic, type, keyed}, qosForProfile(meta("qos"), channel.topic).qos);
      out.enabled = true;
      if (out.topic != channel.topic) spdlog::info("play: {} -> {}", channel.topic, out.topic);
    } catch (const std::exception& e) {
      spdlog::warn("play: {} ({}): cannot publish: {}", out.topic, type, e.what());
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
  const std::uint64_t end = options.end_s >= 0 ? first + static_cast<std::uint64_t>(options.end_s * 1e9)
                                               : std::numeric_limits<std::uint64_t>::max();
  PlaybackProgress p;
  p.duration_s = static_cast<double>(summary.message_end_time - first) * 1e-9;
  using Clock = std::chrono::steady_clock;
  auto last_report = Clock::now();
  const auto clock_period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / options.clock_hz));
  PlaybackControl* control = options.control;
  auto report = [&](std::chrono::milliseconds every) {
    if (progress && Clock::now() - last_report > every) {
      p.paused = control && control->paused.load();
      progress(p);
      last_report = Clock::now();
    }
  };
  auto toWall = [&](std::uint64_t ns) { return std::chrono::nanoseconds(static_cast<std::int64_t>(static_cast<double>(ns) / options.rate)); };

  auto wall_start = Clock::now();
  for (;;) {
    std::uint64_t attempted = 0;  // messages this pass reached the publish step
    std::uint64_t last_time = begin;
    // Recorded time -> wall time: offset from `begin`, divided by the rate.
    auto due = [&](std::uint64_t log_time) { return wall_start + toWall(log_time - begin); };
    auto recordedNow = [&] {
      const auto elapsed = std::chrono::duration<double>(Clock::now() - wall_start).count();
      return begin + static_cast<std::uint64_t>(elapsed * options.rate * 1e9);
    };
    auto publishClock = [&](std::uint64_t t) {
      msg::Clock c;
      c.stamp_ns(static_cast<std::int64_t>(t));
      clock.publish(c);
    };
    // Paused: wall time stands still for the recording. Returns true when one step was granted.
    auto holdWhilePaused = [&]() {
      if (control == nullptr || !control->paused.load()) return false;
      const auto paused_at = Clock::now();
      while (control->paused.load() && !stop.load()) {
        int steps = control->steps.load();
        if (steps > 0 && control->steps.compare_exchange_strong(steps, steps - 1)) {
          wall_start += Clock::now() - paused_at;
          return true;
        }
        report(std::chrono::milliseconds(100));
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      wall_start += Clock::now() - paused_at;
      return false;
    };
    auto next_tick = Clock::now();
    auto onDamaged = [&](const DamagedChunk& d) {
      ++p.damaged_chunks;
      spdlog::warn("play: skipping the damaged chunk at byte {} of {}: {}", d.offset, file.path(), d.reason);
    };
    file.forEachMessage([&](const MessageView& m) {
      if (stop.load()) return false;
      if (m.log_time < begin) return true;
      if (m.log_time > end) return false;  // ddsnav files are in log-time order
      Output& out = outputs[m.channel->id];
      if (!out.enabled) return true;
      // Sleep until the message is due, ticking the clock meanwhile.
      for (;;) {
        if (stop.load()) return false;
        if (holdWhilePaused()) {
          wall_start = Clock::now() - toWall(m.log_time - begin);  // the stepped message is due now
          break;
        }
        const auto now = Clock::now();
        if (options.clock && now >= next_tick) {
          publishClock(std::min<std::uint64_t>(recordedNow(), m.log_time));
          next_tick = now + clock_period;
        }
        const auto when = due(m.log_time);
        if (now >= when) break;
        auto wake = options.clock ? std::min(when, next_tick) : when;
        wake = std::min(wake, now + std::chrono::milliseconds(control ? 20 : 100));  // stay responsive to stop / pause
        std::this_thread::sleep_until(wake);
      }
      // The clock reaches the message's time before the message is out.
      if (options.clock) publishClock(m.log_time);
      ++attempted;
      last_time = m.log_time;
      try {
        out.publisher.publish(m.data);
        ++p.published;
      } catch (const std::exception& e) {
        if (p.failed++ == 0) spdlog::warn("play: {}: {}", out.topic, e.what());
      }
      p.recorded_s = static_cast<double>(m.log_time - first) * 1e-9;
      report(std::chrono::milliseconds(500));
      return true;
    }, onDamaged);
    // A pass with nothing to publish would repeat instantly forever under --loop; without it, it is still
    // a replay that did nothing. Either way the caller gets the reason.
    if (attempted == 0 && !stop.load()) {
      const std::string why = p.damaged_chunks > 0 && summary.message_count > 0
                                  ? "every chunk holding the replayed messages is damaged (see warnings)"
                                  : whyNothingPlays(file, options, outputs, begin);
      throw std::runtime_error(file.path() + ": nothing to play: " + why);
    }
    if (!options.loop || stop.load()) break;
    ++p.passes;
    // The next pass starts one mean message interval after this pass's last message, as the recording's
    // own rhythm would continue, and never sooner than kMinLoopPass after this pass began.
    const auto span = toWall(last_time - begin);
    const auto gap = attempted > 1 ? span / static_cast<std::int64_t>(attempted - 1) : std::chrono::nanoseconds(0);
    const auto next_start = wall_start + std::max<std::chrono::nanoseconds>(span + gap, kMinLoopPass);
    while (!stop.load() && Clock::now() < next_start) {
      std::this_thread::sleep_until(std::min(next_start, Clock::now() + std::chrono::milliseconds(20)));
      report(std::chrono::milliseconds(500));
    }
    wall_start = std::max(next_start, Clock::now() - std::chrono::milliseconds(0));
  }
  p.paused = control && control->paused.load();
  if (progress) progress(p);
  // Reliable samples not yet acknowledged are resent on the writer's next heartbeat, and the writers are
  // `outputs`: they must outlive the last message by a while, or the tail is lost (ddsnav play delivered
  // one of five readings to a Fast DDS reader in 3 of 5 runs while its wait ran after the writers were gone).
  const auto linger_end = Clock::now() + options.linger;
  while (p.published > 0 && !stop.load() && Clock::now() < linger_end)
    std::this_thread::sleep_for(std::min<Clock::duration>(linger_end - Clock::now(), std::chrono::milliseconds(100)));
  return p;
}

}  // namespace ddsnav::record
