// ddsnav-planner: planning/request -> planning/path. Plans on the newest world it has heard of:
// perception/obstacles (the default), map/octomap, both fused (the demo's choice), or the scenario's exact
// geometry (ground truth, for comparisons). Bounds, robot radius and vehicle limits come
// from the scenario file.

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"
#include <ddsnav/runtime/component.hpp>
#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/planner/planner.hpp>

#include <spdlog/spdlog.h>

#include <cmath>

using namespace ddsnav;
using nodes::sleepFor;

int main(int argc, char** argv) {
  return runtime::runComponent("planner", argc, argv, [](runtime::Context& ctx) {
    const auto scenario = planner::loadScenario(ctx.params().require<std::string>("scenario"));
    const auto world_params = nodes::declareWorldParameters(ctx.params());
    const auto kind = world_params.kind;
    const bool kinodynamic = ctx.params().declare<bool>("kinodynamic", scenario.vehicle.has_value());
    const double max_budget = ctx.params().declare<double>("max_time_budget_s", 30.0);
    if (!(max_budget > 0) || !std::isfinite(max_budget))
      throw runtime::ParameterError(fmt::format("parameter max_time_budget_s: expected a positive finite number of seconds, got {}", max_budget));
    if (kinodynamic && !scenario.vehicle) throw runtime::ParameterError("parameter kinodynamic: the scenario has no vehicle block");
    // "planner.option=value" entries (docs/planners.md, "Options"), checked once here against each planner.
    const auto planner_options = planner::parsePlannerOptions(
        ctx.params().declare<std::vector<std::string>>("planner_options", {}, "planner.option=value entries"));
    for (const auto& [name, assignments] : planner_options) {
      try {
        planner::applyOptions(*planner::makePlanner(name), assignments);
      } catch (const std::exception& e) {
        throw runtime::ParameterError(std::string("parameter planner_options: ") + e.what());
      }
    }

    nodes::WorldSource world_source(ctx.bus(), world_params, scenario);
    auto paths = ctx.bus().publisher<msg::Path>("planning/path", bus::Qos::state());

    auto answer = [&](const msg::PlanRequest& request) {
      const auto fail = [&](const std::string& why) {
        spdlog::warn("planning/request {}: {}", request.request_id(), why);
        planner::PlanResult failed;
        failed.planner = request.planner();
        msg::Path path = nodes::toMsg(failed, request.request_id(), ctx.clock().nowNs());
        path.failure(why);
        paths.publish(path);
      };
      // Every number of the request is bounded here, once: coordinates inside the scenario's bounds (a planner
      // would otherwise walk a 1e300 m segment), a positive finite budget, capped below. An empty frame_id
      // is taken as the map frame.
      const std::string frame = request.header().frame_id().empty() ? "" : nodes::kWorldFrame;
      if (const auto error = nodes::checkPlanRequest(request, scenario, frame); !error.empty())
        return fail("refused: " + error);
      std::unique_ptr<planner::Planner> algorithm;
      try {
        algorithm = planner::makePlanner(request.planner());
        if (auto it = planner_options.find(request.planner()); it != planner_options.end()) {
          planner::applyOptions(*algorithm, it->second);
        }
      } catch (const std::exception& e) {
        return fail(e.what());
      }
      // Every failure below is answered with an unsolved Path (the reason goes to the log): the requester
      // must hear back, and a bad world must not escape this bus callback.
      std::unique_ptr<planner::CollisionWorld> world;
      try {
        world = world_source.snapshot(nodes::fromMsg(request.start()).position);
      } catch (const std::exception& e) {
        return fail(std::string("cannot build the world: ") + e.what());
      }
      if (!world)
        return fail(kind == nodes::WorldKind::Map     ? "no map/octomap received yet"
                    : kind == nodes::WorldKind::Fused ? "no map/octomap and perception/obstacles received yet"
                                                      : "no perception/obstacles received yet");
      planner::PlanProblem problem;
      problem.world = world.get();
      problem.start = nodes::fromMsg(request.start());
      problem.goal = nodes::fromMsg(request.goal()).position;
      problem.goal_radius = request.goal_radius();
      problem.vehicle = scenario.vehicle;
      problem.kinodynamic = kinodynamic;
      problem.seed = request.seed();
      problem.time_limit_s = std::min(request.time_budget_s(), max_budget);
      try {
        const auto result = algorithm->solve(problem);
        spdlog::info("request {}: {} {} in {:.3f} s, {} iterations, cost {:.2f} m", request.request_id(), result.planner,
                     result.solved ? "solved" : "failed", result.stats.time_s, result.stats.iterations, result.cost);
        msg::Path path = nodes::toMsg(result, request.request_id(), ctx.clock().nowNs());
        if (!result.solved) {
          path.failure(fmt::format("no path within the time budget ({:.2f} s, {} iterations)", problem.time_limit_s,
                                   result.stats.iterations));
        }
        paths.publish(path);
      } catch (const std::exception& e) {
        fail(e.what());
      }
    };
    auto requests = ctx.bus().subscribe<msg::PlanRequest>("planning/request", bus::Qos::commands(), answer);

    ctx.ready();
    while (sleepFor(ctx, std::chrono::milliseconds(200))) {
    }
  });
}
