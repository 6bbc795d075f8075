// ddsnav-bench-perception: stock PCL pipeline vs ddsnav's perception on the same simulated
// city-block lidar scans, in one run. Also times the simulator's ray casting.
//
// The component runs detect + track per cloud, so that sum is also compared with PCL, and the
// tracker is timed against the straightforward reference tracker (the one before the
// optimisation, reference/reference_tracker.cpp) on the same detections, checking they agree.
//
// Then drives the demo_2d scenario (2-D scanner, the demo's noise) through detector + tracker and
// times both per scan; --svg draws the final tracked ellipses over the world.
//
//   ddsnav-bench-perception [--scans 30] [--seed 1] [--json out.json] [--svg docs/perception-demo.svg]

#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/obstacle_tracker.hpp"
#include "ddsnav/perception/pcl_reference.hpp"
#include "ddsnav/perception/reference_tracker.hpp"
#include "ddsnav/sim/city_block.hpp"
#include "ddsnav/sim/range_sensor.hpp"

#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/svg.hpp>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

namespace {

using namespace ddsnav;
using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// CPU time of this thread: on a shared, oversubscribed machine wall time mostly measures how often
// the scheduler preempted us, so both are reported.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

struct Summary {
  double median = 0, p90 = 0, mean = 0;
};

Summary summarize(std::vector<double> v) {
  Summary s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[static_cast<size_t>(q * (v.size() - 1) + 0.5)]; };
  s.median = at(0.5);
  s.p90 = at(0.9);
  for (double x : v) s.mean += x;
  s.mean /= v.size();
  return s;
}

struct LidarModel {
  std::string name;
  int rings, columns;
  double vmin, vmax;
};


// The demo's drive: (3,3) -> (8,6) -> (8,30) -> (36,35), a scan every 0.17 m (1.7 m/s at 10 Hz),
// 720-beam scanner, 0.02 m noise, 1 % NaN/inf; detector + tracker per scan, as ddsnav-perception.
nlohmann::json demoDrive(const std::string& scenario_path, const std::string& svg_path) {
  const planner::Scenario scenario = planner::loadScenario(scenario_path);
  auto config = sim::RangeSensorConfig::scanner2d(720, 30.0);
  config.walls = false;
  config.range_noise_sigma = 0.02;
  config.invalid_fraction = 0.01;
  sim::RangeSensor sensor(scenario, config);
  perception::DetectorParams params;
  params.beam_spacing = 2.0 * std::numbers::pi / 720;
  perception::ObstacleDetector detector(params);
  perception::ObstacleTracker tracker(perception::TrackerParams::matching(params));
  const std::vector<Eigen::Vector3d> waypoints = {{3, 3, 0}, {8, 6, 0}, {8, 30, 0}, {36, 35, 0}};
  std::vector<double> detect_cpu, track_cpu;
  planner::SvgPolyline driven;
  driven.colour = "#1f77b4";
  driven.width_px = 2.0;
  driven.label = "drive";
  std::size_t detections = 0;
  for (std::size_t w = 0; w + 1 < waypoints.size(); ++w) {
    const Eigen::Vector3d d = waypoints[w + 1] - waypoints[w];
    const int steps = static_cast<int>(std::ceil(d.norm() / 0.17));
    for (int i = 0; i < steps; ++i) {
      const sim::SensorPose pose{waypoints[w] + d * (double(i) / steps), std::atan2(d.y(), d.x())};
      driven.points.push_back(pose.position);
      const auto cloud = sensor.scan(pose);
      double cpu = threadCpuMs();
      const auto found = detector.detect(cloud.points, cloud.origin);
      detect_cpu.push_back(threadCpuMs() - cpu);
      cpu = threadCpuMs();
      tracker.update(found);
      track_cpu.push_back(threadCpuMs() - cpu);
      detections += found.size();
    }
  }
  const Summary det = summarize(detect_cpu), trk = summarize(track_cpu);
  std::size_t support = 0;
  for (const auto& t : tracker.obstacles()) support += t.support.size();
  std::printf("\ndemo drive on %s: %zu scans, %.1f detections per scan, %zu tracks (%zu voxels) at the end\n",
              scenario.name.c_str(), detect_cpu.size(), double(detections) / detect_cpu.size(),
              tracker.obstacles().size(), support);
  std::printf("  cpu ms per scan: detect median %.3f p90 %.3f; tracker.update median %.3f p90 %.3f\n", det.median,
              det.p90, trk.median, trk.p90);
  if (!svg_path.empty()) {
    planner::SvgScene svg;
    svg.scenario = &scenario;
    svg.title = "perception: tracked ellipses after the demo drive (" + std::to_string(tracker.obstacles().size()) +
                " tracks, p = 0.99)";
    for (const auto& t : tracker.obstacles())
      svg.ellipses.push_back({static_cast<int>(t.id), t.center, t.semi_axes, t.axes});
    svg.polylines.push_back(driven);
    planner::writeSvg(svg_path, svg);
    std::printf("  wrote %s\n", svg_path.c_str());
  }
  return {{"drive", scenario.name},
          {"scans", detect_cpu.size()},
          {"tracks", tracker.obstacles().size()},
          {"detect_cpu_ms", {{"median", det.median}, {"p90", det.p90}}},
          {"tracker_cpu_ms", {{"median", trk.median}, {"p90", trk.p90}}}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Perception benchmark: stock PCL pipeline vs ddsnav perception on simulated city-block scans"};
  int scans = 30;
  std::uint64_t seed = 1;
  std::string json_path;
  double sigma = 0.02, invalid = 0.005;
  app.add_option("--scans", scans, "timed scans per lidar model")->check(CLI::Range(1, 100000));
  app.add_option("--seed", seed, "city block and noise seed");
  app.add_option("--sigma", sigma, "lidar range noise, m")->check(CLI::Range(0.0, 1.0));
  app.add_option("--invalid", invalid, "fraction of NaN/inf returns")->check(CLI::Range(0.0, 1.0));
  app.add_option("--json", json_path, "also write the results as JSON here");
  std::string svg_path, scenario_path = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";
  app.add_option("--svg", svg_path, "draw the demo drive's final tracked ellipses here");
  app.add_option("--drive-scenario", scenario_path, "2-D scenario for the drive (default: demo_2d.yaml)");
  CLI11_PARSE(app, argc, argv);

  const planner::Scenario world = sim::makeCityBlock(seed);
  const std::vector<LidarModel> models = {
      {"16x1800", 16, 1800, -15.0, 15.0}, {"32x1024", 32, 1024, -20.0, 15.0}, {"64x1800", 64, 1800, -24.8, 2.0}};
  nlohmann::json out = nlohmann::json::array();

  std::printf("city block: %zu obstacles, %d timed scans per model (+2 warm-up), noise %.3f m, invalid %.3f\n",
              world.obstacles.size(), scans, sigma, invalid);
  std::printf("times in ms per scan; first line wall clock, second line thread CPU time\n");
  std::printf("%-8s %8s %8s | %9s %9s | %9s %9s | %7s %7s | %9s | %s\n", "lidar", "points", "voxels", "pcl med",
              "pcl p90", "ours med", "ours p90", "ratio", "p90/med", "sim med", "same clusters");

  for (const auto& model : models) {
    auto config = sim::RangeSensorConfig::lidar3d(model.rings, model.columns, model.vmin, model.vmax, 100.0);
    config.range_noise_sigma = sigma;
    config.invalid_fraction = invalid;
    config.seed = seed;
    sim::RangeSensor sensor(world, config);

    perception::DetectorParams params;  // 0.1 m voxels, ground z <= 0.15, 0.4 m tolerance
    params.range_noise_sigma = sigma;
    params.beam_spacing = 2.0 * std::numbers::pi / model.columns;
    perception::ObstacleDetector detector(params);
    perception::PclReferencePipeline reference(params);

    perception::ObstacleTracker tracker(perception::TrackerParams::matching(params));
    perception::reference::ReferenceObstacleTracker reference_tracker(perception::TrackerParams::matching(params));
    std::vector<double> pcl_cpu, ours_cpu, sim_cpu, track_cpu, ref_track_cpu, total_cpu, total_ms;
    std::size_t track_mismatches = 0;
    std::size_t refreshed = 0, added = 0, created = 0;
    std::vector<double> sim_ms, pcl_ms, ours_ms, voxel_ms, cluster_ms, split_ms, fit_ms;
    size_t points = 0, voxels = 0, mismatches = 0, obstacles = 0, clusters = 0;
    for (int k = -2; k < scans; ++k) {
      // Drive down the street, turning a little.
      const double x = -40.0 + 80.0 * (k + 2) / (scans + 2);
      const sim::SensorPose pose{{x, 0.8 * std::sin(0.3 * k), 1.8}, 0.15 * std::sin(0.2 * k)};
      auto start = Clock::now();
      const double sim_cpu_start = threadCpuMs();
      const auto cloud = sensor.scan(pose, k * 0.1);
      const double t_sim = msSince(start), c_sim = threadCpuMs() - sim_cpu_start;

      reference.setInput(cloud.points);
      start = Clock::now();
      double cpu = threadCpuMs();
      reference.run(3);
      const double t_pcl = msSince(start), c_pcl = threadCpuMs() - cpu;

      start = Clock::now();
      cpu = threadCpuMs();
      const auto found = detector.detect(cloud.points, cloud.origin, 3);
      const double t_ours = msSince(start), c_ours = threadCpuMs() - cpu;
      start = Clock::now();
      cpu = threadCpuMs();
      tracker.update(found);
      const double c_track = threadCpuMs() - cpu, t_track = msSince(start);
      cpu = threadCpuMs();
      reference_tracker.update(found);
      const double c_ref_track = threadCpuMs() - cpu;
      {
        // The optimised tracker must keep the reference's tracks (ids, voxel counts, centres).
        const auto& a = tracker.obstacles();
        const auto& b = reference_tracker.obstacles();
        bool same_tracks = a.size() == b.size();
        for (std::size_t i = 0; same_tracks && i < a.size(); ++i)
          same_tracks = a[i].id == b[i].id && a[i].support.size() == b[i].support.size() &&
                        (a[i].center - b[i].center).cwiseAbs().maxCoeff() <= 1e-9;
        if (k >= 0) track_mismatches += !same_tracks;
      }
      if (k >= 0) {
        refreshed += tracker.lastUpdate().refreshed_voxels;
        added += tracker.lastUpdate().added_voxels;
        created += tracker.lastUpdate().created;
      }

      const auto& st = detector.stats();
      size_t pcl_clustered = 0;
      for (const auto& c : reference.clusters()) pcl_clustered += c.size();
      const bool same = st.voxels == reference.voxelCountBeforeGround() && st.clusters == reference.clusters().size() &&
                        st.clustered_points == pcl_clustered && detector.voxels().size() == reference.voxels().size();
      if (k < 0) continue;
      mismatches += !same;
      sim_ms.push_back(t_sim);
      pcl_ms.push_back(t_pcl);
      pcl_cpu.push_back(c_pcl);
      ours_cpu.push_back(c_ours);
      track_cpu.push_back(c_track);
      ref_track_cpu.push_back(c_ref_track);
      total_cpu.push_back(c_ours + c_track);
      total_ms.push_back(t_ours + t_track);
      sim_cpu.push_back(c_sim);
      ours_ms.push_back(t_ours);
      voxel_ms.push_back(st.ms_filter + st.ms_voxel);
      cluster_ms.push_back(st.ms_cluster);
      split_ms.push_back(st.ms_split);
      fit_ms.push_back(st.ms_fit);
      points += cloud.points.size();
      voxels += st.voxels;
      clusters += st.clusters;
      obstacles += found.size();
    }
    const Summary pcl = summarize(pcl_ms), ours = summarize(ours_ms), simt = summarize(sim_ms);
    std::printf("%-8s %8zu %8zu | %9.2f %9.2f | %9.2f %9.2f | %7.3f %7.2f | %9.2f | %zu/%d\n", model.name.c_str(),
                points / scans, voxels / scans, pcl.median, pcl.p90, ours.median, ours.p90, ours.median / pcl.median,
                ours.p90 / ours.median, simt.median, scans - mismatches, scans);
    const Summary pcl_c = summarize(pcl_cpu), ours_c = summarize(ours_cpu), sim_c = summarize(sim_cpu);
    std::printf("%-8s %8s %8s | %9.2f %9.2f | %9.2f %9.2f | %7.3f %7.2f | %9.2f |\n", "  cpu", "", "",
                pcl_c.median, pcl_c.p90, ours_c.median, ours_c.p90, ours_c.median / pcl_c.median,
                ours_c.p90 / ours_c.median, sim_c.median);
    std::printf("         ours by stage (median ms): filter+voxel+ground %.2f, cluster %.2f, gap split %.2f, fit %.2f;"
                " %zu clusters -> %zu ellipsoids per scan\n",
                summarize(voxel_ms).median, summarize(cluster_ms).median, summarize(split_ms).median,
                summarize(fit_ms).median, clusters / scans, obstacles / scans);
    const Summary trk = summarize(track_cpu);
    std::printf("         tracker.update (cpu ms): median %.2f, p90 %.2f; per scan %zu voxels refreshed, %zu added to tracks,"
                " %zu new tracks; %zu tracks after the drive\n",
                trk.median, trk.p90, refreshed / scans, added / scans, created / scans, tracker.obstacles().size());
    const Summary ref_trk = summarize(ref_track_cpu), tot_c = summarize(total_cpu), tot = summarize(total_ms);
    std::printf("         reference tracker (before optimisation, cpu ms): median %.2f, p90 %.2f -> %.1fx faster;"
                " same tracks %zu/%d\n",
                ref_trk.median, ref_trk.p90, ref_trk.median / trk.median, scans - track_mismatches, scans);
    std::printf("         DETECT+TRACK vs PCL: cpu median %.2f p90 %.2f ratio %.3f p90/med %.2f;"
                " wall median %.2f p90 %.2f ratio %.3f p90/med %.2f\n",
                tot_c.median, tot_c.p90, tot_c.median / pcl_c.median, tot_c.p90 / tot_c.median, tot.median, tot.p90,
                tot.median / pcl.median, tot.p90 / tot.median);
    out.push_back({{"lidar", model.name},
                   {"scans", scans},
                   {"points_per_scan", points / scans},
                   {"voxels_per_scan", voxels / scans},
                   {"pcl_ms", {{"median", pcl.median}, {"p90", pcl.p90}, {"mean", pcl.mean}}},
                   {"ours_ms", {{"median", ours.median}, {"p90", ours.p90}, {"mean", ours.mean}}},
                   {"ratio_median", ours.median / pcl.median},
                   {"pcl_cpu_ms", {{"median", pcl_c.median}, {"p90", pcl_c.p90}}},
                   {"ours_cpu_ms", {{"median", ours_c.median}, {"p90", ours_c.p90}}},
                   {"ratio_cpu_median", ours_c.median / pcl_c.median},
                   {"ours_cpu_p90_over_median", ours_c.p90 / ours_c.median},
                   {"ours_p90_over_median", ours.p90 / ours.median},
                   {"sim_raycast_ms", {{"median", simt.median}, {"p90", simt.p90}}},
                   {"sim_raycast_cpu_ms", {{"median", sim_c.median}, {"p90", sim_c.p90}}},
                   {"same_clusters_scans", scans - mismatches},
                   {"tracker_cpu_ms", {{"median", trk.median}, {"p90", trk.p90}}},
                   {"reference_tracker_cpu_ms", {{"median", ref_trk.median}, {"p90", ref_trk.p90}}},
                   {"same_tracks_scans", scans - track_mismatches},
                   {"detect_track_cpu_ms", {{"median", tot_c.median}, {"p90", tot_c.p90}}},
                   {"detect_track_ms", {{"median", tot.median}, {"p90", tot.p90}}},
                   {"ratio_detect_track_cpu_median", tot_c.median / pcl_c.median},
                   {"ratio_detect_track_median", tot.median / pcl.median},
                   {"tracks", tracker.obstacles().size()}});
    if (mismatches) spdlog::error("{}: {} of {} scans differ from the PCL pipeline", model.name, mismatches, scans);
    if (track_mismatches)
      spdlog::error("{}: {} of {} scans: tracks differ from the reference tracker", model.name, track_mismatches, scans);
  }
  out.push_back(demoDrive(scenario_path, svg_path));
  if (!json_path.empty()) {
    std::ofstream(json_path) << out.dump(2) << "\n";
  }
  return 0;
}
