#include <ddsnav/foxglove/derived.hpp>

#include <cmath>

namespace ddsnav::foxglove {
namespace {

constexpr const char* kPointCloud = "foxglove.PointCloud";
constexpr const char* kSceneUpdate = "foxglove.SceneUpdate";
constexpr const char* kGrid = "foxglove.Grid";
constexpr const char* kFrameTransform = "foxglove.FrameTransform";

std::string derivedTopic(std::string_view topic) { return std::string(kTopicPrefix) + std::string(topic); }

template <class T>
T decode(std::string_view topic, std::span<const std::uint8_t> payload) {
  T sample;
  const auto& type = msg::type_support<T>();
  if (!type.deserialize(payload.data(), payload.size(), &sample))
    throw ConversionError(std::string(topic) + ": " + std::to_string(payload.size()) + " bytes are not a complete " +
                          std::string(type.name));
  return sample;
}

double distance(const msg::Vec3& a, const msg::Vec3& b) {
  return std::sqrt((a.x() - b.x()) * (a.x() - b.x()) + (a.y() - b.y()) * (a.y() - b.y()) + (a.z() - b.z()) * (a.z() - b.z()));
}

}  // namespace

SceneDeriver::SceneDeriver(SceneDeriverOptions options) : options_(std::move(options)) {
  if (options_.max_track_points < 2) options_.max_track_points = 2;
}

std::vector<DerivedChannel> SceneDeriver::channelsFor(std::string_view topic, std::string_view type) {
  const std::string derived = derivedTopic(topic);
  if (type == "ddsnav::msg::PointCloud") return {{derived, kPointCloud}};
  if (type == "ddsnav::msg::ObstacleArray" || type == "ddsnav::msg::Path" || type == "ddsnav::msg::Trajectory")
    return {{derived, kSceneUpdate}};
  if (type == "ddsnav::msg::VehicleState") return {{derived, kSceneUpdate}, {kTransformTopic, kFrameTransform}};
  if (type == "ddsnav::msg::OccupancyMap") return {{derived, kSceneUpdate}, {derived + "/grid", kGrid}};
  return {};
}

std::vector<DerivedChannel> SceneDeriver::standingChannels() const {
  if (!options_.scenario) return {};
  return {{kScenarioTopic, kSceneUpdate}};
}

std::vector<DerivedMessage> SceneDeriver::standingMessages(std::int64_t stamp_ns) const {
  if (!options_.scenario) return {};
  return {{{kScenarioTopic, kSceneUpdate}, stamp_ns, scenarioScene(*options_.scenario, stamp_ns).dump()}};
}

std::vector<DerivedMessage> SceneDeriver::onSample(std::string_view topic, std::string_view type,
                                                   std::span<const std::uint8_t> payload) {
  const std::string derived = derivedTopic(topic);
  // Every conversion error is reported as "topic: field ...".
  try {
    if (type == "ddsnav::msg::PointCloud") {
      const auto cloud = decode<msg::PointCloud>(topic, payload);
      return {{{derived, kPointCloud}, cloud.header().stamp_ns(), pointCloud(cloud).dump()}};
    }
    if (type == "ddsnav::msg::ObstacleArray") {
      const auto array = decode<msg::ObstacleArray>(topic, payload);
      return {{{derived, kSceneUpdate}, array.header().stamp_ns(), obstacleScene(array).dump()}};
    }
    if (type == "ddsnav::msg::Path") {
      const auto path = decode<msg::Path>(topic, payload);
      return {{{derived, kSceneUpdate}, path.header().stamp_ns(), pathScene(path).dump()}};
    }
    if (type == "ddsnav::msg::Trajectory") {
      const auto trajectory = decode<msg::Trajectory>(topic, payload);
      return {{{derived, kSceneUpdate}, trajectory.header().stamp_ns(), trajectoryScene(trajectory).dump()}};
    }
    if (type == "ddsnav::msg::VehicleState") {
      const auto state = decode<msg::VehicleState>(topic, payload);
      const std::int64_t stamp = state.header().stamp_ns();
      std::vector<DerivedMessage> out;
      out.push_back({{kTransformTopic, kFrameTransform}, stamp, vehicleTransform(state).dump()});  // checks the values
      if (track_.empty() || distance(track_.back(), state.position()) >= options_.track_spacing_m) {
        if (track_.size() >= options_.max_track_points) {  // keep every other point: the shape, not every step
          std::vector<msg::Vec3> thinned;
          for (std::size_t i = 0; i < track_.size(); i += 2) thinned.push_back(track_[i]);
          track_ = std::move(thinned);
        }
        track_.push_back(state.position());
      }
      vehicle_z_ = state.position().z();
      if (last_vehicle_scene_ns_ < 0 || stamp - last_vehicle_scene_ns_ >= options_.vehicle_scene_period_ns ||
          stamp < last_vehicle_scene_ns_) {
        last_vehicle_scene_ns_ = stamp;
        out.push_back({{derived, kSceneUpdate}, stamp, vehicleScene(state, track_).dump()});
      }
      return out;
    }
    if (type == "ddsnav::msg::OccupancyMap") {
      const auto map = decode<msg::OccupancyMap>(topic, payload);
      const std::int64_t stamp = map.header().stamp_ns();
      return {{{derived, kSceneUpdate}, stamp, mapScene(map, options_.max_voxels).dump()},
              {{derived + "/grid", kGrid}, stamp, mapGrid(map, vehicle_z_, options_.max_grid_cells).dump()}};
    }
  } catch (const ConversionError& e) {
    const std::string what = e.what();
    if (what.starts_with(std::string(topic) + ":")) throw;
    throw ConversionError(std::string(topic) + ": " + what);
  }
  return {};
}

}  // namespace ddsnav::foxglove
