#pragma once
// Conversions between the bus messages (idl/) and the library types, one place per type, so components
// stay thin and every library stays free of DDS.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/runtime/component.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/planner.hpp>
#include <ddsnav/tracker/trajectory.hpp>
#include <ddsnav/tracker/vehicle.hpp>

#include <Eigen/Geometry>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace ddsnav::sim {
struct PointCloud;
}
namespace ddsnav::mapper {
struct Scan;
}
namespace ddsnav::perception {
struct ObstacleEllipsoid;
}

namespace ddsnav::nodes {

inline constexpr const char* kWorldFrame = "map";

// Sleeps `duration` of wall time; false as soon as the component is asked to shut down.
inline bool sleepForWall(runtime::Context& ctx, std::chrono::nanoseconds duration) {
  return !ctx.waitForShutdown(std::chrono::ceil<std::chrono::milliseconds>(duration));
}

// Sleeps `duration` on the component's clock: wall time on the system clock; on `clock: topic` until the
// followed clock (the simulator's system/clock) has advanced by `duration`, first waiting for its first
// sample, so a loop paced by it runs at its rate in simulated time whatever the speed-up. False as soon as
// the component is asked to shut down.
bool sleepFor(runtime::Context& ctx, std::chrono::nanoseconds duration);

msg::Vec3 toMsg(const Eigen::Vector3d& v);
Eigen::Vector3d fromMsg(const msg::Vec3& v);

// Sensor data. The world frame is "map" on the bus.
msg::PointCloud toMsg(const sim::PointCloud& cloud, std::int64_t stamp_ns);
// Points as float triples (non-finite ones kept: the consumers clean them and count them).
std::vector<Eigen::Vector3f> pointsOf(const msg::PointCloud& cloud);
mapper::Scan toScan(const msg::PointCloud& cloud, double max_range);

// Vehicle.
msg::VehicleState toMsg(const tracker::VehicleState& state, std::int64_t stamp_ns);
tracker::VehicleState fromMsg(const msg::VehicleState& state);
msg::VelocityCommand toMsg(const tracker::VehicleCommand& command, std::int64_t stamp_ns);
tracker::VehicleCommand fromMsg(const msg::VelocityCommand& command);

// Obstacles.
msg::ObstacleEllipsoid toMsg(const perception::ObstacleEllipsoid& obstacle);
// Throws std::invalid_argument naming the first malformed obstacle (see checkObstacleArray); the frame is
// not checked here.
std::vector<planner::EllipsoidObstacle> toEllipsoidObstacles(const msg::ObstacleArray& array);
// Removes the obstacles that a robot of `radius` at `position` would touch. The robot is physically there, so such an ellipse is
// perception's over-estimate of an obstacle's extent, not a wall around the robot; keeping it would leave
// the planner with a start in collision. Returns how many were removed. In 2-D it also reduces every
// orientation to its heading (rotation about z), the only rotation a 2-D world represents.
std::size_t clearFootprint(std::vector<planner::EllipsoidObstacle>& obstacles, const Eigen::Vector3d& position, double radius,
                           int dimensions);

// Planning.
msg::PathState toMsg(const planner::State& state);
planner::State fromMsg(const msg::PathState& state);
msg::Path toMsg(const planner::PlanResult& result, std::uint32_t request_id, std::int64_t stamp_ns);
std::vector<planner::State> statesOf(const msg::Path& path);
// Samples only: the analytic curve stays with the tracker.
msg::Trajectory toMsg(const tracker::Trajectory& trajectory, std::uint32_t request_id, std::int64_t start_ns);

}  // namespace ddsnav::nodes
