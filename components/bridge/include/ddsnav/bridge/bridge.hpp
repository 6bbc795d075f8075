// `ddsnav bridge`: every topic of a DDS domain on a Foxglove WebSocket server (server.hpp), raw, plus the
// derived Foxglove channels (foxglove/derived.hpp). A thin adapter: discovery -> channels, raw samples ->
// publish, derivation on one worker thread (never on a DDS thread).
//
//   bus::Participant bus({.vendor = ..., .domain_id = 7, .name = "ddsnav-bridge"});
//   bridge::Bridge bridge(bus, {.server = {.port = 8765}});
//   for (;;) { bridge.poll(); sleep 100 ms; }
//
// Raw channels: the topic's name, its type's OMG IDL text (the recordings' schemas), `cdr` encoding, the
// DDS payload unchanged (encapsulation + XCDR1). A topic whose publishers are all gone for `gone_after`
// is unadvertised (with its derived channels) and advertised again when a publisher returns.
#pragma once

#include <ddsnav/bridge/server.hpp>
#include <ddsnav/bus/bus.hpp>
#include <ddsnav/foxglove/derived.hpp>

#include <chrono>
#include <condition_variable>
#include <atomic>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

namespace ddsnav::bridge {

struct BridgeOptions {
  ServerOptions server;
  foxglove::SceneDeriverOptions derive;           // the scenario, track and map limits
  std::size_t derive_queue = 64;                  // raw samples waiting for conversion; oldest dropped beyond
  std::chrono::milliseconds gone_after{3000};     // no matched publisher this long: channel unadvertised
};

struct BridgeStats {
  std::uint64_t received = 0;        // raw samples from the bus (all forwarded to the server)
  std::uint64_t derived = 0;         // derived messages published
  std::uint64_t derive_dropped = 0;  // raw samples not converted (conversion queue full)
  std::uint64_t derive_failed = 0;   // raw samples that could not be converted (bad values)
  std::map<std::string, std::uint64_t> received_by_topic;
  std::size_t advertised_topics = 0;
  ServerStats server;
};

class Bridge {
 public:
  // Starts the server (ServerError when the port is taken) and the conversion worker.
  Bridge(bus::Participant& bus, BridgeOptions options);
  ~Bridge();
  Bridge(const Bridge&) = delete;
  Bridge& operator=(const Bridge&) = delete;

  // Subscribes to newly discovered topics; unadvertises gone ones and re-advertises returning ones.
  // Call from one thread, e.g. every 100 ms.
  void poll();
  BridgeStats stats() const;
  std::uint16_t port() const { return server_.port(); }

 private:
  struct Topic {
    bus::TopicInfo info;
    bool latched = false;
    std::vector<foxglove::DerivedChannel> derived;
    std::atomic<std::uint32_t> channel{0};  // 0: not advertised (read on DDS threads)
    std::atomic<std::uint64_t> received{0};
    std::chrono::steady_clock::time_point last_matched;
    bus::Subscription subscription;
  };
  struct Work {
    const Topic* topic;
    std::shared_ptr<const std::vector<std::uint8_t>> payload;
  };

  void advertise(Topic& topic);
  void unadvertise(Topic& topic);
  void onSample(Topic& topic, const bus::RawSample& sample);
  void deriveLoop();
  std::uint32_t derivedChannelId(const std::string& derived_topic);

  bus::Participant& bus_;
  BridgeOptions options_;
  FoxgloveServer server_;
  mutable std::mutex topics_mutex_;            // the container (poll adds, stats reads)
  std::deque<std::unique_ptr<Topic>> topics_;  // stable addresses for the callbacks
  std::set<std::pair<std::string, std::string>> seen_;
  std::atomic<std::uint64_t> received_{0}, derived_{0}, derive_dropped_{0}, derive_failed_{0};

  mutable std::mutex channels_mutex_;                                        // derived channel table
  std::map<std::string, std::pair<std::uint32_t, int>> derived_channels_;    // topic -> (id, sources advertising it)

  std::mutex queue_mutex_;
  std::condition_variable queue_changed_;
  std::deque<Work> queue_;
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace ddsnav::bridge
