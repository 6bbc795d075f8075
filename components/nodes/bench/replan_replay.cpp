// ddsnav replan-replay: a recorded mission's plan requests searched again, offline, on the planner's plain world as it
// was, with several seeds and two planner settings side by side.
//
//   ddsnav-replan-replay --recording run.mcap --scenario S.yaml [--reason trajectory_blocked] [--seeds 10]
//                        [--previous-path-bias 0.3] [--time-limit 1]
//
// For each request with the reason asked for (its reason's first word): the newest map/octomap and
// perception/obstacles received before it, built as the planner builds its plain world (fused, optimistic, solid
// below the surface with the 1 m margin, the 3-D sensor view from the start, the ellipses cleared around the start),
// the start moved out of the map's voxels as the planner moves it, and the path last answered before it (the
// planner's previous_path_bias guide). Each request is searched with the request's planner on seeds 1..N, without a
// guide and with the previous path as a guide; prints per request and over all the iterations and time to the first
// solution (median, p90, max) of each arm. Not reproduced: the preferred world (the 3 m wider margin) tried before
// the plain map, the search's CPU share in a mission, and its restarts.
#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"
#include "ddsnav/nodes/world_source.hpp"
#include "recorded_sample.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/coarse_route.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/planners.hpp>
#include <ddsnav/record/mcap.hpp>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

using namespace ddsnav;

namespace {

// One request as the planner met it: the newest map and obstacles before it, and the path answered last before it.
struct Replayed {
  msg::PlanRequest request;
  std::optional<msg::OccupancyMap> map;
  std::optional<msg::ObstacleArray> obstacles;
  std::vector<planner::Vec3> previous_path;
};

std::vector<Replayed> findRequests(const std::string& file, const std::string& reason, std::size_t max_requests) {
  std::vector<Replayed> out;
  std::optional<msg::OccupancyMap> map;
  std::optional<msg::ObstacleArray> obstacles;
  std::vector<planner::Vec3> last_path;
  std::map<std::uint32_t, bool> seen;  // a repeated request (resent while unanswered) is replayed once
  std::map<std::uint32_t, bool> shorter_route;
  record::McapReader reader(file);
  reader.forEachMessage(
      [&](const record::MessageView& v) {
        const std::string& topic = v.channel->topic;
        if (topic == "map/octomap") {
          if (auto m = bench::decodeRecorded<msg::OccupancyMap>(v)) map = std::move(*m);
        } else if (topic == "perception/obstacles") {
          if (auto m = bench::decodeRecorded<msg::ObstacleArray>(v)) obstacles = std::move(*m);
        } else if (topic == "planning/path") {
          // As the planner remembers its answers (previous_path_bias): not those to a shorter route's request.
          if (auto m = bench::decodeRecorded<msg::Path>(v); m && m->solved() && !shorter_route[m->request_id()] && nodes::checkPath(*m).empty()) {
            last_path.clear();
            for (const auto& s : nodes::statesOf(*m)) last_path.push_back(s.position);
          }
        } else if (topic == "planning/request") {
          auto m = bench::decodeRecorded<msg::PlanRequest>(v);
          if (!m || seen[m->request_id()]) return true;
          seen[m->request_id()] = true;
          shorter_route[m->request_id()] = nodes::asksForAShorterRoute(*m);
          const std::string first_word = m->reason().substr(0, m->reason().find_first_of(": "));
          if (reason.empty() || first_word == reason) out.push_back({*m, map, obstacles, last_path});
        }
        return out.size() < max_requests;
      },
      [](const record::DamagedChunk&) {});
  return out;
}

struct Arm {
  std::vector<double> iterations, ms;
  int failed = 0;
};

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

void print(const char* name, const Arm& arm) {
  if (arm.iterations.empty()) {
    std::printf("  %-10s no solution (unsolved %d)\n", name, arm.failed);
    return;
  }
  std::printf("  %-10s iterations median %6.0f p90 %6.0f max %6.0f | ms median %6.1f p90 %6.1f max %6.1f | unsolved %d of %zu\n", name,
              quantile(arm.iterations, 0.5), quantile(arm.iterations, 0.9), quantile(arm.iterations, 1.0), quantile(arm.ms, 0.5),
              quantile(arm.ms, 0.9), quantile(arm.ms, 1.0), arm.failed, arm.iterations.size() + static_cast<std::size_t>(arm.failed));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ddsnav replan-replay: a recorded mission's plan requests searched again on the planner's plain world, without and with the last path as a guide"};
  std::string recording, scenario_file, reason = "trajectory_blocked";
  int seeds = 10;
  double bias = 0.3, time_limit = 1.0;
  std::size_t max_requests = 1000;
  app.add_option("--recording", recording, "the mission's MCAP recording (bench-mission --keep-recordings)")->required()->check(CLI::ExistingFile);
  app.add_option("--scenario", scenario_file, "its scenario file")->required()->check(CLI::ExistingFile);
  app.add_option("--reason", reason, "replay the requests whose reason starts with this word (empty: all)")->capture_default_str();
  app.add_option("--seeds", seeds, "seeds 1..N per request and arm")->capture_default_str()->check(CLI::Range(1, 1000));
  app.add_option("--previous-path-bias", bias, "the guided arm's share of samples near the last path")->capture_default_str()->check(CLI::Range(0.0, 1.0));
  app.add_option("--time-limit", time_limit, "seconds per search")->capture_default_str()->check(CLI::Range(1e-3, 60.0));
  app.add_option("--max-requests", max_requests, "replay at most this many requests")->capture_default_str()->check(CLI::Range(1, 100000));
  CLI11_PARSE(app, argc, argv);

  try {
    const planner::Scenario scenario = planner::loadScenario(scenario_file);
    if (!scenario.vehicle) throw std::invalid_argument("the scenario has no vehicle block");
    const auto requests = findRequests(recording, reason, max_requests);
    std::printf("%zu request(s) with reason '%s' in %s\n", requests.size(), reason.c_str(), recording.c_str());
    const nodes::WorldParameters defaults;
    planner::OctoMapWorldOptions options;
    options.solid_below_surface = defaults.solid_below_surface;
    options.surface_margin_m = scenario.dimensions == 3 ? defaults.surface_margin_m : 0.0;
    Arm all_plain, all_guided;
    for (const Replayed& r : requests) {
      if (const auto error = nodes::checkPlanRequest(r.request, scenario, "map"); !error.empty()) {
        std::printf("request %u: refused as the planner refuses it: %s\n", r.request.request_id(), error.c_str());
        continue;
      }
      const planner::State start = nodes::fromMsg(r.request.start());
      std::shared_ptr<const planner::CollisionWorld> map_world;
      if (r.map) {
        auto built = nodes::buildOccupancyMap(*r.map, "map", scenario, options);
        if (!built.error.empty()) throw std::invalid_argument("the recorded map: " + built.error);
        map_world = std::move(built.world);
      }
      auto ellipses = r.obstacles ? nodes::toEllipsoidObstacles(*r.obstacles) : std::vector<planner::EllipsoidObstacle>{};
      nodes::clearFootprint(ellipses, start.position, scenario.robot_radius, scenario.dimensions);
      std::optional<planner::SensorView> view;
      if (map_world && scenario.dimensions == 3 && defaults.sensor_view)
        view = bench::recordedSensorView(scenario, start.position, nodes::fromMsg(r.request.goal()).position, r.request.goal_radius());
      const auto world = bench::recordedFusedWorld(scenario, map_world, ellipses, view);
      planner::PlanProblem problem;
      problem.world = world.get();
      problem.start = start;
      // Moved out of the map's voxels as the planner moves it.
      if (const auto moved = nodes::plannerStartOutOfCollision(*world, start.position, scenario.robot_radius, options.surface_margin_m))
        problem.start.position = *moved;
      problem.goal = nodes::fromMsg(r.request.goal()).position;
      problem.goal_radius = r.request.goal_radius();
      problem.vehicle = scenario.vehicle;
      problem.kinodynamic = true;
      problem.time_limit_s = time_limit;
      planner::PlanProblem guided = problem;
      planner::guideAlongPath(guided, r.previous_path, bias);
      Arm plain, with_guide;
      for (int seed = 1; seed <= seeds; ++seed) {
        for (auto [p, arm] : {std::pair{&problem, &plain}, std::pair{&guided, &with_guide}}) {
          p->seed = static_cast<std::uint64_t>(seed);
          const auto result = planner::makePlanner(r.request.planner())->solve(*p);
          if (!result.solved) {
            ++arm->failed;
            continue;
          }
          arm->iterations.push_back(static_cast<double>(result.stats.iterations_to_first_solution));
          arm->ms.push_back(1e3 * result.stats.time_to_first_solution_s);
        }
      }
      std::printf("request %u (%s) from (%.1f, %.1f, %.1f), %zu guide points of a %zu-corner path:\n", r.request.request_id(),
                  r.request.reason().substr(0, 60).c_str(), start.position.x(), start.position.y(), start.position.z(), guided.guide.size(),
                  r.previous_path.size());
      print("plain", plain);
      print("guided", with_guide);
      for (auto [from, to] : {std::pair{&plain, &all_plain}, std::pair{&with_guide, &all_guided}}) {
        to->iterations.insert(to->iterations.end(), from->iterations.begin(), from->iterations.end());
        to->ms.insert(to->ms.end(), from->ms.begin(), from->ms.end());
        to->failed += from->failed;
      }
    }
    std::printf("all requests:\n");
    print("plain", all_plain);
    print("guided", all_guided);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddsnav replan-replay: %s\n", e.what());
    return 2;
  }
}
