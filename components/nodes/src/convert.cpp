#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"

#include <ddsnav/mapper/occupancy_mapper.hpp>
#include <ddsnav/perception/obstacle.hpp>
#include <ddsnav/sim/range_sensor.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ddsnav::nodes {

bool sleepFor(runtime::Context& ctx, std::chrono::nanoseconds duration) {
  const auto* followed = dynamic_cast<const runtime::TopicClock*>(&ctx.clock());
  if (!followed) return sleepForWall(ctx, duration);
  using std::chrono::milliseconds;
  while (!followed->valid())
    if (ctx.waitForShutdown(milliseconds(20))) return false;
  const std::int64_t until = followed->nowNs() + duration.count();
  // The speed-up is unknown here: wake often enough for a fast clock (a slice is at most an eighth of what
  // is left in simulated time, so at speed s the overshoot is about s/8 of the rest), rarely for a slow one.
  for (std::int64_t left = until - followed->nowNs(); left > 0; left = until - followed->nowNs()) {
    const auto slice = std::clamp<std::int64_t>(left / 8 / 1'000'000, 1, 20);
    if (ctx.waitForShutdown(milliseconds(slice))) return false;
  }
  return !ctx.shutdownRequested();
}

msg::Vec3 toMsg(const Eigen::Vector3d& v) {
  msg::Vec3 out;
  out.x(v.x());
  out.y(v.y());
  out.z(v.z());
  return out;
}

Eigen::Vector3d fromMsg(const msg::Vec3& v) { return {v.x(), v.y(), v.z()}; }

namespace {
msg::Header header(std::int64_t stamp_ns) {
  msg::Header h;
  h.stamp_ns(stamp_ns);
  h.frame_id(kWorldFrame);
  return h;
}
}  // namespace

msg::PointCloud toMsg(const sim::PointCloud& cloud, std::int64_t stamp_ns) {
  msg::PointCloud out;
  out.header(header(stamp_ns));
  out.sensor_origin(toMsg(cloud.origin));
  auto& xyz = out.xyz();
  xyz.resize(cloud.points.size() * 3);
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    xyz[3 * i + 0] = cloud.points[i].x();
    xyz[3 * i + 1] = cloud.points[i].y();
    xyz[3 * i + 2] = cloud.points[i].z();
  }
  return out;
}

std::vector<Eigen::Vector3f> pointsOf(const msg::PointCloud& cloud) {
  const auto& xyz = cloud.xyz();
  std::vector<Eigen::Vector3f> points(xyz.size() / 3);
  for (size_t i = 0; i < points.size(); ++i) points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
  return points;
}

mapper::Scan toScan(const msg::PointCloud& cloud, double max_range) {
  mapper::Scan scan;
  const auto& xyz = cloud.xyz();
  scan.points.resize(xyz.size() / 3);
  for (size_t i = 0; i < scan.points.size(); ++i) scan.points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
  const auto& o = cloud.sensor_origin();
  scan.origin = {static_cast<float>(o.x()), static_cast<float>(o.y()), static_cast<float>(o.z())};
  scan.max_range = max_range;
  return scan;
}

msg::VehicleState toMsg(const tracker::VehicleState& state, std::int64_t stamp_ns) {
  msg::VehicleState out;
  out.header(header(stamp_ns));
  out.position(toMsg(state.position));
  out.heading(state.heading);
  out.velocity(toMsg({state.v * std::cos(state.heading), state.v * std::sin(state.heading), state.vz}));
  out.yaw_rate(state.omega);
  return out;
}

tracker::VehicleState fromMsg(const msg::VehicleState& state) {
  tracker::VehicleState out;
  out.position = fromMsg(state.position());
  out.heading = state.heading();
  const auto& v = state.velocity();
  out.v = std::cos(state.heading()) * v.x() + std::sin(state.heading()) * v.y();
  out.vz = v.z();
  out.omega = state.yaw_rate();
  out.time = static_cast<double>(state.header().stamp_ns()) * 1e-9;
  return out;
}

msg::VelocityCommand toMsg(const tracker::VehicleCommand& command, std::int64_t stamp_ns) {
  msg::VelocityCommand out;
  out.stamp_ns(stamp_ns);
  out.v(command.v);
  out.omega(command.omega);
  out.vz(command.vz);
  return out;
}

tracker::VehicleCommand fromMsg(const msg::VelocityCommand& command) {
  return {command.v(), command.omega(), command.vz()};
}

msg::ObstacleEllipsoid toMsg(const perception::ObstacleEllipsoid& obstacle) {
  msg::ObstacleEllipsoid out;
  out.id(static_cast<std::uint32_t>(obstacle.id));
  out.centre(toMsg(obstacle.center));
  out.semi_axes(toMsg(obstacle.semi_axes));
  msg::Quaternion q;
  q.x(obstacle.orientation.x());
  q.y(obstacle.orientation.y());
  q.z(obstacle.orientation.z());
  q.w(obstacle.orientation.w());
  out.orientation(q);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.covariance()[3 * r + c] = obstacle.covariance(r, c);
  out.probability_bound(obstacle.probability);
  out.point_count(static_cast<std::uint32_t>(obstacle.point_count));
  return out;
}

std::vector<planner::EllipsoidObstacle> toEllipsoidObstacles(const msg::ObstacleArray& array) {
  if (const auto error = checkObstacleArray(array, ""); !error.empty())
    throw std::invalid_argument("perception/obstacles: " + error);
  std::vector<planner::EllipsoidObstacle> out;
  out.reserve(array.obstacles().size());
  for (const auto& o : array.obstacles()) {
    planner::EllipsoidObstacle e;
    e.id = static_cast<int>(o.id());
    e.center = fromMsg(o.centre());
    e.semi_axes = fromMsg(o.semi_axes());
    const auto& q = o.orientation();
    Eigen::Quaterniond rotation(q.w(), q.x(), q.y(), q.z());
    e.axes = rotation.normalized().toRotationMatrix();  // non-zero norm: checked above
    out.push_back(e);
  }
  return out;
}

std::size_t clearFootprint(std::vector<planner::EllipsoidObstacle>& obstacles, const Eigen::Vector3d& position, double radius,
                           int dimensions) {
  // The planner's own ellipse test (exact distance to the ellipse), one obstacle at a time, with bounds
  // far enough away not to matter.
  const Eigen::Vector3d far = Eigen::Vector3d::Constant(1e9);
  if (dimensions == 2) {
    // A 2-D world takes each ellipse's in-plane axes, which must be orthonormal: an orientation tilted out
    // of the plane (a valid quaternion, accepted by checkObstacleArray) keeps only its heading, the rotation
    // of its first axis about z. Without this, makeEllipsoidWorld threw on such a sample here and in the
    // world built after it (found by the cdr fuzz target).
    for (planner::EllipsoidObstacle& e : obstacles) {
      const double yaw = std::atan2(e.axes(1, 0), e.axes(0, 0));
      e.axes = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    }
  }
  // One world of them all, numbered by position (not a world per obstacle: each was a grid over the far
  // bounds, and with hundreds of ellipses that was most of the tracker's CPU): those within the robot's
  // radius of the position are the ones that cover it.
  std::vector<planner::EllipsoidObstacle> numbered = obstacles;
  for (std::size_t i = 0; i < numbered.size(); ++i) numbered[i].id = static_cast<int>(i);
  const auto covering = planner::makeEllipsoidWorld(dimensions, -far, far, radius, std::move(numbered))->obstaclesNear(position, radius);
  if (covering.empty()) return 0;
  std::vector<bool> drop(obstacles.size(), false);
  for (const auto& o : covering) drop[static_cast<std::size_t>(o.id)] = true;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < obstacles.size(); ++i)
    if (!drop[i]) obstacles[kept++] = std::move(obstacles[i]);
  obstacles.resize(kept);
  return covering.size();
}

msg::PathState toMsg(const planner::State& state) {
  msg::PathState out;
  out.x(state.position.x());
  out.y(state.position.y());
  out.z(state.position.z());
  out.heading(state.heading);
  return out;
}

planner::State fromMsg(const msg::PathState& state) {
  return {{state.x(), state.y(), state.z()}, state.heading()};
}

msg::Path toMsg(const planner::PlanResult& result, std::uint32_t request_id, std::int64_t stamp_ns) {
  msg::Path out;
  out.header(header(stamp_ns));
  out.request_id(request_id);
  out.planner(result.planner);
  out.solved(result.solved);
  out.exact(result.exact);
  for (const auto& s : result.path) out.states().push_back(toMsg(s));
  out.cost(std::isfinite(result.cost) ? result.cost : -1.0);
  auto& st = out.statistics();
  const auto& in = result.stats;
  st.iterations(in.iterations);
  st.vertices(in.vertices);
  st.validity_checks(in.validity_checks);
  st.rewires(in.rewires);
  st.time_s(in.time_s);
  st.time_to_first_solution_s(in.time_to_first_solution_s);
  st.iterations_to_first_solution(in.iterations_to_first_solution);
  st.first_directive_connect(in.first_directive_connect);
  st.first_glance_connect(in.first_glance_connect);
  st.pous(in.pous);
  st.por(in.por);
  st.coverage(in.coverage);
  st.growth(in.growth);
  return out;
}

std::vector<planner::State> statesOf(const msg::Path& path) {
  std::vector<planner::State> out;
  out.reserve(path.states().size());
  for (const auto& s : path.states()) out.push_back(fromMsg(s));
  return out;
}

msg::Trajectory toMsg(const tracker::Trajectory& trajectory, std::uint32_t request_id, std::int64_t start_ns) {
  msg::Trajectory out;
  out.header(header(start_ns));
  out.request_id(request_id);
  out.samples().reserve(trajectory.samples.size());
  for (const auto& s : trajectory.samples) {
    msg::TrajectorySample m;
    m.time_from_start_ns(static_cast<std::int64_t>(std::llround(s.time * 1e9)));
    m.position(toMsg(s.position));
    m.heading(s.heading);
    m.velocity(toMsg(s.velocity()));
    m.yaw_rate(s.yaw_rate);
    out.samples().push_back(std::move(m));
  }
  return out;
}

}  // namespace ddsnav::nodes
