// The stock grants, made from the runtime's topic table (components/runtime/src/topics.cpp): each stock
// component may publish and subscribe what the table lists it for, so a new topic or subscription is
// granted by the same line that declares it (and a component opening a topic the table does not list
// fails at start, runtime::topicUseError). Kept apart from ddsnav_security, which the bus links: the
// table lives above the bus.
#include <ddsnav/runtime/topics.hpp>
#include <ddsnav/security/security.hpp>

#include <algorithm>

namespace ddsnav::security {
namespace {

bool lists(const std::vector<std::string>& names, const std::string& component) {
  return std::find(names.begin(), names.end(), component) != names.end() ||
         std::find(names.begin(), names.end(), "*") != names.end();
}

// `name`'s rows of the table ("*" rows included: every process publishes its heartbeat and may follow the
// clock), then `publish` / `subscribe`, then the bus's private probe topics (Cyclone creates a local
// writer and reader on ddsnav_internal/type_probe/* per type) that every participant needs.
Grant fromTable(const std::string& name, std::vector<std::string> publish = {}, std::vector<std::string> subscribe = {}) {
  Grant g{name, {}, {}};
  for (const auto& row : runtime::stockTopics()) {
    if (lists(row.publishers, name)) g.publish.push_back(row.name);
    if (lists(row.subscribers, name)) g.subscribe.push_back(row.name);
  }
  g.publish.insert(g.publish.end(), publish.begin(), publish.end());
  g.subscribe.insert(g.subscribe.end(), subscribe.begin(), subscribe.end());
  g.publish.push_back("ddsnav_internal/*");
  g.subscribe.push_back("ddsnav_internal/*");
  return g;
}

}  // namespace

const std::vector<Grant>& stockGrants() {
  static const std::vector<Grant> grants = [] {
    std::vector<Grant> g;
    for (const auto& component : runtime::stockComponents()) g.push_back(fromTable(component));
    // The tools carry the topics they are told at run time: the recorder, bridge and echo read any, the
    // player writes any; the talker (docs/bus.md's first pipeline) writes vehicle/state.
    g.push_back(fromTable("record", {}, {"*"}));
    g.push_back(fromTable("bridge", {}, {"*"}));
    g.push_back(fromTable("echo", {}, {"*"}));
    g.push_back(fromTable("play", {"*"}, {}));
    g.push_back(fromTable("talker", {runtime::topics::vehicle_state.name}, {}));
    return g;
  }();
  return grants;
}

}  // namespace ddsnav::security
