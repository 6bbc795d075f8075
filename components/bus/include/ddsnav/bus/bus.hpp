// ddsnav bus: publish/subscribe of the generated message classes over Fast DDS or Cyclone DDS, the vendor
// chosen at run time per process. No vendor header is included here; both vendors are linked in.
//
//   #include <ddsnav/bus/bus.hpp>
//   #include <ddsnav/msg/messages.hpp>
//   using namespace ddsnav;
//
//   bus::Participant bus({.vendor = bus::parseVendor("cyclonedds"), .domain_id = 7, .name = "mapper"});
//   auto pub = bus.publisher<msg::OccupancyMap>("map/octomap", bus::Qos::state());
//   bus::Subscription sub = bus.subscribe<msg::PointCloud>("sensors/points", bus::Qos::sensorData(),
//       [&](const msg::PointCloud& cloud) { /* runs on a bus thread */ });
//   msg::OccupancyMap map;  ...  pub.publish(map);
//
//   // Tests and simple loops: a queue instead of a callback.
//   bus::Inbox<msg::Path> paths = bus.inbox<msg::Path>("planning/path", bus::Qos::state());
//   std::optional<msg::Path> p = paths.wait(std::chrono::seconds(5));
//
//   // Raw (serialized) data, for record/replay: find what is published, take and give bytes.
//   std::optional<bus::TopicInfo> t = bus.waitForTopic("sensors/points", std::chrono::seconds(2));
//   bus::Subscription rec = bus.subscribeRaw(*t, bus::Qos::sensorData(), [](const bus::RawSample& s) {});
//   bus::RawPublisher out = bus.rawPublisher(*t, bus::Qos::sensorData());
//   out.publish(bytes);  // 4-byte encapsulation + XCDR1 body, as RawSample::payload
//
// Intra-process delivery (ParticipantOptions::intra_process, what `ddsnav container` turns on): a sample
// published in this process reaches this process's subscriptions of the same vendor and domain as the
// message object itself -- publish(std::shared_ptr<const T>) shares it, publish(const T&) copies it once --
// without serialization, while other processes still get it over DDS (docs/bus.md, "Intra-process").
//
// Threads: callbacks run on the vendor's receive/listener threads (an intra-process sample's, on the
// publishing thread). One subscription's callbacks never
// overlap, different subscriptions' callbacks may run concurrently. Keep them short; publishing from a
// callback is fine. A Subscription (or Inbox) stops its callbacks when destroyed; destroy subscriptions
// before the state their callbacks use.
//
// Network: every participant is loopback-only with no multicast unless ParticipantOptions::network (or
// $DDSNAV_NETWORK, $DDSNAV_PEERS, $DDSNAV_MULTICAST) names an interface and unicast peers (docs/bus.md).
// Security: with ParticipantOptions::security_dir (or $DDSNAV_SECURITY) the participant authenticates,
// is access-controlled and encrypts on either vendor (docs/security.md); its files are checked before the
// vendor sees them and any failure throws BusError: never a silent fall-back to an unsecured participant.
#pragma once

#include <ddsnav/msg/type_support.hpp>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace ddsnav::bus {

// Every error the bus reports: unknown vendor, domain out of range, topic type mismatch, failed write...
class BusError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Vendor { FastDDS, CycloneDDS };

// "fastdds" or "cyclonedds" (also "fast", "cyclone"); throws BusError naming the accepted values.
Vendor parseVendor(std::string_view name);
std::string_view vendorName(Vendor vendor);  // "fastdds" | "cyclonedds"
// DDSNAV_DDS from the environment, or fallback when unset. Throws BusError when set to something unknown.
Vendor vendorFromEnvironment(Vendor fallback = Vendor::FastDDS);

// RTPS port mapping (7400 + 250 * domain + ...) keeps a domain id within [0, 232].
inline constexpr int kMaxDomainId = 232;
// DDSNAV_DOMAIN from the environment, or fallback when unset or empty. The whole value must be a decimal
// integer in [0, kMaxDomainId] ("abc", "5x", "300" are refused): throws std::invalid_argument naming the
// variable and the value, so a typo never silently lands on another domain.
int domainFromEnvironment(int fallback = 0);

enum class Reliability { BestEffort, Reliable };
enum class Durability { Volatile, TransientLocal };

// QoS by intent. History is always KEEP_LAST `depth` (per instance for keyed types); for transient-local
// topics the same depth is what late joiners receive on both vendors (Cyclone's durability service
// history is set to it explicitly). Writer and reader of a topic should use the same profile.
struct Qos {
  Reliability reliability = Reliability::Reliable;
  Durability durability = Durability::Volatile;
  int depth = 10;

  // Best effort, volatile: newest data matters, old data is useless (clouds, vehicle state, clock).
  static Qos sensorData(int depth = 5) { return {Reliability::BestEffort, Durability::Volatile, depth}; }
  // Reliable, volatile: commands and requests that must arrive (plan requests, velocity commands).
  static Qos commands(int depth = 10) { return {Reliability::Reliable, Durability::Volatile, depth}; }
  // Reliable, transient local: latched state a late joiner needs (map, obstacles, path, status).
  static Qos state(int depth = 1) { return {Reliability::Reliable, Durability::TransientLocal, depth}; }
};

// Where a participant talks. The default (empty interface) is loopback only, without multicast.
struct NetworkOptions {
  std::string interface;           // a network interface name ("eth0"); its IPv4 address is used
  std::vector<std::string> peers;  // hosts (IPv4 or names) discovered by unicast; this host is always added
  bool multicast = false;          // also discover by multicast on the interface
};

// A network from $DDSNAV_NETWORK (interface), $DDSNAV_PEERS (comma-separated) and $DDSNAV_MULTICAST
// (1/true/0/false); an empty interface (loopback) when DDSNAV_NETWORK is unset. Throws BusError on
// peers or multicast given without an interface, or a multicast value that is not a boolean.
NetworkOptions networkFromEnvironment();

// DDSNAV_FAST_SHM: 0/false/off leaves Fast DDS participants without their shared-memory transport (UDP on the
// same interface only), 1/true/on or unset keeps it. For hosts or containers whose /dev/shm is small or not
// shared, and for ThreadSanitizer runs (docs/fuzzing.md). Anything else throws BusError naming the variable.
bool fastSharedMemoryFromEnvironment();

// "a,b , c" -> {"a","b","c"}; throws BusError on an empty entry.
std::vector<std::string> parsePeers(std::string_view text);

struct ParticipantOptions {
  Vendor vendor = Vendor::FastDDS;
  int domain_id = 0;            // [0, kMaxDomainId]
  std::string name = "ddsnav";  // participant name, shown by DDS tools
  // Fast DDS only: false leaves only UDPv4 (benchmarks compare SHM against UDP). Unset:
  // fastSharedMemoryFromEnvironment().
  std::optional<bool> fast_shared_memory;
  // Unset: networkFromEnvironment(). An interface that does not exist (or has no IPv4 address) or a peer
  // that does not resolve throws BusError before any participant is created.
  std::optional<NetworkOptions> network;
  // DDS Security directory (`ddsnav security init`). Unset: $DDSNAV_SECURITY when set, else off; an empty
  // string: off whatever the environment says.
  std::optional<std::string> security_dir;
  // Identity within security_dir; empty: the participant name without a leading "ddsnav-".
  std::string identity;
  // Deliver samples between this process's intra-process participants (same vendor and domain) as objects,
  // not over DDS; unkeyed typed topics only (keyed ones, e.g. system/status, and raw endpoints use DDS).
  bool intra_process = false;
};

// What a subscriber learns besides the sample itself.
struct SampleInfo {
  std::int64_t source_timestamp_ns = 0;  // writer's clock when the sample was written
  // Which writer sent it: equal for the samples of one writer, different between writers of one reader
  // (the vendor's publication handle, folded to 64 bits on Fast DDS). Tells requesters apart.
  std::uint64_t publication_handle = 0;
};

// One serialized sample as carried on the wire.
struct RawSample {
  std::string topic;
  std::string type_name;
  std::span<const std::uint8_t> payload;  // encapsulation (4 bytes) + XCDR1 body; valid during the callback
  std::int64_t source_timestamp_ns = 0;
  // When not null, the vector that holds `payload` (Fast DDS): the callback may take the bytes without a
  // copy by swapping in another vector (best with capacity for the next sample); `payload` is then stale.
  std::vector<std::uint8_t>* owned_payload = nullptr;
};

// A topic seen on the bus (from discovery of publishers, local ones included).
struct TopicInfo {
  std::string topic;
  std::string type_name;
  bool keyed = false;
  bool operator==(const TopicInfo&) const = default;
};

namespace detail {
class ParticipantImpl;
class WriterImpl;
class ReaderImpl;
class LocalWriter;
using SampleCallback = std::function<void(const void* sample, const SampleInfo& info)>;
// Receives a sample as a shared object: from DDS a fresh copy, from this process the publisher's object.
using SharedCallback = std::function<void(std::shared_ptr<const void> sample, const SampleInfo& info)>;
// The intra-process side of a publisher: whether any local subscription (or a transient-local history)
// wants the object, handing it over, and whether DDS must still get the sample (another process, or a
// late joiner of a transient-local topic, may want it).
bool localWanted(const LocalWriter& writer);
void localPublish(LocalWriter& writer, std::shared_ptr<const void> sample);
bool ddsWriteNeeded(const LocalWriter& writer, const WriterImpl& dds);
using RawCallback = std::function<void(const RawSample& sample)>;
void write(WriterImpl& writer, const void* sample);
std::uint64_t ddsWrites(const WriterImpl& writer);
std::size_t matchedReaders(const WriterImpl& writer);
std::size_t settledReaders(const WriterImpl& writer);
std::size_t matchedWriters(const ReaderImpl& reader);
std::uint64_t lostSamples(const ReaderImpl& reader);
// Polls the matched count every few ms until it is >= count; false on timeout.
bool waitMatched(const std::function<std::size_t()>& matched, std::size_t count,
                 std::chrono::milliseconds timeout);
}  // namespace detail

// Ends the subscription when destroyed: after the destructor returns, no callback runs.
class Subscription {
 public:
  Subscription() = default;
  explicit Subscription(std::shared_ptr<detail::ReaderImpl> impl) : impl_(std::move(impl)) {}
  std::size_t matchedPublishers() const { return impl_ ? detail::matchedWriters(*impl_) : 0; }
  // Samples this reader will never deliver, as the vendor counts them: the DDS SAMPLE_LOST status (gaps in
  // a writer's sequence numbers: dropped on the way for best effort, given up by the writer for reliable)
  // plus SAMPLE_REJECTED (no room in the reader's history). Cumulative since the subscription began.
  std::uint64_t lostSamples() const { return impl_ ? detail::lostSamples(*impl_) : 0; }
  bool waitForPublishers(std::size_t count, std::chrono::milliseconds timeout) const {
    return detail::waitMatched([this] { return matchedPublishers(); }, count, timeout);
  }
  explicit operator bool() const { return impl_ != nullptr; }

 private:
  std::shared_ptr<detail::ReaderImpl> impl_;
};

template <class T>
class Publisher {
 public:
  Publisher() = default;
  explicit Publisher(std::shared_ptr<detail::WriterImpl> impl, std::shared_ptr<detail::LocalWriter> local = {})
      : impl_(std::move(impl)), local_(std::move(local)) {}
  // Serializes once and hands the bytes to the vendor. Throws BusError when the vendor refuses. With
  // intra-process delivery: local subscriptions get one copy of `sample`, and the bytes go to DDS only
  // when another process may want them.
  void publish(const T& sample) {
    if (local_) {
      if (detail::localWanted(*local_)) detail::localPublish(*local_, std::make_shared<const T>(sample));
      if (!detail::ddsWriteNeeded(*local_, checked())) return;
    }
    detail::write(checked(), &sample);
  }
  // The same without the copy: local subscriptions share `sample` (it must not change afterwards).
  void publish(std::shared_ptr<const T> sample) {
    if (!sample) throw BusError("publish: null sample");
    if (local_) {
      if (detail::localWanted(*local_)) detail::localPublish(*local_, sample);
      if (!detail::ddsWriteNeeded(*local_, checked())) return;
    }
    detail::write(checked(), sample.get());
  }
  std::size_t matchedSubscribers() const { return detail::matchedReaders(checked()); }
  // True once `count` subscribers are matched *both ways*, so a sample published next reaches them: a
  // Cyclone subscriber of a Fast DDS publisher may learn of the publisher up to a second after the
  // publisher has matched it, and a volatile subscriber misses what was written before (docs/bus.md).
  bool waitForSubscribers(std::size_t count, std::chrono::milliseconds timeout) const {
    return detail::waitMatched([this] { return detail::settledReaders(checked()); }, count, timeout);
  }
  // The subscribers waitForSubscribers counts, now (no waiting): a loop that must not block polls this.
  std::size_t settledSubscribers() const { return detail::settledReaders(checked()); }
  // Samples serialized and handed to DDS so far (intra-process deliveries not counted).
  std::uint64_t ddsWrites() const { return detail::ddsWrites(checked()); }

 private:
  detail::WriterImpl& checked() const {
    if (!impl_) throw BusError("use of an empty (default-constructed or moved-from) Publisher");
    return *impl_;
  }
  std::shared_ptr<detail::WriterImpl> impl_;
  std::shared_ptr<detail::LocalWriter> local_;
};

// Publishes serialized samples of one topic/type (replay, bridges).
class RawPublisher {
 public:
  RawPublisher() = default;
  explicit RawPublisher(std::shared_ptr<detail::WriterImpl> impl) : impl_(std::move(impl)) {}
  // payload: encapsulation + XCDR1 body, e.g. a RawSample::payload. Throws BusError when rejected
  // (Cyclone checks the bytes against the type).
  void publish(std::span<const std::uint8_t> payload);
  std::size_t matchedSubscribers() const {
    if (!impl_) throw BusError("use of an empty RawPublisher");
    return detail::matchedReaders(*impl_);
  }
  // As Publisher::waitForSubscribers: matched both ways.
  bool waitForSubscribers(std::size_t count, std::chrono::milliseconds timeout) const {
    if (!impl_) throw BusError("use of an empty RawPublisher");
    return detail::waitMatched([this] { return detail::settledReaders(*impl_); }, count, timeout);
  }

 private:
  std::shared_ptr<detail::WriterImpl> impl_;
};

// A bounded queue of received samples (oldest dropped when full), for tests and simple loops. Mind the
// capacity for large messages: it holds copies.
template <class T>
class Inbox {
 public:
  struct State {
    std::mutex mutex;
    std::condition_variable changed;
    std::deque<T> samples;
    std::size_t capacity = 0;
    std::size_t received = 0;
  };

  Inbox() = default;
  Inbox(std::shared_ptr<State> state, Subscription subscription)
      : state_(std::move(state)), subscription_(std::move(subscription)) {}

  // The oldest queued sample, waiting up to timeout for one.
  std::optional<T> wait(std::chrono::milliseconds timeout) {
    std::unique_lock lock(state_->mutex);
    if (!state_->changed.wait_for(lock, timeout, [&] { return !state_->samples.empty(); })) return std::nullopt;
    T sample = std::move(state_->samples.front());
    state_->samples.pop_front();
    return sample;
  }
  std::optional<T> tryTake() { return wait(std::chrono::milliseconds(0)); }
  std::size_t size() const {
    std::lock_guard lock(state_->mutex);
    return state_->samples.size();
  }
  std::size_t received() const {  // all samples delivered so far, dropped ones included
    std::lock_guard lock(state_->mutex);
    return state_->received;
  }
  const Subscription& subscription() const { return subscription_; }

 private:
  std::shared_ptr<State> state_;
  Subscription subscription_;
};

class Participant {
 public:
  // Throws BusError for a domain out of range or when the vendor cannot create the participant.
  explicit Participant(const ParticipantOptions& options);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  Vendor vendor() const;
  int domainId() const;
  const std::string& name() const;

  template <class T>
  Publisher<T> publisher(const std::string& topic, const Qos& qos) {
    static_assert(msg::IsMessage<T>::value, "publisher<T>: T must be a generated ddsnav::msg class");
    auto writer = createWriter(msg::type_support<T>(), topic, qos);
    auto local = createLocalWriter(msg::type_support<T>(), topic, qos, *writer);
    return Publisher<T>(std::move(writer), std::move(local));
  }

  template <class T, class Callback>
  Subscription subscribe(const std::string& topic, const Qos& qos, Callback callback) {
    static_assert(msg::IsMessage<T>::value, "subscribe<T>: T must be a generated ddsnav::msg class");
    detail::SampleCallback erased;
    if constexpr (std::is_invocable_v<Callback&, const T&, const SampleInfo&>) {
      erased = [cb = std::move(callback)](const void* s, const SampleInfo& info) mutable {
        cb(*static_cast<const T*>(s), info);
      };
    } else {
      static_assert(std::is_invocable_v<Callback&, const T&>,
                    "subscribe<T>: callback must take (const T&) or (const T&, const SampleInfo&)");
      erased = [cb = std::move(callback)](const void* s, const SampleInfo&) mutable {
        cb(*static_cast<const T*>(s));
      };
    }
    return Subscription(createReader(msg::type_support<T>(), topic, qos, std::move(erased), {}));
  }

  // Like subscribe(), the sample handed over as a shared object: a copy of what DDS delivered, or (with
  // intra_process) the very object a publisher in this process published. For executors and queues.
  template <class T>
  Subscription subscribeShared(const std::string& topic, const Qos& qos,
                               std::function<void(std::shared_ptr<const T>, const SampleInfo&)> callback) {
    static_assert(msg::IsMessage<T>::value, "subscribeShared<T>: T must be a generated ddsnav::msg class");
    detail::SampleCallback from_dds = [callback](const void* s, const SampleInfo& info) {
      callback(std::make_shared<const T>(*static_cast<const T*>(s)), info);
    };
    detail::SharedCallback local = [callback](std::shared_ptr<const void> s, const SampleInfo& info) {
      callback(std::static_pointer_cast<const T>(std::move(s)), info);
    };
    return Subscription(createReader(msg::type_support<T>(), topic, qos, std::move(from_dds), std::move(local)));
  }

  template <class T>
  Inbox<T> inbox(const std::string& topic, const Qos& qos, std::size_t capacity = 64) {
    auto state = std::make_shared<typename Inbox<T>::State>();
    state->capacity = capacity;
    Subscription sub = subscribe<T>(topic, qos, [state](const T& sample) {
      {
        std::lock_guard lock(state->mutex);
        if (state->samples.size() >= state->capacity) state->samples.pop_front();
        state->samples.push_back(sample);
        ++state->received;
      }
      state->changed.notify_all();
    });
    return Inbox<T>(std::move(state), std::move(sub));
  }

  // Raw API. The type must be known to this build for Cyclone (and for keyed topics on Fast DDS, to
  // compute key hashes); Fast DDS carries unknown unkeyed types as opaque bytes.
  RawPublisher rawPublisher(const TopicInfo& topic, const Qos& qos);
  Subscription subscribeRaw(const TopicInfo& topic, const Qos& qos, detail::RawCallback callback);

  // Topics with at least one publisher seen so far (remote and local), sorted by name.
  std::vector<TopicInfo> discoveredTopics() const;
  std::optional<TopicInfo> waitForTopic(const std::string& topic, std::chrono::milliseconds timeout) const;
  // Called for every newly seen (topic, type) pair, on a bus thread; replaces any previous callback.
  void onTopicDiscovered(std::function<void(const TopicInfo&)> callback);

 private:
  std::shared_ptr<detail::WriterImpl> createWriter(const msg::TypeSupport& type, const std::string& topic,
                                                   const Qos& qos);
  // `local`: how an intra-process sample is handed over; empty: through `callback` (a pointer to it).
  std::shared_ptr<detail::ReaderImpl> createReader(const msg::TypeSupport& type, const std::string& topic,
                                                   const Qos& qos, detail::SampleCallback callback,
                                                   detail::SharedCallback local);
  // Null unless intra_process is on and the type is unkeyed.
  std::shared_ptr<detail::LocalWriter> createLocalWriter(const msg::TypeSupport& type, const std::string& topic,
                                                         const Qos& qos, const detail::WriterImpl& dds);

  std::unique_ptr<detail::ParticipantImpl> impl_;
};

}  // namespace ddsnav::bus
