// ddsnav-mapper: sensors/points -> map/octomap. Inserts every cloud into an OctoMap octree and publishes
// the binary tree (reliable, transient local) at most at publish_rate_hz, only when it changed and right after the
// cloud that changed it, so a late-joining planner gets the current map. Writes a .bt file on shutdown when save_path is set.

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/bus/printable.hpp>
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>

#include "ddsnav/nodes/map_scale.hpp"
#include <ddsnav/mapper/occupancy_mapper.hpp>
#include <ddsnav/sim/sensor_choice.hpp>

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <optional>

using namespace ddsnav;

namespace {

class MapperComponent : public runtime::Component {
 public:
  struct Params {
    mapper::MapperConfig config;
    double max_range;
    double publish_rate_hz;
    double export_share;
    double free_space_delay_s;
    std::optional<double> free_space_near_m;
    int cloud_queue;
    std::string save_path;
    std::string frame;
    explicit Params(runtime::Parameters& p) {
      const mapper::MapperConfig d;
      const auto scenario = p.declare<std::string>(
          "scenario", "", {.doc = "scenario file the simulator runs: resolution and max_range default to its scale (docs/world-model.md); empty: 0.1 m and 30 m"});
      const auto resolution = p.declareOptional<double>("resolution", {.min = 0.001, .max = 100, .unit = "m", .doc = "leaf size of the octree; default from the scenario"});
      const auto range = p.declareOptional<double>("max_range", {.above = 0, .max = 1e5, .unit = "m", .doc = "beams are cut at this range; default from the scenario"});
      nodes::MapScale scale;
      if (!scenario.empty()) {
        const auto loaded = planner::loadScenario(scenario);
        scale = nodes::mapScaleFor(loaded, sim::defaultMaxRange(loaded));
      }
      config.resolution = resolution.value_or(scale.resolution);
      max_range = range.value_or(scale.max_range);
      config.dimensions = static_cast<int>(
          p.declare<std::int64_t>("dimensions", 0, {.min = 0, .max = 3, .doc = "2 or 3; 0: inferred from the first cloud (a planar scan: 2)"}));
      config.prob_hit = p.declare<double>("prob_hit", d.prob_hit, {.doc = "occupancy probability of a hit"});
      config.prob_miss = p.declare<double>("prob_miss", d.prob_miss, {.doc = "occupancy probability of a miss"});
      config.occupancy_threshold = p.declare<double>("occupancy_threshold", d.occupancy_threshold, {.doc = "occupied above this probability"});
      config.clamping_min = p.declare<double>("clamping_min", d.clamping_min, {.doc = "lower clamping bound of a leaf's probability"});
      config.clamping_max = p.declare<double>("clamping_max", d.clamping_max, {.doc = "upper clamping bound of a leaf's probability"});
      config.clear_beam_gaps = p.declare<bool>(
          "clear_beam_gaps", true,
          {.doc = "clear the space of beams that returned nothing, in gaps of the scan's bearings (in 3-D of each lidar ring's) up to "
                  "max_clear_gap_deg wide, to max_range (a corridor seen end-on onto open space, a window in a wall, was never "
                  "observed free: docs/world-model.md)"});
      config.max_clear_gap_rad = p.declare<double>("max_clear_gap_deg", 20.0,
                                                   {.above = 0, .max = 180, .unit = "deg",
                                                    .doc = "widest gap between returns cleared (a wider one, a blind sector, stays unknown)"}) *
                                 std::numbers::pi / 180.0;
      // On by default since the jittered S-tunnels (2 m corridors whose walls the scanner hits every few metres down
      // the leg): without it the plans went through the gaps between the hits into the blocks between the legs, and
      // the vehicle backtracked whole legs until the mission timed out (docs/world-model.md, "Faces seen at a grazing
      // angle").
      config.fill_surfaces_between_returns = p.declare<bool>(
          "fill_surfaces_between_returns", true,
          {.doc = "2-D: mark occupied the segment between neighbouring returns when both lie on one surface with the returns "
                  "beside them, except where "
                  "beams have looked through with confidence (a wall seen at a grazing angle is hit every few metres, and the "
                  "planner took the stretches between for open space: docs/world-model.md)"});
      config.max_surface_fill_m = p.declare<double>(
          "max_surface_fill_m", 0.0,
          {.min = 0, .max = 1e4, .unit = "m", .doc = "longest segment filled; 0: the scan's max_range / 8"});
      config.threads = static_cast<int>(p.declare<std::int64_t>(
          "threads", 2,
          {.min = 1, .max = 64,
           .doc = "threads that cast the rays and walk the tree (the map is the same for any count; with 2 and the pipeline a "
                  "64x1800 scan at 0.2 m took 57-69 ms on 2 cores, with 1 thread 111-132 ms: docs/benchmarks/mapper.md)"}));
      config.pipeline = p.declare<bool>(
          "pipeline", true,
          {.doc = "overlap each cloud's tree update with the next cloud's ray casting while one thread keeps up with the tree, "
                  "else update the tree on every thread (the map is the same; publishing waits for the pending update)"});
      publish_rate_hz = p.declare<double>(
          "publish_rate_hz", 5.0,
          {.above = 0, .max = 100, .unit = "Hz",
           .doc = "at most this often, and only when changed, right after the cloud that is due (5: a new obstacle reaches the planner within 0.2 s of being mapped; "
                  "at 1 Hz gart_terrain_3d reached its goal in 1 of 4 runs, at 5 Hz in 4 of 5: docs/benchmarks/mission.md)"});
      export_share = p.declare<double>(
          "export_share", 0.5,
          {.above = 0, .max = 1,
           .doc = "at most this share of wall time goes to exporting the map for publishing (a 3-D terrain map: 20-60 ms, only the regions that changed are walked again; "
                  "1: publish at publish_rate_hz whatever it costs)"});
      free_space_delay_s = p.declare<double>(
          "free_space_delay_s", 1.0,
          {.min = 0, .max = 60, .unit = "s",
           .doc = "3-D: free space newly observed in open air (no occupied voxel in its region of 16 voxels or beside it) reaches "
                  "the published map up to this late (such regions are walked again at most this often: a moving lidar's far rays "
                  "find new free voxels in most of them on every scan); anything that turns occupied, or free from occupied, and new "
                  "free space near a mapped surface go out at once; 0: every export is exact. 2-D maps publish everything at once "
                  "(docs/world-model.md)"});
      free_space_near_m = p.declareOptional<double>(
          "free_space_near_m",
          {.min = 0, .max = 1e5, .unit = "m",
           .doc = "with free_space_delay_s: free space found within this distance of the sensor (on each axis) goes out at once "
                  "too; default: a third of max_range"});
      cloud_queue = static_cast<int>(p.declare<std::int64_t>(
          "cloud_queue", 1,
          {.min = 1, .max = 100,
           .doc = "clouds waiting to be inserted; when insertion falls behind the sensor the oldest are dropped and counted, so the map "
                  "lags the sensor by at most this many insertions (a 3-D map at 0.1 m takes longer per cloud than a 10 Hz lidar "
                  "allows on a small machine: a deeper queue only delays what the planner sees)"}));
      save_path = p.declare<std::string>("save_path", "", {.doc = "write the octree (.bt) here on shutdown; empty: do not"});
      frame = p.declare<std::string>("frame", nodes::kWorldFrame, {.doc = "frame_id clouds must carry"});
    }
  };

  explicit MapperComponent(runtime::Context& ctx) : Component(ctx), params_(ctx.params()) {
    if (params_.config.dimensions == 1) throw runtime::ParameterError("parameter 'dimensions': expected 0 (infer), 2 or 3, got 1");
    // Checked now, not at the first cloud: with dimensions 0 (inferred later) a stand-in of 3 checks the rest.
    mapper::MapperConfig check = params_.config;
    if (check.dimensions == 0) check.dimensions = 3;
    if (const auto error = mapper::validateConfig(check); !error.empty()) throw runtime::ParameterError(error);
    maps_ = publisher(runtime::topics::octomap);
    bus::Qos clouds_qos = runtime::topics::points.qos;
    clouds_qos.depth = params_.cloud_queue;
    clouds_ = ctx.subscribe<msg::PointCloud>(runtime::topics::points.name, clouds_qos, [this](const msg::PointCloud& c) { onCloud(c); });
    // The clouds publish the map (onCloud); the timer only a change after which no cloud came for a period.
    publish_ = every(std::chrono::nanoseconds(publishPeriodNs()), [this] {
      if (clock().nowNs() - last_insert_ns_ >= publishPeriodNs()) publishIfChanged();
    });
  }

  void shutdown() override {
    clouds_ = bus::Subscription();  // no more insertions while saving
    publishIfChanged(/*limited=*/false);  // the last map, whatever the last export took and whenever the last went out
    if (params_.save_path.empty() || !map_) return;
    const auto dir = std::filesystem::path(params_.save_path).parent_path();
    if (!dir.empty()) std::filesystem::create_directories(dir);
    map_->writeBt(params_.save_path);
    spdlog::info("wrote {}", params_.save_path);
  }

 private:
  void onCloud(const msg::PointCloud& cloud) {
    if (cloud.header().frame_id() != params_.frame) {
      spdlog::warn("sensors/points: skipping a cloud in frame '{}' (expected '{}')", bus::printable(cloud.header().frame_id()), params_.frame);
      return;
    }
    if (cloud.xyz().size() % 3 != 0) {
      spdlog::warn("sensors/points: skipping a cloud whose xyz has {} values (not a multiple of 3)", cloud.xyz().size());
      return;
    }
    auto scan = nodes::toScan(cloud, params_.max_range);
    if (!map_) {
      // A planar scanner's clouds lie in z = 0 (its origin too): map them on one slab.
      mapper::MapperConfig first = params_.config;
      if (first.dimensions == 0) first.dimensions = scan.origin.z == 0.0f && nodes::isPlanarCloud(nodes::pointsOf(cloud)) ? 2 : 3;
      // In exports: one goes out at most every publish period. 2-D worlds read the free space at once (the unknown
      // margin, the ellipses clipped to what the scanner saw free), and a 2-D export costs little.
      if (first.dimensions == 3) {
        first.free_discovery_delay_exports = static_cast<int>(std::lround(std::min(params_.free_space_delay_s * params_.publish_rate_hz, 1000.0)));
        first.free_discovery_near_range_m = params_.free_space_near_m.value_or(params_.max_range / 3.0);
      }
      map_ = std::make_unique<mapper::OccupancyMapper>(first);
      spdlog::info("mapping in {}-D at {} m, beams cut at {} m", first.dimensions, first.resolution, params_.max_range);
    }
    const auto result = map_->insert(scan);
    if (!result.inserted) spdlog::warn("sensors/points: cloud rejected: {}", result.message);
    else if (!result.message.empty()) spdlog::debug("sensors/points: {}", result.message);
    newest_stamp_ = cloud.header().stamp_ns();
    last_insert_ns_ = clock().nowNs();
    // The map goes out as soon as the cloud is in it, once a publish period has passed since the last one. On the
    // timer alone it went out a fixed time after each cloud, the two being on the same clock: 87-90 ms at 10 Hz clouds
    // in real time (2026-12-06, every 2-D world), most of a replan's latency when a wall had appeared.
    if (clock().nowNs() >= next_publish_ns_) publishIfChanged();
  }

  // `limited`: at most once a publish period, and within the export share.
  void publishIfChanged(bool limited = true) {
    if (!map_ || !map_->changedSinceExport()) return;
    const std::int64_t now_ns = clock().nowNs();
    if (limited && now_ns < next_publish_ns_) return;  // one went out within the period
    // Exporting walks the regions that changed (a 3-D terrain map: 20-60 ms of wall time, 0.1-0.4 s for a whole
    // walk); on a clock run faster than real time the publish period in wall time shrinks with it, and the exports
    // alone took the mapper's core. At most
    // export_share of the wall time goes to them: the next one waits for the last one's time / export_share.
    const auto started = std::chrono::steady_clock::now();
    if (limited && started < next_export_) return;
    const auto exported = map_->exportMap(/*complete=*/!limited);
    const auto took = std::chrono::steady_clock::now() - started;
    next_export_ = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(took / params_.export_share);
    spdlog::debug("map/octomap: exported {} bytes in {:.1f} ms", exported.octree_binary.size(), std::chrono::duration<double, std::milli>(took).count());
    msg::OccupancyMap out;
    msg::Header header;
    header.stamp_ns(newest_stamp_);
    header.frame_id(params_.frame);
    out.header(header);
    out.resolution(exported.resolution);
    out.bounds_min(nodes::toMsg(Eigen::Vector3d(exported.bounds_min[0], exported.bounds_min[1], exported.bounds_min[2])));
    out.bounds_max(nodes::toMsg(Eigen::Vector3d(exported.bounds_max[0], exported.bounds_max[1], exported.bounds_max[2])));
    out.octree(exported.octree_binary);
    maps_.publish(out);
    next_publish_ns_ = now_ns + publishPeriodNs();
  }

  std::int64_t publishPeriodNs() const { return static_cast<std::int64_t>(1e9 / params_.publish_rate_hz); }

  const Params params_;
  std::unique_ptr<mapper::OccupancyMapper> map_;
  std::int64_t newest_stamp_ = 0;
  std::int64_t next_publish_ns_ = 0;  // clock time from which the next map may go out (publish_rate_hz)
  std::int64_t last_insert_ns_ = 0;   // clock time of the last cloud inserted
  std::chrono::steady_clock::time_point next_export_{};
  bus::Publisher<msg::OccupancyMap> maps_;
  bus::Subscription clouds_;
  runtime::Timer publish_;
};

}  // namespace

DDSNAV_COMPONENT(MapperComponent, "mapper")
