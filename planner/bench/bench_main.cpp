// ddsnav bench: every scenario x planner x seed, ddsnav's planners and OMPL's side by side on the same
// CollisionWorld; writes runs.csv, summary.md and chart.svg into --out.
#include "bench_run.hpp"

#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/tree.hpp"
#include "ddsnav/planner/unicycle.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <unistd.h>

namespace ddsnav::bench {

using planner::CollisionWorld;
using planner::PlanProblem;
using planner::Scenario;

PlanProblem makeProblem(const Scenario& scenario, const CollisionWorld& world, std::uint64_t seed, double time_limit_s,
                        bool kinodynamic, bool anytime) {
  PlanProblem problem = planner::problemFromScenario(scenario, world);
  problem.tree_metrics = true;  // the benchmark reports c(G), g(G) and FGC
  problem.kinodynamic = kinodynamic;
  problem.seed = seed;
  problem.time_limit_s = time_limit_s;
  problem.anytime = anytime;
  return problem;
}

namespace {

// The independent check of a returned path: it starts at the start, ends in the goal ball, every edge
// is collision free, and (kinodynamic results) every edge lies in the forward extending region.
void checkPath(const planner::PlanResult& result, const Scenario& scenario, const CollisionWorld& world,
               const PlanProblem& problem, RunRecord& r) {
  r.valid = false;
  if (result.path.empty()) {
    r.invalid_reason = "empty path";
    return;
  }
  if ((result.path.front().position - problem.start.position).norm() > 1e-9) {
    r.invalid_reason = "path does not start at the start";
    return;
  }
  if ((result.path.back().position - problem.goal).norm() > problem.goal_radius + 1e-9) {
    r.invalid_reason = "path does not end in the goal region";
    return;
  }
  if (result.kinodynamic) {
    const auto region = planner::forwardRegion(*problem.vehicle, scenario.dimensions);
    const planner::PathCheck check = planner::checkUnicyclePath(result.path, region, &world);
    r.valid = check.ok;
    r.invalid_reason = check.reason;
    return;
  }
  for (std::size_t i = 0; i + 1 < result.path.size(); ++i) {
    if (!world.isSegmentFree(result.path[i].position, result.path[i + 1].position)) {
      r.invalid_reason = "edge " + std::to_string(i) + " in collision";
      return;
    }
  }
  r.valid = true;
}

// A planner of the grid: a spec ("gart", "gart{rewire=false}") plus the grid-wide --option assignments.
std::unique_ptr<planner::Planner> makeOurs(const std::string& spec, const std::vector<std::string>& options) {
  auto p = planner::makePlannerFromSpec(spec);
  planner::applyOptions(*p, options);
  return p;
}

// Splits --planners at the commas outside braces: "gart{event1=false,rewire=false},rrt".
std::vector<std::string> splitPlannerList(const std::vector<std::string>& args) {
  std::vector<std::string> out;
  for (const std::string& arg : args) {
    std::string current;
    int depth = 0;
    for (char c : arg) {
      if (c == '{') ++depth;
      if (c == '}') --depth;
      if (c == ',' && depth == 0) {
        if (!current.empty()) out.push_back(current);
        current.clear();
      } else {
        current += c;
      }
    }
    if (!current.empty()) out.push_back(current);
  }
  return out;
}

// --ablation: GART with all parts on, then with each part off in turn (and the whole field off).
std::vector<std::string> gartAblation() {
  return {"gart",
          "gart{event1=false}",
          "gart{event2=false}",
          "gart{event3=false}",
          "gart{event2=false,event3=false}",
          "gart{goal_attraction=false}",
          "gart{event1=false,event2=false,event3=false,goal_attraction=false}",
          "gart{forward_region=false}",
          "gart{effort_parent=false}",
          "gart{choose_parent=false}",
          "gart{rewire=false}",
          "gart{choose_parent=false,rewire=false}"};
}

RunRecord runOurs(const std::string& name, const std::vector<std::string>& options, const Scenario& scenario,
                  const CollisionWorld& world, const PlanProblem& problem) {
  RunRecord r;
  r.planner = name;
  r.scenario = scenario.name;
  r.seed = problem.seed;
  planner::PlanResult result;
  try {
    result = makeOurs(name, options)->solve(problem);
  } catch (const std::invalid_argument& e) {
    r.invalid_reason = e.what();  // e.g. a unicycle planner on a scenario without a vehicle block
    return r;
  }
  const planner::PlanStats& s = result.stats;
  r.solved = result.solved;
  r.exact = result.exact;
  r.kinodynamic = result.kinodynamic;
  r.time_s = s.time_s;
  r.time_to_first_s = s.time_to_first_solution_s;
  r.iterations = static_cast<std::int64_t>(s.iterations);
  r.iterations_to_first = s.iterations_to_first_solution;
  r.vertices = static_cast<std::int64_t>(s.vertices);
  r.cost = result.solved ? result.cost : -1.0;
  r.pous = s.pous;
  r.por = s.por;
  r.coverage = s.coverage;
  r.growth = s.growth;
  r.validity_checks = s.validity_checks;
  r.fdc = s.first_directive_connect;
  r.fgc = s.first_glance_connect;
  if (r.solved) checkPath(result, scenario, world, problem, r);
  return r;
}

class ProgressBar {
 public:
  explicit ProgressBar(std::size_t total) : total_(total), tty_(isatty(STDERR_FILENO) != 0) {}
  void show(std::size_t done, const std::string& what) {
    constexpr int kWidth = 30;
    const int filled = total_ ? static_cast<int>(kWidth * done / total_) : kWidth;
    std::string line = "[" + std::string(static_cast<std::size_t>(filled), '#') +
                       std::string(static_cast<std::size_t>(kWidth - filled), '.') + "] " + std::to_string(done) +
                       "/" + std::to_string(total_) + "  " + what;
    if (tty_) {
      line.resize(std::max<std::size_t>(line.size(), last_), ' ');
      std::cerr << '\r' << line << std::flush;
      last_ = line.size();
    } else if (done == total_ || done % std::max<std::size_t>(1, total_ / 20) == 0) {
      std::cerr << line << '\n';  // logs and pipes get a line every 5 %
    }
  }
  void finish() {
    if (tty_) std::cerr << '\n';
  }

 private:
  std::size_t total_;
  bool tty_;
  std::size_t last_ = 0;
};

}  // namespace
}  // namespace ddsnav::bench

int main(int argc, char** argv) {
  using namespace ddsnav;
  CLI::App app{"Benchmark planners over scenarios and seeds (ddsnav's and, when built with it, OMPL's)"};
  std::vector<std::string> scenario_files, planner_names;
  int seeds = 5;
  double time_limit = 10.0;
  std::string out_dir;
  bool kinodynamic = false, anytime = false, ablation = false;
  std::vector<std::string> planner_args, options;
  app.add_option("--scenarios", scenario_files, "scenario YAML files")->required()->expected(1, -1);
  app.add_option("--planners", planner_args, "comma-separated planners: ddsnav names (rrt, rrtstar, lirrt, gart, ...), "
                                             "each optionally with options as name{k=v,k=v}, "
                                             "and ompl:rrt, ompl:rrtconnect, ompl:rrtstar, ompl:bitstar, "
                                             "ompl:control-rrt, ompl:sst, ompl:est, ompl:pdst");
  app.add_option("--option", options, "option name=value for every ddsnav planner of the grid (each must have it)");
  app.add_flag("--ablation", ablation, "add GART with each of its parts switched off (docs/benchmarks/planner.md)");
  app.add_option("--seeds", seeds, "seeds 1..N per scenario and planner")->check(CLI::Range(1, 100000));
  app.add_option("--time-limit", time_limit, "seconds per run, > 0");
  app.add_option("--out", out_dir, "output directory (created)")->required();
  app.add_flag("--kinodynamic", kinodynamic, "rrt/rrtstar/... grow unicycle edges (lirrt, gart and ompl control planners always do)");
  app.add_flag("--anytime", anytime, "keep improving until the time limit instead of stopping at the first solution");
  CLI11_PARSE(app, argc, argv);

  try {
    planner_names = bench::splitPlannerList(planner_args);
    if (ablation) {
      for (const std::string& spec : bench::gartAblation()) {
        if (std::find(planner_names.begin(), planner_names.end(), spec) == planner_names.end()) planner_names.push_back(spec);
      }
    }
    if (planner_names.empty()) throw std::invalid_argument("no planners: give --planners and/or --ablation");
    if (!std::isfinite(time_limit) || time_limit <= 0.0) {
      throw std::invalid_argument("--time-limit must be a positive number of seconds");
    }
    // Check every name before the first run, so a typo does not cost a long grid.
    const auto ours = planner::plannerNames();
    const auto ompl_names = bench::omplPlannerNames();
    for (const std::string& name : planner_names) {
      const bool is_ompl = std::find(ompl_names.begin(), ompl_names.end(), name) != ompl_names.end();
      if (is_ompl) continue;
      if (name.rfind("ompl:", 0) != 0) {
        bench::makeOurs(name, options);  // throws for an unknown planner or a bad option
        continue;
      }
      if (name.rfind("ompl:", 0) == 0 && !bench::omplAvailable()) {
        throw std::invalid_argument("planner '" + name + "' needs OMPL, which was not found when ddsnav was built");
      }
      std::string known;
      for (const auto& n : ours) known += (known.empty() ? "" : ", ") + n;
      for (const auto& n : ompl_names) known += ", " + n;
      throw std::invalid_argument("unknown planner '" + name + "' (known: " + known + ")");
    }
    std::vector<planner::Scenario> scenarios;
    for (const std::string& file : scenario_files) scenarios.push_back(planner::loadScenario(file));

    std::filesystem::create_directories(out_dir);
    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);

    std::vector<bench::RunRecord> runs;
    bench::ProgressBar bar(scenarios.size() * planner_names.size() * static_cast<std::size_t>(seeds));
    std::size_t done = 0;
    for (const planner::Scenario& scenario : scenarios) {
      const auto world = planner::makeScenarioWorld(scenario);
      for (const std::string& name : planner_names) {
        for (int seed = 1; seed <= seeds; ++seed) {
          bar.show(done, scenario.name + "  " + name + "  seed " + std::to_string(seed));
          const planner::PlanProblem problem =
              bench::makeProblem(scenario, *world, static_cast<std::uint64_t>(seed), time_limit, kinodynamic, anytime);
          bench::RunRecord r;
          if (name.rfind("ompl:", 0) == 0) {
            // In a child process: OMPL's SST can ignore its time limit and loop forever, and Debian's OMPL
            // aborts on failed assertions. Errors such as a control planner on a scenario without a
            // vehicle come back as the run's note.
            bench::RunRecord identity;
            identity.planner = name;
            identity.scenario = scenario.name;
            identity.seed = problem.seed;
            r = bench::runIsolated([&] { return bench::runOmpl(name, scenario, *world, problem); }, time_limit,
                                   identity);
          } else {
            r = bench::runOurs(name, options, scenario, *world, problem);
          }
          if (r.solved && !r.valid) {
            spdlog::warn("{} on {} seed {}: returned path failed the independent check: {}", name, scenario.name, seed,
                         r.invalid_reason);
          }
          runs.push_back(std::move(r));
          ++done;
        }
      }
    }
    bar.show(done, "done");
    bar.finish();

    const std::filesystem::path out(out_dir);
    bench::writeRunsCsv((out / "runs.csv").string(), runs);
    bench::writeSummaryMarkdown((out / "summary.md").string(), runs, command, time_limit);
    bench::writeChartSvg((out / "chart.svg").string(), runs, time_limit);
    std::cout << "wrote " << (out / "runs.csv").string() << ", " << (out / "summary.md").string() << ", "
              << (out / "chart.svg").string() << std::endl;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  return 0;
}
