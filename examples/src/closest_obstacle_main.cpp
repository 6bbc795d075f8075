// example-closest-obstacle: a component of your own beside the stock pipeline. It subscribes to the
// vehicle's state and perception's obstacles, and publishes its own message type, ClosestObstacle, on
// example/closest_obstacle each time an obstacle array arrives.
//
//   example-closest-obstacle --domain 7 [--param topic=example/closest_obstacle]
#include "closest_obstacle.hpp"

#include <example_msgs/messages.hpp>  // ddsnav_add_messages(example_msgs ...): example::msg::ClosestObstacle
#include <ddsnav/msg/messages.hpp>    // the stock types: ObstacleArray, VehicleState
#include <ddsnav/runtime/component.hpp>

#include <algorithm>
#include <mutex>

using namespace ddsnav;

int main(int argc, char** argv) {
  return runtime::runComponent("closest_obstacle", argc, argv, [](runtime::Context& ctx) {
    const auto topic = ctx.params().declare<std::string>("topic", "example/closest_obstacle", "output topic");
    auto out = ctx.bus().publisher<example::msg::ClosestObstacle>(topic, bus::Qos::state());

    std::mutex mutex;
    example::Point vehicle;  // the origin until the first vehicle/state arrives
    auto states = ctx.bus().subscribe<msg::VehicleState>("vehicle/state", bus::Qos::sensorData(),
                                                         [&](const msg::VehicleState& s) {
      std::lock_guard lock(mutex);
      vehicle = {s.position().x(), s.position().y(), s.position().z()};
    });
    auto obstacles = ctx.bus().subscribe<msg::ObstacleArray>("perception/obstacles", bus::Qos::state(),
                                                             [&](const msg::ObstacleArray& array) {
      std::vector<example::Obstacle> found;
      for (const msg::ObstacleEllipsoid& e : array.obstacles()) {
        const double largest = std::max({e.semi_axes().x(), e.semi_axes().y(), e.semi_axes().z()});
        found.push_back({e.id(), {e.centre().x(), e.centre().y(), e.centre().z()}, largest});
      }
      example::Point from;
      {
        std::lock_guard lock(mutex);
        from = vehicle;
      }
      example::msg::ClosestObstacle answer;
      answer.header(array.header());
      answer.obstacle_count(static_cast<std::uint32_t>(found.size()));
      if (const auto nearest = example::closestObstacle(found, from)) {
        answer.found(true);
        answer.obstacle_id(nearest->id);
        answer.distance(nearest->distance);
        answer.centre().x(nearest->centre.x);
        answer.centre().y(nearest->centre.y);
        answer.centre().z(nearest->centre.z);
      }
      out.publish(answer);
    });
    ctx.ready();
    ctx.spin();
  });
}
