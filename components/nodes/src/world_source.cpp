#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/sim/sensor_choice.hpp>

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ddsnav::nodes {

namespace {

// A snapshot of the shared map world: the same answers, with its own validity-check count and check
// resolution (segments are sampled here, so no user changes the shared world's setting).
class SharedWorld final : public planner::CollisionWorld {
 public:
  explicit SharedWorld(std::shared_ptr<const planner::CollisionWorld> world) : world_(std::move(world)) {}
  int dimensions() const override { return world_->dimensions(); }
  planner::Vec3 boundsMin() const override { return world_->boundsMin(); }
  planner::Vec3 boundsMax() const override { return world_->boundsMax(); }
  double robotRadius() const override { return world_->robotRadius(); }
  bool isFree(const planner::Vec3& p) const override {
    countCheck();
    return world_->isFree(p);
  }
  double clearance(const planner::Vec3& p) const override { return world_->clearance(p); }
  std::vector<planner::NearbyObstacle> obstaclesNear(const planner::Vec3& p, double range) const override {
    return world_->obstaclesNear(p, range);
  }
  std::vector<planner::NearbyObstacle> nearestPerBrick(const planner::Vec3& p, double range) const override {
    return world_->nearestPerBrick(p, range);
  }

 private:
  std::shared_ptr<const planner::CollisionWorld> world_;
};

}  // namespace

WorldKind parseWorldKind(const std::string& text, const std::string& param) {
  if (text == "obstacles") return WorldKind::Obstacles;
  if (text == "map") return WorldKind::Map;
  if (text == "fused") return WorldKind::Fused;
  if (text == "scenario") return WorldKind::Scenario;
  throw runtime::ParameterError("parameter " + param + ": expected one of obstacles, map, fused, scenario, got '" + text + "'");
}

WorldParameters::WorldParameters(runtime::Parameters& params)
    : kind(parseWorldKind(params.declare<std::string>(
          "world", "obstacles",
          {.doc = "what to plan or check on: perception/obstacles, map/octomap, both fused (docs/world-model.md) or the scenario's exact geometry",
           .choices = {"obstacles", "map", "fused", "scenario"}}))),
      unknown(planner::parseUnknownSpace(params.declare<std::string>(
          "unknown_space", "optimistic",
          {.doc = "how the map's never-observed space counts (map and fused worlds): free or occupied",
           .choices = {"optimistic", "conservative"}}))),
      first_map_wait_s(params.declare<double>(
          "first_map_wait_s", 5.0,
          {.min = 0, .max = 3600, .unit = "s",
           .doc = "fused world: how long after the first perception/obstacles it waits for the first map/octomap before it is planned on without one (optimistic only)"})),
      solid_below_surface(params.declare<bool>(
          "solid_below_surface", true,
          {.doc = "3-D map and fused worlds: below the highest observed occupied voxel of its (x, y) column a point is solid, "
                  "as inside terrain (the space under an overhang too: a 2.5-D elevation map); false: only observed voxels"})),
      surface_margin_m(params.declare<double>(
          "surface_margin_m", 1.0,
          {.min = 0, .max = 100, .unit = "m",
           .doc = "3-D, with solid_below_surface: a column is solid below the highest observed surface within this horizontal distance "
                  "(lidar rings sample a steep flank sparsely; docs/world-model.md)"})),
      sensor_view(params.declare<bool>(
          "sensor_view", true,
          {.doc = "3-D map and fused worlds: space above and below the lidar's vertical field of view, within its range of the "
                  "vehicle, is blocked (it sees nothing there; docs/world-model.md)"})),
      sensor_view_below(params.declare<bool>(
          "sensor_view_below", false,
          {.doc = "with sensor_view: below the fan's lower edge too (off: the ground ahead was seen from farther away, and a "
                  "goal below the fan of a vehicle flying high must stay reachable)"})),
      clip_obstacles_to_map(params.declare<bool>(
          "clip_obstacles_to_map", true,
          {.doc = "2-D fused world: an obstacle ellipse whose axis the map holds as occupied cells loses the part the scanner saw "
                  "free (an ellipse fitted to a wall's end reaches past it into a doorway; docs/world-model.md)"})),
      sensor_vertical_min_deg(params.declareOptional<double>(
          "sensor_vertical_min_deg", {.above = -90, .below = 90, .unit = "deg", .doc = "the lidar fan's lower edge; default: the simulator's sensor for the scenario"})),
      sensor_vertical_max_deg(params.declareOptional<double>(
          "sensor_vertical_max_deg", {.above = -90, .below = 90, .unit = "deg", .doc = "the lidar fan's upper edge; default: the simulator's sensor for the scenario"})),
      sensor_view_range_m(params.declareOptional<double>(
          "sensor_view_range_m", {.min = 0, .max = 1e5, .unit = "m", .doc = "how far from the vehicle the unseen space is blocked; default: the simulator's sensor range"})) {}

bool fusedWorldReady(bool has_obstacles, bool has_map, planner::UnknownSpace unknown, double since_first_obstacles_s,
                     double first_map_wait_s) {
  if (!has_obstacles) return false;
  if (has_map) return true;
  return unknown == planner::UnknownSpace::Optimistic && since_first_obstacles_s >= first_map_wait_s;
}

std::optional<std::int64_t> firstMapWaitStart(std::optional<std::int64_t> started_ns, std::int64_t now_ns) {
  if (started_ns) return started_ns;
  if (now_ns > 0) return now_ns;
  return std::nullopt;
}

std::optional<planner::Vec3> plannerStartOutOfCollision(const planner::CollisionWorld& world, const planner::Vec3& start,
                                                        double robot_radius, double surface_margin_m) {
  const double reach = robot_radius + surface_margin_m;
  if (!(reach > 0.0) || world.isFree(start)) return std::nullopt;
  const double wanted_clearance = std::min(0.5 * robot_radius, 0.3);
  const double escape_length = surface_margin_m > 0.0 ? reach : 0.0;
  return planner::nearestFreePosition(world, start, reach, reach / 6.0, wanted_clearance, escape_length);
}

planner::SensorView sensorViewOf(const planner::Scenario& scenario, const WorldParameters& world) {
  sim::RangeSensorConfig sensor = sim::RangeSensorConfig::lidar3d();
  try {
    sensor = sim::chooseSensor(scenario).config;
  } catch (const std::exception& e) {  // the simulator would refuse this scenario; the planner still plans on it
    spdlog::warn("sensor view: no default sensor for this scenario ({}); assuming a lidar of {:.0f}..{:.0f} deg and {:.0f} m", e.what(),
                 sensor.vertical_min_deg, sensor.vertical_max_deg, sensor.max_range);
  }
  planner::SensorView view;
  view.vertical_min_deg = world.sensor_vertical_min_deg.value_or(sensor.vertical_min_deg);
  view.vertical_max_deg = world.sensor_vertical_max_deg.value_or(sensor.vertical_max_deg);
  view.range = world.sensor_view_range_m.value_or(sensor.max_range);
  // The vehicle is a robot radius wide and follows its trajectory within a few decimetres vertically.
  view.slack = std::max(1.0, 2.0 * scenario.robot_radius);
  view.below = world.sensor_view_below;
  if (!(view.vertical_min_deg < view.vertical_max_deg))
    throw runtime::ParameterError("parameters sensor_vertical_min_deg / sensor_vertical_max_deg: the lower edge must lie below the upper one");
  return view;
}

WorldSource::WorldSource(runtime::Context& ctx, const WorldParameters& world, const planner::Scenario& scenario,
                         double preferred_unknown_margin_m, bool preferred_on_demand, double preferred_surface_margin_m)
    : kind_(world.kind),
      scenario_(scenario),
      unknown_(world.unknown),
      first_map_wait_s_(world.first_map_wait_s),
      solid_below_surface_(world.solid_below_surface),
      surface_margin_m_(world.solid_below_surface && scenario.dimensions == 3 && (kind_ == WorldKind::Map || kind_ == WorldKind::Fused)
                            ? world.surface_margin_m
                            : 0.0),
      clip_obstacles_(world.clip_obstacles_to_map && scenario.dimensions == 2 && kind_ == WorldKind::Fused),
      keep_observed_free_(scenario.dimensions == 2 && (kind_ == WorldKind::Map || kind_ == WorldKind::Fused) &&
                          (clip_obstacles_ || world.keep_observed_free)),
      clock_(ctx.clock()),
      preferred_on_demand_(preferred_on_demand) {
  if (preferred_unknown_margin_m > 0.0 && scenario.dimensions == 2 && (kind_ == WorldKind::Map || kind_ == WorldKind::Fused) &&
      unknown_ == planner::UnknownSpace::Optimistic)
    preferred_unknown_margin_m_ = preferred_unknown_margin_m;
  if (preferred_surface_margin_m > surface_margin_m_ && solid_below_surface_ && scenario.dimensions == 3 &&
      (kind_ == WorldKind::Map || kind_ == WorldKind::Fused) && unknown_ == planner::UnknownSpace::Optimistic)
    preferred_surface_margin_m_ = preferred_surface_margin_m;
  if (world.sensor_view && scenario.dimensions == 3 && (kind_ == WorldKind::Map || kind_ == WorldKind::Fused)) {
    const planner::SensorView view = sensorViewOf(scenario, world);
    view_ = view;
    if (view.below)
      spdlog::info("sensor view: space above {:.1f} deg and below {:.1f} deg is blocked within {:.1f} m of the vehicle", view.vertical_max_deg,
                   view.vertical_min_deg, view.range);
    else
      spdlog::info("sensor view: space above {:.1f} deg is blocked within {:.1f} m of the vehicle", view.vertical_max_deg, view.range);
  }
  // On the component's executor: the arrays are checked there, not on a DDS thread.
  obstacles_sub_ = ctx.subscribe(runtime::topics::obstacles, [this](const msg::ObstacleArray& a) {
    const auto error = checkObstacleArray(a, kWorldFrame);
    {
      std::lock_guard lock(mutex_);
      if (!error.empty()) {
        ++dropped_obstacles_;
        spdlog::warn("perception/obstacles: dropping an array of {} obstacle(s) (stamp {} ns): {}; keeping the {} ({} dropped so far)",
                     a.obstacles().size(), a.header().stamp_ns(), error, obstacles_ ? "last good array" : "world empty",
                     dropped_obstacles_);
        return;
      }
      obstacles_ = a;
      first_obstacles_ns_ = firstMapWaitStart(first_obstacles_ns_, clock_.nowNs());
    }
    if (on_obstacles_) on_obstacles_();
  });
  if (kind_ == WorldKind::Map || kind_ == WorldKind::Fused) {
    // A map is parsed into its world on the map worker: a 3-D octree takes long enough (tens to hundreds of
    // ms) that doing it on the executor held up the planner's requests and the tracker's control loop. A
    // newer map supersedes one still waiting to be built.
    map_sub_ = ctx.subscribe(runtime::topics::octomap, [this, &ctx](const msg::OccupancyMap& m) {
      std::uint64_t number = 0;
      {
        std::lock_guard lock(mutex_);
        number = ++maps_received_;
      }
      map_worker_.submit(0, [this, m, &ctx, number](std::stop_token stop) {
        if (stop.stop_requested()) return;
        const bool built = buildMap(m, number);
        // on_map_ is read on the executor, where it is set (as on_obstacles_ is), not here.
        if (built) ctx.executor().post([this] {
          if (on_map_) on_map_();
        });
        if (built && !stop.stop_requested()) prepareContinuation();
      });
    });
  }
}

planner::OctoMapWorldOptions WorldSource::mapOptions(bool preferred) const {
  planner::OctoMapWorldOptions options;
  options.unknown_is_occupied = unknown_ == planner::UnknownSpace::Conservative;
  options.solid_below_surface = solid_below_surface_;
  options.surface_margin_m = surface_margin_m_;
  options.wider_surface_margin_m = preferred_surface_margin_m_;  // seen by the preferred world only (buildMap)
  options.keep_observed_free = keep_observed_free_;
  if (preferred) options.unknown_margin_m = preferred_unknown_margin_m_;
  return options;
}

bool WorldSource::buildMap(const msg::OccupancyMap& m, std::uint64_t number) {
  auto checked = buildOccupancyMap(m, kWorldFrame, scenario_, mapOptions(/*preferred=*/false));
  const bool good = checked.error.empty();
  {
    std::lock_guard lock(mutex_);
    if (!good) {
      ++dropped_maps_;
      spdlog::warn("map/octomap: dropping a map of {} bytes (stamp {} ns): {}; keeping the {} ({} dropped so far)", m.octree().size(),
                   m.header().stamp_ns(), checked.error, map_world_ ? "last good map" : "world empty", dropped_maps_);
    } else {
      map_world_ = std::move(checked.world);
      plain_map_number_ = number;
      // In 3-D the preferred world is this map seen with its wider surface margin, built with it.
      if (preferred_surface_margin_m_ > 0.0) {
        preferred_map_world_ = planner::makeWiderMarginView(map_world_);
        preferred_map_number_ = number;
      }
      // On demand, the cache follows in preferredOnDemand.
      if (preferred_unknown_margin_m_ > 0.0 && preferred_on_demand_) preferred_source_ = std::make_shared<const msg::OccupancyMap>(m);
    }
    maps_settled_ = std::max(maps_settled_, number);  // a map it superseded is settled with it
    const bool builds_preferred = good && preferred_unknown_margin_m_ > 0.0 && !preferred_on_demand_;
    if (!builds_preferred) preferred_settled_ = std::max(preferred_settled_, number);
  }
  map_settled_.notify_all();
  if (!good) return false;
  // The world with the unknown margin after the plain one is in: it takes 10-16 times as long (13-60 ms on three of
  // 2026-12-06's mission maps). Until it is in, the preferred worlds are the previous map's; a request that waited for
  // it longer than map_wait_s has its answers from them checked on the plain world of this one (docs/world-model.md,
  // "A request waits for the map it was asked on").
  if (preferred_unknown_margin_m_ > 0.0 && !preferred_on_demand_) {
    auto with_margin = buildOccupancyMap(m, kWorldFrame, scenario_, mapOptions(/*preferred=*/true));
    {
      std::lock_guard lock(mutex_);
      preferred_map_world_ = with_margin.error.empty() ? std::shared_ptr<const planner::CollisionWorld>(std::move(with_margin.world)) : nullptr;
      preferred_map_number_ = number;
      preferred_settled_ = std::max(preferred_settled_, number);
    }
    map_settled_.notify_all();
  }
  return true;
}

std::uint64_t WorldSource::plainMapNumber() const {
  std::lock_guard lock(mutex_);
  return plain_map_number_;
}

bool WorldSource::preferredIsStale() const {
  std::lock_guard lock(mutex_);
  return !preferred_on_demand_ && preferred_map_world_ && preferred_map_number_ != plain_map_number_;
}

void WorldSource::prepareContinuation() const {
  std::shared_ptr<const planner::CollisionWorld> preferred;
  {
    std::lock_guard lock(mutex_);
    if (preferred_on_demand_) return;
    preferred = preferred_map_world_;
  }
  // Here, on the map's worker, and not in the first request's snapshot: where the seen surfaces end took 20-30 ms of a
  // bug-trap request's snapshot under a mission's load (the continuation from the request's start is the rest). After
  // the world is in and the requests waiting for it are let go (waitForMapsReceived): most are answered on the world
  // with the unknown margin, which needs no continuation; one that does and comes first waits for this (once per world).
  if (preferred) planner::prepareSurfaceContinuation(*preferred);
}

std::shared_ptr<const planner::CollisionWorld> WorldSource::observedSpace() const {
  if (!keep_observed_free_) return nullptr;
  std::lock_guard lock(mutex_);
  return map_world_;
}

double WorldSource::waitForMapsReceived(std::chrono::milliseconds max_wait) const {
  const auto began = std::chrono::steady_clock::now();
  std::unique_lock lock(mutex_);
  const std::uint64_t wanted = maps_received_;
  map_settled_.wait_for(lock, max_wait, [&] { return maps_settled_ >= wanted && preferred_settled_ >= wanted; });
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
}

bool WorldSource::hasPreferredWorld() const {
  std::lock_guard lock(mutex_);
  return preferred_on_demand_ ? preferred_source_ != nullptr : preferred_map_world_ != nullptr;
}

void WorldSource::prefetchPreferred() {
  if (!preferred_on_demand_ || preferred_unknown_margin_m_ <= 0.0) return;
  // Under its own key: it must not supersede a map waiting to be built, nor be superseded by one.
  map_worker_.submit(1, [this](std::stop_token stop) {
    if (!stop.stop_requested()) preferredOnDemand();
  });
}

std::shared_ptr<const planner::CollisionWorld> WorldSource::preferredOnDemand() const {
  std::lock_guard build(preferred_build_mutex_);
  std::shared_ptr<const msg::OccupancyMap> source;
  {
    std::lock_guard lock(mutex_);
    if (!preferred_source_) return nullptr;
    if (preferred_built_from_ == preferred_source_) return preferred_map_world_;
    source = preferred_source_;
  }
  auto built = buildOccupancyMap(*source, kWorldFrame, scenario_, mapOptions(/*preferred=*/true));
  std::lock_guard lock(mutex_);
  preferred_built_from_ = source;
  preferred_map_world_ = built.error.empty() ? std::shared_ptr<const planner::CollisionWorld>(std::move(built.world)) : nullptr;
  return preferred_map_world_;
}

bool WorldSource::available() const {
  std::lock_guard lock(mutex_);
  return availableLocked();
}

std::string WorldSource::missing() const {
  std::lock_guard lock(mutex_);
  if (availableLocked()) return "";
  const bool wants_map = kind_ == WorldKind::Map || (kind_ == WorldKind::Fused && obstacles_.has_value());
  if (!wants_map) return "no perception/obstacles yet";
  if (kind_ == WorldKind::Fused && unknown_ == planner::UnknownSpace::Optimistic)
    return fmt::format("no map/octomap yet (planned on the obstacles alone {:g} s after the first ones)", first_map_wait_s_);
  return "no map/octomap yet";
}

bool WorldSource::availableLocked() const {
  switch (kind_) {
    case WorldKind::Scenario: return true;
    case WorldKind::Obstacles: return obstacles_.has_value();
    case WorldKind::Map: return map_world_ != nullptr;
    case WorldKind::Fused: {
      const double waited = first_obstacles_ns_ ? static_cast<double>(clock_.nowNs() - *first_obstacles_ns_) * 1e-9 : 0.0;
      return fusedWorldReady(obstacles_.has_value(), map_world_ != nullptr, unknown_, waited, first_map_wait_s_);
    }
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

planner::OccludedContinuation WorldSource::continuation(const std::shared_ptr<const planner::CollisionWorld>& map,
                                                       const planner::Vec3& at, double length_m) const {
  std::lock_guard lock(continuation_mutex_);
  auto& last = last_continuation_;
  if (last.map != map || last.at != at || last.length_m != length_m)
    last = {map, at, length_m, planner::occludedSurfaceContinuation(*map, at, length_m)};
  return last.result;
}

std::unique_ptr<planner::CollisionWorld> WorldSource::snapshot(const planner::Vec3& robot_position, const std::optional<planner::Vec3>& goal,
                                                              double goal_radius, bool preferred, double hidden_continuation_m) const {
  const auto& s = scenario_;
  std::shared_ptr<const planner::CollisionWorld> map_world, knows_unobserved;
  std::vector<planner::EllipsoidObstacle> ellipses;
  {
    std::lock_guard lock(mutex_);
    if (kind_ == WorldKind::Scenario) return planner::makeScenarioWorld(s);
    if (!availableLocked()) return nullptr;
    map_world = preferred && !preferred_on_demand_ && preferred_map_world_ ? preferred_map_world_ : map_world_;
    if (!preferred_on_demand_) knows_unobserved = preferred_map_world_;
    if (kind_ != WorldKind::Map) ellipses = toEllipsoidObstacles(*obstacles_);
  }
  if (preferred_on_demand_ && (preferred || hidden_continuation_m > 0.0))
    if (auto built = preferredOnDemand()) {
      knows_unobserved = built;
      if (preferred) map_world = std::move(built);
    }
  // Perception's ellipses of surfaces the map holds lose what the scanner saw free; their remaining cells join the
  // map (docs/world-model.md, "Ellipses of mapped surfaces").
  std::vector<planner::Vec3> extra_cells;
  double extra_cell_size = 0.0;
  if (kind_ != WorldKind::Map) {
    if (const auto cleared = clearFootprint(ellipses, robot_position, s.robot_radius, s.dimensions))
      spdlog::debug("ignoring {} obstacle ellipse(s) that cover the robot", cleared);
    if (clip_obstacles_ && map_world) {
      auto clipped = planner::clipToObservedSpace(*map_world, ellipses);
      std::vector<planner::EllipsoidObstacle> whole;
      for (std::size_t i = 0; i < ellipses.size(); ++i)
        if (!clipped.clipped[i]) whole.push_back(ellipses[i]);
      ellipses = std::move(whole);
      extra_cells = std::move(clipped.cells);
      extra_cell_size = clipped.cell_size;
    }
  }
  // Seen surfaces continued into the space hidden from the robot (the preferred map is the one that knows which
  // cells were observed); none near the robot or in the goal region, which a plan must be able to start and end in.
  if (hidden_continuation_m > 0.0 && knows_unobserved && map_world) {
    auto continued = continuation(knows_unobserved, robot_position, hidden_continuation_m);
    const double near_robot = 2.0 * s.robot_radius + continued.cell_size;
    const double goal_reach = std::isfinite(goal_radius) ? std::clamp(goal_radius, 0.0, 1e5) + s.robot_radius + continued.cell_size : 0.0;
    std::erase_if(continued.cells, [&](const planner::Vec3& c) {
      return (c - planner::Vec3(robot_position.x(), robot_position.y(), 0.0)).norm() <= near_robot ||
             (goal && (c - planner::Vec3(goal->x(), goal->y(), 0.0)).norm() <= goal_reach);
    });
    if (extra_cells.empty()) extra_cell_size = continued.cell_size;
    // Both are the map's cells (its resolution); a continuation from a map of another resolution is left out.
    if (continued.cell_size == extra_cell_size)
      extra_cells.insert(extra_cells.end(), continued.cells.begin(), continued.cells.end());
  }
  if (!extra_cells.empty() && map_world)
    map_world = planner::makeBlockedCellsWorld(std::move(map_world), std::move(extra_cells), extra_cell_size);
  // The map's world is shared and immutable: a Map snapshot is a view of it (its own validity-check
  // count and check resolution), a Fused one pairs it with this snapshot's obstacles.
  auto viewed = [&](std::unique_ptr<planner::CollisionWorld> world) -> std::unique_ptr<planner::CollisionWorld> {
    if (!view_) return world;
    planner::SensorView view = *view_;
    view.origin = robot_position;
    if (goal && goal->allFinite() && std::isfinite(goal_radius)) {
      view.exempt_center = *goal;
      view.exempt_radius = std::clamp(goal_radius, 0.0, 1e5) + s.robot_radius;
    }
    return planner::makeSensorViewWorld(std::move(world), view);
  };
  if (kind_ == WorldKind::Map) return viewed(std::make_unique<SharedWorld>(std::move(map_world)));
  auto obstacles = planner::makeEllipsoidWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, std::move(ellipses));
  if (kind_ == WorldKind::Obstacles || !map_world) return obstacles;
  return viewed(planner::makeFusedWorld(std::move(map_world), std::move(obstacles)));
}

}  // namespace ddsnav::nodes
