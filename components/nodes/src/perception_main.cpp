// ddsnav-perception: sensors/points -> perception/obstacles. Each cloud is clustered into obstacle
// ellipses/ellipsoids holding the obstacle with probability p, fused with the obstacles already tracked,
// and the tracked set is published (transient local, so a late planner gets it). With structure_extent_m > 0,
// clusters larger than that (terrain, walls: the mapper's octree holds them for the fused world) are no
// obstacles, and tracks of them are dropped from what is published; at most max_obstacles are published,
// the nearest to the sensor (docs/world-model.md). Tracks entirely farther than forget_radius_m from the
// cloud's sensor_origin are forgotten, so the tracker's memory stays bounded on any drive.

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/map_scale.hpp"
#include <ddsnav/bus/printable.hpp>
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/perception/obstacle_detector.hpp>
#include <ddsnav/perception/obstacle_tracker.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <vector>

using namespace ddsnav;

namespace {

class PerceptionComponent : public runtime::Component {
 public:
  struct Params {
    perception::DetectorParams detector;
    std::string frame;
    std::int64_t max_obstacles;
    double forget_radius;
    double track_voxel_3d;
    explicit Params(runtime::Parameters& p) {
      const perception::DetectorParams d;
      detector.voxel_size = p.declare<double>("voxel_size", d.voxel_size, {.above = 0, .unit = "m", .doc = "voxel grid leaf size"});
      detector.cluster_tolerance =
          p.declare<double>("cluster_tolerance", d.cluster_tolerance, {.above = 0, .unit = "m", .doc = "largest gap inside one cluster"});
      detector.min_cluster_size = static_cast<std::size_t>(
          p.declare<std::int64_t>("min_cluster_size", 3, {.min = 1, .unit = "voxels", .doc = "smaller clusters are noise"}));
      detector.ground_z = p.declare<double>("ground_z", d.ground_z, {.unit = "m", .doc = "3-D: voxel centroids at or below it are ground"});
      detector.probability =
          p.declare<double>("probability", d.probability, {.above = 0, .below = 1, .doc = "probability p that an ellipse holds its obstacle"});
      detector.range_noise_sigma = p.declare<double>("range_noise_sigma", d.range_noise_sigma, {.min = 0, .unit = "m", .doc = "the sensor's range noise"});
      detector.max_range = p.declare<double>("max_range", d.max_range, {.above = 0, .unit = "m", .doc = "farther points are dropped as invalid"});
      // The detector calls it 'beam_spacing'; the error names the parameter the user set.
      detector.beam_spacing = p.declare<double>("beam_spacing_rad", 2.0 * M_PI / 720.0, {.above = 0, .below = 1, .unit = "rad", .doc = "the sensor's azimuth step"});
      detector.max_segment_length =
          p.declare<double>("max_segment_length", d.max_segment_length, {.min = 0, .unit = "m", .doc = "longest piece one ellipse may cover (0: never cut)"});
      detector.max_segment_width = p.declare<double>(
          "max_segment_width", d.max_segment_width,
          {.min = 0, .max = 100, .unit = "m", .doc = "2-D: a thicker piece (an L at a corner, a curved arc) is halved (docs/perception.md, step 6; 0: as max_segment_length)"});
      detector.max_segment_width_3d = p.declare<double>(
          "max_segment_width_3d", d.max_segment_width_3d, {.min = 0, .max = 100, .unit = "m", .doc = "the same in 3-D"});
      const auto scenario = p.declare<std::string>(
          "scenario", "", {.doc = "scenario file the simulator runs: structure_extent_m auto follows its robot radius; empty: none"});
      const auto extent = p.declare<std::string>(
          "structure_extent_m", "0",
          {.unit = "m", .doc = "clusters with a longer box diagonal are structure, not obstacles (0: none); auto: min(10 m, 25 x the "
                               "scenario's robot radius) (docs/world-model.md)"});
      detector.structure_extent = structureExtent(extent, scenario);
      // Derived from max_range (as declared above): see TrackerParams::matching and docs/perception.md.
      forget_radius = p.declare<double>(
          "forget_radius_m", perception::TrackerParams::matching(detector).forget_radius,
          {.above = 0, .max = 1e6, .unit = "m",
           .doc = "tracks entirely farther from the cloud's sensor origin are forgotten (default max_range + 4 cluster_tolerance)"});
      // Derived from voxel_size (as declared above): see TrackerParams::voxel_size_3d and docs/perception.md.
      track_voxel_3d = p.declare<double>(
          "track_voxel_3d_m", perception::TrackerParams::matching(detector).voxel_size_3d,
          {.above = 0, .max = 100, .unit = "m",
           .doc = "grid of a 3-D track's evidence (default twice voxel_size, at most cluster_tolerance)"});
      // Only tracks are published, and the tracker refits them from the detections' voxels.
      detector.fit_detections = false;
      max_obstacles = p.declare<std::int64_t>("max_obstacles", 1500, {.min = 1, .max = 1000000, .doc = "most obstacles published per array"});
      frame = p.declare<std::string>("frame", nodes::kWorldFrame, {.doc = "frame_id clouds must carry"});
    }
  };

  // "auto" (the scenario's rule) or a number of metres in [0, 1e6].
  static double structureExtent(const std::string& text, const std::string& scenario) {
    if (text == "auto") {
      if (scenario.empty()) throw runtime::ParameterError("parameter 'structure_extent_m': auto needs the scenario parameter");
      return nodes::defaultStructureExtent(planner::loadScenario(scenario));
    }
    std::size_t used = 0;
    double value = std::nan("");
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
    }
    if (used != text.size() || !(value >= 0.0 && value <= 1e6))
      throw runtime::ParameterError("parameter 'structure_extent_m': expected auto or a number of metres in [0, 1e6], got '" + text + "'");
    return value;
  }

  explicit PerceptionComponent(runtime::Context& ctx)
      : Component(ctx),
        params_(ctx.params()),
        // The tracker groups evidence by the same voxel size, tolerance and piece size as the detector.
        tracker_params_(validated(params_.detector, params_.forget_radius, params_.track_voxel_3d)),
        detector_(params_.detector),
        obstacle_tracker_(tracker_params_),
        obstacles_(publisher(runtime::topics::obstacles)),
        clouds_(subscribe(runtime::topics::points, [this](const msg::PointCloud& c) { onCloud(c); })) {}

  // After the last callback: the per-cloud timing of the whole run.
  void shutdown() override {
    if (cloud_ms_.empty()) return;
    auto at = [](std::vector<double>& v, double q) {
      std::sort(v.begin(), v.end());
      return v[std::min(v.size() - 1, static_cast<std::size_t>(q * double(v.size())))];
    };
    spdlog::info("{} clouds: detect + track wall median {:.1f} ms, p99 {:.1f} ms (CPU median {:.1f} ms, p99 {:.1f} ms); "
                 "{} tracks, {} published at most",
                 cloud_ms_.size(), at(cloud_ms_, 0.5), at(cloud_ms_, 0.99), at(cloud_cpu_ms_, 0.5), at(cloud_cpu_ms_, 0.99),
                 obstacle_tracker_.obstacles().size(), most_published_);
  }

 private:
  // This thread's CPU time: a loaded machine inflates the wall time, not this.
  static double threadCpuMs() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
  }

  static perception::TrackerParams validated(const perception::DetectorParams& detector, double forget_radius,
                                             double track_voxel_3d) {
    auto tracker = perception::TrackerParams::matching(detector);
    tracker.forget_radius = forget_radius;
    tracker.voxel_size_3d = track_voxel_3d;
    if (track_voxel_3d > detector.cluster_tolerance)
      throw runtime::ParameterError(fmt::format(
          "parameter 'track_voxel_3d_m': expected at most cluster_tolerance ({} m), got {} m (a track's evidence cells "
          "must be finer than the distance that associates them)", detector.cluster_tolerance, track_voxel_3d));
    try {
      detector.validate();  // both name the other parameters as the user spells them
      tracker.validate();
    } catch (const std::invalid_argument& e) {
      throw runtime::ParameterError(e.what());
    }
    return tracker;
  }

  void onCloud(const msg::PointCloud& cloud) {
    if (cloud.header().frame_id() != params_.frame) {
      spdlog::warn("sensors/points: skipping a cloud in frame '{}' (expected '{}')", bus::printable(cloud.header().frame_id()), params_.frame);
      return;
    }
    if (cloud.xyz().size() % 3 != 0) {
      spdlog::warn("sensors/points: skipping a cloud whose xyz has {} values (not a multiple of 3)", cloud.xyz().size());
      return;
    }
    const auto origin = nodes::fromMsg(cloud.sensor_origin());
    if (!origin.allFinite()) {
      spdlog::warn("sensors/points: skipping a cloud with a non-finite sensor origin");
      return;
    }
    try {
      const auto points = nodes::pointsOf(cloud);
      const auto started = std::chrono::steady_clock::now();
      const double started_cpu = threadCpuMs();
      const auto detections = detector_.detect(points, origin);
      const auto& tracked = obstacle_tracker_.update(detections, origin);  // forgets what is out of reach
      const bool planar = tracked.empty() ? nodes::isPlanarCloud(points) : tracked.front().dimensions == 2;
      if (!detector_.structure().empty()) obstacle_tracker_.markStructure(detector_.structure(), planar ? 2 : 3);
      obstacle_tracker_.markStructureChains(detector_.params().structure_extent);
      const auto published = obstacle_tracker_.discreteObstacles(origin, static_cast<std::size_t>(params_.max_obstacles));
      cloud_ms_.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count());
      cloud_cpu_ms_.push_back(threadCpuMs() - started_cpu);
      most_published_ = std::max(most_published_, published.size());
      msg::ObstacleArray out;
      out.header(cloud.header());
      out.planar(planar);
      for (const std::size_t i : published) out.obstacles().push_back(nodes::toMsg(tracked[i]));
      obstacles_.publish(out);
      const auto& stats = detector_.stats();
      spdlog::debug("cloud: {} points, {} dropped, {} voxels, {} detections, {} structure clusters, {} tracked ({} new), {} published",
                    stats.input_points, stats.dropped_invalid, stats.voxels, detections.size(), stats.structure_clusters, tracked.size(),
                    obstacle_tracker_.lastUpdate().created, published.size());
    } catch (const std::exception& e) {
      spdlog::warn("sensors/points: skipping a cloud: {}", e.what());
    }
  }

  const Params params_;
  const perception::TrackerParams tracker_params_;
  perception::ObstacleDetector detector_;
  perception::ObstacleTracker obstacle_tracker_;
  bus::Publisher<msg::ObstacleArray> obstacles_;
  // Per cloud: detect + track (+ structure marking) wall and CPU time, and the most obstacles published; logged at shutdown.
  std::vector<double> cloud_ms_, cloud_cpu_ms_;
  std::size_t most_published_ = 0;
  bus::Subscription clouds_;
};

}  // namespace

DDSNAV_COMPONENT(PerceptionComponent, "perception")
