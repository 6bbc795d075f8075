// One process's side of a benchmark link: send numbered samples of a fixed payload size on three
// topics (ping, pong, stream) and get told when one arrives. Implemented over the ddsnav bus and over
// each vendor's own API, so the bus overhead is a measured ratio.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace ddsnav::bench {

enum Topic : int { kPing = 0, kPong = 1, kStream = 2 };
inline const char* topicName(int t) { return t == kPing ? "bench/ping" : t == kPong ? "bench/pong" : "bench/stream"; }

// Called on a receive thread with the topic, the sample's sequence number and its payload bytes.
using ReceiveFn = std::function<void(int topic, std::int64_t seq, std::size_t payload)>;

struct LinkOptions {
  bool cyclone = false;       // vendor of this process
  bool shared_memory = true;  // Fast DDS: SHM + UDP, else UDP only
  int domain = 0;
  std::size_t payload = 1024;  // bytes of the sequence<octet> in each sample
  bool pinger = true;          // pinger: writes ping + stream, reads pong; else the reverse
  std::string security_dir;    // bus only: DDS Security with identity bench-bus from this directory
  ReceiveFn on_receive;
};

class Link {
 public:
  virtual ~Link() = default;
  // Returns false when the vendor refused the sample (history full); the caller retries.
  virtual bool send(int topic, std::int64_t seq) = 0;
  // Readers matched to this process's writers, summed over its writers.
  virtual std::size_t matchedReaders() = 0;
};

std::unique_ptr<Link> makeBusLink(const LinkOptions& options);
std::unique_ptr<Link> makeNativeFastLink(const LinkOptions& options);
std::unique_ptr<Link> makeNativeCycloneLink(const LinkOptions& options);

// Reliable, volatile, keep last: what both paths use.
inline constexpr int kDepth = 32;

}  // namespace ddsnav::bench
