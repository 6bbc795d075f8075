// ddsnav-bench-perception: stock PCL pipeline vs ddsnav's perception on the same simulated
// city-block lidar scans, in one run. Also times the simulator's ray casting.
//
//   ddsnav-bench-perception [--scans 30] [--seed 1] [--json out.json]

#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/pcl_reference.hpp"
#include "ddsnav/sim/city_block.hpp"
#include "ddsnav/sim/range_sensor.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
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

    std::vector<double> pcl_cpu, ours_cpu, sim_cpu;
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
                   {"same_clusters_scans", scans - mismatches}});
    if (mismatches) spdlog::error("{}: {} of {} scans differ from the PCL pipeline", model.name, mismatches, scans);
  }
  if (!json_path.empty()) {
    std::ofstream(json_path) << out.dump(2) << "\n";
  }
  return 0;
}
