// Cyclone DDS 0.10 side of the bus. The only file that includes Cyclone headers.
//
// Topics are created from the idlc descriptors (so Cyclone knows keys and checks incoming bytes), but
// samples never go through Cyclone's C structs: the generated Fast CDR classes produce and consume the
// serialized form, handed over with ddsi_serdata_from_ser_iov + dds_writecdr and dds_takecdr.
#include "backend.hpp"

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>

#include <spdlog/spdlog.h>

#include <cstdlib>
#include <unistd.h>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <vector>

namespace ddsnav::bus::detail {
namespace {

// Unicast discovery to the peers (loopback: 127.0.0.1) over a participant-index range that covers a host.
std::string domainConfig(const Transport& t) {
  std::string x = "<CycloneDDS><Domain id=\"any\"><General><Interfaces>";
  x += t.loopback() ? "<NetworkInterface address=\"127.0.0.1\"/>" : "<NetworkInterface name=\"" + t.interface + "\"/>";
  x += "</Interfaces><AllowMulticast>";
  x += t.multicast ? "spdp" : "false";
  x += "</AllowMulticast></General>"
       "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers>";
  for (const std::string& peer : t.peers) x += "<Peer address=\"" + peer + "\"/>";
  x += "</Peers></Discovery><Internal><SocketReceiveBufferSize min=\"4MB\"/></Internal>";
  // DDSNAV_CYCLONE_TRACE=FILE: Cyclone's full protocol trace to FILE.<pid>, for interop questions (docs/bus.md).
  if (const char* trace = std::getenv("DDSNAV_CYCLONE_TRACE"); trace != nullptr && *trace != '\0') {
    const std::string file = trace;
    if (file.find_first_of("<>&\"'") != std::string::npos)
      throw BusError("DDSNAV_CYCLONE_TRACE='" + file + "': a file name without < > & \" '");
    x += "<Tracing><Category>trace</Category><OutputFile>" + file + "." + std::to_string(::getpid()) + "</OutputFile></Tracing>";
  }
  x += "</Domain></CycloneDDS>";
  return x;
}

std::string errorText(dds_return_t rc) { return dds_strretcode(rc); }

// A domain's configuration is fixed when the process first creates it; later participants share it, so
// one with other network settings is refused rather than silently given the first one's. The domain is
// deleted with its last participant: its threads (receive, timed events, the security plugins' handshakes
// and encryption) must be gone before main returns, or they run on while exit handlers tear down what
// they use -- OpenSSL's OPENSSL_cleanup freed the cipher tables under a secured launcher's send thread
// (SIGSEGV after a clean shutdown, docs/security.md).
struct DomainUse {
  std::string config;
  dds_entity_t entity = 0;  // 0: it existed already (not ours to delete)
  int participants = 0;
};
std::mutex& domainsMutex() {
  static auto* mutex = new std::mutex;  // never destroyed: a participant may outlive static destructors
  return *mutex;
}
std::map<int, DomainUse>& domains() {
  static auto* map = new std::map<int, DomainUse>;
  return *map;
}

void acquireDomain(int domain_id, const Transport& transport) {
  const std::string config = domainConfig(transport);
  std::lock_guard lock(domainsMutex());
  if (auto it = domains().find(domain_id); it != domains().end()) {
    if (it->second.config != config)
      throw BusError("Cyclone DDS domain " + std::to_string(domain_id) +
                     " already exists in this process with other network settings; one process uses one network per domain");
    ++it->second.participants;
    return;
  }
  dds_entity_t domain = dds_create_domain(static_cast<dds_domainid_t>(domain_id), config.c_str());
  if (domain < 0 && domain != DDS_RETCODE_PRECONDITION_NOT_MET)  // NOT_MET: it exists already
    throw BusError("Cyclone DDS could not create domain " + std::to_string(domain_id) +
                   (transport.loopback() ? std::string() : " on network interface '" + transport.interface + "'") + ": " +
                   errorText(domain));
  domains().emplace(domain_id, DomainUse{config, domain > 0 ? domain : 0, 1});
}

// After the participant's own dds_delete: the last one out deletes the domain, which joins its threads.
void releaseDomain(int domain_id) {
  std::lock_guard lock(domainsMutex());
  auto it = domains().find(domain_id);
  if (it == domains().end() || --it->second.participants > 0) return;
  if (it->second.entity > 0) dds_delete(it->second.entity);
  domains().erase(it);
}

// The builtin plugins (Debian installs them outside the library path; CMake found them) and the files.
void addSecurity(dds_qos_t* qos, const security::Credentials& c) {
  const std::string dir = DDSNAV_CYCLONE_SECURITY_DIR;
  if (dir.empty())
    throw BusError("DDS Security on Cyclone DDS: this build found no libdds_security_*.so plugins (see docs/security.md)");
  struct Plugin {
    const char* kind;
    const char* library;
    const char* init;
    const char* finalize;
  };
  for (const Plugin& p : {Plugin{"auth", "libdds_security_auth.so", "init_authentication", "finalize_authentication"},
                          Plugin{"crypto", "libdds_security_crypto.so", "init_crypto", "finalize_crypto"},
                          Plugin{"access", "libdds_security_ac.so", "init_access_control", "finalize_access_control"}}) {
    const std::string prefix = std::string("dds.sec.") + p.kind + ".library.";
    dds_qset_prop(qos, (prefix + "path").c_str(), (dir + "/" + p.library).c_str());
    dds_qset_prop(qos, (prefix + "init").c_str(), p.init);
    dds_qset_prop(qos, (prefix + "finalize").c_str(), p.finalize);
  }
  dds_qset_prop(qos, "dds.sec.auth.identity_ca", fileUri(c.identity_ca).c_str());
  dds_qset_prop(qos, "dds.sec.auth.identity_certificate", fileUri(c.identity_certificate).c_str());
  dds_qset_prop(qos, "dds.sec.auth.private_key", fileUri(c.private_key).c_str());
  dds_qset_prop(qos, "dds.sec.access.permissions_ca", fileUri(c.permissions_ca).c_str());
  dds_qset_prop(qos, "dds.sec.access.governance", fileUri(c.governance).c_str());
  dds_qset_prop(qos, "dds.sec.access.permissions", fileUri(c.permissions).c_str());
}

struct QosHandle {
  dds_qos_t* qos = dds_create_qos();
  ~QosHandle() { dds_delete_qos(qos); }
};

void applyQos(const Qos& q, dds_qos_t* qos) {
  if (q.depth < 1) throw BusError("QoS depth " + std::to_string(q.depth) + ": expected >= 1");
  dds_qset_reliability(qos, q.reliability == Reliability::Reliable ? DDS_RELIABILITY_RELIABLE
                                                                   : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_SECS(1));
  dds_qset_durability(qos, q.durability == Durability::TransientLocal ? DDS_DURABILITY_TRANSIENT_LOCAL
                                                                     : DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, q.depth);
  // Cyclone serves late joiners from the durability service history (default depth 1), not the writer's.
  dds_qset_durability_service(qos, 0, DDS_HISTORY_KEEP_LAST, q.depth, DDS_LENGTH_UNLIMITED,
                              DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
}

class CycloneCore;

class CycloneWriter : public WriterImpl {
 public:
  CycloneWriter(std::shared_ptr<CycloneCore> core, dds_entity_t writer, const ddsi_sertype* sertype,
                const EndpointSpec& spec)
      : core_(std::move(core)), writer_(writer), sertype_(sertype), spec_(spec) {
    dds_get_instance_handle(writer_, &handle_);
  }
  ~CycloneWriter() override { dds_delete(writer_); }
  std::uint64_t handle() const override { return handle_; }
  bool matchedBeyond(const std::set<std::uint64_t>& readers) const override {
    std::vector<dds_instance_handle_t> matched(16);
    for (;;) {
      const dds_return_t n = dds_get_matched_subscriptions(writer_, matched.data(), matched.size());
      if (n < 0) return true;  // cannot tell: write
      if (static_cast<std::size_t>(n) <= matched.size()) {
        for (dds_return_t i = 0; i < n; ++i)
          if (!readers.count(matched[static_cast<std::size_t>(i)])) return true;
        return false;
      }
      matched.resize(static_cast<std::size_t>(n));
    }
  }

  void writeSample(const void* sample) override {
    // One serialization into a per-thread buffer that keeps its capacity (no 8 MB allocation per cloud).
    thread_local std::vector<std::uint8_t> buffer;
    std::size_t size = spec_.type->serialized_size(sample);
    if (buffer.size() < size) buffer.resize(size);
    std::size_t n = spec_.type->serialize(sample, buffer.data(), buffer.size());
    if (n == 0) throw BusError("could not serialize a sample for topic '" + spec_.topic + "'");
    writeBytes(buffer.data(), n);
  }

  void writeRaw(std::span<const std::uint8_t> payload) override { writeBytes(payload.data(), payload.size()); }

  std::size_t matched() const override {
    dds_publication_matched_status_t status{};
    dds_get_publication_matched_status(writer_, &status);
    return status.current_count;
  }

 private:
  void writeBytes(const std::uint8_t* data, std::size_t size) {
    ddsrt_iovec_t iov;
    iov.iov_base = const_cast<std::uint8_t*>(data);
    iov.iov_len = static_cast<ddsrt_iov_len_t>(size);
    // Copies the bytes into Cyclone's sample representation and checks them against the descriptor.
    ddsi_serdata* sd = ddsi_serdata_from_ser_iov(sertype_, SDK_DATA, 1, &iov, size);
    if (sd == nullptr)
      throw BusError("Cyclone DDS rejected a " + std::to_string(size) + "-byte sample on topic '" + spec_.topic +
                     "': not a valid " + spec_.type_name);
    dds_return_t rc = dds_writecdr(writer_, sd);  // takes over the reference
    if (rc < 0) throw BusError("Cyclone DDS write on topic '" + spec_.topic + "' failed: " + errorText(rc));
  }

  std::shared_ptr<CycloneCore> core_;
  dds_entity_t writer_;
  const ddsi_sertype* sertype_;
  EndpointSpec spec_;
  dds_instance_handle_t handle_ = 0;
};

class CycloneReader : public ReaderImpl {
 public:
  CycloneReader(std::shared_ptr<CycloneCore> core, const EndpointSpec& spec, SampleCallback typed, RawCallback raw)
      : core_(std::move(core)), spec_(spec), typed_(std::move(typed)), raw_(std::move(raw)) {
    if (typed_) sample_ = spec.type->create();
  }
  ~CycloneReader() override {
    if (reader_ > 0) dds_delete(reader_);  // returns after a running listener call has finished
    if (sample_ != nullptr) spec_.type->destroy(sample_);
  }

  void attach(dds_entity_t reader) {
    reader_ = reader;
    dds_get_instance_handle(reader_, &handle_);
  }
  std::uint64_t handle() const override { return handle_; }

  std::size_t matched() const override {
    dds_subscription_matched_status_t status{};
    dds_get_subscription_matched_status(reader_, &status);
    return status.current_count;
  }

  std::uint64_t lost() const override {
    dds_sample_lost_status_t lost{};
    dds_sample_rejected_status_t rejected{};
    std::uint64_t n = 0;
    if (dds_get_sample_lost_status(reader_, &lost) == DDS_RETCODE_OK) n += lost.total_count;
    if (dds_get_sample_rejected_status(reader_, &rejected) == DDS_RETCODE_OK) n += rejected.total_count;
    return n;
  }

  static void onDataAvailable(dds_entity_t reader, void* arg) { static_cast<CycloneReader*>(arg)->drain(reader); }

 private:
  void drain(dds_entity_t reader) {
    ddsi_serdata* sd = nullptr;
    dds_sample_info_t info;
    while (dds_takecdr(reader, &sd, 1, &info, DDS_ANY_STATE) == 1) {
      // A sample of a writer of this process was delivered as an object already: dropped undecoded.
      if (info.valid_data && !(spec_.ignore_writer && spec_.ignore_writer(info.publication_handle))) deliver(sd, info);
      ddsi_serdata_unref(sd);
    }
  }

  void deliver(ddsi_serdata* sd, const dds_sample_info_t& info) {
    // A reference into the received sample: no copy before deserialization.
    std::size_t size = ddsi_serdata_size(sd);
    ddsrt_iovec_t iov;
    ddsi_serdata* ref = ddsi_serdata_to_ser_ref(sd, 0, size, &iov);
    SampleInfo si{info.source_timestamp, info.publication_handle};
    if (typed_) {
      if (spec_.type->deserialize(iov.iov_base, iov.iov_len, sample_))
        invokeSafely(spec_.topic, [&] { typed_(sample_, si); });
      else
        spdlog::warn("bus: dropped an undecodable {} sample on topic '{}'", spec_.type_name, spec_.topic);
    } else {
      RawSample s{spec_.topic, spec_.type_name,
                  std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(iov.iov_base), iov.iov_len),
                  si.source_timestamp_ns};
      invokeSafely(spec_.topic, [&] { raw_(s); });
    }
    ddsi_serdata_to_ser_unref(ref, &iov);
  }

  std::shared_ptr<CycloneCore> core_;
  EndpointSpec spec_;
  SampleCallback typed_;
  RawCallback raw_;
  void* sample_ = nullptr;
  dds_entity_t reader_ = 0;
  dds_instance_handle_t handle_ = 0;
};

class CycloneCore : public std::enable_shared_from_this<CycloneCore> {
 public:
  CycloneCore(const ParticipantOptions& options, const Transport& transport, DiscoverySink sink)
      : sink_(std::move(sink)), secured_(transport.security.has_value()), domain_id_(options.domain_id) {
    acquireDomain(options.domain_id, transport);
    QosHandle qos;
    dds_qset_entity_name(qos.qos, options.name.c_str());
    if (transport.security) addSecurity(qos.qos, *transport.security);
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(options.domain_id), qos.qos, nullptr);
    if (participant_ < 0) releaseDomain(domain_id_);
    if (participant_ < 0)
      throw BusError("Cyclone DDS could not create a participant on domain " + std::to_string(options.domain_id) +
                     (transport.security ? " with DDS Security (" + transport.security->identity_certificate + ")" : "") +
                     ": " + errorText(participant_));
    watchBuiltin(DDS_BUILTIN_TOPIC_DCPSPUBLICATION, &CycloneCore::onPublication);
    watchBuiltin(DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION, &CycloneCore::onSubscription);
  }

  ~CycloneCore() {
    dds_delete(participant_);  // and everything in it, waiting for running listeners
    for (auto& [name, st] : sertypes_) ddsi_sertype_unref(const_cast<ddsi_sertype*>(st));
    releaseDomain(domain_id_);
  }

  std::shared_ptr<WriterImpl> createWriter(const EndpointSpec& spec) {
    std::lock_guard lock(mutex_);
    auto [topic, sertype] = topicFor(spec);
    QosHandle qos;
    applyQos(spec.qos, qos.qos);
    dds_entity_t writer = dds_create_writer(participant_, topic, qos.qos, nullptr);
    if (writer < 0)
      throw BusError("Cyclone DDS could not create a writer on topic '" + spec.topic + "': " + errorText(writer) +
                     (secured_ ? " (with DDS Security: do this identity's permissions allow publishing it?)" : ""));
    return std::make_shared<CycloneWriter>(shared_from_this(), writer, sertype, spec);
  }

  std::shared_ptr<ReaderImpl> createReader(const EndpointSpec& spec, SampleCallback typed, RawCallback raw) {
    std::lock_guard lock(mutex_);
    auto [topic, sertype] = topicFor(spec);
    QosHandle qos;
    applyQos(spec.qos, qos.qos);
    auto impl = std::make_shared<CycloneReader>(shared_from_this(), spec, std::move(typed), std::move(raw));
    dds_listener_t* listener = dds_create_listener(impl.get());
    dds_lset_data_available(listener, &CycloneReader::onDataAvailable);
    dds_entity_t reader = dds_create_reader(participant_, topic, qos.qos, listener);
    dds_delete_listener(listener);
    if (reader < 0)
      throw BusError("Cyclone DDS could not create a reader on topic '" + spec.topic + "': " + errorText(reader) +
                     (secured_ ? " (with DDS Security: do this identity's permissions allow subscribing to it?)" : ""));
    impl->attach(reader);
    return impl;
  }

 private:
  std::pair<dds_entity_t, const ddsi_sertype*> topicFor(const EndpointSpec& spec) {
    if (spec.type == nullptr || spec.type->cyclone_descriptor == nullptr)
      throw BusError("topic '" + spec.topic + "': type " + spec.type_name +
                     " is unknown to this build; Cyclone DDS needs its IDL descriptor (use --dds fastdds for "
                     "opaque types)");
    auto* descriptor = static_cast<const dds_topic_descriptor_t*>(spec.type->cyclone_descriptor);
    auto it = topics_.find(spec.topic);
    if (it == topics_.end()) {
      dds_entity_t topic = dds_create_topic(participant_, descriptor, spec.topic.c_str(), nullptr, nullptr);
      if (topic < 0)
        throw BusError("Cyclone DDS could not create topic '" + spec.topic + "' of type " + spec.type_name + ": " +
                       errorText(topic) +
                       (secured_ ? " (with DDS Security: do this identity's permissions allow the topic?)" : ""));
      it = topics_.emplace(spec.topic, topic).first;
    }
    return {it->second, sertypeFor(spec.type_name, descriptor)};
  }

  // Cyclone 0.10 has no public call returning a topic's sertype, but every serdata points to its sertype
  // and Cyclone shares one sertype per (domain, descriptor). So: write one default sample through a
  // private topic of the same descriptor, take it back as serdata, and keep a reference to its type.
  const ddsi_sertype* sertypeFor(const std::string& type_name, const dds_topic_descriptor_t* descriptor) {
    auto it = sertypes_.find(type_name);
    if (it != sertypes_.end()) return it->second;
    std::string probe_name = std::string(kInternalTopicPrefix) + "type_probe/" + type_name;
    for (char& ch : probe_name)
      if (ch == ':') ch = '_';  // not allowed in topic names
    dds_entity_t topic = dds_create_topic(participant_, descriptor, probe_name.c_str(), nullptr, nullptr);
    QosHandle qos;
    dds_qset_reliability(qos.qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(qos.qos, DDS_HISTORY_KEEP_ALL, 0);
    dds_entity_t reader = dds_create_reader(participant_, topic, qos.qos, nullptr);
    dds_entity_t writer = dds_create_writer(participant_, topic, qos.qos, nullptr);
    // An all-zero C sample is a valid default for idlc types (null strings serialize as empty strings).
    std::vector<std::uint8_t> zero(descriptor->m_size + 64, 0);
    const ddsi_sertype* sertype = nullptr;
    if (topic > 0 && reader > 0 && writer > 0 && dds_write(writer, zero.data()) == DDS_RETCODE_OK) {
      ddsi_serdata* sd = nullptr;
      dds_sample_info_t info;
      if (dds_takecdr(reader, &sd, 1, &info, DDS_ANY_STATE) == 1) {
        sertype = ddsi_sertype_ref(sd->type);
        ddsi_serdata_unref(sd);
      }
    }
    dds_delete(writer);
    dds_delete(reader);
    dds_delete(topic);
    if (sertype == nullptr) throw BusError("Cyclone DDS: could not obtain the serializer of type " + type_name);
    sertypes_.emplace(type_name, sertype);
    return sertype;
  }

  using Handler = void (CycloneCore::*)(dds_entity_t);
  struct BuiltinWatch {
    CycloneCore* core;
    Handler handler;
  };

  void watchBuiltin(dds_entity_t builtin_topic, Handler handler) {
    watches_.push_back(std::make_unique<BuiltinWatch>(BuiltinWatch{this, handler}));
    dds_listener_t* listener = dds_create_listener(watches_.back().get());
    dds_lset_data_available(listener, [](dds_entity_t reader, void* arg) {
      auto* w = static_cast<BuiltinWatch*>(arg);
      (w->core->*(w->handler))(reader);
    });
    dds_entity_t reader = dds_create_reader(participant_, builtin_topic, nullptr, listener);
    dds_delete_listener(listener);
    if (reader < 0) spdlog::warn("bus: Cyclone discovery reader failed: {}", errorText(reader));
  }

  void onPublication(dds_entity_t reader) { takeEndpoints(reader, true); }
  void onSubscription(dds_entity_t reader) { takeEndpoints(reader, false); }

  void takeEndpoints(dds_entity_t reader, bool writers) {
    constexpr int kBatch = 16;
    void* samples[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    int n;
    while ((n = dds_take(reader, samples, infos, kBatch, kBatch)) > 0) {
      for (int i = 0; i < n; ++i) {
        if (!infos[i].valid_data || infos[i].instance_state != DDS_IST_ALIVE) continue;
        auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
        // RTPS entity kind (last GUID byte): 0x02 keyed writer, 0x07 keyed reader.
        std::uint8_t kind = ep->key.v[15];
        bool keyed = writers ? kind == 0x02 : kind == 0x07;
        sink_({ep->topic_name, ep->type_name, keyed}, writers);
      }
      dds_return_loan(reader, samples, n);
    }
  }

  DiscoverySink sink_;
  bool secured_ = false;
  int domain_id_ = 0;
  dds_entity_t participant_ = 0;
  std::mutex mutex_;
  std::map<std::string, dds_entity_t> topics_;
  std::map<std::string, const ddsi_sertype*> sertypes_;
  std::vector<std::unique_ptr<BuiltinWatch>> watches_;
};

class CycloneBackend : public Backend {
 public:
  CycloneBackend(const ParticipantOptions& options, const Transport& transport, DiscoverySink sink)
      : core_(std::make_shared<CycloneCore>(options, transport, std::move(sink))) {}
  std::shared_ptr<WriterImpl> createWriter(const EndpointSpec& spec) override { return core_->createWriter(spec); }
  std::shared_ptr<ReaderImpl> createReader(const EndpointSpec& spec, SampleCallback typed, RawCallback raw) override {
    return core_->createReader(spec, std::move(typed), std::move(raw));
  }

 private:
  std::shared_ptr<CycloneCore> core_;
};

}  // namespace

std::unique_ptr<Backend> makeCycloneBackend(const ParticipantOptions& options, const Transport& transport,
                                            DiscoverySink sink) {
  return std::make_unique<CycloneBackend>(options, transport, std::move(sink));
}

}  // namespace ddsnav::bus::detail
