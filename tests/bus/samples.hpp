// Filled samples of every message type, distinct per `variant`, for round-trip tests and the test peer.
#pragma once

#include <ddsnav/msg/messages.hpp>

#include <cstdint>
#include <string>
#include <tuple>

namespace ddsnav::test {

inline msg::Vec3 vec3(double x, double y, double z) {
  msg::Vec3 v;
  v.x(x);
  v.y(y);
  v.z(z);
  return v;
}

inline msg::Header header(int variant) {
  msg::Header h;
  h.stamp_ns(1'700'000'000'000'000'000LL + variant);
  h.frame_id("map");
  return h;
}

template <class T>
T makeSample(int variant);

// `points` lets tests build large clouds (8 MB = 699051 points of 12 bytes).
inline msg::PointCloud makeCloud(int variant, std::size_t points, bool intensity = true) {
  msg::PointCloud c;
  c.header(header(variant));
  c.sensor_origin(vec3(1.5, -2.0, 0.75));
  c.xyz().resize(points * 3);
  for (std::size_t i = 0; i < c.xyz().size(); ++i) c.xyz()[i] = static_cast<float>(i % 1000) * 0.01f + variant;
  if (intensity) {
    c.intensity().resize(points);
    for (std::size_t i = 0; i < points; ++i) c.intensity()[i] = static_cast<float>(i % 7);
  }
  return c;
}

template <>
inline msg::PointCloud makeSample<msg::PointCloud>(int variant) {
  return makeCloud(variant, 100 + variant);
}

template <>
inline msg::VehicleState makeSample<msg::VehicleState>(int variant) {
  msg::VehicleState s;
  s.header(header(variant));
  s.position(vec3(variant, 2.0, 0.0));
  s.heading(0.25 + variant);
  s.velocity(vec3(1.0, 0.5, 0.0));
  s.yaw_rate(-0.1);
  return s;
}

template <>
inline msg::VelocityCommand makeSample<msg::VelocityCommand>(int variant) {
  msg::VelocityCommand c;
  c.stamp_ns(42 + variant);
  c.v(1.25);
  c.omega(-0.5 * variant);
  c.vz(0.1);
  return c;
}

inline msg::ObstacleEllipsoid ellipsoid(int id) {
  msg::ObstacleEllipsoid e;
  e.id(static_cast<std::uint32_t>(id));
  e.centre(vec3(3.0 * id, 4.0, 0.0));
  e.semi_axes(vec3(1.0, 0.5, 0.0));
  msg::Quaternion q;
  q.z(0.3826834);
  q.w(0.9238795);
  e.orientation(q);
  e.covariance({0.2, 0.01, 0, 0.01, 0.05, 0, 0, 0, 0});
  e.probability_bound(0.99);
  e.point_count(57 + id);
  return e;
}

template <>
inline msg::ObstacleEllipsoid makeSample<msg::ObstacleEllipsoid>(int variant) {
  return ellipsoid(variant);
}

template <>
inline msg::ObstacleArray makeSample<msg::ObstacleArray>(int variant) {
  msg::ObstacleArray a;
  a.header(header(variant));
  a.planar(true);
  for (int i = 0; i < 3 + variant; ++i) a.obstacles().push_back(ellipsoid(i));
  return a;
}

template <>
inline msg::OccupancyMap makeSample<msg::OccupancyMap>(int variant) {
  msg::OccupancyMap m;
  m.header(header(variant));
  m.resolution(0.1);
  m.bounds_min(vec3(-10, -10, 0));
  m.bounds_max(vec3(10, 10, 3));
  m.octree().resize(5000 + variant);
  for (std::size_t i = 0; i < m.octree().size(); ++i) m.octree()[i] = static_cast<std::uint8_t>(i * 31);
  return m;
}

inline msg::PathState pathState(double x, double y, double heading) {
  msg::PathState s;
  s.x(x);
  s.y(y);
  s.z(0.0);
  s.heading(heading);
  return s;
}

template <>
inline msg::PlanRequest makeSample<msg::PlanRequest>(int variant) {
  msg::PlanRequest r;
  r.header(header(variant));
  r.request_id(7 + variant);
  r.start(pathState(0, 0, 0.5));
  r.goal(pathState(20, 15, 0));
  r.goal_radius(1.0);
  r.planner("lirrt");
  r.time_budget_s(2.5);
  r.seed(123456789012ULL + variant);
  return r;
}

template <>
inline msg::Path makeSample<msg::Path>(int variant) {
  msg::Path p;
  p.header(header(variant));
  p.request_id(7 + variant);
  p.planner("rrtstar");
  p.solved(true);
  p.exact(true);
  for (int i = 0; i < 10 + variant; ++i) p.states().push_back(pathState(i, 0.5 * i, 0.1 * i));
  p.cost(12.5);
  msg::PlannerStatistics s;
  s.iterations(1000);
  s.vertices(400);
  s.validity_checks(5000);
  s.rewires(30);
  s.time_s(0.25);
  s.time_to_first_solution_s(0.05);
  s.iterations_to_first_solution(200);
  s.first_directive_connect(-1);
  s.first_glance_connect(3);
  s.pous(0.4);
  s.por(0.075);
  s.coverage(0.6);
  s.growth(0.2);
  p.statistics(s);
  return p;
}

template <>
inline msg::Trajectory makeSample<msg::Trajectory>(int variant) {
  msg::Trajectory t;
  t.header(header(variant));
  t.request_id(7 + variant);
  for (int i = 0; i < 20 + variant; ++i) {
    msg::TrajectorySample s;
    s.time_from_start_ns(i * 100'000'000LL);
    s.position(vec3(0.1 * i, 0.0, 0.0));
    s.heading(0.01 * i);
    s.velocity(vec3(1.0, 0.0, 0.0));
    s.yaw_rate(0.1);
    t.samples().push_back(s);
  }
  return t;
}

template <>
inline msg::TrackingStatus makeSample<msg::TrackingStatus>(int variant) {
  msg::TrackingStatus s;
  s.stamp_ns(99 + variant);
  s.request_id(7);
  s.cross_track_error(-0.12);
  s.along_track_error(0.3);
  s.mean_cross_track_error(0.08);
  s.max_cross_track_error(0.2 + variant);
  s.progress(0.5);
  s.goal_reached(variant % 2 == 1);
  return s;
}

template <>
inline msg::ComponentStatus makeSample<msg::ComponentStatus>(int variant) {
  msg::ComponentStatus s;
  s.name("component-" + std::to_string(variant));
  s.stamp_ns(5 + variant);
  s.state(msg::LIFECYCLE_READY);
  s.ready(true);
  s.pid(4242 + variant);
  s.detail("serving");
  return s;
}

template <>
inline msg::Clock makeSample<msg::Clock>(int variant) {
  msg::Clock c;
  c.stamp_ns(1'000'000'000LL * variant + 17);
  return c;
}

template <>
inline msg::Progress makeSample<msg::Progress>(int variant) {
  msg::Progress p;
  p.name("component-" + std::to_string(variant));
  p.stamp_ns(2'000'000'000LL * variant + 3);
  return p;
}

// Every top-level message type (the ones with a topic).
using AllMessages = std::tuple<msg::PointCloud, msg::VehicleState, msg::VelocityCommand, msg::ObstacleEllipsoid,
                               msg::ObstacleArray, msg::OccupancyMap, msg::PlanRequest, msg::Path, msg::Trajectory,
                               msg::TrackingStatus, msg::ComponentStatus, msg::Clock, msg::Progress>;

template <class F>
void forEachMessageType(F&& f) {
  std::apply([&](auto... sample) { (f(sample), ...); }, AllMessages{});
}

template <class T>
std::string shortName() {
  std::string_view n = msg::type_support<T>().name;
  return std::string(n.substr(n.rfind(':') + 1));
}

}  // namespace ddsnav::test
