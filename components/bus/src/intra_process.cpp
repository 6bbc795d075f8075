#include "intra_process.hpp"

#include <algorithm>
#include <chrono>
#include <map>

namespace ddsnav::bus::detail {

struct LocalSubscriber {
  std::string type_name;
  Qos qos;
  std::shared_ptr<CallbackGate> gate;
  SharedCallback deliver;
  std::string topic;

  void give(const std::shared_ptr<const void>& sample, const SampleInfo& info) const {
    std::lock_guard lock(gate->mutex);
    if (gate->alive) invokeSafely(topic, [&] { deliver(sample, info); });
  }
};

struct TopicEntry {
  std::mutex mutex;
  std::vector<std::shared_ptr<LocalSubscriber>> subscribers;
  std::vector<LocalWriter*> writers;
};

// What DDS itself would match (request/offered): reliability and durability of the reader may not ask
// for more than the writer offers.
static bool compatible(const Qos& writer, const Qos& reader) {
  if (reader.reliability == Reliability::Reliable && writer.reliability == Reliability::BestEffort) return false;
  if (reader.durability == Durability::TransientLocal && writer.durability == Durability::Volatile) return false;
  return true;
}

class LocalWriter {
 public:
  LocalWriter(std::shared_ptr<IntraDomain> domain, std::shared_ptr<TopicEntry> entry, std::string type_name, Qos qos,
              std::uint64_t handle)
      : domain_(std::move(domain)), entry_(std::move(entry)), type_name_(std::move(type_name)), qos_(qos), handle_(handle) {
    {
      std::lock_guard lock(entry_->mutex);
      entry_->writers.push_back(this);
    }
    domain_->addWriter(handle_);
  }
  ~LocalWriter() {
    {
      std::lock_guard lock(entry_->mutex);
      std::erase(entry_->writers, this);
    }
    domain_->removeWriter(handle_);
  }

  bool wanted() const {
    if (qos_.durability == Durability::TransientLocal) return true;  // kept for local late joiners
    std::lock_guard lock(entry_->mutex);
    return !entry_->subscribers.empty();
  }

  void publish(std::shared_ptr<const void> sample) {
    const SampleInfo info{std::chrono::duration_cast<std::chrono::nanoseconds>(
                              std::chrono::system_clock::now().time_since_epoch()).count(),
                          handle_};
    std::vector<std::shared_ptr<LocalSubscriber>> to;
    {
      std::lock_guard lock(entry_->mutex);
      if (qos_.durability == Durability::TransientLocal) {
        history_.emplace_back(sample, info);
        while (history_.size() > static_cast<std::size_t>(qos_.depth)) history_.pop_front();
      }
      for (const auto& s : entry_->subscribers)
        if (s->type_name == type_name_ && compatible(qos_, s->qos)) to.push_back(s);
    }
    for (const auto& s : to) s->give(sample, info);
  }

  bool ddsNeeded(const WriterImpl& dds) const {
    return qos_.durability == Durability::TransientLocal || domain_->matchedOutside(dds);
  }

  // Under entry->mutex: the newest samples a new subscriber with `qos` is owed.
  void owed(const LocalSubscriber& s, std::vector<std::pair<std::shared_ptr<const void>, SampleInfo>>& out) const {
    if (s.type_name != type_name_ || s.qos.durability != Durability::TransientLocal || !compatible(qos_, s.qos)) return;
    const std::size_t n = std::min(history_.size(), static_cast<std::size_t>(s.qos.depth));
    out.insert(out.end(), history_.end() - static_cast<std::ptrdiff_t>(n), history_.end());
  }

 private:
  std::shared_ptr<IntraDomain> domain_;
  std::shared_ptr<TopicEntry> entry_;
  std::string type_name_;
  Qos qos_;
  std::uint64_t handle_;
  std::deque<std::pair<std::shared_ptr<const void>, SampleInfo>> history_;  // guarded by entry_->mutex
};

bool localWanted(const LocalWriter& writer) { return writer.wanted(); }
void localPublish(LocalWriter& writer, std::shared_ptr<const void> sample) { writer.publish(std::move(sample)); }
bool ddsWriteNeeded(const LocalWriter& writer, const WriterImpl& dds) { return writer.ddsNeeded(dds); }

std::shared_ptr<TopicEntry> IntraDomain::topic(const std::string& name) {
  std::unique_lock lock(mutex_);
  auto& entry = topics_[name];
  if (!entry) entry = std::make_shared<TopicEntry>();
  return entry;
}

bool IntraDomain::isLocalWriter(std::uint64_t handle) const {
  std::shared_lock lock(mutex_);
  return writers_.count(handle) > 0;
}
void IntraDomain::mark(std::set<std::uint64_t>& handles, std::uint64_t handle, bool present) {
  std::unique_lock lock(mutex_);
  if (present) handles.insert(handle);
  else handles.erase(handle);
}
void IntraDomain::addWriter(std::uint64_t handle) { mark(writers_, handle, true); }
void IntraDomain::removeWriter(std::uint64_t handle) { mark(writers_, handle, false); }
void IntraDomain::markReader(std::uint64_t handle, bool present) {
  std::unique_lock lock(mutex_);
  auto readers = std::make_shared<std::set<std::uint64_t>>(*readers_);
  if (present) readers->insert(handle);
  else readers->erase(handle);
  readers_ = std::move(readers);
}
void IntraDomain::addReader(std::uint64_t handle) { markReader(handle, true); }
void IntraDomain::removeReader(std::uint64_t handle) { markReader(handle, false); }
bool IntraDomain::matchedOutside(const WriterImpl& dds) const {
  std::shared_ptr<const std::set<std::uint64_t>> readers;
  {
    std::shared_lock lock(mutex_);
    readers = readers_;
  }
  // Asked without mutex_: matchedBeyond takes the vendor's own locks, and the vendor calls back into
  // isLocalWriter (a reader's data callback) while it holds them. Holding mutex_ here was a lock-order
  // inversion (ThreadSanitizer, bus IntraProcess tests).
  return dds.matchedBeyond(*readers);
}

std::shared_ptr<IntraDomain> intraDomain(Vendor vendor, int domain_id) {
  static std::mutex mutex;
  static std::map<std::pair<Vendor, int>, std::shared_ptr<IntraDomain>> domains;
  std::lock_guard lock(mutex);
  auto& d = domains[{vendor, domain_id}];
  if (!d) d = std::make_shared<IntraDomain>();
  return d;
}

SampleCallback gated(std::shared_ptr<CallbackGate> gate, SampleCallback callback) {
  return [gate = std::move(gate), callback = std::move(callback)](const void* sample, const SampleInfo& info) {
    std::lock_guard lock(gate->mutex);
    if (gate->alive) callback(sample, info);
  };
}

namespace {

class IntraReader : public ReaderImpl {
 public:
  IntraReader(std::shared_ptr<IntraDomain> domain, std::shared_ptr<TopicEntry> entry, std::shared_ptr<LocalSubscriber> sub,
              std::shared_ptr<ReaderImpl> dds)
      : domain_(std::move(domain)), entry_(std::move(entry)), sub_(std::move(sub)), dds_(std::move(dds)) {}
  ~IntraReader() override {
    {
      std::lock_guard lock(entry_->mutex);
      std::erase(entry_->subscribers, sub_);
    }
    {
      std::lock_guard lock(sub_->gate->mutex);  // waits for a delivery in progress
      sub_->gate->alive = false;
    }
    domain_->removeReader(dds_->handle());
    dds_.reset();
  }
  // Local writers are DDS writers too, matched like any other: the DDS counts are the whole story.
  std::size_t matched() const override { return dds_->matched(); }
  std::uint64_t lost() const override { return dds_->lost(); }
  std::uint64_t handle() const override { return dds_->handle(); }

 private:
  std::shared_ptr<IntraDomain> domain_;
  std::shared_ptr<TopicEntry> entry_;
  std::shared_ptr<LocalSubscriber> sub_;
  std::shared_ptr<ReaderImpl> dds_;
};

}  // namespace

std::shared_ptr<ReaderImpl> makeIntraReader(std::shared_ptr<IntraDomain> domain, const std::string& topic,
                                            const std::string& type_name, const Qos& qos,
                                            std::shared_ptr<ReaderImpl> dds, std::shared_ptr<CallbackGate> gate,
                                            SharedCallback local) {
  auto sub = std::make_shared<LocalSubscriber>(LocalSubscriber{type_name, qos, std::move(gate), std::move(local), topic});
  auto entry = domain->topic(topic);
  domain->addReader(dds->handle());
  std::vector<std::pair<std::shared_ptr<const void>, SampleInfo>> owed;
  {
    std::lock_guard lock(entry->mutex);
    entry->subscribers.push_back(sub);
    for (const LocalWriter* w : entry->writers) w->owed(*sub, owed);
  }
  for (const auto& [sample, info] : owed) sub->give(sample, info);
  return std::make_shared<IntraReader>(std::move(domain), std::move(entry), std::move(sub), std::move(dds));
}

std::shared_ptr<LocalWriter> makeLocalWriter(std::shared_ptr<IntraDomain> domain, const std::string& topic,
                                             const std::string& type_name, const Qos& qos, const WriterImpl& dds) {
  auto entry = domain->topic(topic);
  return std::make_shared<LocalWriter>(std::move(domain), std::move(entry), type_name, qos, dds.handle());
}

}  // namespace ddsnav::bus::detail
