// Benchmark link over the ddsnav bus (msg::OccupancyMap, its octree bytes as the payload).
#include "link.hpp"

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>

#include <map>

namespace ddsnav::bench {
namespace {

class BusLink : public Link {
 public:
  explicit BusLink(const LinkOptions& o) {
    bus::ParticipantOptions po;
    po.vendor = o.cyclone ? bus::Vendor::CycloneDDS : bus::Vendor::FastDDS;
    po.domain_id = o.domain;
    po.name = "bench-bus";
    po.fast_shared_memory = o.shared_memory;
    po.security_dir = o.security_dir;  // empty: explicitly unsecured, whatever $DDSNAV_SECURITY says
    participant_ = std::make_unique<bus::Participant>(po);
    sample_.header().frame_id("bench");
    sample_.octree().resize(o.payload, 0x5a);
    const bus::Qos qos = bus::Qos::commands(kDepth);
    const std::vector<int> out = o.pinger ? std::vector<int>{kPing, kStream} : std::vector<int>{kPong};
    const std::vector<int> in = o.pinger ? std::vector<int>{kPong} : std::vector<int>{kPing, kStream};
    for (int t : out) writers_[t] = participant_->publisher<msg::OccupancyMap>(topicName(t), qos);
    for (int t : in)
      subs_.push_back(participant_->subscribe<msg::OccupancyMap>(
          topicName(t), qos, [fn = o.on_receive, t](const msg::OccupancyMap& m) {
            fn(t, m.header().stamp_ns(), m.octree().size());
          }));
  }
  ~BusLink() override {
    subs_.clear();
  }

  bool send(int topic, std::int64_t seq) override {
    sample_.header().stamp_ns(seq);
    try {
      writers_[topic].publish(sample_);
    } catch (const bus::BusError&) {
      return false;
    }
    return true;
  }

  std::size_t matchedReaders() override {
    std::size_t n = 0;
    for (auto& [t, w] : writers_) n += w.matchedSubscribers();
    return n;
  }

 private:
  std::unique_ptr<bus::Participant> participant_;
  msg::OccupancyMap sample_;
  std::map<int, bus::Publisher<msg::OccupancyMap>> writers_;
  std::vector<bus::Subscription> subs_;
};

}  // namespace

std::unique_ptr<Link> makeBusLink(const LinkOptions& options) { return std::make_unique<BusLink>(options); }

}  // namespace ddsnav::bench
