// Recording and replaying DDS traffic as raw payloads in MCAP files (docs/record.md).
//
// The recorder subscribes raw to every discovered topic (or a chosen set), with QoS by the topic's
// intent, and hands the bytes to one writer thread through a bounded queue: DDS threads only copy and
// enqueue, so a slow disk costs dropped samples (counted per topic), never a stalled reader.
#pragma once

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/record/mcap.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace ddsnav::record {

// The QoS a topic is recorded and replayed with. The bus does not report a publisher's QoS, so it comes
// from the table of ddsnav topic names (the same profiles the components publish with); unknown topics
// get "default": reliable, volatile, which matches reliable publishers of any durability.
struct TopicQos {
  bus::Qos qos;
  std::string profile;  // "sensorData" | "state" | "commands" | "default"
};
TopicQos qosForTopic(const std::string& topic);
// The profile named in a recording's channel metadata (falls back to the table for unknown names).
TopicQos qosForProfile(const std::string& profile, const std::string& topic);

struct RecorderOptions {
  std::string output;                 // .mcap path
  std::vector<std::string> topics;    // empty: every topic discovered
  McapWriterOptions mcap;
  std::size_t queue_bytes = 256u << 20;   // samples waiting for the writer, in payload bytes
  std::size_t queue_messages = 100000;    // ... and in samples
  std::uint64_t max_messages = 0;         // stop once this many are written (0: no limit)
  // Pause after every write: stands in for a slow disk in tests and benchmarks.
  std::chrono::microseconds write_delay{0};
  std::string vendor_name;            // stored in the file's metadata
  int domain_id = 0;
};

struct TopicCounts {
  std::string topic;
  std::string type_name;
  std::string qos_profile;
  std::uint64_t received = 0;  // delivered by DDS
  std::uint64_t written = 0;   // in the file
  std::uint64_t dropped = 0;   // queue full: never written
};

class Recorder {
 public:
  // Creates the file (McapError when it cannot) and starts the writer thread.
  Recorder(bus::Participant& bus, RecorderOptions options);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Subscribes to topics discovered since the last call. Call from one thread (the main loop).
  void poll();
  // Ends the subscriptions, writes what is queued, stores per-topic counts in the file, closes it.
  void stop();

  std::vector<TopicCounts> counts() const;
  std::uint64_t bytesWritten() const { return bytes_written_.load(); }
  bool reachedMaxMessages() const { return max_reached_.load(); }
  // True once writing failed (disk full, I/O error); error() says why. Later samples count as dropped.
  bool failed() const { return failed_.load(); }
  std::string error() const;
  // Topics the recorder could not subscribe to (type unknown to this build, type conflicts), with why.
  std::vector<std::string> skipped() const;
  // Topics asked for with RecorderOptions::topics that no publisher ever announced (a typo, or a component
  // that never started): nothing of them is in the file.
  std::vector<std::string> notDiscovered() const;
  std::uint64_t messagesWritten() const { return total_written_.load(); }

 private:
  struct Topic {
    bus::TopicInfo info;
    TopicQos qos;
    std::uint16_t channel = 0;
    std::atomic<std::uint64_t> received{0}, written{0}, dropped{0};
    bus::Subscription subscription;
    std::chrono::steady_clock::time_point subscribed_at;
    bool checked_match = false;
  };
  struct Item {
    Topic* topic;
    std::uint64_t log_time;
    std::uint64_t publish_time;
    std::vector<std::uint8_t> payload;
  };

  void onSample(Topic& topic, const bus::RawSample& sample);
  void fallBackToBestEffort(Topic& topic);
  void writerLoop();
  void setError(const std::string& what);
  bool wanted(const std::string& topic) const;
  std::uint16_t schemaFor(const std::string& type_name);

  bus::Participant& bus_;
  RecorderOptions options_;
  mutable std::mutex writer_mutex_;  // the McapWriter: writer thread + channel creation
  std::string error_;                // first write failure
  std::atomic<bool> failed_{false};
  McapWriter writer_;
  std::map<std::string, std::uint16_t> schemas_;
  std::deque<std::unique_ptr<Topic>> topics_;
  std::vector<std::string> skipped_;
  std::set<std::pair<std::string, std::string>> seen_;
  mutable std::mutex topics_mutex_;

  std::mutex queue_mutex_;
  std::condition_variable queue_changed_;
  std::deque<Item> queue_;
  std::size_t queued_bytes_ = 0;
  std::uint64_t last_log_time_ = 0;
  bool stopping_ = false;
  bool stopped_ = false;
  std::atomic<std::uint64_t> total_written_{0};
  std::atomic<std::uint64_t> bytes_written_{0};
  std::atomic<bool> max_reached_{false};
  std::thread writer_thread_;
};

struct PlayerOptions {
  double rate = 1.0;                 // 2: twice as fast
  std::vector<std::string> topics;   // empty: every recorded topic except system/status and, with clock, system/clock
  bool loop = false;
  bool clock = false;                // publish msg::Clock on system/clock following the recorded time
  double clock_hz = 100.0;
  double start_s = 0.0;              // skip the first seconds of the recording
  std::chrono::milliseconds wait_subscribers{2000};  // per topic, before the first message
  // After our writers see their subscribers, the subscribers may not see us yet (a Fast DDS participant is
  // discovered by Cyclone only at its next announcement): samples sent before that wait for the next
  // heartbeat or are lost on best-effort topics. This pause covers it.
  std::chrono::milliseconds settle{1000};
};

struct PlaybackProgress {
  std::uint64_t published = 0;
  std::uint64_t failed = 0;           // the vendor refused the payload
  double recorded_s = 0;              // position in the recording, s from its start
  double duration_s = 0;
};

// Replays a recording's raw payloads with their recorded timing. `stop` ends it early (signal handler
// flag); `progress` is called about every 0.5 s.
PlaybackProgress play(bus::Participant& bus, const McapReader& file, const PlayerOptions& options,
                      const std::atomic<bool>& stop,
                      const std::function<void(const PlaybackProgress&)>& progress = {});

}  // namespace ddsnav::record
