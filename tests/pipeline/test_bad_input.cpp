// Bad input from outside: perception and the mapper log and skip (or clean) bad clouds on sensors/points;
// the planner and the tracker drop malformed perception/obstacles arrays (keeping the last good one) and
// keep answering; bad parameters end a component at startup with status 2 and the parameter named.
// Everything here shares domain 215, so the parts run one after the other inside one test.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <thread>

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

constexpr int kDomain = 215;
const std::string kScenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";

// Polls NAME's log until it contains `text`; bounded.
bool waitForLog(harness::Harness& h, const std::string& name, const std::string& text, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (h.log(name).find(text) == std::string::npos) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(50ms);
  }
  return true;
}

msg::ObstacleEllipsoid ellipse(std::uint32_t id, double x, double y, double a, double b) {
  msg::ObstacleEllipsoid o;
  o.id(id);
  o.centre().x(x);
  o.centre().y(y);
  o.semi_axes().x(a);
  o.semi_axes().y(b);
  o.orientation().w(1.0);
  o.probability_bound(0.99);
  return o;
}

// demo_2d's yard with one small obstacle off the straight line from start to goal.
msg::ObstacleArray goodArray() {
  msg::ObstacleArray array;
  array.header().frame_id("map");
  array.planar(true);
  array.obstacles().push_back(ellipse(1, 30, 8, 1.0, 1.0));
  return array;
}

// One negative semi-axis and one NaN centre: no world can be built from it.
msg::ObstacleArray malformedArray() {
  auto array = goodArray();
  array.obstacles().push_back(ellipse(2, 20, 20, -1.0, 0.5));
  array.obstacles().push_back(ellipse(3, std::nan(""), 5, 1.0, 1.0));
  return array;
}

msg::PlanRequest request(std::uint32_t id) {
  msg::PlanRequest r;
  r.header().frame_id("map");
  r.request_id(id);
  r.planner("rrtstar");
  r.start().x(3);
  r.start().y(3);
  r.goal().x(36);
  r.goal().y(35);
  r.goal_radius(1.5);
  r.time_budget_s(1.0);
  r.seed(id);
  return r;
}

std::optional<msg::Path> answerTo(bus::Inbox<msg::Path>& paths, std::uint32_t id) {
  for (auto p = paths.wait(15s); p; p = paths.wait(15s))
    if (p->request_id() == id) return p;
  return std::nullopt;
}

// Starts NAME with `params`, waits (bounded) for it to end by itself and returns its log; whether it did goes
// to `ended`, its wait status to `status`.
std::string runToExit(const std::string& name, const std::map<std::string, std::string>& params, bool& ended, int& status) {
  harness::Harness h(kDomain);
  h.start({.name = name, .command = "ddsnav-" + name, .params = params});
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (h.running(name) && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(50ms);
  ended = !h.running(name);
  status = h.stop(name);  // ends it if it is still running
  return h.log(name);
}

void perceptionAndMapperSkipBadCloudsAndKeepServing() {
  harness::Harness h(kDomain);
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

void plannerAndTrackerDropMalformedWorlds() {
  harness::Harness h(kDomain);
  h.startReady({.name = "planner", .command = "ddsnav-planner", .params = {{"scenario", kScenario}}, .dds = "cyclonedds"});
  h.startReady({.name = "tracker",
                .command = "ddsnav-tracker",
                .params = {{"scenario", kScenario}, {"planner", "rrtstar"}, {"time_budget_s", "1"}, {"replan_check_period_s", "0.1"}},
                .dds = "fastdds"});
  auto obstacles = h.bus().publisher<msg::ObstacleArray>("perception/obstacles", bus::Qos::state());
  auto requests = h.bus().publisher<msg::PlanRequest>("planning/request", bus::Qos::commands());
  auto paths = h.bus().inbox<msg::Path>("planning/path", bus::Qos::state());
  auto trajectories = h.bus().inbox<msg::Trajectory>("control/trajectory", bus::Qos::state());
  ASSERT_TRUE(obstacles.waitForSubscribers(2, 20s));
  ASSERT_TRUE(requests.waitForSubscribers(1, 20s));

  // The vehicle stands at the start, so the tracker plans, follows and keeps checking its world.
  std::atomic<bool> driving{true};
  std::thread vehicle([&] {
    auto states = h.bus().publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());
    while (driving) {
      msg::VehicleState s;
      s.header().frame_id("map");
      s.header().stamp_ns(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
      s.position().x(3);
      s.position().y(3);
      s.heading(std::atan2(32.0, 33.0));
      states.publish(s);
      std::this_thread::sleep_for(50ms);
    }
  });
  struct Join {
    std::atomic<bool>& flag;
    std::thread& thread;
    ~Join() {
      flag = false;
      thread.join();
    }
  } join{driving, vehicle};

  // 1. Only a malformed array so far: dropped on arrival, so the planner has no world and says so.
  obstacles.publish(malformedArray());
  ASSERT_TRUE(waitForLog(h, "planner", "perception/obstacles: dropping", 10s)) << h.log("planner");
  requests.publish(request(1001));
  auto answer = answerTo(paths, 1001);
  ASSERT_TRUE(answer) << h.log("planner");
  EXPECT_FALSE(answer->solved());
  EXPECT_NE(h.log("planner").find("obstacle 1 (id 2): semi-axis x is -1"), std::string::npos) << h.log("planner");

  // 2. A good array: planned around.
  obstacles.publish(goodArray());
  requests.publish(request(1002));
  answer = answerTo(paths, 1002);
  ASSERT_TRUE(answer) << h.log("planner");
  EXPECT_TRUE(answer->solved()) << h.log("planner");
  // The tracker saw the good world too: it planned and smoothed a trajectory, and now checks it against the world.
  ASSERT_TRUE(trajectories.wait(20s)) << h.log("tracker");

  // 3. Malformed again: the last good world stays in use for both.
  obstacles.publish(malformedArray());
  ASSERT_TRUE(waitForLog(h, "planner", "(2 dropped so far)", 10s)) << h.log("planner");
  requests.publish(request(1003));
  answer = answerTo(paths, 1003);
  ASSERT_TRUE(answer) << h.log("planner");
  EXPECT_TRUE(answer->solved()) << h.log("planner");
  ASSERT_TRUE(waitForLog(h, "tracker", "(2 dropped so far)", 10s)) << h.log("tracker");
  std::this_thread::sleep_for(1s);  // ten world checks by the tracker with the malformed array around

  EXPECT_TRUE(h.running("planner")) << h.log("planner");
  EXPECT_TRUE(h.running("tracker")) << h.log("tracker");
  EXPECT_EQ(h.log("planner").find("threw"), std::string::npos) << h.log("planner");
}

// A map/octomap whose bytes are no octree is dropped by a planner on world=map; it keeps answering.
void plannerDropsAMapThatIsNoOctree() {
  harness::Harness h(kDomain);
  h.startReady({.name = "planner", .command = "ddsnav-planner", .params = {{"scenario", kScenario}, {"world", "map"}}});
  auto maps = h.bus().publisher<msg::OccupancyMap>("map/octomap", bus::Qos::state());
  auto requests = h.bus().publisher<msg::PlanRequest>("planning/request", bus::Qos::commands());
  auto paths = h.bus().inbox<msg::Path>("planning/path", bus::Qos::state());
  ASSERT_TRUE(maps.waitForSubscribers(1, 20s));
  ASSERT_TRUE(requests.waitForSubscribers(1, 20s));
  msg::OccupancyMap garbage;
  garbage.header().frame_id("map");
  garbage.resolution(0.1);
  const std::string text = "# not an octree\n";
  garbage.octree().assign(text.begin(), text.end());
  maps.publish(garbage);
  ASSERT_TRUE(waitForLog(h, "planner", "map/octomap: dropping", 10s)) << h.log("planner");
  requests.publish(request(2001));
  const auto answer = answerTo(paths, 2001);
  ASSERT_TRUE(answer) << h.log("planner");
  EXPECT_FALSE(answer->solved());
  EXPECT_NE(h.log("planner").find("not a binary OctoMap"), std::string::npos) << h.log("planner");
  EXPECT_TRUE(h.running("planner")) << h.log("planner");
}

// Nobody answers the tracker's requests (the test only listens on planning/request): after
// max_plan_attempts unanswered requests it ends with a failure naming the cause instead of asking forever.
void trackerGivesUpWhenThePlannerNeverAnswers() {
  harness::Harness h(kDomain);
  auto requests = h.bus().inbox<msg::PlanRequest>("planning/request", bus::Qos::commands());
  auto states = h.bus().publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());
  // world=scenario is there from the start; an unanswered request is re-sent after 2 * 0.5 + 2 = 3 s.
  h.startReady({.name = "tracker",
                .command = "ddsnav-tracker",
                .params = {{"scenario", kScenario}, {"world", "scenario"}, {"time_budget_s", "0.5"}, {"max_plan_attempts", "2"}}});
  ASSERT_TRUE(states.waitForSubscribers(1, 20s));
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (h.running("tracker") && std::chrono::steady_clock::now() < deadline) {
    msg::VehicleState s;
    s.header().frame_id("map");
    s.position().x(3);
    s.position().y(3);
    states.publish(s);
    std::this_thread::sleep_for(50ms);
  }
  const bool ended_by_itself = !h.running("tracker");
  const int status = h.stop("tracker");
  const std::string log = h.log("tracker");
  ASSERT_TRUE(ended_by_itself && WIFEXITED(status)) << "still running after 30 s\n" << log;
  EXPECT_EQ(WEXITSTATUS(status), 1) << log;
  EXPECT_NE(log.find("no answer from the planner (planning/path) after 2 attempts"), std::string::npos) << log;
  std::size_t asked = 0;
  while (requests.wait(100ms)) ++asked;
  EXPECT_EQ(asked, 2u) << log;
}

void badParametersEndTheComponentWithStatus2() {
  struct Case {
    std::string component;
    std::map<std::string, std::string> params;
    std::string named;
  };
  const std::vector<Case> cases = {
      {"mapper", {{"resolution", "0"}}, "'resolution'"},
      {"mapper", {{"prob_hit", "0.3"}}, "'prob_hit'"},
      {"tracker", {{"scenario", kScenario}, {"max_plan_attempts", "0"}}, "parameter max_plan_attempts"},
      {"tracker", {{"scenario", kScenario}, {"replan_deviation", "-1"}}, "parameter replan_deviation"},
      {"planner", {{"scenario", kScenario}, {"max_time_budget_s", "0"}}, "parameter max_time_budget_s"},
      {"planner", {{"scenario", kScenario}, {"world", "lidar"}}, "parameter world"},
      {"sim", {{"scenario", kScenario}, {"beams", "0"}}, "parameter beams"},
      {"sim", {{"scenario", kScenario}, {"command_timeout_s", "-1"}}, "parameter command_timeout_s"},
      {"perception", {{"beam_spacing_rad", "0"}}, "parameter beam_spacing_rad"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.component + ": " + c.named);
    int status = 0;
    bool ended = false;
    const auto log = runToExit(c.component, c.params, ended, status);
    ASSERT_TRUE(ended && WIFEXITED(status)) << "still running after 20 s or killed by a signal\n" << log;
    EXPECT_EQ(WEXITSTATUS(status), 2) << log;
    EXPECT_NE(log.find(c.named), std::string::npos) << log;
  }
}

}  // namespace

TEST(BadInput, ComponentsSurviveBadMessagesAndRefuseBadParameters) {
  {
    SCOPED_TRACE("bad clouds");
    perceptionAndMapperSkipBadCloudsAndKeepServing();
  }
  {
    SCOPED_TRACE("malformed obstacle arrays");
    plannerAndTrackerDropMalformedWorlds();
  }
  {
    SCOPED_TRACE("malformed map");
    plannerDropsAMapThatIsNoOctree();
  }
  {
    SCOPED_TRACE("planner never answers");
    trackerGivesUpWhenThePlannerNeverAnswers();
  }
  {
    SCOPED_TRACE("bad parameters");
    badParametersEndTheComponentWithStatus2();
  }
}
