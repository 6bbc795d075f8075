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

// Memory for floods (docs/record.md, "Payload memory kept warm"). A 1 MB sample copied into memory the
// process never touched costs ~470 us of page faults on the DDS thread, ten times the copy into resident
// memory: at a flood of 1 MB clouds that alone made the receive thread too slow and the publisher gave
// samples up. So a recording process keeps its payload memory resident and reuses it:
//
// configureAllocatorForRecording() — first thing in main(), before any thread starts: one glibc malloc
// arena for all threads (so a buffer the DDS thread frees is reused by the next one it allocates, and
// memory touched by main() serves every thread), blocks up to 32 MB from the heap instead of each its own
// mmap, and freed memory kept instead of handed back to the system. No-op with another allocator.
void configureAllocatorForRecording();
// Touches `bytes` of heap now, in whole 1 MB blocks, and frees them: the first payloads of a flood land in
// these resident pages. Capped at half of the memory available now; returns the bytes touched (0 in ASan and
// TSan builds, whose allocators keep nothing of it).
std::size_t prefaultPayloadMemory(std::size_t bytes);
// What to prefault when the user says nothing: the memory a full queue would hold anyway, at most 1 GB.
std::size_t defaultPayloadPreallocation(std::size_t queue_bytes);

struct RecorderOptions {
  std::string output;                 // .mcap path (with splitting or snapshots: the name files are numbered from)
  std::vector<std::string> topics;    // empty: every topic discovered
  McapWriterOptions mcap;
  int compression_threads = -1;       // chunk CRC/compression workers; -1: one per core (at most 4)
  // Nice increment of the writer thread and the workers: on a busy machine the DDS receive threads get
  // the CPU first (a late ack makes a reliable writer give samples up), the bounded queue absorbs the
  // difference, and the disk side catches up when reception idles.
  int writer_nice = 10;
  std::size_t queue_bytes = 256u << 20;   // samples waiting for the writer, in payload bytes
  std::size_t queue_messages = 100000;    // ... and in samples
  std::uint64_t max_messages = 0;         // stop once this many are written (0: no limit)
  // Splitting: start the next file once this one holds this many bytes / spans this long (0: never).
  // Files are named <stem>_<N><ext> from N = 0, each a complete MCAP with every schema and channel.
  std::uint64_t max_file_bytes = 0;
  std::chrono::milliseconds max_file_duration{0};
  // Snapshot mode: nothing goes to disk until requestSnapshot(); the last snapshot_duration / snapshot_bytes
  // of messages are kept in memory (oldest forgotten first) and each snapshot writes them to the next
  // numbered file. Either limit may be 0 (unbounded), not both.
  bool snapshot = false;
  std::chrono::milliseconds snapshot_duration{0};
  std::uint64_t snapshot_bytes = 0;
  // Pause after every write: stands in for a slow disk in tests and benchmarks.
  std::chrono::microseconds write_delay{0};
  std::string vendor_name;            // stored in the file's metadata
  int domain_id = 0;
};

// Depth of the recorder's reader histories: room for a burst while a callback runs (the callbacks only
// hand the sample over, so it rarely holds more than one).
inline constexpr int kRecorderReaderDepth = 100;

struct TopicCounts {
  std::string topic;
  std::string type_name;
  std::string qos_profile;
  std::uint64_t received = 0;  // delivered by DDS
  std::uint64_t written = 0;   // in the file(s) (snapshot mode: in the snapshot buffer)
  std::uint64_t dropped = 0;   // received, never written: queue full or the file failed
  std::uint64_t lost = 0;      // never delivered by DDS: the reader's sample-lost + sample-rejected status
};

class Recorder {
 public:
  // Creates the (first) file (McapError when it cannot) and starts the writer thread.
  Recorder(bus::Participant& bus, RecorderOptions options);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Subscribes to topics discovered since the last call and refreshes the DDS loss counts. Call from one
  // thread (the main loop).
  void poll();
  // Ends the subscriptions, writes what is queued, stores per-topic counts in the file, closes it.
  void stop();
  // Snapshot mode: write the buffered messages to the next file (asynchronously, on the writer thread).
  void requestSnapshot();

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
  // Files completed (closed with their summary) so far, in order.
  std::vector<std::string> filesWritten() const;
  // Messages in the snapshot buffer now.
  std::size_t snapshotMessages() const { return snapshot_messages_.load(); }

 private:
  struct Topic {
    bus::TopicInfo info;
    TopicQos qos;
    std::uint16_t channel = 0;
    std::atomic<std::uint64_t> received{0}, written{0}, dropped{0}, lost{0};
    std::uint64_t lost_before = 0;  // by subscriptions this topic had before the current one
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
  struct ChannelDef {
    std::string type_name;
    std::string topic;
    StringMap metadata;
  };

  void onSample(Topic& topic, const bus::RawSample& sample);
  void fallBackToBestEffort(Topic& topic);
  void updateLost();
  void writerLoop();
  void rotateIfDue();
  void openFile();
  void closeFile();
  void writeSnapshot();
  void remember(Item&& item);
  void recycle(std::vector<std::uint8_t>&& buffer);
  void returnFreedBuffers();
  std::string filePath(std::size_t index) const;
  void setError(const std::string& what);
  bool wanted(const std::string& topic) const;
  std::uint16_t schemaFor(McapWriter& writer, std::map<std::string, std::uint16_t>& schemas, const std::string& type_name);

  bus::Participant& bus_;
  RecorderOptions options_;
  mutable std::mutex writer_mutex_;  // the McapWriter, channel definitions, files: writer thread + channel creation
  std::string error_;                // first write failure
  std::atomic<bool> failed_{false};
  std::unique_ptr<McapWriter> writer_;  // the open file; none between snapshots
  std::map<std::string, std::uint16_t> schemas_;  // of the open file
  std::vector<ChannelDef> channels_;  // every channel so far, by id: re-added to each new file
  std::size_t file_index_ = 0;
  std::string file_path_;
  std::chrono::steady_clock::time_point file_opened_;
  std::vector<std::string> files_written_;
  std::deque<std::unique_ptr<Topic>> topics_;
  std::vector<std::string> skipped_;
  std::set<std::pair<std::string, std::string>> seen_;
  mutable std::mutex topics_mutex_;

  std::mutex queue_mutex_;
  std::condition_variable queue_changed_;
  std::deque<Item> queue_;
  std::size_t queued_bytes_ = 0;
  std::vector<std::vector<std::uint8_t>> spare_;  // payload buffers to reuse (guarded by queue_mutex_)
  std::vector<std::vector<std::uint8_t>> freed_;  // written, not yet back in spare_ (writer thread only)
  std::size_t spare_bytes_ = 0;
  std::uint64_t last_log_time_ = 0;
  bool stopping_ = false;
  bool stopped_ = false;
  std::atomic<bool> snapshot_requested_{false};
  std::deque<Item> snapshot_buffer_;  // writer thread only
  std::uint64_t snapshot_buffer_bytes_ = 0;
  std::atomic<std::size_t> snapshot_messages_{0};
  std::atomic<std::uint64_t> total_written_{0};
  std::atomic<std::uint64_t> bytes_written_{0};
  std::atomic<bool> max_reached_{false};
  std::thread writer_thread_;
};

// Pause / resume / single step of a running play(), from another thread (the terminal keys).
struct PlaybackControl {
  std::atomic<bool> paused{false};
  std::atomic<int> steps{0};  // while paused: publish this many more messages, then stay paused
};

// A pass of --loop lasts at least this long, so a recording of one message (or many at one instant) is
// replayed at most 10 times a second instead of spinning a core.
inline constexpr std::chrono::milliseconds kMinLoopPass{100};

struct PlayerOptions {
  double rate = 1.0;                 // 2: twice as fast
  std::vector<std::string> topics;   // empty: every recorded topic except system/status and, with clock, system/clock
  std::map<std::string, std::string> remap;  // recorded topic -> topic published on (--remap from=to)
  bool loop = false;
  bool clock = false;                // publish msg::Clock on system/clock following the recorded time
  double clock_hz = 100.0;
  double start_s = 0.0;              // skip the first seconds of the recording
  double end_s = -1.0;               // stop at this many seconds from the recording's start (< 0: at its end)
  std::chrono::milliseconds wait_subscribers{2000};  // per topic, before the first message
  // After our writers see their subscribers, the subscribers may not see us yet (a Fast DDS participant is
  // discovered by Cyclone only at its next announcement): samples sent before that wait for the next
  // heartbeat or are lost on best-effort topics. This pause covers it.
  std::chrono::milliseconds settle{1000};
  // After the last message, the writers stay this long so reliable resends reach slow subscribers.
  std::chrono::milliseconds linger{1000};
  PlaybackControl* control = nullptr;  // optional: pause/step from outside
};

struct PlaybackProgress {
  std::uint64_t published = 0;
  std::uint64_t failed = 0;           // the vendor refused the payload
  std::uint64_t damaged_chunks = 0;   // skipped (each logged with its offset)
  std::uint64_t passes = 0;           // completed passes over the file (--loop)
  double recorded_s = 0;              // position in the recording, s from its start
  double duration_s = 0;
  bool paused = false;
};

// Replays a recording's raw payloads with their recorded timing. `stop` ends it early (signal handler
// flag); `progress` is called about every 0.5 s (every 0.1 s while paused). A damaged chunk is skipped
// with a warning naming its offset. Throws std::invalid_argument for bad options (unknown topic, start
// after end, remap of a topic not in the file) and std::runtime_error when nothing could be played.
PlaybackProgress play(bus::Participant& bus, const McapReader& file, const PlayerOptions& options,
                      const std::atomic<bool>& stop,
                      const std::function<void(const PlaybackProgress&)>& progress = {});

}  // namespace ddsnav::record
