#pragma once
// The collision world a component plans or checks against, kept current from the bus: perception's
// ellipses (perception/obstacles), the mapper's octree (map/octomap) or the scenario's exact geometry.
// The planner and the tracker use the same one, so a trajectory is checked against the world it was
// planned in. Every message is checked when it arrives (see validate.hpp): a malformed one is dropped with
// a warning naming the topic and what is wrong, and the last good one stays in use.

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/runtime/component.hpp>

#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace ddsnav::nodes {

enum class WorldKind { Obstacles, Map, Scenario };

// "obstacles" | "map" | "scenario"; throws runtime::ParameterError naming the parameter `param` (exit status 2).
WorldKind parseWorldKind(const std::string& text, const std::string& param = "world");

class WorldSource {
 public:
  // Subscribes through ctx (its executor, its topic names).
  WorldSource(runtime::Context& ctx, WorldKind kind, const planner::Scenario& scenario);

  // False until the world's input has arrived (always true for the scenario world).
  bool available() const;
  // A snapshot of the newest world, seen from a robot at `robot_position`: obstacle ellipses that would
  // cover the robot there are left out (see clearFootprint). nullptr when not available(). Inputs are
  // checked on arrival, so this throws only for a world the scenario itself cannot hold; callers still
  // catch, so nothing that reaches here can end the process.
  std::unique_ptr<planner::CollisionWorld> snapshot(const planner::Vec3& robot_position) const;
  bool hasObstacles() const;  // perception/obstacles received (whatever the kind)
  // Messages dropped as malformed so far, per topic.
  std::size_t droppedObstacleArrays() const;
  std::size_t droppedMaps() const;

 private:
  WorldKind kind_;
  const planner::Scenario& scenario_;
  mutable std::mutex mutex_;
  std::optional<msg::ObstacleArray> obstacles_;
  std::optional<msg::OccupancyMap> map_;
  std::size_t dropped_obstacles_ = 0, dropped_maps_ = 0;
  bus::Subscription obstacles_sub_, map_sub_;
};

}  // namespace ddsnav::nodes
