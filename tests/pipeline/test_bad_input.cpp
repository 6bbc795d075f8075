// Bad clouds on sensors/points: perception and the mapper log and skip (or clean) them and keep serving.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace ddsnav;
using namespace std::chrono_literals;

namespace {

// A planar scan of one 1 m box at x = 5 seen from the origin: enough points for one obstacle.
msg::PointCloud boxCloud(const std::string& frame = "map") {
  msg::PointCloud cloud;
  cloud.header().frame_id(frame);
  cloud.header().stamp_ns(1);
  for (int i = 0; i <= 40; ++i) {
    const float y = -0.5f + i * 0.025f;
    cloud.xyz().insert(cloud.xyz().end(), {5.0f, y, 0.0f});
  }
  return cloud;
}

}  // namespace

TEST(BadInput, PerceptionAndMapperSkipBadCloudsAndKeepServing) {
  harness::Harness h(215);
  h.startReady({.name = "perception", .command = "ddsnav-perception", .dds = "cyclonedds"});
  h.startReady({.name = "mapper", .command = "ddsnav-mapper", .params = {{"publish_rate_hz", "10"}}, .dds = "fastdds"});
  auto clouds = h.bus().publisher<msg::PointCloud>("sensors/points", bus::Qos::sensorData());
  ASSERT_TRUE(clouds.waitForSubscribers(2, 20s));
  auto obstacles = h.bus().inbox<msg::ObstacleArray>("perception/obstacles", bus::Qos::state());
  auto maps = h.bus().inbox<msg::OccupancyMap>("map/octomap", bus::Qos::state());

  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  auto wrong_frame = boxCloud("lidar");
  auto ragged = boxCloud();
  ragged.xyz().push_back(1.0f);  // not a multiple of 3
  auto bad_origin = boxCloud();
  bad_origin.sensor_origin().x(std::nan(""));
  auto far_origin = boxCloud();
  far_origin.sensor_origin().x(1e12);
  auto all_invalid = boxCloud();
  for (auto& v : all_invalid.xyz()) v = nan;
  msg::PointCloud empty = boxCloud();
  empty.xyz().clear();
  auto huge = boxCloud();
  huge.xyz().resize(3 * 2'000'000, 0.5f);  // 2 M points, far more than any scan here
  for (auto* bad : {&wrong_frame, &ragged, &bad_origin, &far_origin, &all_invalid, &empty, &huge}) {
    clouds.publish(*bad);
    std::this_thread::sleep_for(100ms);  // best effort: do not let the burst overrun the readers' queues
  }
  auto mixed = boxCloud();
  mixed.xyz().insert(mixed.xyz().end(), {nan, 0, 0, inf, 1, 0, 0, -inf, 0});
  clouds.publish(mixed);

  // Both still serve: the good points of the mixed cloud make one obstacle and a map.
  std::optional<msg::ObstacleArray> seen;
  for (auto a = obstacles.wait(15s); a; a = obstacles.wait(5s)) {
    if (!a->obstacles().empty()) {
      seen = a;
      break;
    }
  }
  ASSERT_TRUE(seen) << h.log("perception");
  EXPECT_NEAR(seen->obstacles()[0].centre().x(), 5.0, 0.3);
  EXPECT_NEAR(seen->obstacles()[0].centre().y(), 0.0, 0.3);
  std::optional<msg::OccupancyMap> map;
  for (auto m = maps.wait(15s); m; m = maps.wait(5s)) {
    if (!m->octree().empty()) {
      map = m;
      break;
    }
  }
  ASSERT_TRUE(map) << h.log("mapper");
  EXPECT_TRUE(h.running("perception"));
  EXPECT_TRUE(h.running("mapper"));

  const std::string perception_log = h.log("perception"), mapper_log = h.log("mapper");
  EXPECT_NE(perception_log.find("frame 'lidar'"), std::string::npos) << perception_log;
  EXPECT_NE(perception_log.find("not a multiple of 3"), std::string::npos) << perception_log;
  EXPECT_NE(perception_log.find("non-finite sensor origin"), std::string::npos) << perception_log;
  EXPECT_NE(mapper_log.find("frame 'lidar'"), std::string::npos) << mapper_log;
  EXPECT_NE(mapper_log.find("not a multiple of 3"), std::string::npos) << mapper_log;
  EXPECT_NE(mapper_log.find("rejected"), std::string::npos) << mapper_log;
}
