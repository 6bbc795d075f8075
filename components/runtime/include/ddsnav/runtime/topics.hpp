// The stock topics, each defined once: name, message type and QoS. Components subscribe and publish
// through these (so a name is never spelled twice), the recorder picks a recorded topic's QoS here, and
// the topic table of docs/architecture.md is checked against this one (components/runtime/tests).
//
//   auto clouds = ctx.subscribe(runtime::topics::points, [&](const msg::PointCloud& c) { ... });
//   auto paths = ctx.publisher(runtime::topics::path);
#pragma once

#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace ddsnav::runtime {

// A topic of message type T with the QoS its writers and readers use.
template <class T>
struct Topic {
  using Message = T;
  const char* name;
  bus::Qos qos;
};

// One row of the table: what docs and the recorder need, without the C++ type.
struct TopicRow {
  std::string name;
  std::string type;     // the idl struct, e.g. "PointCloud"
  std::string profile;  // "sensorData" | "state" | "commands" (bus::Qos's constructors)
  bus::Qos qos;
  std::string flow;     // producer -> consumers, for the docs (made from the two lists below and a note)
  // The stock components that publish and subscribe it ("*": any process). The DDS Security grants are
  // made from these lists (components/security), and a stock component that opens a topic otherwise
  // fails at start (topicUseError), so a new topic or subscription cannot be left out of the grants.
  std::vector<std::string> publishers;
  std::vector<std::string> subscribers;
};

enum class TopicUse { Publish, Subscribe };

namespace topics {
// QoS by intent (bus::Qos): sensor data best effort keep last 5, state reliable transient local depth 1,
// commands reliable keep last 10.
inline const Topic<msg::PointCloud> points{"sensors/points", bus::Qos::sensorData()};
inline const Topic<msg::VehicleState> vehicle_state{"vehicle/state", bus::Qos::sensorData()};
inline const Topic<msg::ObstacleArray> obstacles{"perception/obstacles", bus::Qos::state()};
inline const Topic<msg::OccupancyMap> octomap{"map/octomap", bus::Qos::state()};
inline const Topic<msg::PlanRequest> plan_request{"planning/request", bus::Qos::commands()};
inline const Topic<msg::Path> path{"planning/path", bus::Qos::state()};
inline const Topic<msg::Trajectory> trajectory{"control/trajectory", bus::Qos::state()};
inline const Topic<msg::VelocityCommand> cmd_vel{"control/cmd_vel", bus::Qos::commands()};
inline const Topic<msg::TrackingStatus> tracking{"control/tracking", bus::Qos::sensorData()};
inline const Topic<msg::ComponentStatus> status{"system/status", bus::Qos::state(1)};
inline const Topic<msg::Clock> clock{"system/clock", bus::Qos::sensorData(1)};
inline const Topic<msg::Progress> progress{"system/progress", bus::Qos::sensorData(1)};
}  // namespace topics

// Every stock topic, in the order of the docs' table.
const std::vector<TopicRow>& stockTopics();
// The row of `name`, also when `name` carries a namespace ("uav1/sensors/points"); nullptr when none.
const TopicRow* findStockTopic(std::string_view name);
// The components the table names (as publisher or subscriber of some topic), in table order.
std::vector<std::string> stockComponents();
// Empty when stock component `component` may open `topic` (its own name for it, before remapping) as
// `use` per the table, or when `component` is not a stock one; else the complaint naming both and the table.
std::string topicUseError(std::string_view component, std::string_view topic, TopicUse use);
// The Markdown table of docs/architecture.md (topic | type | QoS | producer -> consumers).
std::string topicTable();

}  // namespace ddsnav::runtime
