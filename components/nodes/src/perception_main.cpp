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
using nodes::sleepFor;

int main(int argc, char** argv) {
  return runtime::runComponent("perception", argc, argv, [](runtime::Context& ctx) {
    perception::DetectorParams detector_params;
    detector_params.voxel_size = ctx.params().declare<double>("voxel_size", detector_params.voxel_size);
    detector_params.cluster_tolerance = ctx.params().declare<double>("cluster_tolerance", detector_params.cluster_tolerance);
    const auto min_cluster_size = ctx.params().declare<std::int64_t>("min_cluster_size", 3);
    if (min_cluster_size < 1) throw runtime::ParameterError(fmt::format("parameter min_cluster_size: expected >= 1, got {}", min_cluster_size));
    detector_params.min_cluster_size = static_cast<std::size_t>(min_cluster_size);
    detector_params.ground_z = ctx.params().declare<double>("ground_z", detector_params.ground_z);
    detector_params.probability = ctx.params().declare<double>("probability", detector_params.probability);
    detector_params.range_noise_sigma = ctx.params().declare<double>("range_noise_sigma", detector_params.range_noise_sigma);
    detector_params.max_range = ctx.params().declare<double>("max_range", detector_params.max_range);
    detector_params.beam_spacing = ctx.params().declare<double>("beam_spacing_rad", 2.0 * M_PI / 720.0);
    // The detector calls it 'beam_spacing'; the error must name the parameter the user set.
    if (!(detector_params.beam_spacing > 0 && detector_params.beam_spacing < 1.0))
      throw runtime::ParameterError(fmt::format("parameter beam_spacing_rad: expected (0, 1) rad, got {}", detector_params.beam_spacing));
    detector_params.max_segment_length = ctx.params().declare<double>("max_segment_length", detector_params.max_segment_length,
                                                                      "m, longest piece one ellipse may cover");
    // The tracker groups evidence by the same voxel size, tolerance and piece size as the detector.
    const auto tracker_params = perception::TrackerParams::matching(detector_params);
    try {
      detector_params.validate();  // both name the other parameters as the user spells them
      tracker_params.validate();
    } catch (const std::invalid_argument& e) {
      throw runtime::ParameterError(e.what());
    }
    const std::string world_frame = ctx.params().declare<std::string>("frame", nodes::kWorldFrame);

    perception::ObstacleDetector detector(detector_params);
    perception::ObstacleTracker obstacle_tracker(tracker_params);
    auto obstacles = ctx.bus().publisher<msg::ObstacleArray>("perception/obstacles", bus::Qos::state());

    // Runs on the bus thread; one subscription's callbacks never overlap, so the detector needs no lock.
    auto clouds = ctx.bus().subscribe<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), [&](const msg::PointCloud& cloud) {
      if (cloud.header().frame_id() != world_frame) {
        spdlog::warn("sensors/points: skipping a cloud in frame '{}' (expected '{}')", bus::printable(cloud.header().frame_id()), world_frame);
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
        const auto detections = detector.detect(points, origin);
        const auto& tracked = obstacle_tracker.update(detections);
        msg::ObstacleArray out;
        out.header(cloud.header());
        out.planar(tracked.empty() ? nodes::isPlanarCloud(points) : tracked.front().dimensions == 2);
        for (const auto& o : tracked) out.obstacles().push_back(nodes::toMsg(o));
        obstacles.publish(out);
        const auto& stats = detector.stats();
        spdlog::debug("cloud: {} points, {} dropped, {} voxels, {} detections, {} tracked ({} new)", stats.input_points,
                      stats.dropped_invalid, stats.voxels, detections.size(), tracked.size(),
                      obstacle_tracker.lastUpdate().created);
      } catch (const std::exception& e) {
        spdlog::warn("sensors/points: skipping a cloud: {}", e.what());
      }
    });

    ctx.ready();
    while (sleepFor(ctx, std::chrono::milliseconds(200))) {
    }
  });
}
