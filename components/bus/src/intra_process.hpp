// Intra-process delivery: what the participants of one process with ParticipantOptions::intra_process
// share per (vendor, domain). Private to components/bus; see docs/bus.md, "Intra-process".
//
// A typed publisher of an unkeyed topic gets a LocalWriter beside its DDS writer, a typed subscription a
// LocalSubscriber beside its DDS reader. Publishing hands the message object (a shared_ptr<const T>) to
// every compatible local subscriber, with the DDS request/offered rules (a reliable reader needs a
// reliable writer, a transient-local reader a transient-local writer), and keeps the last `depth` objects
// of a transient-local writer for local late joiners. DDS still gets the sample when a reader outside
// this process's intra-process set is matched, and always on transient-local topics (a process that
// joins later must get the last sample from the DDS writer's history). Local readers drop, undecoded,
// what DDS brings them from local intra-process writers: the dedupe is by writer handle, so a local
// writer that is not intra-process (a raw publisher, another vendor) still reaches them over DDS.
#pragma once

#include "backend.hpp"

#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <map>
#include <shared_mutex>
#include <string>
#include <vector>

namespace ddsnav::bus::detail {

struct LocalSubscriber;
struct TopicEntry;

// The intra-process participants of one vendor and domain in this process.
class IntraDomain {
 public:
  std::shared_ptr<TopicEntry> topic(const std::string& name);
  bool isLocalWriter(std::uint64_t handle) const;
  void addWriter(std::uint64_t handle);
  void removeWriter(std::uint64_t handle);
  void addReader(std::uint64_t handle);
  void removeReader(std::uint64_t handle);
  // Whether `dds` is matched with a reader that is not one of ours (so it needs the DDS sample).
  bool matchedOutside(const WriterImpl& dds) const;

 private:
  mutable std::shared_mutex mutex_;
  std::map<std::string, std::shared_ptr<TopicEntry>> topics_;
  void mark(std::set<std::uint64_t>& handles, std::uint64_t handle, bool present);
  void markReader(std::uint64_t handle, bool present);
  std::set<std::uint64_t> writers_;
  // Replaced, never changed in place: matchedOutside reads a snapshot without holding mutex_.
  std::shared_ptr<const std::set<std::uint64_t>> readers_ = std::make_shared<const std::set<std::uint64_t>>();
};

// The shared state of (vendor, domain_id); created on first use, kept for the process's life.
std::shared_ptr<IntraDomain> intraDomain(Vendor vendor, int domain_id);

// The callback side of a subscription, shared by its DDS and its intra-process paths: one mutex keeps
// the promise that one subscription's callbacks never overlap, and `alive` lets the destructor wait out
// a delivery in progress.
struct CallbackGate {
  std::mutex mutex;
  bool alive = true;
};

// Wraps a reader's DDS callback so that it runs under the gate.
SampleCallback gated(std::shared_ptr<CallbackGate> gate, SampleCallback callback);

// Registers a local subscriber (and replays the transient-local history it is owed); the returned
// ReaderImpl wraps `dds` and unregisters when destroyed.
std::shared_ptr<ReaderImpl> makeIntraReader(std::shared_ptr<IntraDomain> domain, const std::string& topic,
                                            const std::string& type_name, const Qos& qos,
                                            std::shared_ptr<ReaderImpl> dds, std::shared_ptr<CallbackGate> gate,
                                            SharedCallback local);

std::shared_ptr<LocalWriter> makeLocalWriter(std::shared_ptr<IntraDomain> domain, const std::string& topic,
                                             const std::string& type_name, const Qos& qos, const WriterImpl& dds);

}  // namespace ddsnav::bus::detail
