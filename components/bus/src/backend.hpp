// What each vendor implements behind the bus API. Private to components/bus.
#pragma once

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/security/security.hpp>

#include <atomic>
#include <functional>
#include <memory>
#include <set>
#include <span>
#include <string>

namespace ddsnav::bus::detail {

class WriterImpl {
 public:
  virtual ~WriterImpl() = default;
  virtual void writeSample(const void* sample) = 0;                 // a generated class
  virtual void writeRaw(std::span<const std::uint8_t> payload) = 0;  // encapsulation + body
  virtual std::size_t matched() const = 0;
  // Matched readers that have also had time to match this writer (see the Fast DDS backend): what
  // waitForSubscribers waits for. matched() is what delivery decisions use.
  virtual std::size_t settled() const { return matched(); }
  // The writer's handle as a reader's SampleInfo::publication_handle shows it.
  virtual std::uint64_t handle() const = 0;
  // Whether a matched reader exists whose handle (ReaderImpl::handle) is not in `readers`.
  virtual bool matchedBeyond(const std::set<std::uint64_t>& readers) const = 0;
  std::atomic<std::uint64_t> typed_writes{0};  // writeSample calls, for Publisher::ddsWrites
};

class ReaderImpl {
 public:
  virtual ~ReaderImpl() = default;
  virtual std::size_t matched() const = 0;
  virtual std::uint64_t lost() const = 0;  // sample lost + sample rejected totals
  virtual std::uint64_t handle() const { return 0; }  // as the writers' matched-reader lists show it
};

// One endpoint to create. `type` is null only for raw endpoints of a type unknown to this build.
struct EndpointSpec {
  std::string topic;
  std::string type_name;
  bool keyed = false;
  const msg::TypeSupport* type = nullptr;
  Qos qos;
  // Readers only: when set and true for a sample's writer handle, the sample is dropped before it is
  // decoded (it came from this process and was delivered intra-process already).
  std::function<bool(std::uint64_t writer)> ignore_writer;
};

// A discovered endpoint: is_writer false for a subscription.
using DiscoverySink = std::function<void(const TopicInfo& info, bool is_writer)>;

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::shared_ptr<WriterImpl> createWriter(const EndpointSpec& spec) = 0;
  // Exactly one of typed / raw is set.
  virtual std::shared_ptr<ReaderImpl> createReader(const EndpointSpec& spec, SampleCallback typed,
                                                   RawCallback raw) = 0;
};

// The network and security settings of one participant, resolved and checked by bus.cpp before a
// backend is made: backends only translate them into vendor settings.
struct Transport {
  std::string address = "127.0.0.1";  // IPv4 address of the interface every socket uses
  std::string interface;              // its name; empty: loopback
  std::vector<std::string> peers;     // IPv4 addresses for unicast discovery, this host's included
  bool multicast = false;
  bool fast_shared_memory = true;  // Fast DDS only
  std::optional<security::Credentials> security;
  bool loopback() const { return interface.empty(); }
};

// URI of a credentials file as both vendors' plugins take it.
inline std::string fileUri(const std::string& path) { return "file://" + path; }

// The sink may be called from vendor threads until the backend is destroyed.
std::unique_ptr<Backend> makeFastBackend(const ParticipantOptions& options, const Transport& transport,
                                         DiscoverySink sink);
std::unique_ptr<Backend> makeCycloneBackend(const ParticipantOptions& options, const Transport& transport,
                                            DiscoverySink sink);

// Topics whose name starts with this are the bus's own plumbing, hidden from discovery.
inline constexpr std::string_view kInternalTopicPrefix = "ddsnav_internal/";

// Runs a user callback, logging (not propagating) what it throws: vendor threads must not unwind.
void invokeSafely(const std::string& topic, const std::function<void()>& call);

}  // namespace ddsnav::bus::detail
