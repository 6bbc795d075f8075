// ddsnav bench-mission: the whole pipeline (configs/launch/demo.yaml) on each scenario, on simulated time,
// against the oracle — the trajectory planned once on the scenario's ground truth and smoothed as the
// tracker would. Per scenario: goal reached, time to goal vs the oracle's duration, plans and their reasons,
// tracking error, true minimum clearance, tracked obstacles (the monitor's summary.json) and the latencies of
// the recording (mission_latency.hpp). Writes OUT/results.json and prints a Markdown table
// (docs/benchmarks.md, "Missions").
//
//   ddsnav bench-mission [--scenario FILE]... [--speed 4] [--domain 140] [--out out/bench-mission]
//
// Each run takes the DDS domain given (run it under the DDS test lock when others run DDS tests).

#include "bench_common.hpp"
#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/mission_latency.hpp"
#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/planners.hpp>
#include <ddsnav/record/mcap.hpp>
#include <ddsnav/tracker/smoother.hpp>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

using namespace ddsnav;
namespace fs = std::filesystem;

using bench::binDir;

namespace {

const std::vector<std::string> kDefaultScenarios = {"demo_2d",      "gart_cluttered_2d", "gart_terrain_3d", "auv_coastal",
                                                    "auv_harbour",  "bugtrap_1.0",       "stunnel_1.0"};
// The vehicle's own topics too (small, at the control rate): a failed run's recording shows where it went.
const std::vector<std::string> kRecordedTopics = {"sensors/points",   "perception/obstacles", "map/octomap",     "planning/request",
                                                  "planning/path",    "control/trajectory",   "vehicle/state",   "control/cmd_vel",
                                                  "control/tracking"};

// A child process with stdout and stderr in `log`.
pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int error = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (error != 0) throw std::runtime_error("cannot start " + args.front() + ": " + std::strerror(error));
  return pid;
}

// Set by SIGINT / SIGTERM: the run in progress is ended as at its deadline (its launch and recorder stopped, not left
// behind as orphans), and no further scenario is started.
volatile sig_atomic_t stop_requested = 0;
extern "C" void onStopSignal(int) { stop_requested = 1; }

// Waits for `pid` until `deadline` (or a stop signal); then SIGINT, and SIGKILL 10 s later. Returns the wait status.
int waitUntil(pid_t pid, std::chrono::steady_clock::time_point deadline) {
  int status = 0;
  bool interrupted = false;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) return status;
    if (done < 0) return -1;
    const auto now = std::chrono::steady_clock::now();
    if ((now > deadline || stop_requested) && !interrupted) {
      ::kill(pid, SIGINT);
      interrupted = true;
      deadline = now + std::chrono::seconds(10);
    } else if (now > deadline) {
      ::kill(pid, SIGKILL);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

template <class T>
std::optional<T> decode(const record::MessageView& view) {
  T sample;
  if (!msg::type_support<T>().deserialize(view.data.data(), view.data.size(), &sample)) return std::nullopt;
  return sample;
}

nodes::MissionRecording readRecording(const fs::path& file) {
  nodes::MissionRecording r;
  record::McapReader reader(file.string());
  reader.forEachMessage(
      [&](const record::MessageView& v) {
        const std::string& topic = v.channel->topic;
        auto add = [&](std::vector<nodes::RecordedEvent>& to, std::int64_t key) { to.push_back({v.log_time, key}); };
        if (topic == "sensors/points") {
          if (auto m = decode<msg::PointCloud>(v)) add(r.clouds, m->header().stamp_ns());
        } else if (topic == "perception/obstacles") {
          if (auto m = decode<msg::ObstacleArray>(v)) add(r.obstacles, m->header().stamp_ns());
        } else if (topic == "map/octomap") {
          if (auto m = decode<msg::OccupancyMap>(v)) add(r.maps, m->header().stamp_ns());
        } else if (topic == "planning/request") {
          if (auto m = decode<msg::PlanRequest>(v)) {
            add(r.requests, m->request_id());
            r.request_reasons.emplace(m->request_id(), m->reason());
          }
        } else if (topic == "planning/path") {
          if (auto m = decode<msg::Path>(v)) add(r.paths, m->request_id());
        } else if (topic == "control/trajectory") {
          if (auto m = decode<msg::Trajectory>(v)) add(r.trajectories, m->request_id());
        }
        return true;
      },
      [&](const record::DamagedChunk&) {});
  return r;
}

// Every trajectory of a run against the ground truth: its true clearance along the samples, and where it first
// enters the true obstacles, with what the map it was planned on (the newest map/octomap received before it, as a
// map world with the components' 3-D defaults: solid below the observed surface, 1 m surface margin; without
// perception's ellipses or the sensor view) said about that point. A plan into terrain the map had seen is a
// world-model bug; one the map had as free is a sensing or policy gap (docs/benchmarks/mission.md).
nlohmann::json auditTrajectories(const fs::path& file, const planner::Scenario& scenario) {
  const auto truth = planner::makeScenarioWorld(scenario);
  planner::OctoMapWorldOptions options;
  options.solid_below_surface = true;
  options.surface_margin_m = nodes::WorldParameters{}.surface_margin_m;
  std::optional<msg::OccupancyMap> map;  // the newest one so far (messages come in receive order)
  std::unique_ptr<planner::CollisionWorld> map_world;  // built from `map` when first needed, once per map
  nlohmann::json out = nlohmann::json::array();
  record::McapReader reader(file.string());
  reader.forEachMessage(
      [&](const record::MessageView& v) {
        if (v.channel->topic == "map/octomap") {
          if (auto m = decode<msg::OccupancyMap>(v)) {
            map = std::move(*m);
            map_world.reset();
          }
          return true;
        }
        if (v.channel->topic != "control/trajectory") return true;
        const auto trajectory = decode<msg::Trajectory>(v);
        if (!trajectory || trajectory->samples().empty()) return true;
        const auto& samples = trajectory->samples();
        double least = std::numeric_limits<double>::infinity();
        std::optional<std::size_t> entry;
        for (std::size_t i = 0; i < samples.size(); ++i) {
          const double c = truth->clearance(nodes::fromMsg(samples[i].position()));
          least = std::min(least, c);
          if (!entry && c < 0.0) entry = i;
        }
        nlohmann::json row = {{"request_id", trajectory->request_id()},
                              {"start_true_clearance_m", truth->clearance(nodes::fromMsg(samples.front().position()))},
                              {"min_true_clearance_m", least}};
        if (entry) {
          const Eigen::Vector3d p = nodes::fromMsg(samples[*entry].position());
          nlohmann::json e = {{"t_s", static_cast<double>(samples[*entry].time_from_start_ns()) * 1e-9}, {"position", {p.x(), p.y(), p.z()}}};
          if (map) {
            try {
              if (!map_world) {
                const std::vector<std::uint8_t> bytes(map->octree().begin(), map->octree().end());
                map_world = planner::makeOctoMapWorld(scenario.dimensions, scenario.bounds_min, scenario.bounds_max,
                                                      scenario.robot_radius, bytes, options);
              }
              e["map_free"] = map_world->isFree(p);
              e["map_clearance_m"] = map_world->clearance(p);
              e["map_age_s"] = static_cast<double>(trajectory->header().stamp_ns() - map->header().stamp_ns()) * 1e-9;
            } catch (const std::exception& ex) {
              e["map_error"] = ex.what();
            }
          }
          row["enters_obstacles"] = e;
        }
        out.push_back(row);
        return true;
      },
      [&](const record::DamagedChunk&) {});
  return out;
}

// The oracle: one plan on the scenario's true geometry with the tracker's planner and budget, smoothed
// exactly as the tracker smooths; its duration is the time the mission would take knowing the world.
struct Oracle {
  bool solved = false;
  double duration_s = std::nan("");
  double length_m = std::nan("");
  std::string why;
};

Oracle planOracle(const planner::Scenario& scenario, const std::string& planner_name, double budget_s) {
  Oracle out;
  if (!scenario.vehicle) {
    out.why = "no vehicle block";
    return out;
  }
  // A scenario the planner refuses (a start or goal in collision, r3d_116 of make_random_scenarios.py seed 116: the
  // bench ended with std::terminate) or a path the smoother refuses has no oracle; its mission still runs, and its
  // report says why the goal was not reached.
  try {
    const auto world = planner::makeScenarioWorld(scenario);
    auto problem = planner::problemFromScenario(scenario, *world);
    problem.kinodynamic = true;  // as the planner component on a scenario with a vehicle
    problem.time_limit_s = budget_s;
    const auto result = planner::makePlanner(planner_name)->solve(problem);
    if (!result.solved) {
      out.why = "the oracle found no path in " + std::to_string(budget_s) + " s";
      return out;
    }
    tracker::SmootherConfig config;
    config.initial_heading = problem.start.heading;
    const auto trajectory = tracker::smoothPath(result.path, *world, *scenario.vehicle, config);
    out.solved = true;
    out.duration_s = trajectory.report.duration;
    out.length_m = trajectory.report.length;
  } catch (const std::exception& e) {
    out.why = std::string("no oracle: ") + e.what();
    spdlog::warn("{}: {}", scenario.name, out.why);
  }
  return out;
}

nlohmann::json statsJson(const nodes::LatencyStats& s) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"count", s.count}, {"median_ms", number(s.median_ms)}, {"p99_ms", number(s.p99_ms)}, {"max_ms", number(s.max_ms)}};
}

std::string cell(const nlohmann::json& j, const char* key, const char* format = "{:.1f}") {
  if (!j.contains(key) || !j.at(key).is_number()) return "–";
  return fmt::format(fmt::runtime(format), j.at(key).get<double>());
}

std::string latencyCell(const nlohmann::json& s) {
  if (!s.at("median_ms").is_number()) return "–";
  return fmt::format("{:.0f} / {:.0f}", s.at("median_ms").get<double>(), s.at("p99_ms").get<double>());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ddsnav bench-mission: the full pipeline on each scenario against the ground-truth oracle"};
  std::vector<std::string> scenarios;
  std::string configs = std::string(DDSNAV_SOURCE_DIR) + "/configs";
  std::string out_dir = "out/bench-mission";
  std::string planner_name = "gart-lazy";
  double speed = 4.0;
  int domain = 140;
  double oracle_budget = 5.0;
  double timeout_factor = 2.5;
  bool keep = false;
  std::vector<std::string> sets;
  app.add_option("--scenario", scenarios, "scenario file (repeatable; default: the issue-9 set in configs/scenarios)");
  app.add_option("--configs", configs, "the configs directory (launch/demo.yaml, scenarios/)");
  app.add_option("--out", out_dir, "where each run's report, recording and logs go");
  app.add_option("--planner", planner_name, "planner of the tracker and of the oracle");
  app.add_option("--speed", speed, "simulated seconds per wall second")->check(CLI::Range(0.01, 1000.0));
  app.add_option("--domain", domain, "DDS domain id of the runs")->check(CLI::Range(0, 232));
  app.add_option("--oracle-budget-s", oracle_budget, "wall-time budget of the oracle's plan")->check(CLI::PositiveNumber);
  app.add_option("--timeout-factor", timeout_factor, "monitor timeout_s = max(60, factor x oracle duration) simulated s")
      ->check(CLI::PositiveNumber);
  app.add_flag("--keep-recordings", keep, "keep each run's MCAP recording (they are large in 3-D)");
  app.add_option("--set", sets, "KEY=VALUE passed on to ddsnav launch (a demo.yaml variable, e.g. world=obstacles; repeatable)");
  CLI11_PARSE(app, argc, argv);
  if (scenarios.empty())
    for (const auto& name : kDefaultScenarios) scenarios.push_back(configs + "/scenarios/" + name + ".yaml");

  const std::string bin = binDir();
  struct sigaction on_stop {};
  on_stop.sa_handler = onStopSignal;
  ::sigaction(SIGINT, &on_stop, nullptr);
  ::sigaction(SIGTERM, &on_stop, nullptr);
  nlohmann::json results = nlohmann::json::array();
  for (const auto& file : scenarios) {
    if (stop_requested) {
      spdlog::warn("stopped by a signal: {} scenario(s) not run", scenarios.size() - results.size());
      break;
    }
    nlohmann::json row;
    row["scenario_file"] = file;
    if (!sets.empty()) row["sets"] = sets;
    planner::Scenario scenario;
    try {
      scenario = planner::loadScenario(file);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      row["error"] = e.what();
      results.push_back(row);
      continue;
    }
    row["scenario"] = scenario.name;
    const Oracle oracle = planOracle(scenario, planner_name, oracle_budget);
    row["oracle_duration_s"] = oracle.solved ? nlohmann::json(oracle.duration_s) : nlohmann::json(nullptr);
    if (!oracle.why.empty()) row["oracle_why"] = oracle.why;
    const double timeout = std::max(60.0, timeout_factor * (oracle.solved ? oracle.duration_s : 120.0));
    row["timeout_s"] = timeout;

    const fs::path run_dir = fs::path(out_dir) / scenario.name;
    fs::remove_all(run_dir);
    fs::create_directories(run_dir);
    const fs::path recording = run_dir / "run.mcap";
    std::string topics;
    for (const auto& t : kRecordedTopics) topics += (topics.empty() ? "" : ",") + t;
    spdlog::info("{}: oracle {:.1f} s; running at speed {:g}, timeout {:.0f} s simulated", scenario.name, oracle.duration_s, speed, timeout);
    const auto wall_start = std::chrono::steady_clock::now();
    const pid_t recorder = spawn({bin + "/ddsnav-record", "-o", recording.string(), "--topics", topics, "--compression", "none",
                                  "--domain", std::to_string(domain)},
                                 run_dir / "record.log");
    std::vector<std::string> launch = {bin + "/ddsnav-launch", configs + "/launch/demo.yaml", "--set", "scenario=" + fs::absolute(file).string(),
                                       "--set", "out=" + fs::absolute(run_dir).string(), "--set", fmt::format("speed={:g}", speed), "--set",
                                       fmt::format("timeout_s={:.0f}", timeout), "--set", "planner=" + planner_name, "--domain",
                                       std::to_string(domain)};
    for (const auto& s : sets) launch.insert(launch.end(), {"--set", s});
    const pid_t launcher = spawn(launch, run_dir / "launch.log");
    // A guard against a hang, not the mission's limit (the monitor's timeout_s, on the simulated clock, is): the clock
    // runs slower than asked when two cores cannot keep up, since the simulator waits for the slowest component
    // (auv_harbour at speed 10: 3.4-5.8 achieved; at 1.5 x timeout / speed the guard ended a mission 29 m before its
    // goal, 2026-12-06). A quarter of the asked speed is allowed for.
    const double wall_limit_s = 4.0 * timeout / speed + 120.0;
    const int launch_status = waitUntil(
        launcher, wall_start + std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(wall_limit_s)));
    const bool guard_ended = std::chrono::steady_clock::now() >= wall_start + std::chrono::duration<double>(wall_limit_s);
    ::kill(recorder, SIGINT);
    waitUntil(recorder, std::chrono::steady_clock::now() + std::chrono::seconds(20));
    row["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    row["launch_exit"] = WIFEXITED(launch_status) ? WEXITSTATUS(launch_status) : -1;
    if (guard_ended)
      row["error"] = fmt::format("ended by the bench's wall-time guard after {:.0f} s (4 x timeout_s / speed + 120 s): the clock ran at "
                                 "under a quarter of the asked speed, or the launch hung", wall_limit_s);

    nlohmann::json summary;
    if (std::ifstream in(run_dir / "summary.json"); in) {
      try {
        in >> summary;
      } catch (const std::exception& e) {
        row["error"] = std::string("summary.json: ") + e.what();
      }
    } else {
      // The launch's last error line says why (a refused --set, a component that failed to start).
      std::string why, line;
      for (std::ifstream log(run_dir / "launch.log"); std::getline(log, line);)
        if (line.find("[error]") != std::string::npos) why = line.substr(line.find("[error]") + 8);
      row["error"] = "no summary.json" + (why.empty() ? "" : ": " + why) + " (see " + (run_dir / "launch.log").string() + ")";
    }
    row["summary"] = summary;
    try {
      const auto latencies = nodes::missionLatencies(readRecording(recording));
      row["latency"] = {{"cloud_to_obstacles", statsJson(latencies.cloud_to_obstacles)},
                        {"cloud_to_map", statsJson(latencies.cloud_to_map)},
                        {"request_to_path", statsJson(latencies.request_to_path)},
                        {"obstacles_to_trajectory", statsJson(latencies.obstacles_to_trajectory)},
                        {"replans_answered_later", latencies.replans_answered_later},
                        {"replan_obstacles_to_request", statsJson(latencies.replan_obstacles_to_request)},
                        {"replan_request_to_path", statsJson(latencies.replan_request_to_path)},
                        {"replan_path_to_trajectory", statsJson(latencies.replan_path_to_trajectory)}};
      nlohmann::json each = nlohmann::json::array();
      auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
      for (const auto& r : latencies.replans)
        each.push_back({{"request_id", r.request_id},
                        {"obstacles_to_trajectory_ms", number(r.obstacles_to_trajectory_ms)},
                        {"obstacles_to_request_ms", number(r.obstacles_to_request_ms)},
                        {"map_to_request_ms", number(r.map_to_request_ms)},
                        {"answered_by_own_trajectory", r.answered_by_own_trajectory}});
      row["latency"]["replans"] = std::move(each);
      spdlog::info("{}: {} replans for a blocked trajectory ({} answered by a later plan's trajectory): obstacles -> trajectory median "
                   "{:.0f} ms, p99 {:.0f} ms; of it, where the replan's own trajectory answered, "
                   "obstacles -> request {:.0f} / {:.0f}, request -> path {:.0f} / {:.0f}, path -> trajectory {:.0f} / {:.0f}",
                   scenario.name, latencies.obstacles_to_trajectory.count, latencies.replans_answered_later,
                   latencies.obstacles_to_trajectory.median_ms, latencies.obstacles_to_trajectory.p99_ms,
                   latencies.replan_obstacles_to_request.median_ms,
                   latencies.replan_obstacles_to_request.p99_ms, latencies.replan_request_to_path.median_ms,
                   latencies.replan_request_to_path.p99_ms, latencies.replan_path_to_trajectory.median_ms,
                   latencies.replan_path_to_trajectory.p99_ms);
    } catch (const std::exception& e) {
      row["latency_error"] = e.what();
    }
    try {
      row["trajectories"] = auditTrajectories(recording, scenario);
      int entering = 0, from_inside = 0, map_free = 0;
      for (const auto& t : row["trajectories"]) {
        if (t.at("start_true_clearance_m").get<double>() < 0.0) {
          ++from_inside;
        } else if (t.contains("enters_obstacles")) {
          ++entering;
          map_free += t.at("enters_obstacles").value("map_free", false);
        }
      }
      // Only what the vehicle could have flown matters: a trajectory replaced before its entry never took it there.
      spdlog::info("{}: {} trajectories; {} planned from outside into the true obstacles ({} of them through space the map had as "
                   "free), {} started inside", scenario.name, row["trajectories"].size(), entering, map_free, from_inside);
    } catch (const std::exception& e) {
      row["trajectories_error"] = e.what();
    }
    if (!keep) fs::remove(recording);
    if (summary.is_object() && summary.contains("sim_time_to_goal_s") && oracle.solved)
      row["time_ratio"] = summary.at("sim_time_to_goal_s").get<double>() / oracle.duration_s;
    // No summary (the launch refused its arguments, or a component failed before the monitor wrote one): said, not thrown.
    const bool reached = summary.is_object() && summary.value("goal_reached", false);
    spdlog::info("{}: {} in {:.0f} s of wall time{}", scenario.name, reached ? "goal reached" : "goal NOT reached", row["wall_s"].get<double>(),
                 row.contains("error") ? " — " + row["error"].get<std::string>() : std::string());
    results.push_back(row);
    std::ofstream(fs::path(out_dir) / "results.json") << results.dump(2) << "\n";
  }

  std::printf("| scenario | reached | time to goal s | oracle s | ratio | plans | replan reasons | mean / max tracking error m | "
              "min true clearance m | tracked obstacles max | cloud→obstacles ms p50 / p99 | cloud→map | request→path | "
              "obstacles→trajectory |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& row : results) {
    const auto& s = row.value("summary", nlohmann::json::object());
    std::string reasons;
    if (s.is_object() && s.contains("replan_reasons"))
      for (const auto& [kind, n] : s.at("replan_reasons").items()) reasons += (reasons.empty() ? "" : "; ") + fmt::format("{} × {}", n.get<int>(), kind);
    const auto& l = row.value("latency", nlohmann::json::object());
    auto lat = [&](const char* key) { return l.contains(key) ? latencyCell(l.at(key)) : std::string("–"); };
    std::printf("| %s | %s | %s | %s | %s | %s | %s | %s / %s | %s | %s | %s | %s | %s | %s |\n", row.value("scenario", "?").c_str(),
                s.is_object() && s.value("goal_reached", false) ? "yes" : "**no**", cell(s, "sim_time_to_goal_s").c_str(),
                cell(row, "oracle_duration_s").c_str(), cell(row, "time_ratio", "{:.2f}").c_str(),
                s.is_object() && s.contains("plan_requests") ? std::to_string(s.at("plan_requests").get<int>()).c_str() : "–",
                reasons.empty() ? "–" : reasons.c_str(), cell(s, "mean_cross_track_error_m", "{:.2f}").c_str(),
                cell(s, "max_cross_track_error_m", "{:.2f}").c_str(), cell(s, "min_true_clearance_m", "{:.2f}").c_str(),
                s.is_object() && s.contains("tracked_obstacles_max") ? std::to_string(s.at("tracked_obstacles_max").get<int>()).c_str() : "–",
                lat("cloud_to_obstacles").c_str(), lat("cloud_to_map").c_str(), lat("request_to_path").c_str(),
                lat("obstacles_to_trajectory").c_str());
  }
  return 0;
}
