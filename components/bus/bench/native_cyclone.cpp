// Benchmark link over Cyclone DDS's own C API: the idlc ddsnav_msg_OccupancyMap struct, dds_write, and a
// data-available listener taking loaned samples; same loopback configuration as the bus.
#include "link.hpp"

#include "map.h"  // idlc output (build tree)

#include <dds/dds.h>

#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

namespace ddsnav::bench {
namespace {

constexpr const char* kConfig =
    "<CycloneDDS><Domain id=\"any\">"
    "<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
    "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery>"
    "<Internal><SocketReceiveBufferSize min=\"4MB\"/></Internal>"
    "</Domain></CycloneDDS>";

struct ReaderCtx {
  int topic;
  ReceiveFn fn;
};

void onData(dds_entity_t reader, void* arg) {
  auto* ctx = static_cast<ReaderCtx*>(arg);
  void* samples[1] = {nullptr};
  dds_sample_info_t info;
  while (dds_take(reader, samples, &info, 1, 1) == 1) {
    if (info.valid_data) {
      auto* m = static_cast<const ddsnav_msg_OccupancyMap*>(samples[0]);
      ctx->fn(ctx->topic, m->header.stamp_ns, m->octree._length);
    }
    dds_return_loan(reader, samples, 1);
  }
}

class NativeCycloneLink : public Link {
 public:
  explicit NativeCycloneLink(const LinkOptions& o) {
    static std::mutex m;
    static std::set<int> domains;
    {
      std::lock_guard lock(m);
      if (domains.insert(o.domain).second) dds_create_domain(o.domain, kConfig);
    }
    participant_ = dds_create_participant(o.domain, nullptr, nullptr);
    if (participant_ < 0) throw std::runtime_error("native Cyclone participant failed");
    payload_.assign(o.payload, 0x5a);
    sample_ = {};
    sample_.header.frame_id = const_cast<char*>("bench");
    sample_.octree._buffer = payload_.data();
    sample_.octree._length = sample_.octree._maximum = static_cast<uint32_t>(payload_.size());
    sample_.octree._release = false;

    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, kDepth);
    const std::vector<int> out = o.pinger ? std::vector<int>{kPing, kStream} : std::vector<int>{kPong};
    const std::vector<int> in = o.pinger ? std::vector<int>{kPong} : std::vector<int>{kPing, kStream};
    for (int t : out) writers_[t] = dds_create_writer(participant_, topic(t), qos, nullptr);
    for (int t : in) {
      ctxs_.push_back(std::make_unique<ReaderCtx>(ReaderCtx{t, o.on_receive}));
      dds_listener_t* l = dds_create_listener(ctxs_.back().get());
      dds_lset_data_available(l, &onData);
      dds_create_reader(participant_, topic(t), qos, l);
      dds_delete_listener(l);
    }
    dds_delete_qos(qos);
  }

  ~NativeCycloneLink() override { dds_delete(participant_); }

  bool send(int t, std::int64_t seq) override {
    sample_.header.stamp_ns = seq;
    return dds_write(writers_[t], &sample_) == DDS_RETCODE_OK;
  }

  std::size_t matchedReaders() override {
    std::size_t n = 0;
    for (auto& [t, w] : writers_) {
      dds_publication_matched_status_t s{};
      dds_get_publication_matched_status(w, &s);
      n += s.current_count;
    }
    return n;
  }

 private:
  dds_entity_t topic(int t) {
    auto it = topics_.find(t);
    if (it != topics_.end()) return it->second;
    return topics_[t] = dds_create_topic(participant_, &ddsnav_msg_OccupancyMap_desc, topicName(t), nullptr, nullptr);
  }

  dds_entity_t participant_ = 0;
  std::map<int, dds_entity_t> topics_;
  std::map<int, dds_entity_t> writers_;
  std::vector<std::unique_ptr<ReaderCtx>> ctxs_;
  std::vector<std::uint8_t> payload_;
  ddsnav_msg_OccupancyMap sample_;
};

}  // namespace

std::unique_ptr<Link> makeNativeCycloneLink(const LinkOptions& options) {
  return std::make_unique<NativeCycloneLink>(options);
}

}  // namespace ddsnav::bench
