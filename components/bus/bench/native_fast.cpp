// Benchmark link over Fast DDS's own API: the fastddsgen OccupancyMapPubSubType, a DataReaderListener,
// and the same loopback participant settings the bus uses.
#include "link.hpp"

#include <ddsnav/msg/mapPubSubTypes.h>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <map>
#include <stdexcept>

namespace ddsnav::bench {
namespace {

namespace dds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;

class Listener : public dds::DataReaderListener {
 public:
  Listener(int topic, ReceiveFn fn) : topic_(topic), fn_(std::move(fn)) {}
  void on_data_available(dds::DataReader* reader) override {
    dds::SampleInfo info;
    while (reader->take_next_sample(&sample_, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK)
      if (info.valid_data) fn_(topic_, sample_.header().stamp_ns(), sample_.octree().size());
  }

 private:
  int topic_;
  ReceiveFn fn_;
  ddsnav::msg::OccupancyMap sample_;
};

class NativeFastLink : public Link {
 public:
  explicit NativeFastLink(const LinkOptions& o) {
    dds::DomainParticipantQos pq;
    pq.name("bench-native-fast");
    pq.transport().use_builtin_transports = false;
    if (o.shared_memory) {
      auto shm = std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>();
      shm->segment_size(16 * 1024 * 1024);
      pq.transport().user_transports.push_back(shm);
    }
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.emplace_back("127.0.0.1");
    udp->maxInitialPeersRange = 32;
    udp->sendBufferSize = udp->receiveBufferSize = 4 * 1024 * 1024;
    pq.transport().user_transports.push_back(udp);
    pq.transport().send_socket_buffer_size = pq.transport().listen_socket_buffer_size = 4 * 1024 * 1024;
    rtps::Locator_t loc;
    rtps::IPLocator::setIPv4(loc, 127, 0, 0, 1);
    pq.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(loc);
    pq.wire_protocol().builtin.initialPeersList.push_back(loc);
    pq.wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod = {0, 500'000'000};
    auto* factory = dds::DomainParticipantFactory::get_instance();
    participant_ = factory->create_participant(o.domain, pq);
    if (participant_ == nullptr) throw std::runtime_error("native Fast DDS participant failed");
    dds::TypeSupport type(new ddsnav::msg::OccupancyMapPubSubType());
    type.register_type(participant_);
    publisher_ = participant_->create_publisher(dds::PUBLISHER_QOS_DEFAULT);
    subscriber_ = participant_->create_subscriber(dds::SUBSCRIBER_QOS_DEFAULT);
    sample_.header().frame_id("bench");
    sample_.octree().resize(o.payload, 0x5a);

    const std::vector<int> out = o.pinger ? std::vector<int>{kPing, kStream} : std::vector<int>{kPong};
    const std::vector<int> in = o.pinger ? std::vector<int>{kPong} : std::vector<int>{kPing, kStream};
    for (int t : out) {
      dds::DataWriterQos wq = publisher_->get_default_datawriter_qos();
      wq.reliability().kind = dds::RELIABLE_RELIABILITY_QOS;
      wq.durability().kind = dds::VOLATILE_DURABILITY_QOS;
      wq.history().kind = dds::KEEP_LAST_HISTORY_QOS;
      wq.history().depth = kDepth;
      wq.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
      wq.reliable_writer_qos().times.heartbeatPeriod = {0, 100'000'000};
      writers_[t] = publisher_->create_datawriter(topic(t, type), wq);
    }
    for (int t : in) {
      dds::DataReaderQos rq = subscriber_->get_default_datareader_qos();
      rq.reliability().kind = dds::RELIABLE_RELIABILITY_QOS;
      rq.durability().kind = dds::VOLATILE_DURABILITY_QOS;
      rq.history().kind = dds::KEEP_LAST_HISTORY_QOS;
      rq.history().depth = kDepth;
      rq.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
      listeners_.push_back(std::make_unique<Listener>(t, o.on_receive));
      readers_.push_back(subscriber_->create_datareader(topic(t, type), rq, listeners_.back().get()));
    }
  }

  ~NativeFastLink() override {
    for (auto* r : readers_) r->set_listener(nullptr);
    participant_->delete_contained_entities();
    dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }

  bool send(int t, std::int64_t seq) override {
    sample_.header().stamp_ns(seq);
    return writers_[t]->write(&sample_);
  }

  std::size_t matchedReaders() override {
    std::size_t n = 0;
    for (auto& [t, w] : writers_) {
      dds::PublicationMatchedStatus s;
      w->get_publication_matched_status(s);
      n += s.current_count;
    }
    return n;
  }

 private:
  dds::Topic* topic(int t, dds::TypeSupport& type) {
    auto it = topics_.find(t);
    if (it != topics_.end()) return it->second;
    return topics_[t] = participant_->create_topic(topicName(t), type.get_type_name(), dds::TOPIC_QOS_DEFAULT);
  }

  dds::DomainParticipant* participant_ = nullptr;
  dds::Publisher* publisher_ = nullptr;
  dds::Subscriber* subscriber_ = nullptr;
  std::map<int, dds::Topic*> topics_;
  std::map<int, dds::DataWriter*> writers_;
  std::vector<dds::DataReader*> readers_;
  std::vector<std::unique_ptr<Listener>> listeners_;
  ddsnav::msg::OccupancyMap sample_;
};

}  // namespace

std::unique_ptr<Link> makeNativeFastLink(const LinkOptions& options) {
  return std::make_unique<NativeFastLink>(options);
}

}  // namespace ddsnav::bench
