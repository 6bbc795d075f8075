// The derived Foxglove channels of a ddsnav run, defined once for the live bridge (`ddsnav bridge`) and
// for recordings (`ddsnav export --foxglove`): raw samples of ddsnav topics (encapsulation + XCDR1, as
// the bus and MCAP files carry them) go in, JSON messages in Foxglove's schemas come out.
//
//   foxglove::SceneDeriver derive({.scenario = planner::loadScenario(path)});
//   for (const auto& channel : foxglove::SceneDeriver::channelsFor(topic, type_name)) advertise(channel);
//   for (const auto& m : derive.onSample(topic, type_name, payload)) send(m.channel.topic, m.json);
//
// Channels (<topic> is the source topic, e.g. foxglove/perception/obstacles):
//   PointCloud    -> foxglove/<topic>            foxglove.PointCloud
//   ObstacleArray -> foxglove/<topic>            foxglove.SceneUpdate (ellipsoids, probability labels)
//   Path          -> foxglove/<topic>            foxglove.SceneUpdate (the planned path)
//   Trajectory    -> foxglove/<topic>            foxglove.SceneUpdate (the smoothed trajectory)
//   VehicleState  -> foxglove/<topic>            foxglove.SceneUpdate (vehicle arrow + driven track, <= 10 Hz)
//                    foxglove/tf                 foxglove.FrameTransform (map -> vehicle, every sample)
//   OccupancyMap  -> foxglove/<topic>            foxglove.SceneUpdate (occupied voxels as cubes)
//                    foxglove/<topic>/grid       foxglove.Grid (slice at the vehicle's height)
//   scenario file -> foxglove/scenario           foxglove.SceneUpdate (true obstacles, bounds, start, goal)
//
// Not thread-safe: one caller at a time (the bridge calls it from one worker thread).
#pragma once

#include <ddsnav/foxglove/scene.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace ddsnav::foxglove {

inline constexpr std::string_view kTopicPrefix = "foxglove/";
inline constexpr const char* kScenarioTopic = "foxglove/scenario";
inline constexpr const char* kTransformTopic = "foxglove/tf";

struct DerivedChannel {
  std::string topic;        // e.g. "foxglove/perception/obstacles"
  std::string schema_name;  // e.g. "foxglove.SceneUpdate" (its JSON Schema: jsonSchema(schema_name))
  bool operator==(const DerivedChannel&) const = default;
};

struct DerivedMessage {
  DerivedChannel channel;
  std::int64_t stamp_ns = 0;  // the source message's header stamp
  std::string json;           // the message, serialized
};

struct SceneDeriverOptions {
  std::optional<planner::Scenario> scenario;  // drawn on foxglove/scenario when given
  std::size_t max_track_points = 4000;        // driven track: older points thinned out beyond this
  double track_spacing_m = 0.05;              // a track point once the vehicle moved this far
  std::int64_t vehicle_scene_period_ns = 100'000'000;  // vehicle scene at most every 0.1 s
  std::size_t max_voxels = 50000;             // cubes per map scene
  std::size_t max_grid_cells = 1u << 20;
};

class SceneDeriver {
 public:
  explicit SceneDeriver(SceneDeriverOptions options = {});

  // Derived channels a source topic of this type feeds (empty for types with no Foxglove view).
  static std::vector<DerivedChannel> channelsFor(std::string_view topic, std::string_view type_name);
  // Channels that exist without any source topic (foxglove/scenario when a scenario is given).
  std::vector<DerivedChannel> standingChannels() const;
  // Messages of the standing channels (the scenario scene), stamped stamp_ns.
  std::vector<DerivedMessage> standingMessages(std::int64_t stamp_ns) const;

  // Derived messages for one raw sample, stamped with the source message's header stamp.
  // Throws ConversionError "TOPIC: what" for bytes that are not a complete sample of the type or for a
  // message with bad values; the deriver's state (track, last vehicle height) is unchanged then.
  std::vector<DerivedMessage> onSample(std::string_view topic, std::string_view type_name,
                                       std::span<const std::uint8_t> payload);

  const std::vector<msg::Vec3>& track() const { return track_; }

 private:
  SceneDeriverOptions options_;
  std::vector<msg::Vec3> track_;
  std::int64_t last_vehicle_scene_ns_ = -1;
  double vehicle_z_ = 0;
};

}  // namespace ddsnav::foxglove
