#include <ddsnav/runtime/topics.hpp>

#include <algorithm>

namespace ddsnav::runtime {
namespace {

std::string shortType(std::string_view registered) {
  const auto colon = registered.rfind(':');
  return std::string(colon == std::string_view::npos ? registered : registered.substr(colon + 1));
}

using Names = std::vector<std::string>;

std::string listed(const Names& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + (n == "*" ? std::string("any process") : n);
  return out;
}

template <class T>
TopicRow row(const Topic<T>& t, std::string profile, Names publishers, Names subscribers, const std::string& note = "") {
  std::string flow = listed(publishers) + " → " + listed(subscribers) + (note.empty() ? "" : " (" + note + ")");
  return {t.name, shortType(msg::type_support<T>().name), std::move(profile), t.qos, std::move(flow), std::move(publishers),
          std::move(subscribers)};
}

bool names(const Names& list, std::string_view component) {
  for (const auto& n : list)
    if (n == "*" || n == component) return true;
  return false;
}

}  // namespace

// Who opens what: the constructors in components/nodes/src/*_main.cpp and world_source.cpp (planner and
// tracker read the map and obstacles through it), the runtime itself (heartbeat, clock: topic) and the
// launcher. The tools that carry any topic (record, play, bridge, echo) get wildcards in their grants.
const std::vector<TopicRow>& stockTopics() {
  static const std::vector<TopicRow> table = {
      row(topics::points, "sensorData", {"sim"}, {"perception", "mapper", "tracker", "monitor"}),
      row(topics::vehicle_state, "sensorData", {"sim"}, {"tracker", "monitor"}),
      row(topics::obstacles, "state", {"perception"}, {"planner", "tracker", "monitor"}),
      row(topics::octomap, "state", {"mapper"}, {"planner", "tracker", "monitor"}, "planner and tracker with `world: map` or `fused`"),
      row(topics::plan_request, "commands", {"tracker"}, {"planner", "monitor"}),
      row(topics::path, "state", {"planner"}, {"tracker", "monitor"}, "unsolved paths carry `failure`: the planner's reason"),
      row(topics::trajectory, "state", {"tracker"}, {"monitor"}),
      row(topics::cmd_vel, "commands", {"tracker"}, {"sim"}),
      row(topics::tracking, "sensorData", {"tracker"}, {"monitor"}),
      row(topics::status, "state", {"*"}, {"launch", "monitor"}, "also tests; keyed by `name`; never remapped or namespaced"),
      row(topics::clock, "sensorData", {"sim"}, {"*"}, "or a replay; read by processes run with `clock: topic`; not namespaced"),
      row(topics::progress, "sensorData", {"*"}, {"sim"},
          "every process on `clock: topic`: how far it has caught up; the sim paces its clock by it; keyed by `name`; not namespaced"),
  };
  return table;
}

std::vector<std::string> stockComponents() {
  std::vector<std::string> out;
  for (const auto& r : stockTopics())
    for (const Names* list : {&r.publishers, &r.subscribers})
      for (const auto& n : *list)
        if (n != "*" && std::find(out.begin(), out.end(), n) == out.end()) out.push_back(n);
  return out;
}

std::string topicUseError(std::string_view component, std::string_view topic, TopicUse use) {
  const auto stock = stockComponents();
  if (std::find(stock.begin(), stock.end(), component) == stock.end()) return "";
  const char* verb = use == TopicUse::Publish ? "publishes" : "subscribes to";
  const std::string where = " (components/runtime/src/topics.cpp; the DDS Security grants are made from it): add it there";
  const TopicRow* r = nullptr;
  for (const auto& candidate : stockTopics())
    if (candidate.name == topic) r = &candidate;
  if (!r) return std::string(component) + " " + verb + " '" + std::string(topic) + "', which is not in the stock topic table" + where;
  if (names(use == TopicUse::Publish ? r->publishers : r->subscribers, component)) return "";
  return std::string(component) + " " + verb + " '" + std::string(topic) + "', but the topic table does not list it among the topic's " +
         (use == TopicUse::Publish ? "publishers" : "subscribers") + where;
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
