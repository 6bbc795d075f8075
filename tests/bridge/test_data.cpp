// Inputs for the bridge and export tests: real ddsnav messages, serialized by the generated classes.
//   bridge_test_data recording OUT.mcap     a small recording of every topic kind with a Foxglove view
//   bridge_test_data publish --domain N     publishes perception/obstacles (latched) and vehicle/state at
//                                           20 Hz until SIGTERM; prints "ready" once its writers exist
#include <ddsnav/bus/bus.hpp>
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/mcap.hpp>
#include <ddsnav/record/schemas.hpp>

#include <octomap/OcTree.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <thread>

using namespace ddsnav;

namespace {

volatile sig_atomic_t stop_requested = 0;

msg::Vec3 v3(double x, double y, double z) {
  msg::Vec3 v;
  v.x(x), v.y(y), v.z(z);
  return v;
}

// The obstacles both tests look for: an ellipse (id 7) at (4, 5) with semi-axes 2 x 1, yaw 0.5, p 0.99.
msg::ObstacleArray obstacles(std::int64_t stamp) {
  msg::ObstacleArray a;
  a.header().stamp_ns(stamp);
  a.header().frame_id("map");
  a.planar(true);
  msg::ObstacleEllipsoid o;
  o.id(7);
  o.centre(v3(4, 5, 0));
  o.semi_axes(v3(2, 1, 0));
  o.orientation().z(std::sin(0.25));
  o.orientation().w(std::cos(0.25));
  o.probability_bound(0.99);
  o.point_count(42);
  a.obstacles().push_back(o);
  return a;
}

msg::VehicleState vehicle(int i, std::int64_t stamp) {
  msg::VehicleState s;
  s.header().stamp_ns(stamp);
  s.header().frame_id("map");
  s.position(v3(3 + 0.1 * i, 3 + 0.05 * i, 0));
  s.heading(0.46);
  s.velocity(v3(1, 0.5, 0));
  return s;
}


int recording(const std::string& file) {
  record::McapWriter w(file);
  std::map<std::string, std::uint16_t> channels;
  auto write = [&](const std::string& topic, const auto& sample, std::int64_t t) {
    using T = std::decay_t<decltype(sample)>;
    const std::string type(msg::type_support<T>().name);
    auto it = channels.find(topic);
    if (it == channels.end()) {
      const auto schema = w.addSchema(type, "omgidl", *record::idlSchemaFor(type));
      it = channels.emplace(topic, w.addChannel(schema, topic, "cdr", {{"keyed", "false"}})).first;
    }
    w.write(it->second, t, t, msg::serializeToBytes(sample));
  };
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  msg::ComponentStatus status;
  status.name("sim");
  status.state(msg::LifecycleState::LIFECYCLE_READY);
  status.ready(true);
  write("system/status", status, t0);
  for (int i = 0; i < 60; ++i) {
    const std::int64_t t = t0 + std::int64_t{i} * 50'000'000;  // 64-bit: 59 * 5e7 overflows int
    write("vehicle/state", vehicle(i, t), t);
    if (i % 10 == 0) {
      msg::PointCloud c;
      c.header().stamp_ns(t);
      c.header().frame_id("map");
      c.sensor_origin(vehicle(i, t).position());
      for (int k = 0; k < 360; ++k) {
        c.xyz().push_back(static_cast<float>(3 + 10 * std::cos(k * M_PI / 180)));
        c.xyz().push_back(static_cast<float>(3 + 10 * std::sin(k * M_PI / 180)));
        c.xyz().push_back(0.f);
      }
      write("sensors/points", c, t);
      write("perception/obstacles", obstacles(t), t);
    }
  }
  msg::Path path;
  path.header().stamp_ns(t0 + 1);
  path.header().frame_id("map");
  path.planner("gart");
  path.solved(true);
  path.exact(true);
  for (int k = 0; k <= 4; ++k) {
    msg::PathState s;
    s.x(3 + 8 * k), s.y(3 + 8 * k);
    path.states().push_back(s);
  }
  path.cost(45.2);
  write("planning/path", path, t0 + 1);
  msg::Path failed = path;
  failed.solved(false);
  failed.states({});
  failed.failure("no path within the time budget");
  write("planning/path", failed, t0 + 2);
  msg::Trajectory tr;
  tr.header().stamp_ns(t0 + 3);
  tr.header().frame_id("map");
  for (int k = 0; k < 30; ++k) {
    msg::TrajectorySample s;
    s.time_from_start_ns(k * 100'000'000LL);
    s.position(v3(3 + k, 3 + k, 0));
    tr.samples().push_back(s);
  }
  write("control/trajectory", tr, t0 + 3);
  octomap::OcTree tree(0.5);
  for (int k = 0; k < 20; ++k) tree.updateNode(octomap::point3d(10.25f, 0.25f + 0.5f * k, 0.25f), true);
  std::ostringstream bt;
  tree.writeBinary(bt);
  msg::OccupancyMap map;
  map.header().stamp_ns(t0 + 4);
  map.header().frame_id("map");
  map.resolution(0.5);
  map.bounds_min(v3(0, 0, 0));
  map.bounds_max(v3(12, 12, 1));
  const std::string bytes = bt.str();
  map.octree().assign(bytes.begin(), bytes.end());
  write("map/octomap", map, t0 + 60 * 50'000'000LL);
  w.close();
  return 0;
}

int publish(int domain, const std::string& vendor) {
  struct sigaction sa{};
  sa.sa_handler = [](int) { stop_requested = 1; };
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  bus::Participant p({.vendor = bus::parseVendor(vendor), .domain_id = domain, .name = "bridge-test-data"});
  auto obstacles_pub = p.publisher<msg::ObstacleArray>("perception/obstacles", bus::Qos::state());
  auto vehicle_pub = p.publisher<msg::VehicleState>("vehicle/state", bus::Qos::sensorData());
  std::printf("ready\n");
  std::fflush(stdout);
  auto now = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  };
  for (int i = 0; !stop_requested; ++i) {
    if (i % 20 == 0) obstacles_pub.publish(obstacles(now()));  // once a second, latched
    vehicle_pub.publish(vehicle(i % 200, now()));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && std::strcmp(argv[1], "recording") == 0) return recording(argv[2]);
    if (argc >= 4 && std::strcmp(argv[1], "publish") == 0 && std::strcmp(argv[2], "--domain") == 0)
      return publish(std::stoi(argv[3]), argc >= 6 ? argv[5] : "fastdds");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bridge_test_data: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "usage: bridge_test_data recording OUT.mcap | publish --domain N [--dds V]\n");
  return 2;
}
