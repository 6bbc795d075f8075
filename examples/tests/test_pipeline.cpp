// The example component among the stock ones, with the installed harness (ddsnav::testing): the whole
// launch file on a domain of the test's own, then assertions on the example's own topic.
#include <example_msgs/messages.hpp>

#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>

using namespace std::chrono_literals;
using example::msg::ClosestObstacle;

namespace {

TEST(ClosestObstaclePipeline, ReportsTheNearestObstacleOfTheDemoYard) {
  ddsnav::testing::Harness h;
  h.launch(EXAMPLE_LAUNCH_FILE, {{"ddsnav_share", DDSNAV_SHARE_DIR}, {"component", EXAMPLE_COMPONENT}});
  const auto qos = ddsnav::bus::Qos::state();
  // The demo yard has obstacles in view of the start pose: one is found, at a finite, positive distance.
  EXPECT_TRUE(h.sampleWithin<ClosestObstacle>("example/closest_obstacle", qos, 20s,
      [](const ClosestObstacle& c) { return c.found() && c.obstacle_count() > 0 && c.distance() > 0 && c.distance() < 50; },
      "an obstacle found within 50 m"));
  // Perception publishes on every scan; the example answers each array, so its topic keeps coming.
  EXPECT_TRUE(h.rateWithin<ClosestObstacle>("example/closest_obstacle", ddsnav::bus::Qos::state(10), 1.0, 100.0, 3s));
}

TEST(ClosestObstaclePipeline, NoAnswerWithoutPerception) {
  ddsnav::testing::Harness h;
  h.startReady({.name = "closest_obstacle", .command = EXAMPLE_COMPONENT});
  EXPECT_TRUE(h.noSampleDuring<ClosestObstacle>("example/closest_obstacle", ddsnav::bus::Qos::state(), 2s));
}

}  // namespace
