// ddsnav-perception: sensors/points -> perception/obstacles. Each cloud is clustered into obstacle
// ellipses/ellipsoids holding the obstacle with probability p, fused with the obstacles already tracked,
// and the tracked set is published (transient local, so a late planner gets it). With structure_extent_m > 0,
// clusters larger than that (terrain, walls: the mapper's octree holds them for the fused world) are no
// obstacles, and tracks of them are dropped from what is published; at most max_obstacles are published,
// the nearest to the sensor (docs/world-model.md).

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/bus/printable.hpp>
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/perception/obstacle_detector.hpp>
#include <ddsnav/perception/obstacle_tracker.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <ctime>

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
    detector_params.structure_extent = ctx.params().declare<double>(
        "structure_extent_m", 0.0, "m, clusters with a longer box diagonal are structure, not obstacles (0: none)");
    const auto max_obstacles = ctx.params().declare<std::int64_t>("max_obstacles", 1500, "most obstacles published per array");
    if (max_obstacles < 1 || max_obstacles > 1000000)
      throw runtime::ParameterError(fmt::format("parameter max_obstacles: expected [1, 1000000], got {}", max_obstacles));
    if (!(detector_params.structure_extent >= 0.0) || !std::isfinite(detector_params.structure_extent))
      throw runtime::ParameterError(fmt::format("parameter structure_extent_m: expected a finite number >= 0, got {}",
                                                detector_params.structure_extent));
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

    // Per cloud: detect + track (+ structure marking) wall time, and the most obstacles published; logged at exit.
    std::vector<double> cloud_ms, cloud_cpu_ms;  // wall and this thread's CPU time (a loaded machine inflates wall)
    auto threadCpuMs = [] {
      timespec ts{};
      clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
      return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
    };
    std::size_t most_published = 0;
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
        const auto started = std::chrono::steady_clock::now();
        const double started_cpu = threadCpuMs();
        const auto detections = detector.detect(points, origin);
        const auto& tracked = obstacle_tracker.update(detections);
        const bool planar = tracked.empty() ? nodes::isPlanarCloud(points) : tracked.front().dimensions == 2;
        if (!detector.structure().empty()) obstacle_tracker.markStructure(detector.structure(), planar ? 2 : 3);
        const auto published = obstacle_tracker.discreteObstacles(origin, static_cast<std::size_t>(max_obstacles));
        cloud_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count());
        cloud_cpu_ms.push_back(threadCpuMs() - started_cpu);
        most_published = std::max(most_published, published.size());
        msg::ObstacleArray out;
        out.header(cloud.header());
        out.planar(planar);
        for (const std::size_t i : published) out.obstacles().push_back(nodes::toMsg(tracked[i]));
        obstacles.publish(out);
        const auto& stats = detector.stats();
        spdlog::debug("cloud: {} points, {} dropped, {} voxels, {} detections, {} structure clusters, {} tracked ({} new), {} published",
                      stats.input_points, stats.dropped_invalid, stats.voxels, detections.size(), stats.structure_clusters,
                      tracked.size(), obstacle_tracker.lastUpdate().created, published.size());
      } catch (const std::exception& e) {
        spdlog::warn("sensors/points: skipping a cloud: {}", e.what());
      }
    });

    ctx.ready();
    while (sleepFor(ctx, std::chrono::milliseconds(200))) {
    }
    clouds = {};  // no callback runs past here
    if (!cloud_ms.empty()) {
      auto at = [](std::vector<double>& v, double q) {
        std::sort(v.begin(), v.end());
        return v[std::min(v.size() - 1, static_cast<std::size_t>(q * double(v.size())))];
      };
      spdlog::info("{} clouds: detect + track wall median {:.1f} ms, p99 {:.1f} ms (CPU median {:.1f} ms, p99 {:.1f} ms); "
                   "{} tracks, {} published at most",
                   cloud_ms.size(), at(cloud_ms, 0.5), at(cloud_ms, 0.99), at(cloud_cpu_ms, 0.5), at(cloud_cpu_ms, 0.99),
                   obstacle_tracker.obstacles().size(), most_published);
    }
  });
}
