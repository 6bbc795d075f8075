// ddsnav plan: solve one scenario with one planner, print statistics (or one JSON line), draw an SVG.
#include "ddsnav/planner/coarse_route.hpp"
#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/scenario.hpp"
#include "ddsnav/planner/svg.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

namespace {

using namespace ddsnav::planner;

nlohmann::json toJson(const std::string& scenario_file, const Scenario& scenario, const PlanResult& r,
                      std::uint64_t seed) {
  auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  nlohmann::json path = nlohmann::json::array();
  for (const State& s : r.path) {
    if (scenario.dimensions == 3) path.push_back({s.position.x(), s.position.y(), s.position.z(), s.heading});
    else path.push_back({s.position.x(), s.position.y(), s.heading});
  }
  const PlanStats& st = r.stats;
  return {{"scenario", scenario.name},
          {"scenario_file", scenario_file},
          {"planner", r.planner},
          {"seed", seed},
          {"solved", r.solved},
          {"exact", r.exact},
          {"kinodynamic", r.kinodynamic},
          {"time_s", st.time_s},
          {"time_to_first_solution_s", number(st.time_to_first_solution_s >= 0 ? st.time_to_first_solution_s : NAN)},
          {"iterations", st.iterations},
          {"iterations_to_first_solution", st.iterations_to_first_solution},
          {"vertices", st.vertices},
          {"validity_checks", st.validity_checks},
          {"rewires", st.rewires},
          {"restarts", st.restarts},
          {"cost", number(r.cost)},
          {"pous", st.pous},
          {"por", st.por},
          {"fdc", st.first_directive_connect},
          {"tree_metrics", st.tree_metrics},
          {"fgc", st.tree_metrics ? nlohmann::json(st.first_glance_connect) : nlohmann::json(nullptr)},
          {"coverage", st.tree_metrics ? nlohmann::json(st.coverage) : nlohmann::json(nullptr)},
          {"growth", st.tree_metrics ? nlohmann::json(st.growth) : nlohmann::json(nullptr)},
          {"path", path}};
}

// A one-line progress display on stderr for runs a user waits on (long time limits, --anytime): only when
// stderr is a terminal, so logs and pipes stay clean, and at most four updates a second.
class ProgressLine {
 public:
  explicit ProgressLine(double time_limit_s) : limit_s_(time_limit_s), enabled_(isatty(STDERR_FILENO) == 1) {}
  ~ProgressLine() {
    if (shown_) std::fprintf(stderr, "\r%*s\r", 60, "");
  }
  void update(std::uint64_t iterations) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    if (elapsed < 0.5 || now - last_ < std::chrono::milliseconds(250)) return;  // short runs show nothing
    last_ = now;
    shown_ = true;
    std::fprintf(stderr, "\rplanning: %.1f / %.1f s, %llu iterations ", elapsed, limit_s_,
                 static_cast<unsigned long long>(iterations));
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point last_ = start_;
  double limit_s_;
  bool enabled_;
  bool shown_ = false;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Plan a path through a scenario with one planner"};
  std::string scenario_file, planner_name, svg_file;
  std::uint64_t seed = 1;
  double time_limit = 10.0;
  std::uint64_t max_iterations = std::numeric_limits<std::uint64_t>::max();
  bool anytime = false, json = false, kinodynamic = false, tree_metrics = false, list_options = false;
  std::vector<std::string> options;
  app.add_option("--scenario", scenario_file, "scenario YAML file")->required();
  app.add_option("--planner", planner_name, "planner: rrt, rrtstar, lirrt, gart, gart-lazy, apgd-rrtstar, rrrt, ddrrt, rrt-controls")->required();
  app.add_option("--seed", seed, "random seed (same seed, same result)");
  app.add_option("--time-limit", time_limit, "seconds, > 0");
  app.add_option("--max-iterations", max_iterations, "iteration cap, > 0");
  app.add_flag("--anytime", anytime, "keep improving until a limit instead of stopping at the first solution");
  double improve_for = std::numeric_limits<double>::infinity();
  app.add_option("--improve-for", improve_for, "with --anytime: stop this many seconds after the first solution (as the planner component's improve_for_s)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--svg", svg_file, "write a picture of the world, tree and path");
  app.add_flag("--json", json, "print exactly one JSON object on one line");
  app.add_flag("--kinodynamic", kinodynamic, "rrt/rrtstar: grow unicycle edges (needs the scenario's vehicle block)");
  app.add_option("--option", options, "planner option name=value (repeatable; docs/planners.md lists them)");
  app.add_flag("--tree-metrics", tree_metrics, "also compute c(G), g(G) and FGC (within the time limit)");
  double guide_bias = 0.0;
  app.add_option("--guide-bias", guide_bias,
                 "draw this share of the samples along a lattice route found first (as the planner component's guide_bias; "
                 "docs/planners.md, \"Lattice routes\"); 0: uniform sampling")
      ->check(CLI::Range(0.0, 1.0));
  bool route_path = false;
  app.add_flag("--route-path", route_path,
               "also find a lattice route (as --guide-bias does) and answer with it, shortcut, when the planner's path is "
               "longer or there is none (as the planner component's route_path; docs/planners.md, \"The route as the answer\")");
  app.add_flag("--list-options", list_options, "print the planner's options, their ranges and defaults, and exit");
  CLI11_PARSE(app, argc, argv);

  try {
    if (!std::isfinite(time_limit) || time_limit <= 0.0) {
      throw std::invalid_argument("--time-limit must be a positive number of seconds, got " + std::to_string(time_limit));
    }
    if (max_iterations == 0) throw std::invalid_argument("--max-iterations must be positive");
    auto planner = makePlanner(planner_name);  // unknown names and bad options fail before the scenario is read
    applyOptions(*planner, options);
    if (list_options) {
      for (const PlannerOption& o : planner->options()) {
        std::printf("%s = %s  (%s) %s\n", o.name.c_str(), o.value.c_str(), o.range().c_str(), o.description.c_str());
      }
      if (planner->options().empty()) std::printf("planner %s has no options\n", planner->name().c_str());
      return 0;
    }
    const Scenario scenario = loadScenario(scenario_file);
    const auto world = makeScenarioWorld(scenario);

    PlanProblem problem = problemFromScenario(scenario, *world);
    problem.kinodynamic = kinodynamic;
    problem.seed = seed;
    problem.time_limit_s = time_limit;
    problem.max_iterations = max_iterations;
    problem.anytime = anytime;
    problem.improve_for_s = improve_for;
    problem.tree_metrics = tree_metrics;
    if (kinodynamic && !scenario.vehicle) {
      throw std::invalid_argument("--kinodynamic needs a 'vehicle' block in " + scenario_file);
    }

    std::optional<PlanResult> along_route;
    if (guide_bias > 0.0 || route_path) {
      CoarseRouteOptions lattice;
      lattice.time_limit_s = time_limit;
      const CoarseRoute route = findCoarseRoute(*world, problem.start.position, problem.goal, problem.goal_radius, lattice);
      if (!json)
        std::printf("lattice route (%.3f m cells): %s, %.1f m, %zu cells expanded in %.4f s\n", route.cell_m,
                    route.outcome == CoarseRoute::Outcome::found  ? "found"
                    : route.outcome == CoarseRoute::Outcome::none ? "none"
                                                                   : "gave up",
                    route.length_m, route.expanded, route.time_s);
      guideAlong(problem, route, guide_bias);
      if (route_path) {
        along_route = resultAlongRoute(*world, route, problem);
        if (!json) std::printf("route path: %s\n", along_route ? "found" : "none (no route, or a move the world's checks refuse)");
      }
    }

    PlanResult result;
    {
      ProgressLine progress(time_limit);
      problem.on_progress = [&progress](std::uint64_t iterations) { progress.update(iterations); };
      result = planner->solve(problem);
    }
    if (along_route) {
      const std::string sampler = result.planner;
      const double sampled_cost = result.solved ? result.cost : -1.0;
      std::vector<TreeEdge> tree = std::move(result.tree);
      result = shorterAnswer(std::move(result), std::move(*along_route));
      if (result.planner != sampler) {
        if (!json && sampled_cost >= 0.0)
          std::printf("%s: found %.1f m; answering with the lattice route, %.1f m\n", sampler.c_str(), sampled_cost, result.cost);
        else if (!json)
          std::printf("%s: found none; answering with the lattice route, %.1f m\n", sampler.c_str(), result.cost);
      }
      result.tree = std::move(tree);  // the sampler's, for --svg
    }

    if (!svg_file.empty()) {
      SvgScene scene;
      scene.scenario = &scenario;
      scene.tree = result.tree;
      scene.path = result.path;
      char title[256];
      std::snprintf(title, sizeof title, "%s - %s, seed %llu: %s, cost %.2f m, %llu iterations, %.4f s",
                    scenario.name.c_str(), result.planner.c_str(), static_cast<unsigned long long>(seed),
                    result.solved ? "solved" : "not solved", result.solved ? result.cost : 0.0,
                    static_cast<unsigned long long>(result.stats.iterations), result.stats.time_s);
      scene.title = title;
      writeSvg(svg_file, scene);
    }

    if (json) {
      std::cout << toJson(scenario_file, scenario, result, seed).dump() << std::endl;
    } else {
      const PlanStats& s = result.stats;
      std::printf("scenario %s, planner %s, seed %llu%s\n", scenario.name.c_str(), result.planner.c_str(),
                  static_cast<unsigned long long>(seed), result.kinodynamic ? " (unicycle edges)" : " (geometric)");
      std::printf("solved: %s (exact: %s)\n", result.solved ? "yes" : "no", result.exact ? "yes" : "no");
      if (result.solved) {
        std::printf("cost %.3f m, %zu states, first solution after %.6f s / %lld iterations\n", result.cost,
                    result.path.size(), s.time_to_first_solution_s, static_cast<long long>(s.iterations_to_first_solution));
      }
      std::printf("time %.6f s, iterations %llu, vertices %llu, validity checks %llu, rewires %llu\n", s.time_s,
                  static_cast<unsigned long long>(s.iterations), static_cast<unsigned long long>(s.vertices),
                  static_cast<unsigned long long>(s.validity_checks), static_cast<unsigned long long>(s.rewires));
      std::printf("POUS %.3f, POR %.3f, FDC %lld\n", s.pous, s.por, static_cast<long long>(s.first_directive_connect));
      if (s.tree_metrics) {
        std::printf("FGC %lld, c(G) %.4f, g(G) %.3g\n", static_cast<long long>(s.first_glance_connect), s.coverage, s.growth);
      } else if (tree_metrics) {
        std::printf("tree metrics: not finished within the time limit\n");
      }
    }
    return 0;  // an unsolved run is a result (solved: false), not an error
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddsnav plan: error: %s\n", e.what());
    return 2;
  }
}
