#include "ddsnav/nodes/world_source.hpp"

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

namespace ddsnav::nodes {

WorldKind parseWorldKind(const std::string& text, const std::string& param) {
  if (text == "obstacles") return WorldKind::Obstacles;
  if (text == "map") return WorldKind::Map;
  if (text == "scenario") return WorldKind::Scenario;
  throw runtime::ParameterError("parameter " + param + ": expected one of obstacles, map, scenario, got '" + text + "'");
}

WorldSource::WorldSource(runtime::Context& ctx, WorldKind kind, const planner::Scenario& scenario)
    : kind_(kind), scenario_(scenario) {
  // On the component's executor: the arrays and maps are checked there, not on a DDS thread.
  obstacles_sub_ = ctx.subscribe(runtime::topics::obstacles, [this](const msg::ObstacleArray& a) {
    const auto error = checkObstacleArray(a, kWorldFrame);
    std::lock_guard lock(mutex_);
    if (!error.empty()) {
      ++dropped_obstacles_;
      spdlog::warn("perception/obstacles: dropping an array of {} obstacle(s) (stamp {} ns): {}; keeping the {} ({} dropped so far)",
                   a.obstacles().size(), a.header().stamp_ns(), error, obstacles_ ? "last good array" : "world empty",
                   dropped_obstacles_);
      return;
    }
    obstacles_ = a;
  });
  if (kind_ == WorldKind::Map) {
    map_sub_ = ctx.subscribe(runtime::topics::octomap, [this](const msg::OccupancyMap& m) {
      // Parsed outside the lock: a large octree takes a while, and snapshot() must not wait for it.
      const auto error = checkOccupancyMap(m, kWorldFrame, scenario_);
      std::lock_guard lock(mutex_);
      if (!error.empty()) {
        ++dropped_maps_;
        spdlog::warn("map/octomap: dropping a map of {} bytes (stamp {} ns): {}; keeping the {} ({} dropped so far)",
                     m.octree().size(), m.header().stamp_ns(), error, map_ ? "last good map" : "world empty", dropped_maps_);
        return;
      }
      map_ = m;
    });
  }
}

bool WorldSource::available() const {
  std::lock_guard lock(mutex_);
  switch (kind_) {
    case WorldKind::Scenario: return true;
    case WorldKind::Obstacles: return obstacles_.has_value();
    case WorldKind::Map: return map_.has_value();
  }
  return false;
}

bool WorldSource::hasObstacles() const {
  std::lock_guard lock(mutex_);
  return obstacles_.has_value();
}

std::size_t WorldSource::droppedObstacleArrays() const {
  std::lock_guard lock(mutex_);
  return dropped_obstacles_;
}

std::size_t WorldSource::droppedMaps() const {
  std::lock_guard lock(mutex_);
  return dropped_maps_;
}

std::unique_ptr<planner::CollisionWorld> WorldSource::snapshot(const planner::Vec3& robot_position) const {
  const auto& s = scenario_;
  std::lock_guard lock(mutex_);
  switch (kind_) {
    case WorldKind::Scenario:
      return planner::makeScenarioWorld(s);
    case WorldKind::Obstacles: {
      if (!obstacles_) return nullptr;
      auto ellipses = toEllipsoidObstacles(*obstacles_);
      if (const auto cleared = clearFootprint(ellipses, robot_position, s.robot_radius, s.dimensions))
        spdlog::debug("ignoring {} obstacle ellipse(s) that cover the robot", cleared);
      return planner::makeEllipsoidWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, std::move(ellipses));
    }
    case WorldKind::Map:
      if (!map_) return nullptr;
      return planner::makeOctoMapWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, map_->octree());
  }
  return nullptr;
}

}  // namespace ddsnav::nodes
