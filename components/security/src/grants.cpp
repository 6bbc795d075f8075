// ddsnav's topic table as access rights: which stock component publishes and subscribes what. Taken from
// the node sources (components/nodes/src/*_main.cpp, world_source.cpp, the runtime, launch, record);
// one place, so that a new topic is added here once and `ddsnav security init` grants it.
#include <ddsnav/security/security.hpp>

namespace ddsnav::security {
namespace {

// Every participant: its heartbeat, the simulated clock (clock=topic), and the bus's private probe
// topics (Cyclone creates a local writer and reader on ddsnav_internal/type_probe/* per type).
Grant withCommon(Grant g) {
  g.publish.insert(g.publish.end(), {"system/status", "ddsnav_internal/*"});
  g.subscribe.insert(g.subscribe.end(), {"system/clock", "ddsnav_internal/*"});
  return g;
}

}  // namespace

const std::vector<Grant>& stockGrants() {
  static const std::vector<Grant> grants = [] {
    std::vector<Grant> g = {
        {"sim", {"sensors/points", "vehicle/state", "system/clock"}, {"control/cmd_vel"}},  // system/clock: simulated time
        {"perception", {"perception/obstacles"}, {"sensors/points"}},
        {"mapper", {"map/octomap"}, {"sensors/points"}},
        {"planner", {"planning/path"}, {"planning/request", "perception/obstacles", "map/octomap"}},
        {"tracker",
         {"planning/request", "control/trajectory", "control/cmd_vel", "control/tracking"},
         {"vehicle/state", "planning/path", "perception/obstacles", "map/octomap"}},
        {"monitor",
         {},
         {"vehicle/state", "perception/obstacles", "planning/request", "planning/path", "control/trajectory", "control/tracking",
          "map/octomap", "sensors/points", "system/status"}},
        {"launch", {}, {"system/status"}},
        // Tools that carry any topic: the recorder, bridge and echo read everything, the player writes it.
        {"record", {}, {"*"}},
        {"bridge", {}, {"*"}},
        {"echo", {}, {"*"}},
        {"play", {"*"}, {}},
        {"talker", {"vehicle/state"}, {}},
    };
    for (Grant& grant : g) grant = withCommon(std::move(grant));
    return g;
  }();
  return grants;
}

}  // namespace ddsnav::security
