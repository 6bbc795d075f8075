// ddsnav-mapper: sensors/points -> map/octomap. Inserts every cloud into an OctoMap octree and publishes
// the binary tree (reliable, transient local) at most at publish_rate_hz and only when it changed, so a
// late-joining planner gets the current map. Writes a .bt file on shutdown when save_path is set.

#include "ddsnav/nodes/convert.hpp"
#include <ddsnav/bus/printable.hpp>
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>

#include <ddsnav/mapper/occupancy_mapper.hpp>

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <mutex>

using namespace ddsnav;
using nodes::sleepFor;

int main(int argc, char** argv) {
  return runtime::runComponent("mapper", argc, argv, [](runtime::Context& ctx) {
    mapper::MapperConfig config;
    config.resolution = ctx.params().declare<double>("resolution", 0.1);
    config.dimensions = static_cast<int>(ctx.params().declare<std::int64_t>("dimensions", 0));  // 0: infer from the first cloud
    config.prob_hit = ctx.params().declare<double>("prob_hit", config.prob_hit);
    config.prob_miss = ctx.params().declare<double>("prob_miss", config.prob_miss);
    config.occupancy_threshold = ctx.params().declare<double>("occupancy_threshold", config.occupancy_threshold);
    config.clamping_min = ctx.params().declare<double>("clamping_min", config.clamping_min);
    config.clamping_max = ctx.params().declare<double>("clamping_max", config.clamping_max);
    const double max_range = ctx.params().declare<double>("max_range", 30.0);
    const double publish_rate = ctx.params().declare<double>("publish_rate_hz", 1.0);
    const std::string save_path = ctx.params().declare<std::string>("save_path", "");
    const std::string world_frame = ctx.params().declare<std::string>("frame", nodes::kWorldFrame);
    if (!(max_range > 0)) throw runtime::ParameterError(fmt::format("parameter max_range: expected > 0 m, got {}", max_range));
    if (!(publish_rate > 0 && publish_rate <= 100))
      throw runtime::ParameterError(fmt::format("parameter publish_rate_hz: expected (0, 100] Hz, got {}", publish_rate));
    if (config.dimensions != 0 && config.dimensions != 2 && config.dimensions != 3)
      throw runtime::ParameterError(fmt::format("parameter dimensions: expected 0 (infer), 2 or 3, got {}", config.dimensions));
    {
      // Checked now, not at the first cloud: with dimensions 0 (inferred later) a stand-in of 3 checks the rest.
      mapper::MapperConfig check = config;
      if (check.dimensions == 0) check.dimensions = 3;
      if (const auto error = mapper::validateConfig(check); !error.empty()) throw runtime::ParameterError(error);
    }

    std::mutex mutex;
    std::unique_ptr<mapper::OccupancyMapper> map;
    std::int64_t newest_stamp = 0;
    auto maps = ctx.bus().publisher<msg::OccupancyMap>("map/octomap", bus::Qos::state());
    auto clouds = ctx.bus().subscribe<msg::PointCloud>("sensors/points", bus::Qos::sensorData(), [&](const msg::PointCloud& cloud) {
      if (cloud.header().frame_id() != world_frame) {
        spdlog::warn("sensors/points: skipping a cloud in frame '{}' (expected '{}')", bus::printable(cloud.header().frame_id()), world_frame);
        return;
      }
      if (cloud.xyz().size() % 3 != 0) {
        spdlog::warn("sensors/points: skipping a cloud whose xyz has {} values (not a multiple of 3)", cloud.xyz().size());
        return;
      }
      auto scan = nodes::toScan(cloud, max_range);
      std::lock_guard lock(mutex);
      if (!map) {
        // A planar scanner's clouds lie in z = 0 (its origin too): map them on one slab.
        mapper::MapperConfig first = config;
        if (first.dimensions == 0)
          first.dimensions = scan.origin.z == 0.0f && nodes::isPlanarCloud(nodes::pointsOf(cloud)) ? 2 : 3;
        map = std::make_unique<mapper::OccupancyMapper>(first);
        spdlog::info("mapping in {}-D at {} m", first.dimensions, first.resolution);
      }
      const auto result = map->insert(scan);
      if (!result.inserted) spdlog::warn("sensors/points: cloud rejected: {}", result.message);
      else if (!result.message.empty()) spdlog::debug("sensors/points: {}", result.message);
      newest_stamp = cloud.header().stamp_ns();
    });

    auto publishIfChanged = [&] {
      std::lock_guard lock(mutex);
      if (!map || !map->changedSinceExport()) return;
      const auto exported = map->exportMap();
      msg::OccupancyMap out;
      msg::Header header;
      header.stamp_ns(newest_stamp);
      header.frame_id(world_frame);
      out.header(header);
      out.resolution(exported.resolution);
      out.bounds_min(nodes::toMsg(Eigen::Vector3d(exported.bounds_min[0], exported.bounds_min[1], exported.bounds_min[2])));
      out.bounds_max(nodes::toMsg(Eigen::Vector3d(exported.bounds_max[0], exported.bounds_max[1], exported.bounds_max[2])));
      out.octree(exported.octree_binary);
      maps.publish(out);
    };

    ctx.ready();
    const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / publish_rate));
    while (sleepFor(ctx, period)) publishIfChanged();
    clouds = bus::Subscription();  // no more insertions while saving
    publishIfChanged();
    if (!save_path.empty()) {
      std::lock_guard lock(mutex);
      if (map) {
        const auto dir = std::filesystem::path(save_path).parent_path();
        if (!dir.empty()) std::filesystem::create_directories(dir);
        map->writeBt(save_path);
        spdlog::info("wrote {}", save_path);
      }
    }
  });
}
