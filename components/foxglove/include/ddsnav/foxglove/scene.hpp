// ddsnav messages as Foxglove messages (JSON, matching the schemas in schemas.hpp), so Foxglove's 3D
// panel can draw a run: clouds, perception's ellipses/ellipsoids, the scenario's true obstacles, planned
// paths, the smoothed trajectory, the vehicle and its driven track, occupied map voxels, and the
// vehicle's frame. No DDS: the inputs are the generated message classes (or the scenario), the outputs
// plain JSON documents.
//
// Every numeric input is checked once here: a non-finite coordinate, a negative size or a time before
// the epoch throws ConversionError naming the field ("obstacles[2].semi_axes.y is nan"), since JSON has
// no NaN and Foxglove would refuse the whole message.
#pragma once

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::foxglove {

class ConversionError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

inline constexpr const char* kVehicleFrame = "vehicle";

struct Rgba {
  double r = 1, g = 1, b = 1, a = 1;
};

// {sec, nsec} of a stamp in ns since the epoch (throws for a negative stamp).
nlohmann::json timeOf(std::int64_t stamp_ns);

// foxglove.PointCloud: x, y, z (float32) and, when the cloud has them, intensity (float32) per point.
nlohmann::json pointCloud(const msg::PointCloud& cloud);

// foxglove.SceneUpdate with one entity per obstacle ("obstacle/<id>"): a sphere scaled to the semi-axes
// and turned by the orientation (an ellipse in 2-D: a flat disc of `planar_thickness`), a label with the
// probability bound, and the probability and point count as entity metadata. Entities of the previous
// array are removed first (a deletion of every "obstacle/" id is not expressible, so all are deleted).
nlohmann::json obstacleScene(const msg::ObstacleArray& obstacles, double planar_thickness = 0.05);

// foxglove.SceneUpdate with the scenario's true obstacles (boxes, spheres/circles, ellipsoids, hills as
// cylinders of their sigma), its bounds as a line loop, start and goal.
nlohmann::json scenarioScene(const planner::Scenario& scenario, std::int64_t stamp_ns);

// foxglove.SceneUpdate: the planned path as a line strip ("path"); an unsolved path clears it and shows
// the failure reason as text.
nlohmann::json pathScene(const msg::Path& path);

// foxglove.SceneUpdate: the smoothed trajectory's positions as a line strip ("trajectory").
nlohmann::json trajectoryScene(const msg::Trajectory& trajectory);

// foxglove.SceneUpdate: the vehicle as an arrow along its heading ("vehicle") and the driven track as a
// line strip ("track").
nlohmann::json vehicleScene(const msg::VehicleState& state, const std::vector<msg::Vec3>& track);

// foxglove.FrameTransform map -> vehicle (the pose of the vehicle frame in the state's frame).
nlohmann::json vehicleTransform(const msg::VehicleState& state);

// Occupied leaves of the map's octree (msg::OccupancyMap::octree, OctoMap binary format).
struct Voxel {
  double x, y, z, size;
};
// Throws ConversionError when the bytes are no OctoMap binary tree. At most max_voxels are returned;
// *truncated (if given) says whether there were more.
std::vector<Voxel> occupiedVoxels(const msg::OccupancyMap& map, std::size_t max_voxels, bool* truncated = nullptr);

// foxglove.SceneUpdate: occupied voxels as cubes ("map"), at most max_voxels of them.
nlohmann::json mapScene(const msg::OccupancyMap& map, std::size_t max_voxels = 50000);

// foxglove.Grid: a 2-D slice of the map at height z (occupied 100, free 0, unknown -1 as int8 "occupancy"),
// one cell per leaf-size square over the map's bounds; at most max_cells cells (coarser cells otherwise).
nlohmann::json mapGrid(const msg::OccupancyMap& map, double z, std::size_t max_cells = 1u << 20);

// Base64 of bytes (RFC 4648, with padding): how JSON carries Foxglove `bytes` fields.
std::string base64(const std::uint8_t* data, std::size_t size);

}  // namespace ddsnav::foxglove
