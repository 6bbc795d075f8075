#pragma once
// The collision world a component plans or checks against, kept current from the bus: perception's
// ellipses (perception/obstacles), the mapper's octree (map/octomap), both fused into one world (the
// octree for structure and unknown space, the ellipses for discrete obstacles; docs/world-model.md) or the
// scenario's exact geometry.
// The planner and the tracker use the same one, so a trajectory is checked against the world it was
// planned in. Every message is checked when it arrives (see validate.hpp): a malformed one is dropped with
// a warning naming the topic and what is wrong, and the last good one stays in use.

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/runtime/component.hpp>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace ddsnav::nodes {

enum class WorldKind { Obstacles, Map, Fused, Scenario };

// "obstacles" | "map" | "fused" | "scenario"; throws runtime::ParameterError naming the parameter `param` (exit status 2).
WorldKind parseWorldKind(const std::string& text, const std::string& param = "world");

// The world parameters every component on a WorldSource declares (a member of its Params): `world`
// ("obstacles", the default; the demo launch file picks "fused") and `unknown_space` ("optimistic", the
// default, or "conservative"), declared with their descriptors (choices checked by the runtime).
struct WorldParameters {
  WorldKind kind = WorldKind::Obstacles;
  planner::UnknownSpace unknown = planner::UnknownSpace::Optimistic;
  double first_map_wait_s = 5.0;  // `first_map_wait_s`: see fusedWorldReady
  bool solid_below_surface = true;  // `solid_below_surface`: planner::OctoMapWorldOptions (3-D maps)
  double surface_margin_m = 1.0;    // `surface_margin_m`: planner::OctoMapWorldOptions (3-D maps)
  // `sensor_view` (3-D map and fused worlds): the space above and below the lidar's fan is blocked near the
  // vehicle (planner::SensorView); the fan's edges and reach default to the simulator's sensor for the scenario.
  bool sensor_view = true;
  bool sensor_view_below = false;  // `sensor_view_below`: also below the fan's lower edge
  bool clip_obstacles_to_map = true;  // `clip_obstacles_to_map`: planner::clipToObservedSpace (2-D fused world)
  std::optional<double> sensor_vertical_min_deg, sensor_vertical_max_deg, sensor_view_range_m;
  // Not a parameter: 2-D maps also keep which cells were observed free, for observedSpace() (the tracker's speed
  // bound). Fused worlds that clip ellipses keep them anyway.
  bool keep_observed_free = false;
  WorldParameters() = default;
  explicit WorldParameters(runtime::Parameters& params);
};

// Whether the fused world can be planned on (docs/world-model.md, "Before the first map"): once the
// obstacles have arrived and so has the first map; without a map, under the optimistic policy only after
// `first_map_wait_s` has passed since the first obstacles (a sensor that sees nothing makes no map, and the
// obstacles alone are then the world), never under the conservative one. Waiting matters because a plan
// made on the obstacles alone crosses terrain and walls the first scans have already seen.
bool fusedWorldReady(bool has_obstacles, bool has_map, planner::UnknownSpace unknown, double since_first_obstacles_s,
                     double first_map_wait_s);
// When the wait for the first map starts, given when it started (nullopt: not yet) and the component clock now. A
// component on `clock: topic` reads 0 until the first clock sample, and obstacles (transient local) can arrive
// before it: a wait started at 0 had already passed at the first request, so the planner planned on the obstacles
// alone while the map was still being discovered — through walls the tracker's map held (the first one to three
// plans of 4 of 24 2-D missions checked, 2026-12-05: a race with discovery). The wait starts at the first obstacles
// that arrive with the clock running.
std::optional<std::int64_t> firstMapWaitStart(std::optional<std::int64_t> started_ns, std::int64_t now_ns);

// The 3-D sensor view a WorldSource with `world` blocks near the vehicle (its origin and goal exemption unset): the
// fan's edges and reach from `world` or else the simulator's default sensor for `scenario`. Throws
// runtime::ParameterError for a lower edge not below the upper one.
planner::SensorView sensorViewOf(const planner::Scenario& scenario, const WorldParameters& world);

// Where the planner plans from when `start` is not free in its world: the nearest free state within the robot radius
// plus `surface_margin_m` (by which a 3-D map widens observed terrain), on to half the robot radius of clearance (at
// most 0.3 m) when that is near, and — with a margin — one that leads out by a free straight segment as long as that
// reach (planner::nearestFreePosition). nullopt when `start` is free, nothing is in reach, or the reach is 0.
std::optional<planner::Vec3> plannerStartOutOfCollision(const planner::CollisionWorld& world, const planner::Vec3& start,
                                                        double robot_radius, double surface_margin_m);

class WorldSource {
 public:
  // Subscribes through ctx (its executor, its topic names). `world.unknown`: how the map's never-observed
  // space counts (map and fused worlds).
  // `preferred_unknown_margin_m` (the planner's `unknown_margin_m`; 2-D map and fused worlds): each map is also
  // built with that OctoMapWorldOptions::unknown_margin_m, for snapshot(..., preferred = true): as it arrives
  // (the planner, which plans on it every time), or with `preferred_on_demand` at the first such snapshot of
  // each map (the tracker, which wants it only to smooth a new path: the margin makes a build ~10x dearer, 42
  // ms for the AUV's coast, and maps come several times a second).
  // `preferred_surface_margin_m` (the planner's `preferred_surface_margin_m`; 3-D map and fused worlds with
  // solid_below_surface, optimistic): each map is built with that OctoMapWorldOptions::wider_surface_margin_m too, and
  // its preferred world is the map seen with it (planner::makeWiderMarginView): no second build.
  WorldSource(runtime::Context& ctx, const WorldParameters& world, const planner::Scenario& scenario,
              double preferred_unknown_margin_m = 0.0, bool preferred_on_demand = false, double preferred_surface_margin_m = 0.0);
  WorldKind kind() const { return kind_; }

  // False until the world's input has arrived (always true for the scenario world; for the fused one see
  // fusedWorldReady: the obstacles and the first map, or, optimistically, the obstacles alone once the
  // first map is first_map_wait_s late).
  bool available() const;
  // Why it is not available yet, for a status line ("no perception/obstacles yet", ...); empty when it is.
  std::string missing() const;
  // A snapshot of the newest world, seen from a robot at `robot_position`: obstacle ellipses that would
  // cover the robot there are left out (see clearFootprint). nullptr when not available(). Inputs are
  // checked on arrival, so this throws only for a world the scenario itself cannot hold; callers still
  // catch, so nothing that reaches here can end the process.
  // `goal` (3-D sensor view only): the ball of goal_radius + the robot radius around it is never blocked as
  // unseen (planner::SensorView::exempt_center).
  // `preferred`: on the map built with the preferred unknown margin, or seen with the wider surface margin, when there
  // is one (hasPreferredWorld).
  // `hidden_continuation_m` > 0 (2-D, with a preferred world, which knows the map's unobserved cells): seen surfaces
  // also go on that far into space hidden from robot_position (planner::occludedSurfaceContinuation), except
  // within two robot radii of it and in the goal region.
  std::unique_ptr<planner::CollisionWorld> snapshot(const planner::Vec3& robot_position,
                                                    const std::optional<planner::Vec3>& goal = std::nullopt,
                                                    double goal_radius = 0.0, bool preferred = false,
                                                    double hidden_continuation_m = 0.0) const;
  // With preferred_on_demand: builds the preferred world of the newest map now, on the map worker, so that the
  // snapshot that asks for it soon (the tracker's, for the path a request it just sent will bring) finds it
  // built. Nothing otherwise.
  void prefetchPreferred();
  // Whether maps are also built with the preferred unknown margin or seen with the wider surface margin (and one has been).
  bool hasPreferredWorld() const;
  // How far its maps widen observed terrain (OctoMapWorldOptions::surface_margin_m): surface_margin_m for a
  // 3-D map or fused world with solid_below_surface, else 0. A start the map puts in collision is searched for
  // a free state this much farther out.
  double surfaceMargin() const { return surface_margin_m_; }
  bool hasObstacles() const;  // perception/obstacles received (whatever the kind)
  // The newest 2-D map as built, when it knows which cells were observed free (planner::robotInObservedFreeSpace);
  // nullptr otherwise (no map yet, a 3-D or scenario world, or keep_observed_free off and no ellipse clipping).
  std::shared_ptr<const planner::CollisionWorld> observedSpace() const;
  // Called on the component's executor after each good perception/obstacles array is taken in (not for maps,
  // which are built on a worker): the tracker checks its trajectory at once instead of at its next period.
  void onObstacles(std::function<void()> callback) { on_obstacles_ = std::move(callback); }
  // Called on the component's executor after each good map has been built into its world (on the map worker):
  // a surface the map has just added is checked against the trajectory then, not at the next period.
  void onMap(std::function<void()> callback) { on_map_ = std::move(callback); }
  // Waits, at most `max_wait` of wall time, until every map received before the call has been built into the plain
  // world and, when this source builds it as maps come, the preferred one (or dropped, or superseded by a newer one that
  // has). The wall time waited. A requester that checks its trajectory on a map as soon as it has built it asks for a
  // plan while that map may still be being built here; past `max_wait` the preferred world may still be an older map's
  // (preferredIsStale).
  double waitForMapsReceived(std::chrono::milliseconds max_wait) const;
  // Whether the preferred world is still an older map's than the plain one (built after it: buildMap).
  bool preferredIsStale() const;
  // The number (as received, from 1) of the map the plain world was last built from; 0 before any. A search that began
  // on a smaller number is on an older map than the newest built.
  std::uint64_t plainMapNumber() const;
  // Messages dropped as malformed so far, per topic.
  std::size_t droppedObstacleArrays() const;
  std::size_t droppedMaps() const;

 private:
  // The map's plain world, then (preferred, not on demand) the one with the unknown margin; each settles `number` for
  // waitForMapsReceived as it is put in. False: dropped as malformed (logged).
  bool buildMap(const msg::OccupancyMap& map, std::uint64_t number);
  // Finds where the newest preferred world's seen surfaces end (planner::prepareSurfaceContinuation), on the map worker
  // after buildMap.
  void prepareContinuation() const;
  // The options every map of this source is built with; `preferred`: with the preferred unknown margin.
  planner::OctoMapWorldOptions mapOptions(bool preferred) const;
  // On demand: the preferred world of the newest map, built now unless it was already; nullptr without one.
  std::shared_ptr<const planner::CollisionWorld> preferredOnDemand() const;
  bool availableLocked() const;
  // occludedSurfaceContinuation of `map` seen from `at`, reused while neither changes: the planner's worlds with and
  // without the unknown margin both ask for it in one request.
  planner::OccludedContinuation continuation(const std::shared_ptr<const planner::CollisionWorld>& map, const planner::Vec3& at,
                                             double length_m) const;

  WorldKind kind_;
  const planner::Scenario& scenario_;
  planner::UnknownSpace unknown_;
  double first_map_wait_s_;
  bool solid_below_surface_;
  double surface_margin_m_;
  bool clip_obstacles_;  // 2-D fused: ellipses of mapped surfaces clipped to the space not observed free
  bool keep_observed_free_;  // 2-D map or fused: maps keep their observed free cells (clip_obstacles_ or asked for)
  std::optional<planner::SensorView> view_;  // set when the sensor view applies (3-D, map or fused, enabled)
  const runtime::Clock& clock_;
  mutable std::mutex mutex_;
  // The newest map as a collision world, built once per map (not per snapshot: a 3-D map takes a while)
  // on map_worker_, so neither the executor nor a snapshot waits for it; snapshots share it.
  std::shared_ptr<const planner::CollisionWorld> map_world_;
  double preferred_unknown_margin_m_ = 0.0;  // > 0 only for 2-D map and fused worlds
  double preferred_surface_margin_m_ = 0.0;  // > surface_margin_m_ only for 3-D map and fused worlds, else 0
  // The same map with that margin; on demand, built (and replaced) by snapshot() when preferred_source_ is
  // newer than what it was built from.
  mutable std::shared_ptr<const planner::CollisionWorld> preferred_map_world_;
  bool preferred_on_demand_ = false;
  std::shared_ptr<const msg::OccupancyMap> preferred_source_;  // on demand: the newest good map
  mutable std::shared_ptr<const msg::OccupancyMap> preferred_built_from_;
  mutable std::mutex preferred_build_mutex_;  // one on-demand build at a time; taken before mutex_, never while holding it
  struct LastContinuation {
    std::shared_ptr<const planner::CollisionWorld> map;  // held: a freed map's address could come back
    planner::Vec3 at = planner::Vec3::Zero();
    double length_m = 0.0;
    planner::OccludedContinuation result;
  };
  mutable LastContinuation last_continuation_;  // continuation()'s; under continuation_mutex_
  mutable std::mutex continuation_mutex_;
  std::optional<msg::ObstacleArray> obstacles_;
  std::optional<std::int64_t> first_obstacles_ns_;  // component clock
  std::size_t dropped_obstacles_ = 0, dropped_maps_ = 0;
  // Maps numbered as received (on the executor) and the newest number built or dropped (on the map worker), under
  // mutex_: waitForMapsReceived's.
  std::uint64_t maps_received_ = 0, maps_settled_ = 0;
  std::uint64_t preferred_settled_ = 0;  // the newest number whose preferred world is built (or none is built of it)
  std::uint64_t plain_map_number_ = 0, preferred_map_number_ = 0;  // the maps the two worlds were built from
  mutable std::condition_variable map_settled_;
  runtime::Worker map_worker_{"map"};  // after what its jobs use, before the subscriptions that feed it
  std::function<void()> on_obstacles_, on_map_;
  bus::Subscription obstacles_sub_, map_sub_;
};

}  // namespace ddsnav::nodes
