#include <ddsnav/runtime/topics.hpp>

namespace ddsnav::runtime {
namespace {

std::string shortType(std::string_view registered) {
  const auto colon = registered.rfind(':');
  return std::string(colon == std::string_view::npos ? registered : registered.substr(colon + 1));
}

template <class T>
TopicRow row(const Topic<T>& t, std::string profile, std::string flow) {
  return {t.name, shortType(msg::type_support<T>().name), std::move(profile), t.qos, std::move(flow)};
}

}  // namespace

const std::vector<TopicRow>& stockTopics() {
  static const std::vector<TopicRow> table = {
      row(topics::points, "sensorData", "sim → perception, mapper, monitor"),
      row(topics::vehicle_state, "sensorData", "sim → tracker, monitor"),
      row(topics::obstacles, "state", "perception → planner, tracker, monitor"),
      row(topics::octomap, "state", "mapper → planner (`world: map`), monitor"),
      row(topics::plan_request, "commands", "tracker → planner"),
      row(topics::path, "state", "planner → tracker, monitor (unsolved paths carry `failure`: the planner's reason)"),
      row(topics::trajectory, "state", "tracker → monitor"),
      row(topics::cmd_vel, "commands", "tracker → sim"),
      row(topics::tracking, "sensorData", "tracker → monitor"),
      row(topics::status, "state", "every process → launcher, tests (keyed by `name`; never remapped or namespaced)"),
      row(topics::clock, "sensorData", "a replay/simulation → processes run with `clock: topic` (not namespaced)"),
  };
  return table;
}

const TopicRow* findStockTopic(std::string_view name) {
  for (const auto& r : stockTopics()) {
    if (name == r.name) return &r;
    // A namespaced name: "uav1/sensors/points" ends in "/sensors/points".
    if (name.size() > r.name.size() && name.compare(name.size() - r.name.size(), r.name.size(), r.name) == 0 &&
        name[name.size() - r.name.size() - 1] == '/')
      return &r;
  }
  return nullptr;
}

std::string topicTable() {
  std::string out = "| topic | type (idl/) | QoS | producer → consumers |\n|---|---|---|---|\n";
  for (const auto& r : stockTopics()) {
    const std::string reliability = r.qos.reliability == bus::Reliability::Reliable ? "reliable" : "best effort";
    const std::string durability = r.qos.durability == bus::Durability::TransientLocal ? ", transient local" : "";
    out += "| `" + r.name + "` | `" + r.type + "` | " + r.profile + ": " + reliability + durability + ", keep last " +
           std::to_string(r.qos.depth) + " | " + r.flow + " |\n";
  }
  return out;
}

}  // namespace ddsnav::runtime
