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
#include <string>
#include <vector>

using namespace ddsnav;

namespace {

// Message to algorithm and back: the nearest obstacle of one array, seen from `vehicle`.
example::msg::ClosestObstacle closestOf(const msg::ObstacleArray& array, const example::Point& vehicle) {
  std::vector<example::Obstacle> obstacles;
  for (const msg::ObstacleEllipsoid& e : array.obstacles()) {
    const double largest = std::max({e.semi_axes().x(), e.semi_axes().y(), e.semi_axes().z()});
    obstacles.push_back({e.id(), {e.centre().x(), e.centre().y(), e.centre().z()}, largest});
  }
  example::msg::ClosestObstacle answer;
  answer.header(array.header());
  answer.obstacle_count(static_cast<std::uint32_t>(obstacles.size()));
  if (const auto nearest = example::closestObstacle(obstacles, vehicle)) {
    answer.found(true);
    answer.obstacle_id(nearest->id);
    answer.distance(nearest->distance);
    answer.centre().x(nearest->centre.x);
    answer.centre().y(nearest->centre.y);
    answer.centre().z(nearest->centre.z);
  }
  return answer;
}

class ClosestObstacleComponent : public runtime::Component {
 public:
  // Every parameter, declared once (`--describe` prints them).
  struct Params {
    std::string topic;
    explicit Params(runtime::Parameters& p)
        : topic(p.declare<std::string>("topic", "example/closest_obstacle", {.doc = "where ClosestObstacle is published"})) {}
  };

  // The stock topics come from the runtime's table (name and QoS once); the own one is made here. The
  // callbacks run one at a time on the component's executor, so the state needs no lock.
  explicit ClosestObstacleComponent(runtime::Context& ctx)
      : Component(ctx),
        params_(ctx.params()),
        answers_(publisher(runtime::Topic<example::msg::ClosestObstacle>{params_.topic.c_str(), bus::Qos::state()})),
        states_(subscribe(runtime::topics::vehicle_state, [this](const msg::VehicleState& s) {
          vehicle_ = {s.position().x(), s.position().y(), s.position().z()};
        })),
        obstacles_(subscribe(runtime::topics::obstacles,
                             [this](const msg::ObstacleArray& array) { answers_.publish(closestOf(array, vehicle_)); })) {}

 private:
  const Params params_;
  example::Point vehicle_;  // the origin until the first vehicle/state arrives
  bus::Publisher<example::msg::ClosestObstacle> answers_;
  // Last, so they end first: no callback runs on the members above once they are gone.
  bus::Subscription states_;
  bus::Subscription obstacles_;
};

}  // namespace

int main(int argc, char** argv) { return runtime::runComponent<ClosestObstacleComponent>("closest_obstacle", argc, argv); }
