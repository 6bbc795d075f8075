// ddsnav-bench-mapper: OctoMap's insertPointCloud in each of its modes vs the mapper's insertion, on the same
// simulated lidar scans of a city block, in one run; then point-occupancy query throughput of OcTree::search
// vs the planner's OctoMap collision world on the resulting map. Every fast result is checked against the
// OctoMap result it claims to equal before its time is reported.
#include "ddsnav/mapper/occupancy_mapper.hpp"
#include "ddsnav/mapper/synthetic_scan.hpp"
#include "ddsnav/planner/coarse_route.hpp"
#include "ddsnav/planner/tree.hpp"
#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/scenario.hpp"
#include "ddsnav/tracker/smoother.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <octomap/OcTree.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <fstream>
#include <memory>
#include <optional>
#include <malloc.h>
#include <iostream>
#include <iterator>
#include <random>
#include <sstream>

namespace {

using namespace ddsnav::mapper;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string fullBytes(const octomap::OcTree& tree) {
  std::ostringstream s;
  tree.write(s);
  return s.str();
}

struct Run {
  std::string method;
  std::vector<double> seconds;  // per scan
  std::size_t memory = 0;       // OcTree::memoryUsage after the last scan
  std::size_t scratch = 0;      // ours: scratch buffers kept between scans
  std::size_t cells = 0;        // distinct voxel updates over all scans
  double rays = 0, merge = 0, tree = 0;  // ours: summed phase times, s
  bool identical = true;        // the map equals the reference it claims to equal
  std::string reference;
  double meanMs() const {
    double s = 0;
    for (double x : seconds) s += x;
    return 1000.0 * s / seconds.size();
  }
  double cellsPerSecond() const {
    double s = 0;
    for (double x : seconds) s += x;
    return cells / s;
  }
};

struct Pattern {
  int rings, columns;
};

Pattern parsePattern(const std::string& s) {
  Pattern p{};
  if (std::sscanf(s.c_str(), "%dx%d", &p.rings, &p.columns) != 2 || p.rings < 1 || p.columns < 1) {
    throw CLI::ValidationError("--patterns", "expected RINGSxCOLUMNS such as 16x1800, got '" + s + "'");
  }
  return p;
}

int queryMismatches(const octomap::OcTree& a, const octomap::OcTree& b, int points, int rays, unsigned seed) {
  double x0, y0, z0, x1, y1, z1;
  a.getMetricMin(x0, y0, z0);
  a.getMetricMax(x1, y1, z1);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(x0, x1), uy(y0, y1), uz(z0, z1), angle(-3.14159, 3.14159);
  int mismatches = 0;
  for (int i = 0; i < points; ++i) {
    const double x = ux(rng), y = uy(rng), z = uz(rng);
    const octomap::OcTreeNode* na = a.search(x, y, z);
    const octomap::OcTreeNode* nb = b.search(x, y, z);
    if ((na == nullptr) != (nb == nullptr) || (na && a.isNodeOccupied(na) != b.isNodeOccupied(nb))) ++mismatches;
  }
  for (int i = 0; i < rays; ++i) {
    const octomap::point3d o(ux(rng) * 0.3, uy(rng) * 0.3, 1.8f);
    const double yaw = angle(rng), pitch = 0.2 * angle(rng);
    const octomap::point3d d(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
    octomap::point3d ea, eb;
    const bool ha = a.castRay(o, d, ea, true, 20.0), hb = b.castRay(o, d, eb, true, 20.0);
    if (ha != hb || !(ea == eb)) ++mismatches;
  }
  return mismatches;
}

}  // namespace

// --world-map: the planner's world from a recorded map, built 5 times each way (the mean per build). The 3-D defaults
// are solid below the surface with a 1 m margin yielding to space observed free (docs/world-model.md).
// With `route` (x0 y0 z0 x1 y1 z1), also the lattice route search between the two points on each world (the planner's
// per-request search, docs/planners.md "Lattice routes"), without its time limit.
// With a scenario too, gart-lazy from the route's start to its end, seeds 1-10, with the route as its guide and without.
int timeWorldBuilds(const std::string& path, const std::vector<double>& route, const std::string& scenario_path, double wall_cost,
                    int smoothings, bool samplers) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  octomap::OcTree tree(0.1);
  std::istringstream stream(std::string(bytes.begin(), bytes.end()));
  if (!tree.readBinary(stream)) {
    std::fprintf(stderr, "--world-map %s: not a binary OctoMap (.bt)\n", path.c_str());
    return 1;
  }
  double x0, y0, z0, x1, y1, z1;
  tree.getMetricMin(x0, y0, z0);
  tree.getMetricMax(x1, y1, z1);
  using ddsnav::planner::Vec3;
  constexpr int kBuilds = 5;
  std::optional<ddsnav::planner::Scenario> scenario;
  if (!scenario_path.empty()) scenario = ddsnav::planner::loadScenario(scenario_path);
  // The digest of a world's answers (free or not) on a 64 x 64 x 64 lattice over the box: two builds of this
  // binary, or of two binaries, with the same digest built the same world there.
  auto digest = [&](const ddsnav::planner::CollisionWorld& world) {
    std::uint64_t hash = 1469598103934665603ull;  // FNV-1a over the answers
    constexpr int kSteps = 64;
    for (int k = 0; k < kSteps; ++k)
      for (int j = 0; j < kSteps; ++j)
        for (int i = 0; i < kSteps; ++i) {
          const Vec3 p(x0 + (x1 - x0) * (i + 0.5) / kSteps, y0 + (y1 - y0) * (j + 0.5) / kSteps, z0 + (z1 - z0) * (k + 0.5) / kSteps);
          hash = (hash ^ (world.isFree(p) ? 1u : 0u)) * 1099511628211ull;
        }
    return hash;
  };
  std::printf("| world from %s (%zu bytes, %zu nodes) | ms per build | digest of its answers | ns per isFree (the digest's 262 144) |\n|---|---|---|---|\n",
              path.c_str(), bytes.size(), tree.size());
  auto time = [&](const char* name, int dims, const ddsnav::planner::OctoMapWorldOptions& options) {
    const auto started = Clock::now();
    for (int i = 0; i < kBuilds; ++i) ddsnav::planner::makeOctoMapWorld(dims, Vec3(x0, y0, z0), Vec3(x1, y1, z1), 0.5, bytes, options);
    const double ms = 1000.0 * secondsSince(started) / kBuilds;
    const std::shared_ptr<const ddsnav::planner::CollisionWorld> world =
        ddsnav::planner::makeOctoMapWorld(dims, Vec3(x0, y0, z0), Vec3(x1, y1, z1), 0.5, bytes, options);
    const auto queried = Clock::now();
    const std::uint64_t answers = digest(*world);
    const double ns_per_query = 1e9 * secondsSince(queried) / (64.0 * 64.0 * 64.0);
    std::printf("| %s | %.1f | %016llx | %.0f |\n", name, ms, static_cast<unsigned long long>(answers), ns_per_query);
    if (route.size() == 6 && dims == 2 && options.unknown_margin_m > 0.0) {
      // The seen surfaces continued out of sight from the route's start (the planner's preferred world, 15 m): on a
      // fresh world, where finding the surfaces' ends is part of it, then once more from the route's end.
      const auto continued_started = Clock::now();
      const auto from_start = ddsnav::planner::occludedSurfaceContinuation(*world, Vec3(route[0], route[1], 0.0), 15.0);
      const double first_ms = 1e3 * secondsSince(continued_started);
      const auto again_started = Clock::now();
      const auto from_end = ddsnav::planner::occludedSurfaceContinuation(*world, Vec3(route[3], route[4], 0.0), 15.0);
      std::printf("|   seen surfaces continued out of sight: %zu cells in %.1f ms on a fresh world, %zu from another viewpoint in %.1f ms | | | |\n",
                  from_start.cells.size(), first_ms, from_end.cells.size(), 1e3 * secondsSince(again_started));
    }
    if (route.size() == 6) {
      ddsnav::planner::CoarseRouteOptions lattice;
      lattice.time_limit_s = 60.0;
      lattice.wall_cost = wall_cost;
      const auto found = ddsnav::planner::findCoarseRoute(*world, Vec3(route[0], route[1], route[2]), Vec3(route[3], route[4], route[5]),
                                                          1.0, lattice);
      const char* outcome = found.outcome == ddsnav::planner::CoarseRoute::Outcome::found ? "found"
                            : found.outcome == ddsnav::planner::CoarseRoute::Outcome::none ? "none" : "gave up";
      std::printf("|   lattice route: %s, %.1f m, %zu cells expanded in %.1f ms (%.2f us per cell) | | | |\n", outcome,
                  found.length_m, found.expanded, 1e3 * found.time_s, 1e6 * found.time_s / std::max<std::size_t>(found.expanded, 1));
      if (found.outcome == ddsnav::planner::CoarseRoute::Outcome::found) {
        // The route as the planner component answers with it (route_path): shortcut, clearance kept.
        const auto shortcut_started = Clock::now();
        const auto path = ddsnav::planner::pathAlongRoute(*world, found, ddsnav::planner::State{Vec3(route[0], route[1], route[2]), 0.0},
                                                          Vec3(route[3], route[4], route[5]), 1.0);
        const double shortcut_ms = 1e3 * secondsSince(shortcut_started);
        const double length = ddsnav::planner::pathLength(path);
        double least_clearance = std::numeric_limits<double>::infinity();
        for (std::size_t i = 1; i + 1 < path.size(); ++i) least_clearance = std::min(least_clearance, world->clearance(path[i].position));
        std::printf("|   route path: %zu states, %.1f m, least corner clearance %.2f m, in %.1f ms | | | |\n", path.size(), length,
                    least_clearance, shortcut_ms);
        if (scenario && scenario->vehicle && path.size() >= 2) {
          // Smoothed as the tracker component smooths a plan (its defaults: 1 m clearance target, repairs within the
          // robot radius), --smoothings times (5): the path -> trajectory share of a replan's latency.
          ddsnav::tracker::SmootherConfig smoothing;
          smoothing.clearance_target = 1.0;
          smoothing.repair_distance = scenario->robot_radius;
          std::vector<double> smooth_ms;
          std::string outcome_text;
          for (int i = 0; i < smoothings; ++i) {
            const auto smoothing_started = Clock::now();
            try {
              const auto trajectory = ddsnav::tracker::smoothPath(path, *world, *scenario->vehicle, smoothing);
              outcome_text = fmt::format("{:.1f} m, {:.1f} s, min clearance {:.2f} m", trajectory.report.length, trajectory.report.duration,
                                         trajectory.report.min_clearance);
            } catch (const std::exception& e) {
              outcome_text = std::string("refused: ") + e.what();
            }
            smooth_ms.push_back(1e3 * secondsSince(smoothing_started));
          }
          std::sort(smooth_ms.begin(), smooth_ms.end());
          std::printf("|   smoothed as the tracker does: %s; ms median %.1f, max %.1f | | | |\n", outcome_text.c_str(), smooth_ms[smooth_ms.size() / 2],
                      smooth_ms.back());
        }
      }
      if (scenario && samplers) {
        // As the planner component queries it (`world: fused`): the map beside perception's ellipses, here none.
        const auto fused = ddsnav::planner::makeFusedWorld(
            world, ddsnav::planner::makeEllipsoidWorld(dims, world->boundsMin(), world->boundsMax(), 0.5, {}));
        for (const double bias : {0.0, 0.3, 0.6, 0.9}) {
          std::vector<double> times;
          std::vector<std::size_t> iterations;
          int solved = 0;
          for (std::uint64_t seed = 1; seed <= 10; ++seed) {
            auto planner = ddsnav::planner::makePlanner("gart-lazy");
            ddsnav::planner::PlanProblem problem;
            problem.world = fused.get();
            problem.start.position = Vec3(route[0], route[1], route[2]);
            problem.goal = Vec3(route[3], route[4], route[5]);
            problem.goal_radius = scenario->goal_radius;
            problem.vehicle = scenario->vehicle;
            problem.seed = seed;
            problem.time_limit_s = 2.0;
            if (bias > 0.0) ddsnav::planner::guideAlong(problem, found, bias);
            const auto result = planner->solve(problem);
            solved += result.solved ? 1 : 0;
            times.push_back(1e3 * result.stats.time_s);
            iterations.push_back(result.stats.iterations);
          }
          std::sort(times.begin(), times.end());
          std::sort(iterations.begin(), iterations.end());
          std::printf("|   gart-lazy, guide bias %.1f: %d of 10 solved in 2 s; ms median %.0f, max %.0f; iterations median %zu, max %zu | | | |\n",
                      bias, solved, times[5], times.back(), iterations[5], iterations.back());
        }
      }
    }
    return world;
  };
  // A 2-D mission's map is one voxel layer: its worlds are the plain map and the planner's preferred world with the
  // unknown margin (1 m, the default for a 0.5 m robot; docs/world-model.md).
  if (z1 - z0 <= 1.5 * tree.getResolution()) {
    ddsnav::planner::OctoMapWorldOptions margin;
    margin.unknown_margin_m = 1.0;
    time("2-D plain", 2, {});
    time("2-D with the 1 m unknown margin", 2, margin);
    return 0;
  }
  ddsnav::planner::OctoMapWorldOptions solid_below;
  solid_below.solid_below_surface = true;
  ddsnav::planner::OctoMapWorldOptions defaults_3d = solid_below;
  defaults_3d.surface_margin_m = 1.0;
  time("plain (occupied voxels only)", 3, {});
  time("solid below the surface, no margin", 3, solid_below);
  time("3-D defaults (solid below, 1 m margin yielding to free space)", 3, defaults_3d);
  // The planner's build: the same with its preferred world's 3 m margin too (preferred_surface_margin_m); the digest is
  // the plain world's answers, and the view's follow.
  ddsnav::planner::OctoMapWorldOptions planners_3d = defaults_3d;
  planners_3d.wider_surface_margin_m = 3.0;
  const auto built = time("the planner's 3-D build (the 1 m margin and the preferred world's 3 m)", 3, planners_3d);
  if (const auto view = ddsnav::planner::makeWiderMarginView(built)) {
    const auto queried = Clock::now();
    const std::uint64_t answers = digest(*view);
    std::printf("|   its preferred world (makeWiderMarginView: no build) | – | %016llx | %.0f |\n", static_cast<unsigned long long>(answers),
                1e9 * secondsSince(queried) / (64.0 * 64.0 * 64.0));
  }
  return 0;
}

// --planar-corridor: a 2-D scanner (720 beams, 0.5 degrees, 66 m: the paper-scale default) driven down the middle of
// a 2 m corridor 100 m long, a scan every 0.5 m; the mapper as the component configures it for 2-D (0.1 m, the
// beam-gap rays, 2 threads, pipelined) with and without the surface fill, and OctoMap's insertPointCloud of the same
// scans. The fill is what a face seen at a grazing angle costs (docs/world-model.md).
int timePlanarCorridor(int scans) {
  constexpr double kHalfWidth = 1.0, kLength = 100.0, kRange = 66.0;
  std::vector<Scan> corridor_scans;
  for (int k = 0; k < scans; ++k) {
    const double ox = 0.5 * k;
    Scan scan;
    scan.origin = {static_cast<float>(ox), 0.0f, 0.0f};
    scan.max_range = kRange;
    for (int i = 0; i < 720; ++i) {
      const double a = i * 0.5 * M_PI / 180.0, c = std::cos(a), sn = std::sin(a);
      double t = std::numeric_limits<double>::infinity();
      if (std::abs(sn) > 1e-12) t = kHalfWidth / std::abs(sn);                     // a side wall
      if (c > 1e-12) t = std::min(t, (kLength - ox) / c);                         // the far end
      if (c < -1e-12) t = std::min(t, (ox + 5.0) / -c);                           // the near end
      if (t <= kRange) scan.points.push_back({static_cast<float>(ox + t * c), static_cast<float>(t * sn), 0.0f});
    }
    corridor_scans.push_back(std::move(scan));
  }
  std::printf("| 2-D corridor, %d scans of 720 beams, 0.1 m | ms per scan, mean | max |\n|---|---|---|\n", scans);
  auto time = [&](const char* name, const std::function<void(const Scan&)>& insert) {
    double total = 0.0, worst = 0.0;
    for (const Scan& scan : corridor_scans) {
      const auto started = Clock::now();
      insert(scan);
      const double s = secondsSince(started);
      total += s;
      worst = std::max(worst, s);
    }
    std::printf("| %s | %.2f | %.2f |\n", name, 1000.0 * total / scans, 1000.0 * worst);
    return total;
  };
  MapperConfig config;
  config.dimensions = 2;
  config.resolution = 0.1;
  config.clear_beam_gaps = true;
  config.threads = 2;
  config.pipeline = true;
  OccupancyMapper plain(config);
  const double without = time("mapper, beam-gap rays (fill off)", [&](const Scan& s) { plain.insert(s); });
  config.fill_surfaces_between_returns = true;
  OccupancyMapper filling(config);
  const double with = time("mapper, beam-gap rays + surface fill (the component's default)", [&](const Scan& s) { filling.insert(s); });
  octomap::OcTree reference(0.1);
  time("OctoMap insertPointCloud (no gap rays, no fill)", [&](const Scan& s) {
    octomap::Pointcloud cloud;
    for (const Point3f& p : s.points) cloud.push_back(p.x, p.y, 0.0f);
    reference.insertPointCloud(cloud, octomap::point3d(s.origin.x, s.origin.y, 0.0f), s.max_range);
  });
  std::printf("\nfill on / off: %.2fx\n", with / without);
  return 0;
}

// `scans` scans of `lidar` in `city`, the vehicle 1 m further (and 0.3 m to the side every other scan) each time,
// cut at max_range.
std::vector<Scan> streetScans(const CityBlock& city, const LidarPattern& lidar, int scans, double max_range, unsigned seed) {
  std::vector<Scan> out;
  for (int i = 0; i < scans; ++i) {
    Scan s = simulateScan(city, lidar, {float(i) * 1.0f, 0.3f * float(i % 2), 1.8f}, 100 * seed + i);
    s.max_range = max_range;
    out.push_back(std::move(s));
  }
  return out;
}

// --ring-gaps: the simulator's default 3-D lidar (16 rings x 512 columns, +-15 degrees) driven through a city block,
// a scan every metre, into the mapper as the component configures it for 3-D (2 threads, pipelined) with and
// without clear_beam_gaps' per-ring gap rays: what clearing a ring's beams that returned nothing (sky between
// buildings, windows) costs per scan. Resolution and range as --resolutions' first and --max-range.
int timeRingGaps(int scans, double resolution, double max_range, unsigned seed) {
  const CityBlock city = makeCityBlock(seed);
  LidarPattern lidar;
  lidar.rings = 16;
  lidar.columns = 512;
  lidar.sim_range = max_range;
  lidar.range_noise = 0.02;
  const std::vector<Scan> ring_scans = streetScans(city, lidar, scans, max_range, seed);
  // The map is exported after every second scan: the component publishes at 5 Hz from 10 Hz clouds.
  std::printf("| 3-D lidar 16x512, %d scans, %.2f m, range %.1f m, city block seed %u | ms per scan, mean | max | gap rays per scan "
              "| export every 2nd scan, ms mean | max | map bytes, last |\n"
              "|---|---|---|---|---|---|---|\n",
              scans, resolution, max_range, seed);
  // The component's default: per-ring gap rays, and free space found where nothing else changed, beyond a third of the
  // range, exported up to 5 exports late (free_space_delay_s 1 s at 5 Hz) — against every export exact.
  struct Variant {
    bool gaps;
    int delay_exports;
    const char* name;
  };
  const Variant variants[] = {{false, 0, "no gap rays, every export exact"},
                              {true, 0, "gap rays per ring, every export exact"},
                              {true, 5, "gap rays per ring, new free space beyond a third of the range up to 5 exports late (the component's default)"}};
  double totals[2] = {0.0, 0.0};
  for (const Variant& variant : variants) {
    const bool gaps = variant.gaps;
    MapperConfig config;
    config.dimensions = 3;
    config.resolution = resolution;
    config.threads = 2;
    config.pipeline = true;
    config.clear_beam_gaps = gaps;
    config.free_discovery_delay_exports = variant.delay_exports;
    config.free_discovery_near_range_m = max_range / 3.0;
    OccupancyMapper mapper(config);
    double total = 0.0, worst = 0.0, export_total = 0.0, export_worst = 0.0;
    std::size_t rays = 0, exports = 0, bytes = 0;
    for (std::size_t i = 0; i < ring_scans.size(); ++i) {
      const auto started = Clock::now();
      rays += mapper.insert(ring_scans[i]).gap_rays;
      mapper.finish();  // the pipelined tree update belongs to this scan's time
      const double t = secondsSince(started);
      total += t;
      worst = std::max(worst, t);
      if (i % 2 == 1) {
        const auto export_started = Clock::now();
        bytes = mapper.exportMap().octree_binary.size();
        const double e = secondsSince(export_started);
        export_total += e;
        export_worst = std::max(export_worst, e);
        ++exports;
      }
    }
    if (variant.delay_exports == 0) totals[gaps] = total;
    // With a delay: the bytes of a complete export of the same tree after the last one, for what was left out.
    const std::string complete = variant.delay_exports > 0 ? fmt::format(" (complete: {})", mapper.exportMap(/*complete=*/true).octree_binary.size()) : "";
    std::printf("| mapper, %s | %.2f | %.2f | %.0f | %.2f | %.2f | %zu%s |\n", variant.name, 1000.0 * total / scans, 1000.0 * worst,
                double(rays) / scans, exports ? 1000.0 * export_total / exports : 0.0, 1000.0 * export_worst, bytes, complete.c_str());
  }
  std::printf("\ngap rays on / off: %.2fx\n", totals[1] / totals[0]);
  return 0;
}

int main(int argc, char** argv) {
  CLI::App app{"OctoMap insertion and occupancy queries: OctoMap's own paths vs ddsnav's mapper, same scans"};
  std::vector<std::string> pattern_names{"16x1800", "64x1800"};
  std::vector<double> resolutions{0.1, 0.2};
  int scans = 3;
  double max_range = 20.0;
  int threads = 2;
  int queries = 1'000'000;
  int seeds = 1;
  unsigned first_seed = 7;
  std::string json_path;
  bool profile_ours = false;
  app.add_option("--patterns", pattern_names, "lidar patterns RINGSxCOLUMNS")->delimiter(',');
  app.add_option("--resolutions", resolutions, "map resolutions, m")->delimiter(',')->check(CLI::Range(0.01, 10.0));
  app.add_option("--scans", scans, "scans per configuration (the vehicle moves 1 m between scans)")->check(CLI::Range(1, 1000));
  app.add_option("--max-range", max_range, "insertion max range, m")->check(CLI::Range(0.5, 1000.0));
  app.add_option("--threads", threads, "threads for the multi-threaded row of ours")->check(CLI::Range(1, 64));
  app.add_option("--queries", queries, "random point queries for the query benchmark")->check(CLI::Range(1000, 100'000'000));
  app.add_option("--seed", first_seed, "city block seed (the first one with --seeds)");
  app.add_option("--seeds", seeds, "run city blocks seed .. seed + N - 1 and report the spread")->check(CLI::Range(1, 100));
  app.add_option("--json", json_path, "also write the results as JSON to this file");
  app.add_flag("--profile-ours", profile_ours, "only run our insertion (no OctoMap runs, no checks): for profilers");
  std::string world_map;
  app.add_option("--world-map", world_map,
                 "only time the planner's world built from this .bt (a mission's map.bt, `ddsnav bench-mission --keep-recordings`): "
                 "plain and with the 3-D defaults, in the map's own box")
      ->check(CLI::ExistingFile);
  bool planar_corridor = false;
  app.add_flag("--planar-corridor", planar_corridor,
               "only time 2-D insertion down a 2 m corridor (--scans scans, 0.5 m apart): the mapper with and without the "
               "surface fill, and OctoMap");
  bool ring_gaps = false;
  app.add_flag("--ring-gaps", ring_gaps,
               "only time 3-D insertion of a 16x512 lidar in the city block (--scans, --resolutions' first, --max-range, --seed): "
               "the mapper with and without the per-ring gap rays");
  std::vector<double> route;
  app.add_option("--route", route, "with --world-map: also time the lattice route search from X0,Y0,Z0 to X1,Y1,Z1 on each world")
      ->delimiter(',')->expected(6);
  std::string route_scenario;
  app.add_option("--route-scenario", route_scenario, "with --route: also solve with gart-lazy and this scenario's vehicle, guided and not")
      ->check(CLI::ExistingFile);
  double wall_cost = ddsnav::planner::CoarseRouteOptions{}.wall_cost;
  app.add_option("--wall-cost", wall_cost, "with --route: the lattice's extra cost of a move near a wall (CoarseRouteOptions::wall_cost)")
      ->check(CLI::Range(0.0, 100.0));
  int smoothings = 5;
  app.add_option("--smoothings", smoothings, "with --route-scenario: how many times the route path is smoothed (more for a profiler)")
      ->check(CLI::Range(1, 100'000));
  bool no_samplers = false;
  app.add_flag("--no-samplers", no_samplers, "with --route-scenario: leave out the gart-lazy runs (a profiler's view of the rest)");
  CLI11_PARSE(app, argc, argv);
  if (!world_map.empty()) return timeWorldBuilds(world_map, route, route_scenario, wall_cost, smoothings, !no_samplers);
  if (ring_gaps) return timeRingGaps(scans, resolutions.front(), max_range, first_seed);
  if (planar_corridor) return timePlanarCorridor(scans);

  std::vector<Pattern> patterns;
  try {
    for (const std::string& s : pattern_names) patterns.push_back(parsePattern(s));
  } catch (const CLI::Error& e) {
    return app.exit(e);
  }

  nlohmann::json out = nlohmann::json::array();
  struct Row {
    std::string config, method;
    double ms, speedup;
    unsigned seed;
  };
  std::vector<Row> rows;
  std::vector<std::uint8_t> query_map;  // the finest map, for the query benchmark
  double query_map_resolution = 0.0;
  bool all_identical = true;

  for (int seed_index = 0; seed_index < seeds; ++seed_index) {
  const unsigned seed = first_seed + static_cast<unsigned>(seed_index);
  const CityBlock city = makeCityBlock(seed);
  std::printf("%s## city block seed %u\n\n", seed_index ? "\n" : "", seed);
  std::printf("| scan | res m | method | ms/scan | M cell updates/s | speed-up vs fastest OctoMap | phases ms: rays / merge+sort / tree | tree MB | working MB | identical to |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Pattern& pattern : patterns) {
    LidarPattern lidar;
    lidar.rings = pattern.rings;
    lidar.columns = pattern.columns;
    lidar.min_elevation_deg = pattern.rings >= 32 ? -25.0 : -15.0;
    lidar.max_elevation_deg = 15.0;
    lidar.range_noise = 0.02;
    const std::vector<Scan> scan_list = streetScans(city, lidar, scans, max_range, seed);
    std::size_t points = 0;
    for (const Scan& s : scan_list) points += s.points.size();

    for (double res : resolutions) {
      MapperConfig config;
      config.resolution = res;
      config.threads = threads;
      std::vector<octomap::Pointcloud> clouds;
      for (const Scan& s : scan_list) {
        octomap::Pointcloud c;
        for (const Point3f& p : s.points) c.push_back(p.x, p.y, p.z);
        clouds.push_back(std::move(c));
      }

      // Every method inserts scan i before any method sees scan i + 1 (round-robin), so a change in the
      // machine's load during the run hits all methods alike.
      octomap::OcTree plain(res), lazy(res), disc(res), lazy_disc(res);
      struct OctoMapMethod {
        const char* name;
        octomap::OcTree* tree;
        bool lazy, discretize;
      };
      const std::vector<OctoMapMethod> octomap_methods = {{"octomap insertPointCloud", &plain, false, false},
                                                          {"octomap lazy_eval", &lazy, true, false},
                                                          {"octomap discretize", &disc, false, true},
                                                          {"octomap lazy_eval+discretize", &lazy_disc, true, true}};
      struct OurMethod {
        std::string name;
        bool discretize;
        int threads;
      };
      std::vector<OurMethod> our_methods = {{"ours, 1 thread (library default)", false, 1},
                                            {"ours, " + std::to_string(threads) + " threads", false, threads},
                                            {"ours discretize (1 thread)", true, 1}};
      if (profile_ours) our_methods = {{"ours", false, threads}};
      std::vector<std::unique_ptr<OccupancyMapper>> mappers;
      std::vector<Run> runs;
      if (!profile_ours) {
        for (const OctoMapMethod& m : octomap_methods) {
          applySensorModel(*m.tree, config);
          runs.emplace_back().method = m.name;
        }
      }
      for (const OurMethod& m : our_methods) {
        MapperConfig c = config;
        c.discretize = m.discretize;
        c.threads = m.threads;
        mappers.push_back(std::make_unique<OccupancyMapper>(c));
        runs.emplace_back().method = m.name;
      }
      const std::size_t first_ours = profile_ours ? 0 : octomap_methods.size();
      for (std::size_t i = 0; i < scan_list.size(); ++i) {
        const Scan& s = scan_list[i];
        for (std::size_t k = 0; k < first_ours; ++k) {
          const OctoMapMethod& m = octomap_methods[k];
          const auto t = Clock::now();
          m.tree->insertPointCloud(clouds[i], octomap::point3d(s.origin.x, s.origin.y, s.origin.z), max_range, m.lazy,
                                   m.discretize);
          if (m.lazy) m.tree->updateInnerOccupancy();  // the map is published after every scan
          runs[k].seconds.push_back(secondsSince(t));
        }
        for (std::size_t k = 0; k < mappers.size(); ++k) {
          Run& run = runs[first_ours + k];
          const auto t = Clock::now();
          const InsertResult r = mappers[k]->insert(s);
          run.seconds.push_back(secondsSince(t));
          run.cells += r.free_cells + r.occupied_cells;
          run.rays += r.seconds_rays, run.merge += r.seconds_merge, run.tree += r.seconds_tree;
          if (!r.inserted) spdlog::error("scan rejected: {}", r.message);
        }
      }
      // Pipelined (tree update of scan i during the ray keys of scan i + 1): timed as a whole sequence, not
      // round-robin, since its background tree thread would otherwise run during the other methods' turns.
      std::unique_ptr<OccupancyMapper> pipelined;
      if (!profile_ours) {
        MapperConfig c = config;
        c.threads = threads;
        c.pipeline = true;
        pipelined = std::make_unique<OccupancyMapper>(c);
        Run& run = runs.emplace_back();
        run.method = "ours, " + std::to_string(threads) + " threads pipelined (mapper component default)";
        const auto t = Clock::now();
        for (const Scan& s : scan_list) {
          const InsertResult r = pipelined->insert(s);
          run.cells += r.free_cells + r.occupied_cells;
          run.rays += r.seconds_rays, run.merge += r.seconds_merge, run.tree += r.seconds_tree;
          if (!r.inserted) spdlog::error("scan rejected: {}", r.message);
        }
        pipelined->finish();
        const double total = secondsSince(t);
        run.seconds.assign(scan_list.size(), total / double(scan_list.size()));  // throughput per scan
        run.memory = pipelined->octree().memoryUsage();
        run.scratch = pipelined->scratchMemoryUsage();
      }
      for (std::size_t k = 0; k < first_ours; ++k) runs[k].memory = octomap_methods[k].tree->memoryUsage();
      for (std::size_t k = 0; k < mappers.size(); ++k) {
        runs[first_ours + k].memory = mappers[k]->octree().memoryUsage();
        runs[first_ours + k].scratch = mappers[k]->scratchMemoryUsage();
      }

      if (profile_ours) {
        const Run& r = runs[0];
        std::printf("| ours | %.2f | %.1f ms/scan | rays %.1f / merge %.1f / tree %.1f ms |\n", res, r.meanMs(),
                    1e3 * r.rays / scans, 1e3 * r.merge / scans, 1e3 * r.tree / scans);
        continue;
      }
      const OccupancyMapper* ours = mappers[0].get();
      const OccupancyMapper* ours1 = mappers[1].get();
      const OccupancyMapper* ours_disc = mappers[2].get();
      for (Run& r : runs) {
        if (r.method.find("discretize") != std::string::npos) r.cells = runs[6].cells;
        else if (r.method.rfind("octomap", 0) == 0) r.cells = runs[4].cells;
      }
      // The checks: whole trees (structure and every log-odds value) and query answers.
      const std::string plain_bytes = fullBytes(plain), disc_bytes = fullBytes(disc);
      runs[4].identical = fullBytes(ours->octree()) == plain_bytes && queryMismatches(ours->octree(), plain, 100000, 10000, 1) == 0 &&
                          queryMismatches(ours->octree(), lazy, 100000, 10000, 2) == 0;
      runs[4].reference = "insertPointCloud (tree bytes) and lazy_eval (100k points, 10k rays)";
      runs[5].identical = fullBytes(ours1->octree()) == plain_bytes;
      runs[5].reference = "insertPointCloud (tree bytes)";
      runs[6].identical = fullBytes(ours_disc->octree()) == disc_bytes && queryMismatches(ours_disc->octree(), disc, 100000, 10000, 3) == 0;
      runs[6].reference = "discretize (tree bytes, 100k points, 10k rays)";
      runs[7].identical = fullBytes(pipelined->octree()) == plain_bytes;
      runs[7].reference = "insertPointCloud (tree bytes)";
      double fastest_octomap = 1e300;
      for (int i = 0; i < 4; ++i) fastest_octomap = std::min(fastest_octomap, runs[i].meanMs());

      // OctoMap's working memory during one insertion: the two KeySets computeUpdate fills (heap bytes in use
      // while they are alive, from mallinfo2), against our scratch buffers' capacity.
      std::size_t octomap_keysets = 0;
      for (std::size_t i = 0; i < clouds.size(); ++i) {
        const std::size_t before = mallinfo2().uordblks;
        octomap::KeySet free_cells, occupied_cells;
        plain.computeUpdate(clouds[i], octomap::point3d(scan_list[i].origin.x, scan_list[i].origin.y, scan_list[i].origin.z),
                            free_cells, occupied_cells, max_range);
        octomap_keysets = std::max(octomap_keysets, static_cast<std::size_t>(mallinfo2().uordblks - before));
      }
      for (int i = 0; i < 4; ++i) runs[i].scratch = octomap_keysets;

      const std::string scan_name = std::to_string(pattern.rings) + "x" + std::to_string(pattern.columns) + " (" +
                                    std::to_string(points / scan_list.size()) + " pts)";
      for (const Run& r : runs) {
        all_identical = all_identical && r.identical;
        const double n = double(r.seconds.size());
        const std::string phases = r.method.rfind("ours", 0) == 0 && r.method.find("pipelined") == std::string::npos
                                       ? fmt::format("{:.0f} / {:.0f} / {:.0f}", 1e3 * r.rays / n, 1e3 * r.merge / n, 1e3 * r.tree / n)
                                       : "-";
        std::printf("| %s | %.2f | %s | %.1f | %.2f | %.2fx | %s | %.1f | %.1f | %s |\n", scan_name.c_str(), res,
                    r.method.c_str(), r.meanMs(), r.cellsPerSecond() / 1e6, fastest_octomap / r.meanMs(), phases.c_str(),
                    r.memory / 1e6, r.scratch / 1e6, r.reference.empty() ? "-" : (r.identical ? ("yes: " + r.reference).c_str() : "NO"));
        rows.push_back({fmt::format("{}x{} {:.2f} m", pattern.rings, pattern.columns, res), r.method, r.meanMs(),
                        fastest_octomap / r.meanMs(), seed});
        out.push_back({{"seed", seed}, {"scan", scan_name}, {"resolution", res}, {"method", r.method}, {"ms_per_scan", r.meanMs()},
                       {"cell_updates_per_s", r.cellsPerSecond()}, {"speedup_vs_fastest_octomap", fastest_octomap / r.meanMs()},
                       {"tree_bytes", r.memory}, {"scratch_bytes", r.scratch}, {"identical", r.identical},
                       {"scans", scans}, {"max_range", max_range}});
      }
      std::fflush(stdout);
      if (seed_index == 0 && (query_map.empty() || res <= query_map_resolution)) {
        const ExportedMap m = mappers[0]->exportMap();
        query_map = m.octree_binary;
        query_map_resolution = res;
      }
    }
  }

  }  // seeds

  if (profile_ours) return 0;
  // The spread over seeds: per configuration and method, the speed-up against the fastest OctoMap mode
  // of the same seed's run (median, p90, worst) and the slowest seed's ms per scan.
  std::printf("\n## spread over %d seed(s) (%u..%u): speed-up vs the fastest OctoMap mode of the same run\n\n", seeds,
              first_seed, first_seed + seeds - 1);
  std::printf("| configuration | method | speed-up median | p10 (90 %% of seeds reach it) | worst | worst seed | ms/scan median | ms/scan worst |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  std::vector<std::pair<std::string, std::string>> keys;
  for (const Row& r : rows)
    if (r.method.rfind("ours", 0) == 0 &&
        std::find(keys.begin(), keys.end(), std::make_pair(r.config, r.method)) == keys.end())
      keys.emplace_back(r.config, r.method);
  nlohmann::json spread = nlohmann::json::array();
  for (const auto& [config_name, method] : keys) {
    std::vector<double> speedups, ms;
    const Row* worst = nullptr;
    for (const Row& r : rows) {
      if (r.config != config_name || r.method != method) continue;
      speedups.push_back(r.speedup);
      ms.push_back(r.ms);
      if (worst == nullptr || r.speedup < worst->speedup) worst = &r;
    }
    std::sort(speedups.begin(), speedups.end());
    std::sort(ms.begin(), ms.end());
    auto at = [](const std::vector<double>& v, double q) { return v[static_cast<std::size_t>(q * (v.size() - 1) + 0.5)]; };
    // For a speed-up the bad tail is the low side: "p90" is the value 90 % of the seeds reach.
    std::printf("| %s | %s | %.2fx | %.2fx | %.2fx | %u | %.1f | %.1f |\n", config_name.c_str(), method.c_str(),
                at(speedups, 0.5), at(speedups, 0.1), speedups.front(), worst->seed, at(ms, 0.5), ms.back());
    spread.push_back({{"configuration", config_name}, {"method", method}, {"speedup_median", at(speedups, 0.5)},
                      {"speedup_p10", at(speedups, 0.1)}, {"speedup_worst", speedups.front()}, {"worst_seed", worst->seed},
                      {"ms_median", at(ms, 0.5)}, {"ms_worst", ms.back()}});
  }
  out.push_back({{"spread", spread}});
  // Query throughput on the last finest map: OcTree::search vs the planner's OctoMap world (radius 0).
  {
    octomap::OcTree tree(0.1);
    std::istringstream in(std::string(query_map.begin(), query_map.end()));
    const auto read_started = Clock::now();
    tree.readBinary(in);
    const double read_s = secondsSince(read_started);
    double x0, y0, z0, x1, y1, z1;
    tree.getMetricMin(x0, y0, z0);
    tree.getMetricMax(x1, y1, z1);
    using ddsnav::planner::Vec3;
    const Vec3 lo(x0, y0, z0), hi(x1, y1, z1);
    auto t = Clock::now();
    const auto world = ddsnav::planner::makeOctoMapWorld(3, lo - Vec3::Constant(1), hi + Vec3::Constant(1), 0.0, query_map);
    const double load_s = secondsSince(t);
    // The planner's 3-D defaults: solid below the surface, a 1 m margin that yields to space observed free (a
    // second pass over the octree for the free voxels under the margin; docs/world-model.md).
    ddsnav::planner::OctoMapWorldOptions terrain_options;
    terrain_options.solid_below_surface = true;
    terrain_options.surface_margin_m = 1.0;
    t = Clock::now();
    ddsnav::planner::makeOctoMapWorld(3, lo - Vec3::Constant(1), hi + Vec3::Constant(1), 0.5, query_map, terrain_options);
    const double terrain_load_s = secondsSince(t);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> ux(x0, x1), uy(y0, y1), uz(z0, z1);
    std::vector<Vec3> pts(queries);
    for (Vec3& p : pts) p = Vec3(ux(rng), uy(rng), uz(rng));
    std::vector<char> a(queries), b(queries);
    t = Clock::now();
    for (int i = 0; i < queries; ++i) {
      const octomap::OcTreeNode* n = tree.search(pts[i].x(), pts[i].y(), pts[i].z());
      a[i] = n != nullptr && tree.isNodeOccupied(n);
    }
    const double search_s = secondsSince(t);
    t = Clock::now();
    for (int i = 0; i < queries; ++i) b[i] = !world->isFree(pts[i]);
    const double world_s = secondsSince(t);
    const bool same = a == b;
    all_identical = all_identical && same;
    const std::size_t occupied = std::count(a.begin(), a.end(), 1);

    const auto robot = ddsnav::planner::makeOctoMapWorld(3, lo - Vec3::Constant(1), hi + Vec3::Constant(1), 0.3, query_map);
    t = Clock::now();
    std::size_t robot_blocked = 0;
    for (int i = 0; i < queries; ++i) robot_blocked += !robot->isFree(pts[i]);
    const double robot_s = secondsSince(t);

    std::printf("\n| query (%d random points in the %.2f m map, %zu occupied) | M queries/s | ns/query | ratio |\n", queries,
                query_map_resolution, occupied);
    std::printf("|---|---|---|---|\n");
    std::printf("| OcTree::search + isNodeOccupied | %.2f | %.0f | 1.00x |\n", queries / search_s / 1e6, 1e9 * search_s / queries);
    std::printf("| OctoMap world isFree, radius 0 (identical answers: %s) | %.2f | %.0f | %.2fx |\n", same ? "yes" : "NO",
                queries / world_s / 1e6, 1e9 * world_s / queries, search_s / world_s);
    std::printf("| OctoMap world isFree, robot radius 0.3 m (%zu blocked) | %.2f | %.0f | %.2fx |\n", robot_blocked,
                queries / robot_s / 1e6, 1e9 * robot_s / queries, search_s / robot_s);
    std::printf("\nloading the %zu map bytes: OcTree::readBinary %.1f ms, OctoMap world (parse + flatten) %.1f ms, with the 3-D "
                "defaults (solid below the surface, 1 m margin yielding to free space) %.1f ms\n",
                query_map.size(), 1000 * read_s, 1000 * load_s, 1000 * terrain_load_s);
    out.push_back({{"query", "point occupancy"}, {"queries", queries}, {"octree_search_per_s", queries / search_s},
                   {"world_isfree_per_s", queries / world_s}, {"ratio", search_s / world_s}, {"identical", same},
                   {"world_radius_0.3_per_s", queries / robot_s}, {"world_load_s", load_s}, {"world_load_3d_defaults_s", terrain_load_s}, {"octree_read_binary_s", read_s}});
  }
  if (!json_path.empty()) std::ofstream(json_path) << out.dump(2) << "\n";
  if (!all_identical) {
    std::fprintf(stderr, "MISMATCH: a fast result differs from its OctoMap reference\n");
    return 1;
  }
  return 0;
}
