// Vendor-independent part of the bus: option checks, the per-process topic/type table, discovery
// bookkeeping. The vendor code lives in fastdds_backend.cpp and cyclone_backend.cpp.
#include "backend.hpp"
#include "intra_process.hpp"
#include "ddsnav/bus/printable.hpp"

#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netdb.h>
#include <net/if.h>
#include <netinet/in.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdlib>
#include <map>
#include <set>
#include <stdexcept>
#include <thread>

namespace ddsnav::bus {

Vendor parseVendor(std::string_view name) {
  if (name == "fastdds" || name == "fast" || name == "fastrtps") return Vendor::FastDDS;
  if (name == "cyclonedds" || name == "cyclone") return Vendor::CycloneDDS;
  throw BusError("unknown DDS vendor '" + std::string(name) + "': expected 'fastdds' or 'cyclonedds'");
}

std::string_view vendorName(Vendor vendor) { return vendor == Vendor::FastDDS ? "fastdds" : "cyclonedds"; }

Vendor vendorFromEnvironment(Vendor fallback) {
  const char* env = std::getenv("DDSNAV_DDS");
  if (env == nullptr || *env == '\0') return fallback;
  try {
    return parseVendor(env);
  } catch (const BusError& e) {
    throw BusError(std::string("environment variable DDSNAV_DDS: ") + e.what());
  }
}

int domainFromEnvironment(int fallback) {
  const char* env = std::getenv("DDSNAV_DOMAIN");
  if (env == nullptr || *env == '\0') return fallback;
  const std::string text = env;
  int value = -1;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 0 || value > kMaxDomainId)
    throw std::invalid_argument("environment variable DDSNAV_DOMAIN='" + text + "': expected a DDS domain id, an integer in 0.." +
                                std::to_string(kMaxDomainId));
  return value;
}

std::vector<std::string> parsePeers(std::string_view text) {
  std::vector<std::string> peers;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t comma = text.find(',', start);
    std::string_view item = text.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    if (item.empty()) throw BusError("peer list '" + std::string(text) + "': empty entry (expected host,host,...)");
    peers.emplace_back(item);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return peers;
}

NetworkOptions networkFromEnvironment() {
  auto env = [](const char* name) -> std::string {
    const char* v = std::getenv(name);
    return v != nullptr ? v : "";
  };
  NetworkOptions network;
  network.interface = env("DDSNAV_NETWORK");
  const std::string peers = env("DDSNAV_PEERS"), multicast = env("DDSNAV_MULTICAST");
  if (network.interface.empty()) {
    if (!peers.empty() || (!multicast.empty() && multicast != "0" && multicast != "false"))
      throw BusError("DDSNAV_PEERS / DDSNAV_MULTICAST are set but DDSNAV_NETWORK (the interface) is not");
    return network;
  }
  if (!peers.empty()) {
    try {
      network.peers = parsePeers(peers);
    } catch (const BusError& e) {
      throw BusError(std::string("environment variable DDSNAV_PEERS: ") + e.what());
    }
  }
  if (multicast == "1" || multicast == "true") network.multicast = true;
  else if (!multicast.empty() && multicast != "0" && multicast != "false")
    throw BusError("environment variable DDSNAV_MULTICAST='" + multicast + "': expected 1, true, 0 or false");
  return network;
}

bool fastSharedMemoryFromEnvironment() {
  const char* env = std::getenv("DDSNAV_FAST_SHM");
  if (env == nullptr || *env == '\0') return true;
  const std::string_view value = env;
  if (value == "1" || value == "true" || value == "on") return true;
  if (value == "0" || value == "false" || value == "off") return false;
  throw BusError("environment variable DDSNAV_FAST_SHM='" + std::string(value) + "': expected 1, true, on, 0, false or off");
}

namespace detail {
namespace {

// What getifaddrs says of one interface.
struct InterfaceState {
  bool exists = false;
  std::string address;  // its first IPv4 address, empty when it has none
  unsigned flags = 0;   // IFF_*
  std::string names;    // every interface of the host, for the error message
};

InterfaceState lookUpInterface(const std::string& interface) {
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) throw BusError("network interface '" + interface + "': cannot list interfaces");
  InterfaceState state;
  for (ifaddrs* it = list; it != nullptr; it = it->ifa_next) {
    if (it->ifa_name == nullptr) continue;
    const std::string name = it->ifa_name;
    if (state.names.find(" " + name + ",") == std::string::npos) state.names += " " + name + ",";
    if (name != interface) continue;
    state.exists = true;
    state.flags = it->ifa_flags;
    if (it->ifa_addr != nullptr && it->ifa_addr->sa_family == AF_INET && state.address.empty()) {
      char text[INET_ADDRSTRLEN];
      inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(it->ifa_addr)->sin_addr, text, sizeof(text));
      state.address = text;
    }
  }
  freeifaddrs(list);
  if (!state.names.empty()) state.names.pop_back();
  return state;
}

// A link that was just brought up gets its carrier (IFF_RUNNING) from the kernel's link watch, up to about
// a second later; waiting this long covers that and a cable plugged in while the robot boots.
constexpr auto kCarrierWait = std::chrono::seconds(3);

// The IPv4 address of a named interface that can carry traffic; a clear error otherwise (listing what
// exists when it does not). Fast DDS 2.9 leaves out every interface without IFF_RUNNING when it applies its
// whitelist, logs "All whitelist interfaces were filtered out" and runs on without UDP at all -- a
// participant that looks alive and never talks. So an interface without carrier is waited for, then refused.
std::string interfaceAddress(const std::string& interface) {
  InterfaceState state = lookUpInterface(interface);
  if (!state.exists)
    throw BusError("network interface '" + interface + "' does not exist on this host (interfaces:" + state.names + ")");
  if (state.address.empty()) throw BusError("network interface '" + interface + "' has no IPv4 address");
  if (!(state.flags & IFF_UP)) throw BusError("network interface '" + interface + "' is down (ip link set " + interface + " up)");
  const auto until = std::chrono::steady_clock::now() + kCarrierWait;
  while (!(state.flags & IFF_RUNNING) && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    state = lookUpInterface(interface);
  }
  if (!(state.flags & IFF_RUNNING))
    throw BusError("network interface '" + interface + "' is up but has no carrier after " +
                   std::to_string(kCarrierWait.count()) + " s (cable unplugged or the link's peer down)");
  return state.address;
}

std::string resolvePeer(const std::string& peer) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  addrinfo* found = nullptr;
  if (getaddrinfo(peer.c_str(), nullptr, &hints, &found) != 0 || found == nullptr)
    throw BusError("peer '" + peer + "': not an IPv4 address or a host name that resolves to one");
  char text[INET_ADDRSTRLEN];
  inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(found->ai_addr)->sin_addr, text, sizeof(text));
  freeaddrinfo(found);
  return text;
}

Transport resolveTransport(const ParticipantOptions& options) {
  Transport t;
  const NetworkOptions network = options.network ? *options.network : networkFromEnvironment();
  t.fast_shared_memory = options.fast_shared_memory ? *options.fast_shared_memory : fastSharedMemoryFromEnvironment();
  if (network.interface.empty()) {
    if (!network.peers.empty() || network.multicast)
      throw BusError("network: peers or multicast given without an interface");
    t.peers = {t.address};
  } else {
    t.interface = network.interface;
    t.address = interfaceAddress(network.interface);
    t.multicast = network.multicast;
    t.peers.push_back(t.address);
    for (const std::string& peer : network.peers) {
      std::string address = resolvePeer(peer);
      if (std::find(t.peers.begin(), t.peers.end(), address) == t.peers.end()) t.peers.push_back(address);
    }
  }
  std::string dir;
  if (options.security_dir) dir = *options.security_dir;
  else if (const char* env = std::getenv("DDSNAV_SECURITY")) dir = env;
  if (!dir.empty()) {
    if (options.domain_id < security::kMinDomain || options.domain_id > security::kMaxDomain)
      throw BusError("security: domain " + std::to_string(options.domain_id) + " is outside the domains " +
                     std::to_string(security::kMinDomain) + ".." + std::to_string(security::kMaxDomain) +
                     " that ddsnav's governance and permissions cover (Cyclone DDS refuses ids above 230); participant '" +
                     options.name + "' not created");
    std::string identity = options.identity;
    if (identity.empty()) identity = options.name.starts_with("ddsnav-") ? options.name.substr(7) : options.name;
    try {
      t.security = security::credentialsFor(dir, identity, std::string(vendorName(options.vendor)));
    } catch (const security::SecurityError& e) {
      throw BusError(std::string("security: ") + e.what() + "; participant '" + options.name + "' not created");
    }
  }
  return t;
}

}  // namespace

void write(WriterImpl& writer, const void* sample) {
  writer.typed_writes.fetch_add(1, std::memory_order_relaxed);
  writer.writeSample(sample);
}
std::uint64_t ddsWrites(const WriterImpl& writer) { return writer.typed_writes.load(); }
std::size_t matchedReaders(const WriterImpl& writer) { return writer.matched(); }
std::size_t settledReaders(const WriterImpl& writer) { return writer.settled(); }
std::size_t matchedWriters(const ReaderImpl& reader) { return reader.matched(); }
std::uint64_t lostSamples(const ReaderImpl& reader) { return reader.lost(); }

bool waitMatched(const std::function<std::size_t()>& matched, std::size_t count,
                 std::chrono::milliseconds timeout) {
  // Matching is reported by vendor listeners on their own threads; polling a cheap status query every
  // few ms is simpler than wiring a condition variable through both vendors and costs nothing here.
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (matched() < count) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

void invokeSafely(const std::string& topic, const std::function<void()>& call) {
  try {
    call();
  } catch (const std::exception& e) {
    spdlog::error("bus: callback for topic '{}' threw: {}", topic, e.what());
  } catch (...) {
    spdlog::error("bus: callback for topic '{}' threw a non-standard exception", topic);
  }
}

// Discovery state shared with the vendor threads that feed it (it outlives neither).
struct DiscoveryState {
  std::mutex mutex;
  std::condition_variable changed;
  std::set<std::pair<std::string, std::string>> seen;  // (topic, type) with a publisher
  std::vector<TopicInfo> topics;
  std::map<std::string, std::string> local_types;  // topics this participant uses -> type
  std::set<std::pair<std::string, std::string>> reported_conflicts;
  std::function<void(const TopicInfo&)> callback;

  void onEndpoint(const TopicInfo& info, bool is_writer) {
    if (info.topic.starts_with(kInternalTopicPrefix)) return;
    std::function<void(const TopicInfo&)> cb;
    {
      std::lock_guard lock(mutex);
      auto local = local_types.find(info.topic);
      if (local != local_types.end() && local->second != info.type_name &&
          reported_conflicts.emplace(info.topic, info.type_name).second) {
        // DDS silently never matches endpoints whose types differ; say so once.
        spdlog::error("bus: topic '{}' is used here with type {} but a remote {} uses type {}; they will "
                      "not communicate",
                      printable(info.topic), local->second, is_writer ? "publisher" : "subscriber", printable(info.type_name));
      }
      if (!is_writer || !seen.emplace(info.topic, info.type_name).second) return;
      topics.push_back(info);
      cb = callback;
    }
    changed.notify_all();
    if (cb) invokeSafely(info.topic, [&] { cb(info); });
  }
};

class ParticipantImpl {
 public:
  ParticipantOptions options;
  std::shared_ptr<DiscoveryState> discovery = std::make_shared<DiscoveryState>();
  std::unique_ptr<Backend> backend;
  std::shared_ptr<IntraDomain> intra;  // null unless options.intra_process

  // Same topic, same type within one process: DDS would otherwise fail obscurely or never match.
  void claimTopic(const std::string& topic, std::string_view type_name) {
    if (topic.empty()) throw BusError("empty topic name");
    std::lock_guard lock(discovery->mutex);
    auto [it, inserted] = discovery->local_types.emplace(topic, std::string(type_name));
    if (!inserted && it->second != type_name)
      throw BusError("topic '" + topic + "' is already used with type " + it->second +
                     " in this participant; cannot use it with type " + std::string(type_name));
  }
};

}  // namespace detail

Participant::Participant(const ParticipantOptions& options) : impl_(std::make_unique<detail::ParticipantImpl>()) {
  if (options.domain_id < 0 || options.domain_id > kMaxDomainId)
    throw BusError("DDS domain id " + std::to_string(options.domain_id) + " is out of range: expected 0.." +
                   std::to_string(kMaxDomainId));
  impl_->options = options;
  std::weak_ptr<detail::DiscoveryState> weak = impl_->discovery;
  detail::DiscoverySink sink = [weak](const TopicInfo& info, bool is_writer) {
    if (auto state = weak.lock()) state->onEndpoint(info, is_writer);
  };
  const detail::Transport transport = detail::resolveTransport(options);
  impl_->backend = options.vendor == Vendor::FastDDS ? detail::makeFastBackend(options, transport, sink)
                                                     : detail::makeCycloneBackend(options, transport, sink);
  if (options.intra_process) impl_->intra = detail::intraDomain(options.vendor, options.domain_id);
  if (transport.security)
    spdlog::debug("bus: participant '{}' secured as {}", options.name, transport.security->identity_certificate);
}

Participant::~Participant() = default;

Vendor Participant::vendor() const { return impl_->options.vendor; }
int Participant::domainId() const { return impl_->options.domain_id; }
const std::string& Participant::name() const { return impl_->options.name; }

std::shared_ptr<detail::WriterImpl> Participant::createWriter(const msg::TypeSupport& type,
                                                              const std::string& topic, const Qos& qos) {
  impl_->claimTopic(topic, type.name);
  auto writer = impl_->backend->createWriter({topic, std::string(type.name), type.keyed, &type, qos, {}});
  impl_->discovery->onEndpoint({topic, std::string(type.name), type.keyed}, true);
  return writer;
}

std::shared_ptr<detail::ReaderImpl> Participant::createReader(const msg::TypeSupport& type,
                                                              const std::string& topic, const Qos& qos,
                                                              detail::SampleCallback callback,
                                                              detail::SharedCallback local) {
  impl_->claimTopic(topic, type.name);
  detail::EndpointSpec spec{topic, std::string(type.name), type.keyed, &type, qos, {}};
  if (!impl_->intra || type.keyed) return impl_->backend->createReader(spec, std::move(callback), nullptr);
  // Intra-process: samples of this process's intra-process writers come as objects, so the DDS copies of
  // them are dropped; both paths run under one gate.
  if (!local) local = [callback](std::shared_ptr<const void> s, const SampleInfo& info) { callback(s.get(), info); };
  auto gate = std::make_shared<detail::CallbackGate>();
  std::weak_ptr<detail::IntraDomain> domain = impl_->intra;
  spec.ignore_writer = [domain](std::uint64_t writer) {
    auto d = domain.lock();
    return d && d->isLocalWriter(writer);
  };
  auto dds = impl_->backend->createReader(spec, detail::gated(gate, std::move(callback)), nullptr);
  return detail::makeIntraReader(impl_->intra, topic, std::string(type.name), qos, std::move(dds), std::move(gate),
                                 std::move(local));
}

std::shared_ptr<detail::LocalWriter> Participant::createLocalWriter(const msg::TypeSupport& type, const std::string& topic,
                                                                    const Qos& qos, const detail::WriterImpl& dds) {
  if (!impl_->intra || type.keyed) return nullptr;
  return detail::makeLocalWriter(impl_->intra, topic, std::string(type.name), qos, dds);
}

namespace {
detail::EndpointSpec rawSpec(const TopicInfo& topic, const Qos& qos) {
  const msg::TypeSupport* type = msg::find_type_support(topic.type_name);
  if (type != nullptr && type->keyed != topic.keyed)
    throw BusError("topic '" + topic.topic + "': type " + topic.type_name + " is " +
                   (type->keyed ? "keyed" : "unkeyed") + " in this build but was given as " +
                   (topic.keyed ? "keyed" : "unkeyed"));
  return {topic.topic, topic.type_name, topic.keyed, type, qos, {}};
}
}  // namespace

RawPublisher Participant::rawPublisher(const TopicInfo& topic, const Qos& qos) {
  impl_->claimTopic(topic.topic, topic.type_name);
  auto writer = impl_->backend->createWriter(rawSpec(topic, qos));
  impl_->discovery->onEndpoint(topic, true);
  return RawPublisher(std::move(writer));
}

Subscription Participant::subscribeRaw(const TopicInfo& topic, const Qos& qos, detail::RawCallback callback) {
  if (!callback) throw BusError("subscribeRaw('" + topic.topic + "'): empty callback");
  impl_->claimTopic(topic.topic, topic.type_name);
  return Subscription(impl_->backend->createReader(rawSpec(topic, qos), nullptr, std::move(callback)));
}

void RawPublisher::publish(std::span<const std::uint8_t> payload) {
  if (!impl_) throw BusError("use of an empty RawPublisher");
  if (payload.size() < 4) throw BusError("raw sample of " + std::to_string(payload.size()) +
                                         " bytes: expected at least the 4-byte encapsulation header");
  impl_->writeRaw(payload);
}

std::vector<TopicInfo> Participant::discoveredTopics() const {
  std::lock_guard lock(impl_->discovery->mutex);
  std::vector<TopicInfo> topics = impl_->discovery->topics;
  std::sort(topics.begin(), topics.end(), [](const TopicInfo& a, const TopicInfo& b) {
    return std::tie(a.topic, a.type_name) < std::tie(b.topic, b.type_name);
  });
  return topics;
}

std::optional<TopicInfo> Participant::waitForTopic(const std::string& topic,
                                                   std::chrono::milliseconds timeout) const {
  auto& d = *impl_->discovery;
  std::unique_lock lock(d.mutex);
  std::optional<TopicInfo> found;
  d.changed.wait_for(lock, timeout, [&] {
    for (const TopicInfo& t : d.topics)
      if (t.topic == topic) {
        found = t;
        return true;
      }
    return false;
  });
  return found;
}

void Participant::onTopicDiscovered(std::function<void(const TopicInfo&)> callback) {
  std::lock_guard lock(impl_->discovery->mutex);
  impl_->discovery->callback = std::move(callback);
}

}  // namespace ddsnav::bus
