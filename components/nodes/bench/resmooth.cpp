// ddsnav resmooth: one plan of a recorded mission smoothed again, offline, on the world the tracker had.
//
//   ddsnav resmooth --recording run.mcap --scenario S.yaml --request 8
//
// From the recording: the planner's answer to request N (planning/path), the request (start, heading), the newest
// map/octomap, perception/obstacles and vehicle/state received before that answer. The world is the tracker's as the
// demo launch file configures it (fused, optimistic, solid below the surface with a 1 m margin, the 3-D sensor view
// from the path's start) and, first, its preferred world (the 3 m wider margin) as the tracker tries it. Prints what
// the smoother did on each, and for a refusal near a point what blocks that point: the map, an ellipse or the space
// the lidar's fan does not see. Not reproduced: the lead-in along the flown trajectory and the braking stretch (the
// start's speed is the vehicle's at the time unless --speed is given); in 2-D the preferred world (unknown_margin_m)
// and the clipping of ellipses to the map: 2-D plans are smoothed on the plain fused world only.
#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"
#include "ddsnav/nodes/world_source.hpp"
#include "recorded_sample.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/record/mcap.hpp>
#include <ddsnav/tracker/smoother.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <regex>
#include <string>

using namespace ddsnav;

namespace {

struct Recorded {
  std::optional<msg::PlanRequest> request;
  std::optional<msg::Path> path;
  std::optional<msg::OccupancyMap> map;
  std::optional<msg::ObstacleArray> obstacles;
  std::optional<msg::VehicleState> vehicle;
};

// The inputs the tracker had when the answer to `request_id` arrived (messages come in receive order).
Recorded findInputs(const std::string& file, std::uint32_t request_id) {
  Recorded r;
  record::McapReader reader(file);
  reader.forEachMessage(
      [&](const record::MessageView& v) {
        const std::string& topic = v.channel->topic;
        if (topic == "map/octomap") {
          if (auto m = bench::decodeRecorded<msg::OccupancyMap>(v)) r.map = std::move(*m);
        } else if (topic == "perception/obstacles") {
          if (auto m = bench::decodeRecorded<msg::ObstacleArray>(v)) r.obstacles = std::move(*m);
        } else if (topic == "vehicle/state") {
          if (auto m = bench::decodeRecorded<msg::VehicleState>(v)) r.vehicle = std::move(*m);
        } else if (topic == "planning/request") {
          if (auto m = bench::decodeRecorded<msg::PlanRequest>(v); m && m->request_id() == request_id) r.request = std::move(*m);
        } else if (topic == "planning/path") {
          if (auto m = bench::decodeRecorded<msg::Path>(v); m && m->request_id() == request_id) {
            r.path = std::move(*m);
            return false;
          }
        }
        return true;
      },
      [](const record::DamagedChunk&) {});
  return r;
}

std::string point(const planner::Vec3& p) {
  char text[64];
  std::snprintf(text, sizeof text, "(%.2f, %.2f, %.2f)", p.x(), p.y(), p.z());
  return text;
}

// What blocks `p`: each source on its own (`map`: none before the first map).
void explain(const planner::Vec3& p, const planner::CollisionWorld* map, const planner::CollisionWorld& ellipses,
             const std::optional<planner::SensorView>& view) {
  std::string map_says = "no map";
  if (map) {
    char text[64];
    std::snprintf(text, sizeof text, "map %s (clearance %.2f m)", map->isFree(p) ? "free" : "BLOCKED", map->clearance(p));
    map_says = text;
  }
  std::printf("  at %s: %s, ellipses %s, %s\n", point(p).c_str(), map_says.c_str(), ellipses.isFree(p) ? "free" : "BLOCKED",
              !view ? "no sensor view" : view->unseen(p) ? "UNSEEN above/below the lidar's fan" : "seen by the fan");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ddsnav resmooth: smooth one recorded plan again on the tracker's world, and say what blocks it"};
  std::string recording, scenario_file;
  std::uint32_t request_id = 0;
  std::optional<double> speed;
  double preferred_margin = 3.0;
  bool no_view = false, print_path = false, print_slow = false;
  double clearance_target = tracker::SmootherConfig::kTrackerClearanceTargetM;
  app.add_option("--recording", recording, "the mission's MCAP recording (bench-mission --keep-recordings)")->required();
  app.add_option("--scenario", scenario_file, "its scenario file")->required();
  app.add_option("--request", request_id, "the request id whose answer is smoothed")->required();
  app.add_option("--speed", speed, "the start's speed, m/s (default: the vehicle's then)")->check(CLI::Range(0.0, 1000.0));
  app.add_option("--preferred-surface-margin", preferred_margin, "the preferred world's wider margin, m (0: none)")->check(CLI::Range(0.0, 100.0));
  app.add_flag("--no-view", no_view, "leave out the sensor view (3-D)");
  app.add_flag("--print-path", print_path, "print the path's states and which of them the world blocks");
  app.add_option("--clearance-target", clearance_target, "the tracker's clearance_target, m")->capture_default_str()->check(CLI::Range(0.0, 100.0));
  app.add_flag("--print-slow", print_slow, "print the smoothed trajectory's stretches below a quarter of its top speed");
  CLI11_PARSE(app, argc, argv);

  try {
    const planner::Scenario scenario = planner::loadScenario(scenario_file);
    if (!scenario.vehicle) throw std::invalid_argument("the scenario has no vehicle block");
    const Recorded in = findInputs(recording, request_id);
    if (!in.path) throw std::invalid_argument("no planning/path answers request " + std::to_string(request_id));
    if (!in.request) throw std::invalid_argument("planning/request " + std::to_string(request_id) + " is not recorded");
    // Recorded numbers are checked as the tracker checks them on arrival.
    if (const auto error = nodes::checkPath(*in.path); !error.empty()) throw std::invalid_argument("the recorded path: " + error);
    if (!std::isfinite(in.request->start().heading())) throw std::invalid_argument("the recorded request's start heading is not finite");
    if (in.vehicle)
      if (const auto error = nodes::checkVehicleState(*in.vehicle, ""); !error.empty())
        throw std::invalid_argument("the recorded vehicle/state: " + error);
    const auto states = nodes::statesOf(*in.path);
    if (states.empty()) throw std::invalid_argument("the answer has no states");
    std::printf("request %u (%s): %zu states from %s\n", request_id, in.request->reason().c_str(), states.size(),
                point(states.front().position).c_str());

    const nodes::WorldParameters defaults;
    planner::OctoMapWorldOptions options;
    options.solid_below_surface = defaults.solid_below_surface;
    options.surface_margin_m = defaults.surface_margin_m;
    if (scenario.dimensions == 3 && preferred_margin > options.surface_margin_m) options.wider_surface_margin_m = preferred_margin;
    std::shared_ptr<const planner::CollisionWorld> map_world;
    if (in.map) {
      auto built = nodes::buildOccupancyMap(*in.map, "map", scenario, options);
      if (!built.error.empty()) throw std::invalid_argument("the recorded map: " + built.error);
      map_world = std::move(built.world);
    } else {
      std::printf("no map before the answer: the world is the ellipses alone\n");
    }
    auto ellipses = in.obstacles ? nodes::toEllipsoidObstacles(*in.obstacles) : std::vector<planner::EllipsoidObstacle>{};
    nodes::clearFootprint(ellipses, states.front().position, scenario.robot_radius, scenario.dimensions);
    auto ellipse_world = [&] {
      return planner::makeEllipsoidWorld(scenario.dimensions, scenario.bounds_min, scenario.bounds_max, scenario.robot_radius, ellipses);
    };
    std::optional<planner::SensorView> view;
    if (scenario.dimensions == 3 && !no_view && map_world)
      view = bench::recordedSensorView(scenario, states.front().position, scenario.goal, scenario.goal_radius);
    auto worldOn = [&](std::shared_ptr<const planner::CollisionWorld> map) { return bench::recordedFusedWorld(scenario, std::move(map), ellipses, view); };

    tracker::SmootherConfig config;
    config.clearance_target = clearance_target;  // the tracker's parameter (its default, not the library's)
    config.repair_distance = scenario.robot_radius;
    config.short_braking_m = 2.0 * scenario.robot_radius;
    config.initial_heading = in.request->start().heading();
    config.initial_speed = speed.value_or(in.vehicle ? std::hypot(in.vehicle->velocity().x(), in.vehicle->velocity().y()) : 0.0);
    config.initial_vz = in.vehicle && scenario.dimensions == 3 ? in.vehicle->velocity().z() : 0.0;
    std::printf("start speed %.2f m/s (vz %.2f), heading %.1f deg\n", config.initial_speed, config.initial_vz,
                *config.initial_heading * 180.0 / std::numbers::pi);

    auto attempt = [&](const char* name, const planner::CollisionWorld& world) {
      if (print_path) {
        std::printf("%s: the path\n", name);
        for (std::size_t i = 0; i < states.size(); ++i) {
          const auto& p = states[i].position;
          const bool edge_free = i == 0 || world.isSegmentFree(states[i - 1].position, p);
          std::printf("  %3zu %s clearance %.2f%s%s\n", i, point(p).c_str(), world.clearance(p), world.isFree(p) ? "" : " BLOCKED",
                      edge_free ? "" : " (edge to it blocked)");
        }
      }
      try {
        const auto t = tracker::smoothPath(states, world, *scenario.vehicle, config);
        std::printf("%s: smoothed: %.1f m, %.1f s, min clearance %.2f m, %d rounds of corner tightening, %.1f s slow, max curvature %.2f 1/m%s%s\n", name, t.report.length, t.report.duration,
                    t.report.min_clearance, t.report.fallback_iterations, t.report.slow_s, t.report.max_curvature, t.report.lead_in_failure.empty() ? "" : "; lead-in: ", t.report.lead_in_failure.c_str());
        if (print_slow) {
          // Each stretch below a quarter of the top speed: where, how long, and the sharpest curvature in it (a speed
          // capped by omega_max / curvature, or a start or stop).
          std::printf("  waypoints: %zu in, %zu repaired, %zu corners after shortcutting\n", t.report.input_waypoints,
                      t.report.repaired_waypoints, t.report.shortcut_waypoints);
          const double slow = 0.25 * scenario.vehicle->v_max;
          for (std::size_t i = 0; i < t.samples.size();) {
            if (t.samples[i].speed >= slow) { ++i; continue; }
            std::size_t j = i, sharpest = i;
            for (; j < t.samples.size() && t.samples[j].speed < slow; ++j)
              if (std::abs(t.samples[j].curvature) > std::abs(t.samples[sharpest].curvature)) sharpest = j;
            const auto& a = t.samples[i];
            const auto& b = t.samples[j - 1];
            std::printf("  slow %.1f-%.1f s (%.1f m), %s to %s, least %.2f m/s, sharpest curvature %.2f 1/m at %s\n", a.time, b.time,
                        b.arc_length - a.arc_length, point(a.position).c_str(), point(b.position).c_str(),
                        std::min_element(t.samples.begin() + i, t.samples.begin() + j, [](const auto& x, const auto& y) { return x.speed < y.speed; })->speed,
                        t.samples[sharpest].curvature, point(t.samples[sharpest].position).c_str());
            i = j;
          }
        }
        return true;
      } catch (const std::exception& e) {
        std::printf("%s: refused: %s\n", name, e.what());
        static const std::regex near(R"(near \(([-0-9.e]+), ([-0-9.e]+)(?:, ([-0-9.e]+))?\))");
        std::cmatch m;
        if (std::regex_search(e.what(), m, near)) {
          const planner::Vec3 p(std::stod(m[1]), std::stod(m[2]), m[3].matched ? std::stod(m[3]) : 0.0);
          const auto e_world = ellipse_world();
          explain(p, map_world.get(), *e_world, view);
          double nearest = std::numeric_limits<double>::infinity();
          std::size_t at = 0;
          for (std::size_t i = 0; i < states.size(); ++i)
            if (const double d = (states[i].position - p).norm(); d < nearest) nearest = d, at = i;
          std::printf("  nearest path state %zu of %zu, %.2f m away; %.1f m from the start\n", at, states.size(), nearest,
                      (p - states.front().position).norm());
        }
        return false;
      }
    };
    if (map_world && options.wider_surface_margin_m > 0) {
      const auto preferred = worldOn(planner::makeWiderMarginView(map_world));
      attempt("preferred world (wider margin)", *preferred);
    }
    const auto plain = worldOn(map_world);
    return attempt("plain world", *plain) ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddsnav resmooth: %s\n", e.what());
    return 2;
  }
}
