// ddsnav-perception: sensors/points -> perception/obstacles. Each cloud is clustered into obstacle
// ellipses/ellipsoids holding the obstacle with probability p, fused with the obstacles already tracked,
// and the whole tracked set is published (transient local, so a late planner gets it).

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/bus/printable.hpp>
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/perception/obstacle_detector.hpp>
#include <ddsnav/perception/obstacle_tracker.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

using namespace ddsnav;

namespace {

class PerceptionComponent : public runtime::Component {
 public:
  struct Params {
    perception::DetectorParams detector;
    std::string frame;
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
      frame = p.declare<std::string>("frame", nodes::kWorldFrame, {.doc = "frame_id clouds must carry"});
    }
  };

  explicit PerceptionComponent(runtime::Context& ctx)
      : Component(ctx),
        params_(ctx.params()),
        // The tracker groups evidence by the same voxel size, tolerance and piece size as the detector.
        tracker_params_(validated(params_.detector)),
        detector_(params_.detector),
        obstacle_tracker_(tracker_params_),
        obstacles_(publisher(runtime::topics::obstacles)),
        clouds_(subscribe(runtime::topics::points, [this](const msg::PointCloud& c) { onCloud(c); })) {}

 private:
  static perception::TrackerParams validated(const perception::DetectorParams& detector) {
    const auto tracker = perception::TrackerParams::matching(detector);
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
      const auto detections = detector_.detect(points, origin);
      const auto& tracked = obstacle_tracker_.update(detections);
      msg::ObstacleArray out;
      out.header(cloud.header());
      out.planar(tracked.empty() ? nodes::isPlanarCloud(points) : tracked.front().dimensions == 2);
      for (const auto& o : tracked) out.obstacles().push_back(nodes::toMsg(o));
      obstacles_.publish(out);
      const auto& stats = detector_.stats();
      spdlog::debug("cloud: {} points, {} dropped, {} voxels, {} detections, {} tracked ({} new)", stats.input_points, stats.dropped_invalid,
                    stats.voxels, detections.size(), tracked.size(), obstacle_tracker_.lastUpdate().created);
    } catch (const std::exception& e) {
      spdlog::warn("sensors/points: skipping a cloud: {}", e.what());
    }
  }

  const Params params_;
  const perception::TrackerParams tracker_params_;
  perception::ObstacleDetector detector_;
  perception::ObstacleTracker obstacle_tracker_;
  bus::Publisher<msg::ObstacleArray> obstacles_;
  bus::Subscription clouds_;
};

}  // namespace

int main(int argc, char** argv) { return runtime::runComponent<PerceptionComponent>("perception", argc, argv); }
