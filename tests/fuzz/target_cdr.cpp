// Fuzz target: every message type as it arrives from the wire. The first input byte picks the type (its
// index in msg::all_type_supports(), modulo the count), the rest are the sample's bytes: 4-byte
// encapsulation header + XCDR1 body, exactly what both bus backends hand to TypeSupport::deserialize.
// A sample that decodes then goes through the check and conversion its consumers run on arrival
// (components/nodes validate.hpp / convert.hpp).
// Contract: decoding says false, or it yields a sample that re-encodes to bytes which decode to the same
// sample; a sample the checks accept converts without throwing.
#include "fuzz_input.hpp"

#include <ddsnav/mapper/occupancy_mapper.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/nodes/convert.hpp>
#include <ddsnav/nodes/validate.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <cstring>
#include <memory>
#include <vector>

namespace {

using namespace ddsnav;

struct Sample {
  const msg::TypeSupport& type;
  void* data;
  explicit Sample(const msg::TypeSupport& t) : type(t), data(t.create()) {}
  ~Sample() { type.destroy(data); }
  Sample(const Sample&) = delete;
  Sample& operator=(const Sample&) = delete;
};

std::vector<std::uint8_t> encode(const Sample& s) {
  std::vector<std::uint8_t> bytes(s.type.serialized_size(s.data));
  const std::size_t written = s.type.serialize(s.data, bytes.data(), bytes.size());
  if (written == 0) {
    std::fprintf(stderr, "%.*s: a decoded sample does not encode again\n", int(s.type.name.size()), s.type.name.data());
    std::abort();
  }
  bytes.resize(written);
  return bytes;
}

// The demo yard: what the planner and tracker check maps and obstacles against in the demo.
const planner::Scenario& demoScenario() {
  static const planner::Scenario scenario = planner::loadScenario(DDSNAV_SOURCE_DIR "/configs/scenarios/demo_2d.yaml");
  return scenario;
}

// What the consumers of each type do with a sample right after it arrives.
void consume(const void* data, std::string_view type) {
  if (type == "ddsnav::msg::ObstacleArray") {
    const auto& a = *static_cast<const msg::ObstacleArray*>(data);
    if (nodes::checkObstacleArray(a, "").empty()) {
      auto ellipses = nodes::toEllipsoidObstacles(a);  // must not throw: the check accepted it
      const auto& s = demoScenario();
      nodes::clearFootprint(ellipses, s.start, s.robot_radius, s.dimensions);
      const auto world = planner::makeEllipsoidWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, std::move(ellipses));
      (void)world->isSegmentFree(s.start, s.goal);
    }
  } else if (type == "ddsnav::msg::OccupancyMap") {
    (void)nodes::checkOccupancyMap(*static_cast<const msg::OccupancyMap*>(data), nodes::kWorldFrame, demoScenario());
  } else if (type == "ddsnav::msg::PointCloud") {
    const auto& cloud = *static_cast<const msg::PointCloud*>(data);
    (void)nodes::isPlanarCloud(nodes::pointsOf(cloud));
    (void)nodes::toScan(cloud, 30.0);
  } else if (type == "ddsnav::msg::VehicleState") {
    (void)nodes::fromMsg(*static_cast<const msg::VehicleState*>(data));
  } else if (type == "ddsnav::msg::VelocityCommand") {
    (void)nodes::fromMsg(*static_cast<const msg::VelocityCommand*>(data));
  } else if (type == "ddsnav::msg::Path") {
    (void)nodes::statesOf(*static_cast<const msg::Path*>(data));
  } else if (type == "ddsnav::msg::PlanRequest") {
    const auto& r = *static_cast<const msg::PlanRequest*>(data);
    (void)nodes::fromMsg(r.start());
    (void)nodes::fromMsg(r.goal());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto& types = msg::all_type_supports();
  const msg::TypeSupport& type = *types[data[0] % types.size()];
  Sample sample(type);
  if (!type.deserialize(data + 1, size - 1, sample.data)) return 0;
  consume(sample.data, type.name);

  // Re-encoding is what the recorder's and the bus's own path do; its bytes must decode to the same sample.
  const auto once = encode(sample);
  Sample again(type);
  if (!type.deserialize(once.data(), once.size(), again.data)) {
    std::fprintf(stderr, "%.*s: re-encoded bytes do not decode\n", int(type.name.size()), type.name.data());
    std::abort();
  }
  const auto twice = encode(again);
  if (once != twice) {
    std::fprintf(stderr, "%.*s: decode(encode(sample)) differs from sample\n", int(type.name.size()), type.name.data());
    std::abort();
  }
  if (type.keyed) {
    std::vector<unsigned char> key;
    type.serialize_key(sample.data, key);
  }
  return 0;
}
