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
//   ddsnav-bench-perception [--scans 30] [--seed 1] [--seeds 1] [--json out.json] [--svg docs/perception-demo.svg]
//
// --seeds N repeats everything on the city blocks (and noise) of seeds seed .. seed + N - 1 and ends
// with the spread per lidar: the median, p90 and worst seed of detect + track / PCL. Exit status 1
// when a scan's clusters differ from PCL's, the evidence from the reference tracker's, or a voxel
// lies outside its track's ellipse.

#include "ddsnav/perception/chi_square.hpp"
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
#include <span>
#include <string>
#include <unordered_map>
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
      tracker.update(found, cloud.origin);
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


// What one lidar model on one seed gave; the spread over seeds is reported from these.
struct ModelRun {
  std::string lidar;
  std::uint64_t seed = 0;
  double pcl_cpu_median = 0, track_cpu_median = 0, total_cpu_median = 0, total_cpu_p90 = 0;
  double ratio = 0, p90_over_median = 0, wall_ratio = 0;
  int scans = 0, same_clusters = 0, same_evidence = 0, enclosed = 0;
  std::size_t detection_voxels = 0, uncovered_voxels = 0;  // checked, and inside no track ellipse
};

// The detections without the fit carry the same voxels (positions and bearings, in order) as the fitted ones.
bool samePieces(const std::vector<perception::ObstacleEllipsoid>& fitted,
                const std::vector<perception::ObstacleEllipsoid>& unfitted) {
  if (fitted.size() != unfitted.size()) return false;
  for (std::size_t i = 0; i < fitted.size(); ++i) {
    const auto& a = fitted[i].support;
    const auto& b = unfitted[i].support;
    if (a.size() != b.size()) return false;
    for (std::size_t k = 0; k < a.size(); ++k)
      if (a[k].position != b[k].position || a[k].bearing != b[k].bearing) return false;
  }
  return true;
}

// Every evidence voxel of every track, pushed outward by its position uncertainty as the fit
// pushes it, lies inside the track's reported ellipse (deferred refits must keep that).
bool everyVoxelEnclosed(const perception::ObstacleTracker& tracker) {
  const auto& p = tracker.params();
  const auto& tracks = tracker.obstacles();
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    const auto& t = tracks[i];
    const double margin = perception::enclosingMargin(p.range_noise_sigma, p.voxelSize(t.dimensions), t.dimensions);
    Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();
    if (t.dimensions == 2) {
      inverse.topLeftCorner<2, 2>() = t.covariance.topLeftCorner<2, 2>().inverse();
    } else {
      inverse = t.covariance.inverse();
    }
    // 1e-9 relative: the fit's own check is on the same numbers in a different order.
    const double q = perception::chiSquareQuantile(t.probability, t.dimensions) * (1 + 1e-9);
    for (const auto& v : tracker.evidence(i)) {
      Eigen::Vector3d d = v.position.cast<double>() - t.center;
      if (t.dimensions == 2) d.z() = 0.0;
      const double length = d.norm();
      if (length > 0.0) d *= (length + margin) / length;
      if (!(d.dot(inverse * d) <= q)) return false;
    }
  }
  return true;
}

// No missed obstacle: how many of the scan's detection voxels (the detector's grid, finer than the 3-D
// tracks' evidence grid) lie inside no reported track ellipse. Tracks are binned by their bounding boxes on
// a 1 m grid, so each voxel is tested against the few tracks around it.
std::size_t uncoveredDetectionVoxels(std::span<const perception::ObstacleEllipsoid> detections,
                                     const std::vector<perception::ObstacleEllipsoid>& tracks) {
  auto cellOf = [](const Eigen::Vector3d& p) { return Eigen::Vector3i(p.array().floor().cast<int>()); };
  auto keyOf = [](const Eigen::Vector3i& c) {
    return (std::uint64_t(std::uint32_t(c.x()) & 0x1FFFFF) << 42) | (std::uint64_t(std::uint32_t(c.y()) & 0x1FFFFF) << 21) |
           std::uint64_t(std::uint32_t(c.z()) & 0x1FFFFF);
  };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> bins;
  for (std::uint32_t i = 0; i < tracks.size(); ++i) {
    const double r = tracks[i].semi_axes[0];
    const Eigen::Vector3i lo = cellOf(tracks[i].center.array() - r), hi = cellOf(tracks[i].center.array() + r);
    for (int x = lo.x(); x <= hi.x(); ++x)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int z = lo.z(); z <= hi.z(); ++z) bins[keyOf({x, y, z})].push_back(i);
  }
  std::size_t uncovered = 0;
  for (const auto& d : detections)
    for (const auto& v : d.support) {
      const Eigen::Vector3d p = v.position.cast<double>();
      const auto bin = bins.find(keyOf(cellOf(p)));
      const bool covered = bin != bins.end() && std::any_of(bin->second.begin(), bin->second.end(),
                                                             [&](std::uint32_t i) { return tracks[i].contains(p); });
      uncovered += !covered;
    }
  return uncovered;
}

ModelRun runModel(const LidarModel& model, const planner::Scenario& world, std::uint64_t seed, int scans,
                  double sigma, double invalid, int replays, nlohmann::json& out) {
  ModelRun run;
  run.lidar = model.name;
  run.seed = seed;
  run.scans = scans;
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
  // What the perception component runs before its tracker: the same detection without the per-piece
  // ellipse fit (fit_detections = false; the tracker refits its tracks from the voxels).
  perception::DetectorParams unfitted_params = params;
  unfitted_params.fit_detections = false;
  perception::ObstacleDetector unfitted_detector(unfitted_params);

  // The default tracker (refresh-only refits deferred), the same tracker refitting every change
  // (max_refit_delay 0), and the reference it must reproduce.
  // All three forget what lies beyond the lidar's range (+ 4 tolerances), as perception configured with
  // max_range = the sensor's would; the detector keeps its default max_range (detection unchanged).
  perception::TrackerParams tracker_params = perception::TrackerParams::matching(params);
  tracker_params.forget_radius = config.max_range + 4.0 * params.cluster_tolerance;
  perception::ObstacleTracker tracker(tracker_params);
  perception::TrackerParams exact_params = tracker_params;
  exact_params.max_refit_delay = 0;
  perception::ObstacleTracker exact_tracker(exact_params);
  perception::reference::ReferenceObstacleTracker reference_tracker(tracker_params);
  std::vector<double> unfitted_cpu, pcl_cpu, ours_cpu, sim_cpu, track_cpu, exact_track_cpu, ref_track_cpu, total_cpu, total_ms;
  // Each scan's detections and sensor origin, kept for --replay (copied outside the timed regions).
  std::vector<std::pair<std::vector<perception::ObstacleEllipsoid>, Eigen::Vector3d>> stored_scans;
  std::size_t track_mismatches = 0, exact_mismatches = 0, not_enclosed = 0, unfitted_mismatches = 0, uncovered_voxels = 0,
              detection_voxels = 0;
  std::size_t forgotten = 0, most_tracks = 0;
  std::size_t refreshed = 0, added = 0, created = 0, refitted = 0, refitted_late = 0, deferred = 0;
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
    const auto pieces = unfitted_detector.detect(cloud.points, cloud.origin, 3);
    const double t_unfitted = msSince(start), c_unfitted = threadCpuMs() - cpu;
    const bool same_pieces = samePieces(found, pieces);
    if (k >= 0) unfitted_mismatches += !same_pieces;
    if (replays > 0) stored_scans.push_back({pieces, cloud.origin});
    start = Clock::now();
    cpu = threadCpuMs();
    tracker.update(pieces, cloud.origin);
    const double c_track = threadCpuMs() - cpu, t_track = msSince(start);
    cpu = threadCpuMs();
    exact_tracker.update(pieces, cloud.origin);
    const double c_exact_track = threadCpuMs() - cpu;
    cpu = threadCpuMs();
    reference_tracker.update(pieces, cloud.origin);
    const double c_ref_track = threadCpuMs() - cpu;
    {
      // Refitting every change, the tracker keeps the reference's tracks (ids, voxel counts, centres);
      // with deferred refits it keeps the reference's evidence (ids, every voxel bit for bit) and every
      // voxel stays inside its track's ellipse.
      const auto& a = exact_tracker.obstacles();
      const auto& b = reference_tracker.obstacles();
      bool same_tracks = a.size() == b.size();
      for (std::size_t i = 0; same_tracks && i < a.size(); ++i)
        same_tracks = a[i].id == b[i].id && a[i].support.size() == b[i].support.size() &&
                      (a[i].center - b[i].center).cwiseAbs().maxCoeff() <= 1e-9;
      const auto& c = tracker.obstacles();
      bool same_evidence = c.size() == b.size();
      for (std::size_t i = 0; same_evidence && i < c.size(); ++i) {
        const auto voxels = tracker.evidence(i);
        same_evidence = c[i].id == b[i].id && voxels.size() == b[i].support.size();
        for (std::size_t v = 0; same_evidence && v < voxels.size(); ++v)
          same_evidence = voxels[v].position == b[i].support[v].position && voxels[v].bearing == b[i].support[v].bearing;
      }
      if (k >= 0) {
        exact_mismatches += !same_tracks;
        track_mismatches += !same_evidence;
        uncovered_voxels += uncoveredDetectionVoxels(pieces, tracker.obstacles());
        for (const auto& piece : pieces) detection_voxels += piece.support.size();
        not_enclosed += !everyVoxelEnclosed(tracker);
      }
    }
    if (k >= 0) {
      forgotten += tracker.lastUpdate().forgotten;
      most_tracks = std::max(most_tracks, tracker.obstacles().size());
      refreshed += tracker.lastUpdate().refreshed_voxels;
      added += tracker.lastUpdate().added_voxels;
      created += tracker.lastUpdate().created;
      refitted += tracker.lastUpdate().refitted;
      refitted_late += tracker.lastUpdate().refitted_late;
      deferred += tracker.lastUpdate().deferred;
    }

    const auto& st = detector.stats();
    size_t pcl_clustered = 0;
    for (const auto& c : reference.clusters()) pcl_clustered += c.size();
    const bool same = st.voxels == reference.voxelCountBeforeGround() && st.clusters == reference.clusters().size() &&
                      st.clustered_points == pcl_clustered && detector.voxels().size() == reference.voxels().size();
    if (k < 0) continue;
    mismatches += !same || !same_pieces;
    sim_ms.push_back(t_sim);
    pcl_ms.push_back(t_pcl);
    pcl_cpu.push_back(c_pcl);
    ours_cpu.push_back(c_ours);
    track_cpu.push_back(c_track);
    ref_track_cpu.push_back(c_ref_track);
    exact_track_cpu.push_back(c_exact_track);
    unfitted_cpu.push_back(c_unfitted);
    total_cpu.push_back(c_unfitted + c_track);
    total_ms.push_back(t_unfitted + t_track);
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
              " %zu new tracks; %zu tracks after the drive (most %zu, %zu forgotten beyond %.1f m)\n",
              trk.median, trk.p90, refreshed / scans, added / scans, created / scans, tracker.obstacles().size(),
              most_tracks, forgotten, tracker_params.forget_radius);
  std::printf("         tracker refits per scan: %zu (%zu of them deferred ones), %zu refresh-only tracks showing an"
              " older enclosing ellipse; every voxel inside its ellipse %zu/%d, same evidence as the reference %zu/%d;"
              " detection voxels inside no track ellipse: %zu of %zu\n",
              refitted / scans, refitted_late / scans, deferred / scans, scans - not_enclosed, scans,
              scans - track_mismatches, scans, uncovered_voxels, detection_voxels);
  const Summary ref_trk = summarize(ref_track_cpu), tot_c = summarize(total_cpu), tot = summarize(total_ms);
  const Summary exact_trk = summarize(exact_track_cpu);
  std::printf("         reference tracker (before optimisation, cpu ms): median %.2f, p90 %.2f -> %.1fx faster;"
              " refitting every change (max_refit_delay 0): median %.2f, p90 %.2f, same tracks %zu/%d\n",
              ref_trk.median, ref_trk.p90, ref_trk.median / trk.median, exact_trk.median, exact_trk.p90,
              scans - exact_mismatches, scans);
  std::printf("         detection as the component runs it (no per-piece fit, cpu ms): median %.2f\n",
              summarize(unfitted_cpu).median);
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
                 {"same_evidence_scans", scans - track_mismatches},
                 {"every_voxel_enclosed_scans", scans - not_enclosed},
                 {"detection_voxels", detection_voxels},
                 {"uncovered_detection_voxels", uncovered_voxels},
                 {"exact_tracker_cpu_ms", {{"median", exact_trk.median}, {"p90", exact_trk.p90}}},
                 {"exact_same_tracks_scans", scans - exact_mismatches},
                 {"seed", seed},
                 {"detect_track_cpu_ms", {{"median", tot_c.median}, {"p90", tot_c.p90}}},
                 {"detect_track_ms", {{"median", tot.median}, {"p90", tot.p90}}},
                 {"ratio_detect_track_cpu_median", tot_c.median / pcl_c.median},
                 {"ratio_detect_track_median", tot.median / pcl.median},
                 {"tracks", tracker.obstacles().size()}});
  if (replays > 0) {
    // The same detections through a fresh default tracker, `replays` times: the tracker's time without the
    // other trackers and detectors of this loop between its updates (their cache traffic).
    std::vector<double> totals;
    for (int r = 0; r < replays; ++r) {
      perception::ObstacleTracker t(tracker_params);
      double sum = 0;
      for (std::size_t i = 0; i < stored_scans.size(); ++i) {
        const double c0 = threadCpuMs();
        t.update(stored_scans[i].first, stored_scans[i].second);
        if (i >= 2) sum += threadCpuMs() - c0;
      }
      totals.push_back(sum / (stored_scans.size() - 2));
    }
    std::sort(totals.begin(), totals.end());
    std::printf("         replayed %d times through a fresh tracker: cpu ms per scan, mean of the drive: min %.2f, median %.2f\n",
                replays, totals.front(), totals[totals.size() / 2]);
  }
  if (mismatches) spdlog::error("{}: {} of {} scans differ from the PCL pipeline", model.name, mismatches, scans);
  if (track_mismatches)
    spdlog::error("{}: {} of {} scans: evidence differs from the reference tracker", model.name, track_mismatches, scans);
  if (exact_mismatches)
    spdlog::error("{}: {} of {} scans: tracks (max_refit_delay 0) differ from the reference tracker", model.name,
                  exact_mismatches, scans);
  if (unfitted_mismatches)
    spdlog::error("{}: {} of {} scans: detections without the fit carry other voxels", model.name, unfitted_mismatches, scans);
  if (not_enclosed) spdlog::error("{}: {} of {} scans: a voxel outside its track's ellipse", model.name, not_enclosed, scans);
  run.pcl_cpu_median = pcl_c.median;
  run.track_cpu_median = trk.median;
  run.total_cpu_median = tot_c.median;
  run.total_cpu_p90 = tot_c.p90;
  run.ratio = tot_c.median / pcl_c.median;
  run.p90_over_median = tot_c.p90 / tot_c.median;
  run.wall_ratio = tot.median / pcl.median;
  run.same_clusters = scans - static_cast<int>(mismatches);
  run.same_evidence = scans - static_cast<int>(track_mismatches + exact_mismatches);
  run.enclosed = scans - static_cast<int>(not_enclosed);
  run.detection_voxels = detection_voxels;
  run.uncovered_voxels = uncovered_voxels;
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Perception benchmark: stock PCL pipeline vs ddsnav perception on simulated city-block scans"};
  int scans = 30, seeds = 1, replays = 0;
  std::uint64_t seed = 1;
  std::string json_path;
  double sigma = 0.02, invalid = 0.005;
  app.add_option("--scans", scans, "timed scans per lidar model")->check(CLI::Range(1, 100000));
  app.add_option("--seed", seed, "city block and noise seed (the first one with --seeds)");
  app.add_option("--seeds", seeds, "run seeds seed .. seed + N - 1 and report the spread")->check(CLI::Range(1, 1000));
  app.add_option("--sigma", sigma, "lidar range noise, m")->check(CLI::Range(0.0, 1.0));
  app.add_option("--invalid", invalid, "fraction of NaN/inf returns")->check(CLI::Range(0.0, 1.0));
  app.add_option("--json", json_path, "also write the results as JSON here");
  app.add_option("--replay", replays, "also replay each drive's detections through a fresh tracker this many times")
      ->check(CLI::Range(0, 1000));
  std::string svg_path, scenario_path = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";
  app.add_option("--svg", svg_path, "draw the demo drive's final tracked ellipses here");
  app.add_option("--drive-scenario", scenario_path, "2-D scenario for the drive (default: demo_2d.yaml)");
  CLI11_PARSE(app, argc, argv);

  const std::vector<LidarModel> models = {
      {"16x1800", 16, 1800, -15.0, 15.0}, {"32x1024", 32, 1024, -20.0, 15.0}, {"64x1800", 64, 1800, -24.8, 2.0}};
  nlohmann::json out = nlohmann::json::array();
  std::vector<ModelRun> runs;
  bool failed = false;
  for (int s = 0; s < seeds; ++s) {
    const std::uint64_t this_seed = seed + static_cast<std::uint64_t>(s);
    const planner::Scenario world = sim::makeCityBlock(this_seed);
    std::printf("%scity block seed %llu: %zu obstacles, %d timed scans per model (+2 warm-up), noise %.3f m, invalid %.3f\n",
                s ? "\n" : "", static_cast<unsigned long long>(this_seed), world.obstacles.size(), scans, sigma, invalid);
    std::printf("times in ms per scan; first line wall clock, second line thread CPU time\n");
    std::printf("%-8s %8s %8s | %9s %9s | %9s %9s | %7s %7s | %9s | %s\n", "lidar", "points", "voxels", "pcl med",
                "pcl p90", "ours med", "ours p90", "ratio", "p90/med", "sim med", "same clusters");
    for (const auto& model : models) {
      runs.push_back(runModel(model, world, this_seed, scans, sigma, invalid, replays, out));
      const ModelRun& r = runs.back();
      failed = failed || r.same_clusters != scans || r.same_evidence != scans || r.enclosed != scans;
    }
  }

  // The spread over seeds: the per-seed medians of detect + track / PCL (thread CPU time).
  std::printf("\nDETECT+TRACK / PCL over %d seed(s) (%llu..%llu), thread CPU, per-seed medians of %d scans:\n", seeds,
              static_cast<unsigned long long>(seed), static_cast<unsigned long long>(seed + seeds - 1), scans);
  std::printf("%-8s | %7s %7s %7s %6s | %7s %7s %6s | %9s %9s | %s\n", "lidar", "median", "p90", "worst", "seed",
              "p90/med", "worst", "seed", "track med", "trk worst", "clusters/evidence/enclosed ok | detection voxels outside every track");
  std::printf("%-8s | %30s | %22s | %19s |\n", "", "ratio over seeds", "p90/med: median, worst", "tracker cpu ms");
  nlohmann::json spread = nlohmann::json::array();
  for (const auto& model : models) {
    std::vector<double> ratios, track_ms, tails;
    const ModelRun* worst = nullptr;
    const ModelRun* worst_tail = nullptr;
    int ok_clusters = 0, ok_evidence = 0, ok_enclosed = 0, total = 0;
    std::size_t detection_voxels = 0, uncovered_voxels = 0;
    for (const ModelRun& r : runs) {
      if (r.lidar != model.name) continue;
      ratios.push_back(r.ratio);
      track_ms.push_back(r.track_cpu_median);
      tails.push_back(r.p90_over_median);
      if (worst == nullptr || r.ratio > worst->ratio) worst = &r;
      if (worst_tail == nullptr || r.p90_over_median > worst_tail->p90_over_median) worst_tail = &r;
      ok_clusters += r.same_clusters;
      ok_evidence += r.same_evidence;
      ok_enclosed += r.enclosed;
      total += r.scans;
      detection_voxels += r.detection_voxels;
      uncovered_voxels += r.uncovered_voxels;
    }
    const Summary ratio = summarize(ratios), track = summarize(track_ms), tail = summarize(tails);
    std::printf("%-8s | %7.3f %7.3f %7.3f %6llu | %7.2f %7.2f %6llu | %9.2f %9.2f | %d/%d/%d of %d | %zu of %zu\n",
                model.name.c_str(), ratio.median, ratio.p90, worst->ratio,
                static_cast<unsigned long long>(worst->seed), tail.median, worst_tail->p90_over_median,
                static_cast<unsigned long long>(worst_tail->seed), track.median,
                *std::max_element(track_ms.begin(), track_ms.end()), ok_clusters, ok_evidence, ok_enclosed, total,
                uncovered_voxels, detection_voxels);
    spread.push_back({{"lidar", model.name},
                      {"seeds", seeds},
                      {"ratio_detect_track_cpu", {{"median", ratio.median}, {"p90", ratio.p90}, {"worst", worst->ratio}}},
                      {"worst_seed", worst->seed},
                      {"worst_p90_over_median", worst_tail->p90_over_median},
                      {"worst_p90_over_median_seed", worst_tail->seed}});
  }
  out.push_back({{"spread", spread}});
  out.push_back(demoDrive(scenario_path, svg_path));
  if (!json_path.empty()) {
    std::ofstream(json_path) << out.dump(2) << "\n";
  }
  return failed ? 1 : 0;
}
