// Fast DDS 2.9 side of the bus. The only file that includes Fast DDS headers.
//
// One generic TopicDataType per type name carries either a generated class (through its TypeSupport) or
// raw bytes; which one is decided per sample by the Carrier handed to write()/take().
#include "backend.hpp"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastrtps/utils/md5.h>

#include <spdlog/spdlog.h>

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <set>

namespace ddsnav::bus::detail {
namespace {

// Fast DDS keeps at most 10 instances of a keyed topic by default (Cyclone: no limit): with more than ten
// processes on system/status (keyed by name, two pipelines in one domain) the eleventh was never heard.
// KEEP_LAST depth bounds each instance's samples, so the totals can be left open.
void unlimitedInstances(eprosima::fastdds::dds::ResourceLimitsQosPolicy& limits) {
  limits.max_instances = 0;  // 0: no limit
  limits.max_samples = 0;
}

// The writer's 16-byte instance handle (its GUID) folded to 64 bits with FNV-1a.
std::uint64_t publicationHandle(const eprosima::fastdds::dds::InstanceHandle_t& handle) {
  std::uint64_t h = 14695981039346656037ull;
  for (std::size_t i = 0; i < 16; ++i) h = (h ^ handle.value[i]) * 1099511628211ull;
  return h;
}

namespace dds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
using eprosima::fastrtps::types::ReturnCode_t;

// Loopback defaults (see docs/bus.md and dds-notes.md).
constexpr std::uint32_t kShmSegmentSize = 16 * 1024 * 1024;
// Messages a shared-memory port (a reader participant's inbox) holds before a sender's push fails and the
// sample must wait for a repair. Fast DDS's 512 made a reader of 200 000 small messages/s lose 40-60 % of them
// (reliable: GAP'd, counted) while spending 11-16 us of CPU per sample in repairs; 8192 delivered all of them at
// 4-6 us per sample (docs/benchmarks/record.md, 2026-12-02). A port is created by whichever participant opens
// it first, so every ddsnav participant asks for the same size.
constexpr std::uint32_t kShmPortQueueCapacity = 8192;
constexpr std::uint32_t kSocketBufferSize = 4 * 1024 * 1024;
constexpr std::uint32_t kMaxParticipantsPerHost = 32;

// What write()/take() exchange with GenericType: a generated class, or bytes.
struct Carrier {
  void* typed = nullptr;                    // sample to serialize from / deserialize into; null: raw
  std::span<const std::uint8_t> raw_in;     // raw writers: the bytes to send
  std::vector<std::uint8_t> raw_out;        // raw readers and key objects: the bytes received
};

class GenericType : public dds::TopicDataType {
 public:
  GenericType(const std::string& name, bool keyed, const msg::TypeSupport* type) : type_(type) {
    setName(name.c_str());
    // Only a preallocation hint: samples are unbounded, payloads grow per sample (REALLOC memory policy).
    m_typeSize = 4096;
    m_isGetKeyDefined = keyed;
  }

  bool serialize(void* data, rtps::SerializedPayload_t* payload) override {
    auto* c = static_cast<Carrier*>(data);
    if (c->typed != nullptr) {
      std::size_t n = type_->serialize(c->typed, payload->data, payload->max_size);
      if (n == 0) return false;
      payload->length = static_cast<std::uint32_t>(n);
    } else {
      if (c->raw_in.size() > payload->max_size) return false;
      std::memcpy(payload->data, c->raw_in.data(), c->raw_in.size());
      payload->length = static_cast<std::uint32_t>(c->raw_in.size());
    }
    payload->encapsulation = payload->data[1] == 0 ? CDR_BE : CDR_LE;
    return true;
  }

  bool deserialize(rtps::SerializedPayload_t* payload, void* data) override {
    auto* c = static_cast<Carrier*>(data);
    if (c->typed != nullptr) return type_->deserialize(payload->data, payload->length, c->typed);
    c->raw_out.assign(payload->data, payload->data + payload->length);
    return true;
  }

  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override {
    auto* c = static_cast<Carrier*>(data);
    return [this, c]() -> std::uint32_t {
      return static_cast<std::uint32_t>(c->typed != nullptr ? type_->serialized_size(c->typed) : c->raw_in.size());
    };
  }

  void* createData() override { return new Carrier(); }
  void deleteData(void* data) override { delete static_cast<Carrier*>(data); }

  // RTPS key hash: the big-endian key CDR, zero-padded to 16 bytes, or its MD5 when it may be longer.
  bool getKey(void* data, rtps::InstanceHandle_t* handle, bool force_md5) override {
    if (!m_isGetKeyDefined || type_ == nullptr) return false;
    auto* c = static_cast<Carrier*>(data);
    const void* sample = c->typed;
    std::unique_ptr<void, void (*)(void*)> temp(nullptr, type_->destroy);
    if (sample == nullptr) {
      std::span<const std::uint8_t> bytes = c->raw_in.empty() ? std::span<const std::uint8_t>(c->raw_out) : c->raw_in;
      temp.reset(type_->create());
      if (!type_->deserialize(bytes.data(), bytes.size(), temp.get())) return false;
      sample = temp.get();
    }
    std::vector<unsigned char> key;
    type_->serialize_key(sample, key);
    std::memset(handle->value, 0, 16);
    if (force_md5 || type_->key_max_size > 16) {
      ::MD5 md5;
      md5.init();
      md5.update(key.data(), static_cast<unsigned int>(key.size()));
      md5.finalize();
      std::memcpy(handle->value, md5.digest, 16);
    } else {
      std::memcpy(handle->value, key.data(), std::min<std::size_t>(key.size(), 16));
    }
    return true;
  }

 private:
  const msg::TypeSupport* type_;
};

// Fast DDS leaves /dev/shm segments of killed processes behind. Like `fastdds shm clean`: every segment
// or port has an "<name>_el" lock file that its live owner holds locked; unlocked ones are dead.
void cleanStaleSharedMemory() {
  DIR* dir = opendir("/dev/shm");
  if (dir == nullptr) return;
  int removed = 0;
  while (dirent* entry = readdir(dir)) {
    std::string name = entry->d_name;
    if (!name.starts_with("fastrtps_") || !name.ends_with("_el")) continue;
    std::string lock_path = "/dev/shm/" + name;
    int fd = open(lock_path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) continue;
    bool dead = flock(fd, LOCK_EX | LOCK_NB) == 0;
    if (dead) {
      std::string base = name.substr(0, name.size() - 3);
      unlink(("/dev/shm/" + base).c_str());
      if (base.starts_with("fastrtps_port")) unlink(("/dev/shm/sem." + base + "_mutex").c_str());
      unlink(lock_path.c_str());
      ++removed;
    }
    close(fd);
  }
  closedir(dir);
  if (removed > 0) spdlog::debug("bus: removed {} stale Fast DDS shared-memory segments", removed);
}

rtps::Locator_t udpLocator(const std::string& address, std::uint32_t port = 0) {
  rtps::Locator_t loc;
  loc.kind = LOCATOR_KIND_UDPv4;
  rtps::IPLocator::setIPv4(loc, address);
  loc.port = port;  // 0: derived from domain and participant id, for each of the peer range
  return loc;
}

// The builtin plugins' properties (DDS Security 1.1 names, Fast DDS's "builtin.*" plugin ids).
void addSecurity(dds::DomainParticipantQos& qos, const security::Credentials& c) {
  auto& p = qos.properties().properties();
  p.emplace_back("dds.sec.auth.plugin", "builtin.PKI-DH");
  p.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_ca", fileUri(c.identity_ca));
  p.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_certificate", fileUri(c.identity_certificate));
  p.emplace_back("dds.sec.auth.builtin.PKI-DH.private_key", fileUri(c.private_key));
  p.emplace_back("dds.sec.access.plugin", "builtin.Access-Permissions");
  p.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions_ca", fileUri(c.permissions_ca));
  p.emplace_back("dds.sec.access.builtin.Access-Permissions.governance", fileUri(c.governance));
  p.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions", fileUri(c.permissions));
  p.emplace_back("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

dds::DomainParticipantQos participantQos(const ParticipantOptions& options, const Transport& t) {
  dds::DomainParticipantQos qos;  // not the factory default: an environment XML must not re-enable multicast
  qos.name(options.name);
  auto& transport = qos.transport();
  transport.use_builtin_transports = false;
  if (t.fast_shared_memory) {
    auto shm = std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>();
    shm->segment_size(kShmSegmentSize);
    shm->port_queue_capacity(kShmPortQueueCapacity);
    transport.user_transports.push_back(shm);
  }
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.emplace_back(t.address);
  udp->maxInitialPeersRange = kMaxParticipantsPerHost;
  udp->sendBufferSize = kSocketBufferSize;
  udp->receiveBufferSize = kSocketBufferSize;
  transport.user_transports.push_back(udp);
  transport.send_socket_buffer_size = kSocketBufferSize;
  transport.listen_socket_buffer_size = kSocketBufferSize;

  auto& builtin = qos.wire_protocol().builtin;
  // A unicast metatraffic locator is what keeps Fast DDS from adding its multicast discovery locator.
  builtin.metatrafficUnicastLocatorList.push_back(udpLocator(t.address));
  for (const std::string& peer : t.peers) builtin.initialPeersList.push_back(udpLocator(peer));
  if (t.multicast) {
    // The standard SPDP multicast group and port (7400 + 250 * domain).
    builtin.metatrafficMulticastLocatorList.push_back(
        udpLocator("239.255.0.1", 7400 + 250 * static_cast<std::uint32_t>(options.domain_id)));
  }
  // Announce every 0.5 s instead of 3 s: late joiners match in < 1 s.
  builtin.discovery_config.leaseDuration_announcementperiod = eprosima::fastrtps::Duration_t(0, 500'000'000);
  builtin.discovery_config.leaseDuration = eprosima::fastrtps::Duration_t(10, 0);
  if (t.security) addSecurity(qos, *t.security);
  return qos;
}

class FastCore;

// The readers a writer is matched with (Fast DDS 2.9 has no get_matched_subscriptions), and since when.
//
// A reader of another vendor may learn of this writer up to a second after the writer has matched it:
// Cyclone DDS drops a HEARTBEAT that arrives before it has finished discovering the sending participant (it
// handles SPDP on a delivery thread, HEARTBEATs on the receive thread, and Fast DDS sends both at once), and
// Fast DDS 2.9 repeats the heartbeats of its discovery (SEDP) writers only every second, a period no API
// changes. A sample written in that second never reaches the reader: volatile readers get nothing written
// before they matched. Measured (session notes in docs/bus.md): a request written 0.5 s after the match was
// lost in 4 of 8 runs, 2 s after it in none. So a foreign reader counts as *settled* -- what
// waitForSubscribers waits for -- once it has been matched for longer than that period.
class MatchedReaders : public dds::DataWriterListener {
 public:
  static constexpr auto kForeignSettle = std::chrono::milliseconds(1200);  // Fast DDS's SEDP heartbeat period + margin

  void on_publication_matched(dds::DataWriter*, const dds::PublicationMatchedStatus& status) override {
    const std::uint64_t reader = publicationHandle(status.last_subscription_handle);
    std::lock_guard lock(mutex_);
    if (status.current_count_change > 0) {
      // The handle is the reader's GUID; its first two bytes are the vendor id (eProsima: 01.0f).
      const auto& guid = status.last_subscription_handle.value;
      const bool foreign = !(guid[0] == 0x01 && guid[1] == 0x0f);
      readers_[reader] = foreign ? std::chrono::steady_clock::now() + kForeignSettle : std::chrono::steady_clock::time_point{};
    } else if (status.current_count_change < 0) {
      readers_.erase(reader);
    }
  }
  bool beyond(const std::set<std::uint64_t>& readers) const {
    std::lock_guard lock(mutex_);
    for (const auto& entry : readers_)
      if (!readers.count(entry.first)) return true;
    return false;
  }
  std::size_t settled() const {
    const auto now = std::chrono::steady_clock::now();
    std::lock_guard lock(mutex_);
    std::size_t n = 0;
    for (const auto& entry : readers_) n += entry.second <= now;
    return n;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::uint64_t, std::chrono::steady_clock::time_point> readers_;  // -> when it counts as settled
};

class FastWriter : public WriterImpl {
 public:
  FastWriter(std::shared_ptr<FastCore> core, dds::DataWriter* writer, std::string topic, std::unique_ptr<MatchedReaders> matched)
      : core_(std::move(core)), writer_(writer), topic_(std::move(topic)), matched_(std::move(matched)),
        handle_(publicationHandle(writer->get_instance_handle())) {}
  ~FastWriter() override;
  std::uint64_t handle() const override { return handle_; }
  bool matchedBeyond(const std::set<std::uint64_t>& readers) const override { return matched_->beyond(readers); }
  std::size_t settled() const override { return matched_->settled(); }

  void writeSample(const void* sample) override {
    Carrier c;
    c.typed = const_cast<void*>(sample);  // serialize() only reads it
    write(c);
  }
  void writeRaw(std::span<const std::uint8_t> payload) override {
    Carrier c;
    c.raw_in = payload;
    write(c);
  }
  std::size_t matched() const override {
    dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return static_cast<std::size_t>(status.current_count);
  }

 private:
  void write(Carrier& c) {
    if (!writer_->write(&c))
      throw BusError("Fast DDS refused a sample on topic '" + topic_ +
                     "' (serialization failed or the reliable history stayed full)");
  }
  std::shared_ptr<FastCore> core_;
  dds::DataWriter* writer_;
  std::string topic_;
  std::unique_ptr<MatchedReaders> matched_;  // outlives the writer: deleted after it (see ~FastWriter)
  std::uint64_t handle_;
};

class FastReader : public ReaderImpl, public dds::DataReaderListener {
 public:
  FastReader(std::shared_ptr<FastCore> core, const EndpointSpec& spec, SampleCallback typed, RawCallback raw)
      : core_(std::move(core)), spec_(spec), typed_(std::move(typed)), raw_(std::move(raw)) {
    if (typed_) carrier_.typed = spec.type->create();
  }
  ~FastReader() override;

  void attach(dds::DataReader* reader) {
    reader_ = reader;
    handle_ = publicationHandle(reader->get_instance_handle());
  }
  std::uint64_t handle() const override { return handle_; }

  std::size_t matched() const override {
    dds::SubscriptionMatchedStatus status;
    reader_->get_subscription_matched_status(status);
    return static_cast<std::size_t>(status.current_count);
  }

  std::uint64_t lost() const override {
    dds::SampleLostStatus lost;
    dds::SampleRejectedStatus rejected;
    std::uint64_t n = 0;
    if (reader_->get_sample_lost_status(lost) == ReturnCode_t::RETCODE_OK) n += static_cast<std::uint64_t>(std::max(0, lost.total_count));
    if (reader_->get_sample_rejected_status(rejected) == ReturnCode_t::RETCODE_OK) n += rejected.total_count;
    // The vendor's statuses miss what a reliable writer gave up on (its keep-last history overwrote samples
    // this reader had not acknowledged: RTPS calls them irrelevant, sends a GAP, and no status counts them),
    // while every sample lost or rejected shows up as a gap in the writer's sequence numbers too. So the
    // gaps are the count, the statuses only a floor (they can see a loss before a later sample shows it).
    // A sample Fast DDS delivered without its identity (sequence number 0: seen with fragmented 1 MB samples of
    // a Cyclone writer, 1-7 per 300) arrived, but its sequence number fell into a jump and was counted lost.
    const std::uint64_t gaps = sequence_gaps_.load(std::memory_order_relaxed);
    const std::uint64_t unidentified = unidentified_.load(std::memory_order_relaxed);
    return std::max(n, gaps > unidentified ? gaps - unidentified : 0);
  }

  void on_data_available(dds::DataReader* reader) override {
    dds::SampleInfo info;
    // A sample of a writer of this process was delivered to us as an object already: taken as bytes
    // (a copy, no decoding) and dropped.
    if (spec_.ignore_writer) {
      while (reader->get_first_untaken_info(&info) == ReturnCode_t::RETCODE_OK &&
             spec_.ignore_writer(publicationHandle(info.publication_handle))) {
        if (reader->take_next_sample(&skipped_, &info) == ReturnCode_t::RETCODE_OK) countSequenceGap(info);
      }
    }
    // Fast DDS calls this once per reader at a time, so the one carrier (and its grown buffers) is reused.
    while (reader->take_next_sample(&carrier_, &info) == ReturnCode_t::RETCODE_OK) {
      countSequenceGap(info);
      if (spec_.ignore_writer && spec_.ignore_writer(publicationHandle(info.publication_handle))) continue;
      if (!info.valid_data) continue;
      SampleInfo si{info.source_timestamp.to_ns(), publicationHandle(info.publication_handle)};
      if (typed_) {
        invokeSafely(spec_.topic, [&] { typed_(carrier_.typed, si); });
      } else {
        RawSample s{spec_.topic, spec_.type_name, carrier_.raw_out, si.source_timestamp_ns, &carrier_.raw_out};
        invokeSafely(spec_.topic, [&] { raw_(s); });
      }
    }
  }

 private:
  // Samples of a writer that never reached this reader: the jumps in its sequence numbers between the samples
  // taken (the first one taken from a writer sets where counting starts: what it wrote before this reader
  // matched was never meant for it). Called only from on_data_available, which Fast DDS runs once per reader at
  // a time.
  void countSequenceGap(const dds::SampleInfo& info) {
    const rtps::GUID_t& writer = info.sample_identity.writer_guid();
    const std::int64_t sequence = info.sample_identity.sequence_number().to64long();
    if (sequence <= 0 || writer == rtps::GUID_t::unknown()) {
      if (info.valid_data) unidentified_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    if (!(writer == last_writer_)) {
      if (last_sequence_by_writer_.size() >= kMaxTrackedWriters && !last_sequence_by_writer_.count(writer))
        last_sequence_by_writer_.clear();  // bounded; a writer seen again only starts counting anew
      last_writer_ = writer;
      last_sequence_ = &last_sequence_by_writer_[writer];
    }
    if (*last_sequence_ > 0 && sequence > *last_sequence_ + 1)
      sequence_gaps_.fetch_add(static_cast<std::uint64_t>(sequence - *last_sequence_ - 1), std::memory_order_relaxed);
    if (sequence > *last_sequence_) {
      *last_sequence_ = sequence;
    } else if (sequence < *last_sequence_ && sequence_gaps_.load(std::memory_order_relaxed) > 0) {
      // Taken after a later one (seen with fragmented 1 MB samples of a Cyclone writer): the gap had counted
      // it as lost. Only this thread writes the counter.
      sequence_gaps_.fetch_sub(1, std::memory_order_relaxed);
    }
  }
  static constexpr std::size_t kMaxTrackedWriters = 4096;

  std::shared_ptr<FastCore> core_;
  EndpointSpec spec_;
  SampleCallback typed_;
  RawCallback raw_;
  std::map<rtps::GUID_t, std::int64_t> last_sequence_by_writer_;
  rtps::GUID_t last_writer_ = rtps::GUID_t::unknown();
  std::int64_t* last_sequence_ = nullptr;  // last_sequence_by_writer_[last_writer_] (map nodes do not move)
  std::atomic<std::uint64_t> sequence_gaps_{0};
  std::atomic<std::uint64_t> unidentified_{0};  // valid samples taken without a sequence number
  Carrier carrier_;
  Carrier skipped_;  // raw: what samples of ignored writers are taken into
  dds::DataReader* reader_ = nullptr;
  std::uint64_t handle_ = 0;
};

class DiscoveryListener : public dds::DomainParticipantListener {
 public:
  explicit DiscoveryListener(DiscoverySink sink) : sink_(std::move(sink)) {}
  void on_publisher_discovery(dds::DomainParticipant*, rtps::WriterDiscoveryInfo&& info) override {
    if (info.status != rtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    sink_({info.info.topicName().to_string(), info.info.typeName().to_string(),
           info.info.topicKind() == rtps::WITH_KEY},
          true);
  }
  void on_subscriber_discovery(dds::DomainParticipant*, rtps::ReaderDiscoveryInfo&& info) override {
    if (info.status != rtps::ReaderDiscoveryInfo::DISCOVERED_READER) return;
    sink_({info.info.topicName().to_string(), info.info.typeName().to_string(),
           info.info.topicKind() == rtps::WITH_KEY},
          false);
  }

 private:
  DiscoverySink sink_;
};

// The participant and its publisher/subscriber; kept alive by every endpoint created from it.
class FastCore : public std::enable_shared_from_this<FastCore> {
 public:
  FastCore(const ParticipantOptions& options, const Transport& transport, DiscoverySink sink)
      : listener_(std::move(sink)), secured_(transport.security.has_value()) {
    static std::once_flag cleaned;
    std::call_once(cleaned, cleanStaleSharedMemory);
    auto* factory = dds::DomainParticipantFactory::get_instance();
    participant_ = factory->create_participant(options.domain_id, participantQos(options, transport), &listener_,
                                               dds::StatusMask::none());
    if (participant_ == nullptr)
      throw BusError("Fast DDS could not create a participant on domain " + std::to_string(options.domain_id) +
                     (transport.security ? " with DDS Security (" + transport.security->identity_certificate +
                                               "; the vendor's log above says why)"
                                         : std::string()));
    publisher_ = participant_->create_publisher(dds::PUBLISHER_QOS_DEFAULT);
    subscriber_ = participant_->create_subscriber(dds::SUBSCRIBER_QOS_DEFAULT);
    if (publisher_ == nullptr || subscriber_ == nullptr) {
      participant_->delete_contained_entities();
      factory->delete_participant(participant_);
      throw BusError("Fast DDS could not create a publisher/subscriber");
    }
  }

  ~FastCore() {
    participant_->set_listener(nullptr);
    participant_->delete_contained_entities();
    dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }

  std::shared_ptr<WriterImpl> createWriter(const EndpointSpec& spec) {
    std::lock_guard lock(mutex_);
    dds::Topic* topic = topicFor(spec);
    dds::DataWriterQos qos = publisher_->get_default_datawriter_qos();
    applyQos(spec.qos, qos.reliability(), qos.durability(), qos.history());
    qos.durability_service().history_kind = dds::KEEP_LAST_HISTORY_QOS;
    qos.durability_service().history_depth = spec.qos.depth;
    unlimitedInstances(qos.resource_limits());
    qos.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
    // Repair lost fragments of large samples quickly rather than after the default 3 s heartbeat.
    qos.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0, 100'000'000);
    auto matched = std::make_unique<MatchedReaders>();
    dds::DataWriter* writer = publisher_->create_datawriter(topic, qos, matched.get(), dds::StatusMask::publication_matched());
    if (writer == nullptr)
      throw BusError("Fast DDS could not create a writer on topic '" + spec.topic + "'" +
                     (secured_ ? " (with DDS Security: do this identity's permissions allow publishing it?)" : ""));
    return std::make_shared<FastWriter>(shared_from_this(), writer, spec.topic, std::move(matched));
  }

  std::shared_ptr<ReaderImpl> createReader(const EndpointSpec& spec, SampleCallback typed, RawCallback raw) {
    std::lock_guard lock(mutex_);
    dds::Topic* topic = topicFor(spec);
    dds::DataReaderQos qos = subscriber_->get_default_datareader_qos();
    applyQos(spec.qos, qos.reliability(), qos.durability(), qos.history());
    unlimitedInstances(qos.resource_limits());
    qos.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
    auto impl = std::make_shared<FastReader>(shared_from_this(), spec, std::move(typed), std::move(raw));
    dds::DataReader* reader = subscriber_->create_datareader(topic, qos, impl.get(),
                                                             dds::StatusMask::data_available());
    if (reader == nullptr)
      throw BusError("Fast DDS could not create a reader on topic '" + spec.topic + "'" +
                     (secured_ ? " (with DDS Security: do this identity's permissions allow subscribing to it?)" : ""));
    impl->attach(reader);
    return impl;
  }

  void deleteWriter(dds::DataWriter* writer) {
    std::lock_guard lock(mutex_);
    writer->set_listener(nullptr);
    publisher_->delete_datawriter(writer);
  }
  void deleteReader(dds::DataReader* reader) {
    std::lock_guard lock(mutex_);
    reader->set_listener(nullptr);
    subscriber_->delete_datareader(reader);
  }

 private:
  static void applyQos(const Qos& q, dds::ReliabilityQosPolicy& reliability, dds::DurabilityQosPolicy& durability,
                       dds::HistoryQosPolicy& history) {
    if (q.depth < 1) throw BusError("QoS depth " + std::to_string(q.depth) + ": expected >= 1");
    reliability.kind = q.reliability == Reliability::Reliable ? dds::RELIABLE_RELIABILITY_QOS
                                                              : dds::BEST_EFFORT_RELIABILITY_QOS;
    durability.kind = q.durability == Durability::TransientLocal ? dds::TRANSIENT_LOCAL_DURABILITY_QOS
                                                                 : dds::VOLATILE_DURABILITY_QOS;
    history.kind = dds::KEEP_LAST_HISTORY_QOS;
    history.depth = q.depth;
  }

  dds::Topic* topicFor(const EndpointSpec& spec) {
    if (spec.keyed && spec.type == nullptr)
      throw BusError("topic '" + spec.topic + "': keyed type " + spec.type_name +
                     " is unknown to this build, so its key hashes cannot be computed");
    auto registered = types_.find(spec.type_name);
    if (registered == types_.end()) {
      dds::TypeSupport ts(new GenericType(spec.type_name, spec.keyed, spec.type));
      if (participant_->register_type(ts) != ReturnCode_t::RETCODE_OK)
        throw BusError("Fast DDS could not register type " + spec.type_name);
      registered = types_.emplace(spec.type_name, ts).first;
    }
    auto it = topics_.find(spec.topic);
    if (it != topics_.end()) return it->second;
    dds::Topic* topic = participant_->create_topic(spec.topic, spec.type_name, dds::TOPIC_QOS_DEFAULT);
    if (topic == nullptr) throw BusError("Fast DDS could not create topic '" + spec.topic + "'");
    topics_.emplace(spec.topic, topic);
    return topic;
  }

  DiscoveryListener listener_;
  bool secured_ = false;
  dds::DomainParticipant* participant_ = nullptr;
  dds::Publisher* publisher_ = nullptr;
  dds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;
  std::map<std::string, dds::TypeSupport> types_;
  std::map<std::string, dds::Topic*> topics_;
};

FastWriter::~FastWriter() { core_->deleteWriter(writer_); }

FastReader::~FastReader() {
  if (reader_ != nullptr) core_->deleteReader(reader_);
  if (carrier_.typed != nullptr) spec_.type->destroy(carrier_.typed);
}

class FastBackend : public Backend {
 public:
  FastBackend(const ParticipantOptions& options, const Transport& transport, DiscoverySink sink)
      : core_(std::make_shared<FastCore>(options, transport, std::move(sink))) {}
  std::shared_ptr<WriterImpl> createWriter(const EndpointSpec& spec) override { return core_->createWriter(spec); }
  std::shared_ptr<ReaderImpl> createReader(const EndpointSpec& spec, SampleCallback typed, RawCallback raw) override {
    return core_->createReader(spec, std::move(typed), std::move(raw));
  }

 private:
  std::shared_ptr<FastCore> core_;
};

}  // namespace

std::unique_ptr<Backend> makeFastBackend(const ParticipantOptions& options, const Transport& transport,
                                         DiscoverySink sink) {
  return std::make_unique<FastBackend>(options, transport, std::move(sink));
}

}  // namespace ddsnav::bus::detail
