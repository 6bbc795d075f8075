// ddsnav-bench-tracker: how fast the smoother is, and how well the smoother + tracker + vehicle model drive
// the shipped 2-D scenarios under the simulator's nominal noise. Compares the B-spline trajectory with the
// unsmoothed polyline (stop and turn at every corner) and the feedforward+feedback controller with pure
// pursuit, in the same run. Writes one SVG per scenario and optionally a JSON summary.

#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/scenario.hpp"
#include "ddsnav/planner/svg.hpp"
#include "ddsnav/tracker/closed_loop.hpp"
#include "ddsnav/tracker/smoother.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace fs = std::filesystem;
using namespace ddsnav;
using planner::Vec3;

namespace {

struct Options {
  std::vector<std::string> scenarios;
  std::string planner = "rrtstar";
  double plan_time = 10.0;
  std::uint64_t plan_iterations = 30000;
  std::uint64_t seed = 1;
  int runs = 5;            // noise seeds per scenario and variant
  int repeats = 200;       // timing repetitions of the 200-waypoint smoothing
  double control_dt = 0.05;
  std::string svg_dir = "tracker-svg";
  std::string json_path;
  std::string timing_scenario = "demo_2d";
};

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

planner::PlanResult plan(const planner::Scenario& sc, const planner::CollisionWorld& world, const Options& opt,
                         const std::string& name, bool anytime) {
  planner::PlanProblem p = planner::problemFromScenario(sc, world);
  p.seed = opt.seed;
  p.time_limit_s = opt.plan_time;
  p.max_iterations = opt.plan_iterations;
  p.anytime = anytime;
  return planner::makePlanner(name)->solve(p);
}

// Splits the path's edges evenly until it has exactly `count` states, then nudges the interior states
// sideways by +-2 cm (alternating, only where the edges stay free) so no state is collinear and dropped.
std::vector<planner::State> densify(const std::vector<planner::State>& path, std::size_t count,
                                    const planner::CollisionWorld& world) {
  double total = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) total += (path[i].position - path[i - 1].position).norm();
  std::vector<planner::State> out{path.front()};
  const std::size_t edges = count - 1;
  std::size_t made = 0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Vec3 a = path[i - 1].position, b = path[i].position;
    const double len = (b - a).norm();
    std::size_t pieces = i + 1 == path.size() ? edges - made
                                              : std::max<std::size_t>(1, static_cast<std::size_t>(std::round(len / total * edges)));
    pieces = std::min(pieces, edges - made - (path.size() - 1 - i));
    for (std::size_t k = 1; k <= pieces; ++k) out.push_back({a + (b - a) * (double(k) / pieces), 0.0});
    made += pieces;
  }
  for (std::size_t i = 1; i + 1 < out.size(); ++i) {
    const Vec3 d = (out[i + 1].position - out[i - 1].position).normalized();
    const Vec3 n(-d.y(), d.x(), 0.0);
    const Vec3 moved = out[i].position + (i % 2 ? 0.02 : -0.02) * n;
    if (world.isSegmentFree(out[i - 1].position, moved) && world.isSegmentFree(moved, out[i + 1].position))
      out[i].position = moved;
  }
  return out;
}

struct Drive {
  double mean_cte = 0, max_cte = 0, mean_pos = 0, time = 0, max_heading_step = 0;
  std::size_t in_collision = 0;
  int reached = 0;
};

Drive drive(const tracker::Trajectory& traj, const planner::Scenario& sc, const planner::CollisionWorld& world,
            tracker::ControllerType controller, const Options& opt, std::vector<tracker::VehicleState>* track) {
  Drive d;
  for (int run = 0; run < opt.runs; ++run) {
    tracker::ClosedLoopConfig cfg;
    cfg.control_dt = opt.control_dt;
    cfg.vehicle.limits = *sc.vehicle;
    cfg.vehicle.dimensions = sc.dimensions;
    cfg.vehicle.noise = tracker::VehicleNoise::nominal(1000 + run);
    cfg.tracker.controller = controller;
    const auto r = tracker::runClosedLoop(traj, cfg, &world);
    d.mean_cte += r.status.mean_cross_track_error / opt.runs;
    d.mean_pos += r.status.mean_position_error / opt.runs;
    d.time += r.time / opt.runs;
    d.max_cte = std::max(d.max_cte, r.status.max_cross_track_error);
    d.max_heading_step = std::max(d.max_heading_step, r.max_heading_step);
    d.in_collision += r.track_states_in_collision;
    d.reached += r.goal_reached ? 1 : 0;
    if (run == 0 && track) *track = r.track;
  }
  return d;
}

// The planner's picture with the smoothed trajectory and the driven track laid over it.
void writePicture(const std::string& file, const planner::Scenario& sc, const std::vector<planner::State>& path,
                  const tracker::Trajectory& traj, const std::vector<tracker::VehicleState>& track,
                  const std::string& title) {
  planner::SvgScene scene;
  scene.scenario = &sc;
  scene.path = path;
  scene.title = title;
  planner::SvgPolyline smoothed{{}, "#1f77b4", 1.5, false, "smoothed trajectory"};
  for (const auto& s : traj.samples) smoothed.points.push_back(s.position);
  planner::SvgPolyline driven{{}, "#ff7f0e", 1.0, true, "driven (nominal noise)"};
  for (const auto& s : track) driven.points.push_back(s.position);
  scene.polylines = {std::move(smoothed), std::move(driven)};
  planner::writeSvg(file, scene, 900);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Trajectory smoothing and tracking benchmark"};
  app.add_option("scenarios", opt.scenarios, "scenario files (default: every 2-D configs/scenarios/*.yaml)");
  app.add_option("--planner", opt.planner, "planner that makes the paths")->capture_default_str();
  app.add_option("--plan-time", opt.plan_time, "planning time cap per scenario, s")->capture_default_str();
  app.add_option("--plan-iterations", opt.plan_iterations, "planner iterations per scenario (anytime; repeatable)")->capture_default_str();
  app.add_option("--seed", opt.seed, "planner seed")->capture_default_str();
  app.add_option("--runs", opt.runs, "closed-loop runs (noise seeds) per scenario and variant")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--repeats", opt.repeats, "timing repetitions of the 200-waypoint smoothing")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--svg-dir", opt.svg_dir, "where to write one SVG per scenario")->capture_default_str();
  app.add_option("--json", opt.json_path, "write the numbers as JSON here");
  app.add_option("--timing-scenario", opt.timing_scenario, "scenario (name) whose path is densified for the timing")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  if (opt.scenarios.empty()) {
    const fs::path dir = fs::path(DDSNAV_SOURCE_DIR) / "configs" / "scenarios";
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".yaml") opt.scenarios.push_back(e.path().string());
    std::sort(opt.scenarios.begin(), opt.scenarios.end());
  }
  fs::create_directories(opt.svg_dir);
  nlohmann::json out;
  out["command"] = "ddsnav-bench-tracker";
  out["planner"] = opt.planner;
  out["runs"] = opt.runs;

  std::printf("%-17s %7s %7s %7s | %-11s %8s %8s %8s %7s %7s %8s %8s %5s\n", "scenario", "length", "dur_s", "Tpoly_s",
              "tracking", "meanCTE", "maxCTE", "meanPos", "hjump", "wmax*dt", "trajColl", "drvColl", "goal");
  bool timing_done = false;
  for (const auto& file : opt.scenarios) {
    planner::Scenario sc;
    try {
      sc = planner::loadScenario(file);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      return 1;
    }
    if (sc.dimensions != 2 || !sc.vehicle) {
      spdlog::info("{}: skipped ({})", sc.name, sc.dimensions != 2 ? "3-D" : "no vehicle block");
      continue;
    }
    auto world = planner::makeScenarioWorld(sc);
    const auto planned = plan(sc, *world, opt, opt.planner, true);
    if (!planned.solved) {
      spdlog::warn("{}: {} found no path in {} iterations / {} s, skipped", sc.name, opt.planner, opt.plan_iterations, opt.plan_time);
      continue;
    }
    nlohmann::json js;
    js["scenario"] = sc.name;
    js["path_states"] = planned.path.size();

    if (!timing_done && sc.name == opt.timing_scenario) {
      // Smoothing speed on a 200-waypoint version of a jagged (plain RRT) path of this scenario.
      auto jagged = plan(sc, *world, opt, "rrt", false);
      if (!jagged.solved) jagged = planned;
      const auto dense = densify(jagged.path, 200, *world);
      for (bool shortcut : {true, false}) {
        tracker::SmootherConfig scfg;
        scfg.shortcut = shortcut;
        std::vector<double> ms;
        tracker::Trajectory t;
        for (int r = 0; r < opt.repeats; ++r) {
          const auto t0 = std::chrono::steady_clock::now();
          t = tracker::smoothPath(dense, *world, *sc.vehicle, scfg);
          ms.push_back(msSince(t0));
        }
        std::printf("smoothing %zu waypoints (%s, shortcut %s): median %.3f ms, min %.3f ms over %d runs; %zu -> %zu corners, %zu samples\n",
                    dense.size(), sc.name.c_str(), shortcut ? "on" : "off", median(ms), *std::min_element(ms.begin(), ms.end()),
                    opt.repeats, t.report.input_waypoints, t.report.shortcut_waypoints, t.samples.size());
        out[shortcut ? "smoothing_200_shortcut_ms" : "smoothing_200_no_shortcut_ms"] = median(ms);
      }
      timing_done = true;
    }

    tracker::SmootherConfig scfg;
    scfg.initial_heading = sc.start_heading;
    scfg.end_tolerance = std::max(0.0, sc.goal_radius - (planned.path.back().position - sc.goal).norm());
    const auto t0 = std::chrono::steady_clock::now();
    tracker::Trajectory traj;
    try {
      traj = tracker::smoothPath(planned.path, *world, *sc.vehicle, scfg);
    } catch (const tracker::SmoothingError& e) {
      spdlog::error("{}: {}", sc.name, e.what());
      js["error"] = e.what();
      out["scenarios"].push_back(js);
      continue;
    }
    const double smooth_ms = msSince(t0);
    tracker::SmootherConfig pcfg = scfg;
    pcfg.corner_radius = 0.0;  // the baseline: the (shortcut) polyline, stopping to turn at every corner
    const auto poly = tracker::smoothPath(planned.path, *world, *sc.vehicle, pcfg);

    const auto& r = traj.report;
    js["smoothing_ms"] = smooth_ms;
    js["length_m"] = r.length;
    js["duration_s"] = r.duration;
    js["polyline_duration_s"] = poly.report.duration;
    js["max_curvature"] = r.max_curvature;
    js["max_yaw_rate"] = r.max_yaw_rate;
    js["max_heading_jump"] = r.max_heading_jump;
    js["omega_max_dt"] = sc.vehicle->omega_max * scfg.sample_dt;
    js["min_clearance"] = r.min_clearance;
    js["samples_in_collision"] = r.samples_in_collision;
    js["fallback_iterations"] = r.fallback_iterations;

    std::printf("%-17s smoothing %.2f ms: %zu path states -> %zu corners, %d fallback rounds, max curvature %.3f 1/m, "
                "max yaw rate %.3f rad/s, min clearance %.3f m\n",
                sc.name.c_str(), smooth_ms, planned.path.size(), r.shortcut_waypoints, r.fallback_iterations, r.max_curvature,
                r.max_yaw_rate, r.min_clearance);
    std::vector<tracker::VehicleState> track;
    struct Variant { const char* name; const tracker::Trajectory* t; tracker::ControllerType c; };
    const Variant variants[] = {{"ff+fb", &traj, tracker::ControllerType::FeedforwardFeedback},
                                {"purepursuit", &traj, tracker::ControllerType::PurePursuit},
                                {"ff+fb/poly", &poly, tracker::ControllerType::FeedforwardFeedback}};
    for (const auto& v : variants) {
      const Drive d = drive(*v.t, sc, *world, v.c, opt, v.t == &traj && v.c == variants[0].c ? &track : nullptr);
      std::printf("%-17s %7.2f %7.2f %7.2f | %-11s %8.4f %8.4f %8.4f %7.4f %7.4f %8zu %8zu %3d/%d\n", sc.name.c_str(),
                  v.t->report.length, v.t->report.duration, poly.report.duration, v.name, d.mean_cte, d.max_cte, d.mean_pos,
                  v.t->report.max_heading_jump, sc.vehicle->omega_max * scfg.sample_dt, v.t->report.samples_in_collision,
                  d.in_collision, d.reached, opt.runs);
      js["drive"][v.name] = {{"mean_cross_track_m", d.mean_cte}, {"max_cross_track_m", d.max_cte},
                             {"mean_position_error_m", d.mean_pos}, {"time_s", d.time},
                             {"driven_states_in_collision", d.in_collision}, {"goal_reached", d.reached},
                             {"max_vehicle_heading_step", d.max_heading_step}};
    }
    const std::string svg = (fs::path(opt.svg_dir) / (sc.name + "_tracking.svg")).string();
    writePicture(svg, sc, planned.path, traj, track,
                 sc.name + ": " + opt.planner + " path, B-spline trajectory, driven track");
    js["svg"] = svg;
    out["scenarios"].push_back(js);
  }
  if (!opt.json_path.empty()) std::ofstream(opt.json_path) << out.dump(2) << "\n";
  return 0;
}
