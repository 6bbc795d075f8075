#include "ddsnav/nodes/world_source.hpp"

#include "ddsnav/nodes/convert.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

namespace ddsnav::nodes {

WorldKind parseWorldKind(const std::string& text, const std::string& param) {
  if (text == "obstacles") return WorldKind::Obstacles;
  if (text == "map") return WorldKind::Map;
  if (text == "scenario") return WorldKind::Scenario;
  throw std::invalid_argument("parameter " + param + ": '" + text + "' is not one of obstacles, map, scenario");
}

WorldSource::WorldSource(bus::Participant& bus, WorldKind kind, const planner::Scenario& scenario)
    : kind_(kind), scenario_(scenario) {
  obstacles_sub_ = bus.subscribe<msg::ObstacleArray>("perception/obstacles", bus::Qos::state(), [this](const msg::ObstacleArray& a) {
    std::lock_guard lock(mutex_);
    obstacles_ = a;
  });
  if (kind_ == WorldKind::Map) {
    map_sub_ = bus.subscribe<msg::OccupancyMap>("map/octomap", bus::Qos::state(), [this](const msg::OccupancyMap& m) {
      std::lock_guard lock(mutex_);
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
