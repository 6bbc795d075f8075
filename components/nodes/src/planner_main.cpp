// ddsnav-planner: planning/request -> planning/path. Plans on the newest world it has heard of:
// perception/obstacles (the default), map/octomap, both fused (the demo's choice), or the scenario's exact
// geometry (ground truth, for comparisons). Bounds, robot radius and vehicle limits come
// from the scenario file.
//
// Requests are checked on the executor; the solve runs on the worker, so world updates keep arriving
// meanwhile. A request that comes before the planner's world is ready waits for it (at most its time
// budget). A newer request from the same requester (the same DDS writer) supersedes the one queued or
// solving, which stops at its next iteration and is answered as superseded, and replaces one still waiting.

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/map_scale.hpp"
#include "ddsnav/nodes/validate.hpp"
#include "ddsnav/nodes/world_tier.hpp"
#include <ddsnav/runtime/component.hpp>
#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/planner/coarse_route.hpp>
#include <ddsnav/planner/planner.hpp>

#include <spdlog/spdlog.h>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <stop_token>
#include <thread>
#include <vector>

using namespace ddsnav;

namespace {

class PlannerComponent : public runtime::Component {
 public:
  struct Params {
    std::string scenario;
    nodes::WorldParameters world;  // world, unknown_space
    std::optional<bool> kinodynamic;
    double max_time_budget_s;
    std::optional<double> unknown_margin_m;       // default: nodes::defaultUnknownMargin
    std::optional<double> hidden_continuation_m;  // default: nodes::defaultHiddenContinuation
    double preferred_surface_margin_m;
    double improve_for_s;
    double preferred_worlds_s;
    std::optional<double> route_lattice_s;  // default: 0.03 s in 2-D, 0 (off) in 3-D
    double guide_bias;
    std::optional<double> previous_path_bias;  // default: 0.3 in 3-D, 0 (off) in 2-D
    bool route_path;
    bool plain_beside_preferred;
    double map_wait_s;
    std::vector<std::string> planner_options;
    explicit Params(runtime::Parameters& p)
        : scenario(p.require<std::string>("scenario", runtime::ParamSpec{.doc = "scenario file: bounds, robot radius, vehicle limits"})),
          world(p),
          kinodynamic(p.declareOptional<bool>("kinodynamic", {.doc = "plan unicycle edges; default: whether the scenario has a vehicle block"})),
          max_time_budget_s(p.declare<double>("max_time_budget_s", 30.0,
                                              {.above = 0, .unit = "s", .doc = "cap on a request's time_budget_s"})),
          unknown_margin_m(p.declareOptional<double>(
              "unknown_margin_m",
              {.min = 0, .max = 100, .unit = "m",
               .doc = "2-D map and fused worlds, optimistic: plan first keeping never-observed space this close to a seen surface blocked "
                      "(its unseen part continues), then, with no path in a tenth of the budget, on the plain map (docs/world-model.md); 0: off; "
                      "default min(1 m, 2 x the robot radius)"})),
          // On by default since it stopped the first plans of the bug traps from leaving through the stretches of wall
          // hidden behind the neck (docs/world-model.md, "Seen surfaces that go on out of sight": bugtrap_0.6 1.07-1.60x
          // with it against 1.62-2.31x without).
          hidden_continuation_m(p.declareOptional<double>(
              "hidden_continuation_m",
              {.min = 0, .max = 100, .unit = "m",
               .doc = "2-D map and fused worlds: plan first with seen surfaces continued this far into space hidden from the vehicle "
                      "(where something in front hides them), then without (docs/world-model.md); 0: off; default min(15 m, 30 x the "
                      "robot radius)"})),
          // Since 2026-12-07: the first plans through a 3-D terrain's unseen space skirted each newly seen flank and were
          // blocked by its unseen continuation (r3d_69 at speed 4: 9-19 blocked replans, not reached in 3 of 4 runs).
          // docs/world-model.md, "Seen flanks that go on out of sight (3-D)".
          preferred_surface_margin_m(p.declare<double>(
              "preferred_surface_margin_m", 3.0,
              {.min = 0, .max = 100, .unit = "m",
               .doc = "3-D map and fused worlds with solid_below_surface, optimistic: plan first with observed terrain widened this far "
                      "(surface_margin_m's rule, yielding to space observed free) instead of surface_margin_m, then, with no path "
                      "within preferred_worlds_s, on the plain map (docs/world-model.md); not above surface_margin_m: off"})),
          improve_for_s(p.declare<double>(
              "improve_for_s", 0.0,
              {.min = 0, .max = 60, .unit = "s",
               .doc = "after the first solution, keep improving the path this long (within the request's budget; a first solution "
                      "in a bug trap is a 30-50 % detour: docs/planners.md); 0: the first solution. A request's own improve_for_s, "
                      "when > 0, takes its place"})),
          // A world tried first for the first time had a tenth of the budget (0.5 s), and two failures in a row held a
          // bug-trap replan 0.62 s. At 0.15 s (the scan -> trajectory target) bugtrap_0.4 was within 1.5x in 2 of 7
          // runs, against 5 of 6 without the cap and 3 of 3 at 0.3 s (docs/world-model.md).
          preferred_worlds_s(p.declare<double>(
              "preferred_worlds_s", 0.3,
              {.min = 0, .max = 60, .unit = "s",
               .doc = "the most the worlds tried before the plain map (unknown_margin_m, hidden_continuation_m; preferred_surface_margin_m in 3-D) may search together "
                      "before the plain map is planned on; 0: only the plain map"})),
          // On by default in 2-D since the bug traps' replans spent 0.2 s failing on preferred worlds that were closed;
          // off in 3-D, where the one preferred world is seldom closed and city_3d's missions took longer with the guide (docs/planners.md,
          // "Lattice routes").
          route_lattice_s(p.declareOptional<double>(
              "route_lattice_s",
              {.min = 0, .max = 10, .unit = "s",
               .doc = "before each search, look for a route on a lattice (cells a robot radius across diagonally, then half the radius "
                      "wide) for this much of the planner thread's CPU time, and three times it of wall time, at most: a world tried "
                      "before the plain map with no route on it is skipped at once, and a route found guides the samples (guide_bias; "
                      "docs/planners.md, \"Lattice routes\"); 0: no lattice search; default 0.03 s in 2-D, 0 in 3-D"})),
          guide_bias(p.declare<double>("guide_bias", 0.3,
                                       {.min = 0, .max = 1,
                                        .doc = "share of the samples drawn near the lattice route (route_lattice_s) instead of anywhere "
                                               "in the bounds; 0: uniform sampling"})),
          // A replan for a blocked trajectory mostly needs a way round the block and then the rest of the path it had: the
          // waypoints of the last path answered are what execution-extended RRT (Bruce and Veloso, 2002) samples near.
          // In 3-D, where no lattice route guides the samples, the replans' searches were the largest part of their latency
          // (wall_gap_3d_2m in real time: 0.14-0.30 s, 2 400-7 500 iterations; docs/planners.md, "The last path as a guide").
          previous_path_bias(p.declareOptional<double>(
              "previous_path_bias",
              {.min = 0, .max = 1,
               .doc = "for a request that asks for no improvement (a replan for a blocked trajectory) with no lattice route to guide it: "
                      "share of the samples drawn near the free waypoints of the last path answered for the same goal (not to a shorter "
                      "route's request), from the one nearest the new start on (docs/planners.md, \"The last path as a guide\"); 0: off; default 0.3 in 3-D, 0 in 2-D"})),
          // On by default since from inside bugtrap_0.4 no preferred world's guided search finished in its share (0.05-0.1 s)
          // in any of a mission's requests, and the plain map's answers were 190-330 m long where the route was 120-150 m
          // (docs/planners.md, "The route as the answer").
          route_path(p.declare<bool>(
              "route_path", true,
              {.doc = "with a lattice route found (route_lattice_s), give the sampler only half as long as the route search took, "
                      "and answer with the route, shortcut, when the sampler has no shorter path by then (docs/planners.md, \"The route "
                      "as the answer\"); false: the route only guides the samples"})),
          plain_beside_preferred(p.declare<bool>(
              "plain_beside_preferred", true,
              {.doc = "search the plain map on a thread of its own (at a lower priority) while the worlds tried before it "
                      "(preferred_worlds_s) are searched, and answer with it at once when they find nothing; false: after them"})),
          map_wait_s(p.declare<double>(
              "map_wait_s", 0.05,
              {.min = 0, .max = 10, .unit = "s",
               .doc = "a request waits at most this long (wall time) for the maps received before it to be built into its worlds: the "
                      "tracker asks for a replan as soon as it has checked a new map, which the planner may still be building "
                      "(docs/world-model.md); 0: plan on the world as it is"})),
          planner_options(p.declare<std::vector<std::string>>("planner_options", {},
                                                              {.doc = "planner.option=value entries (docs/planners.md, \"Options\")"})) {}
  };

  explicit PlannerComponent(runtime::Context& ctx)
      : Component(ctx),
        params_(ctx.params()),
        scenario_(planner::loadScenario(params_.scenario)),
        kind_(params_.world.kind),
        kinodynamic_(params_.kinodynamic.value_or(scenario_.vehicle.has_value())),
        // "planner.option=value" entries, checked once here against each planner.
        planner_options_(planner::parsePlannerOptions(params_.planner_options)),
        unknown_margin_m_(params_.unknown_margin_m.value_or(nodes::defaultUnknownMargin(scenario_))),
        hidden_continuation_m_(params_.hidden_continuation_m.value_or(nodes::defaultHiddenContinuation(scenario_))),
        route_lattice_s_(params_.route_lattice_s.value_or(scenario_.dimensions == 2 ? 0.03 : 0.0)),
        previous_path_bias_(params_.previous_path_bias.value_or(scenario_.dimensions == 3 ? 0.3 : 0.0)),
        world_source_(ctx, params_.world, scenario_, unknown_margin_m_, /*preferred_on_demand=*/false, params_.preferred_surface_margin_m),
        paths_(publisher(runtime::topics::path)) {
    if (kinodynamic_ && !scenario_.vehicle) throw runtime::ParameterError("parameter kinodynamic: the scenario has no vehicle block");
    for (const auto& [name, assignments] : planner_options_) {
      try {
        planner::applyOptions(*planner::makePlanner(name), assignments);
      } catch (const std::exception& e) {
        throw runtime::ParameterError(std::string("parameter planner_options: ") + e.what());
      }
    }
    requests_ = subscribe(runtime::topics::plan_request, [this](const msg::PlanRequest& r, const bus::SampleInfo& info) { onRequest(r, info); });
  }

  void shutdown() override { worker_.stop(); }  // a solve in progress stops and is answered

 private:
  void fail(const msg::PlanRequest& request, const std::string& why) {
    spdlog::warn("planning/request {}: {}", request.request_id(), why);
    planner::PlanResult failed;
    failed.planner = request.planner();
    msg::Path path = nodes::toMsg(failed, request.request_id(), clock().nowNs());
    path.failure(why);
    paths_.publish(path);
  }

  // On the executor: the checks, then the solve handed to the worker.
  void onRequest(const msg::PlanRequest& request, const bus::SampleInfo& info) {
    // Every number of the request is bounded here, once: coordinates inside the scenario's bounds (a planner
    // would otherwise walk a 1e300 m segment), a positive finite budget, capped below. An empty frame_id
    // is taken as the map frame.
    const std::string frame = request.header().frame_id().empty() ? "" : nodes::kWorldFrame;
    // A requester repeats its request while it has heard no answer from any planner yet (the tracker does, since
    // its first request can be lost in discovery): a copy of the request last taken from it is not solved again
    // (a new job under its key would stop the one solving it).
    if (auto [it, inserted] = last_request_.try_emplace(info.publication_handle, request.request_id()); !inserted) {
      if (it->second == request.request_id()) return;
      it->second = request.request_id();
    }
    if (last_request_.size() > 4096) last_request_.clear();  // bounded; a forgotten requester's repeat is solved again
    if (const auto error = nodes::checkPlanRequest(request, scenario_, frame); !error.empty()) return fail(request, "refused: " + error);
    std::shared_ptr<planner::Planner> algorithm;
    try {
      algorithm = makeAlgorithm(request.planner());
    } catch (const std::exception& e) {
      return fail(request, e.what());
    }
    deferred_.erase(info.publication_handle);  // a newer request from the same requester supersedes a waiting one
    if (!world_source_.available()) {
      // The first map and obstacle array reach each process at its own time: a tracker whose world is ready can
      // ask a planner whose world is not yet (gart_cluttered_2d: three requests refused in 0.6 s, the start of the
      // mission delayed by 3.5 simulated seconds of retries). Such a request waits here, on the executor — a worker
      // job waiting would hold the simulator's pacing while the clock must advance for the world to come —
      // until the world is ready, for at most its time budget of clock time.
      deferred_[info.publication_handle] = {request, algorithm, clock().nowNs()};
      if (!deferred_timer_) deferred_timer_.emplace(every(std::chrono::milliseconds(20), [this] { serveDeferred(); }));
      return;
    }
    worker_.submit(info.publication_handle, [this, request, algorithm](std::stop_token stop) { solve(request, *algorithm, stop); });
  }

  // The named planner with its planner_options applied (names and options were checked at start-up).
  std::shared_ptr<planner::Planner> makeAlgorithm(const std::string& name) const {
    std::shared_ptr<planner::Planner> algorithm = planner::makePlanner(name);
    if (auto it = planner_options_.find(name); it != planner_options_.end()) planner::applyOptions(*algorithm, it->second);
    return algorithm;
  }

  // Requests waiting for the world: solved once it is ready, answered as failed (why, as before) after their budget.
  void serveDeferred() {
    const bool ready = world_source_.available();
    for (auto it = deferred_.begin(); it != deferred_.end();) {
      const auto& [handle, waiting] = *it;
      const double waited_s = static_cast<double>(clock().nowNs() - waiting.since_ns) * 1e-9;
      if (ready) {
        worker_.submit(handle, [this, request = waiting.request, algorithm = waiting.algorithm](std::stop_token stop) {
          solve(request, *algorithm, stop);
        });
      } else if (waited_s > std::min(waiting.request.time_budget_s(), params_.max_time_budget_s)) {
        fail(waiting.request, worldMissing());
      } else {
        ++it;
        continue;
      }
      it = deferred_.erase(it);
    }
    if (deferred_.empty()) deferred_timer_.reset();  // stops polling (a timer may end itself from its callback)
  }

  const char* worldMissing() const {
    return kind_ == nodes::WorldKind::Map     ? "no map/octomap received yet"
           : kind_ == nodes::WorldKind::Fused ? "no perception/obstacles received yet, or still waiting for the first map/octomap (first_map_wait_s)"
                                              : "no perception/obstacles received yet";
  }

  // On the worker. Every failure is answered with an unsolved Path (the reason goes to the log): the
  // requester must hear back, and a bad world must not end the planner.
  void solve(const msg::PlanRequest& request, planner::Planner& algorithm, std::stop_token stop) {
    if (stop.stop_requested()) return answerStopped(request);
    const double budget = std::min(request.time_budget_s(), params_.max_time_budget_s);
    // A replan for a trajectory the tracker found blocked on a map it has just built would otherwise be planned on the
    // map before it, here still being built, and its path through the newly seen wall refused by the tracker and asked
    // again a retry delay later (stunnel_0.5, 2026-12-06: 1-2 such refusals a mission, 250-400 ms each replan).
    if (params_.map_wait_s > 0.0) {
      const double waited_s = world_source_.waitForMapsReceived(std::chrono::milliseconds(static_cast<long>(1e3 * params_.map_wait_s)));
      if (waited_s > 0.005) spdlog::info("request {}: waited {:.1f} ms for the newest map to be built", request.request_id(), 1e3 * waited_s);
    }
    try {
      // The worlds in order of preference, the first that yields a path wins (docs/world-model.md, "Unknown space"):
      // in 2-D with unseen space next to seen surfaces blocked (unknown_margin_m) and seen surfaces continued into
      // hidden space (hidden_continuation_m), with the continuation only, the plain map; in 3-D with observed terrain
      // widened by preferred_surface_margin_m, the plain map. All but the last get a share
      // of the budget (2-D solves that succeed take milliseconds to a few hundred); a world in which the start is not
      // free is skipped (solveInTurn).
      std::vector<Tier*> tiers;
      if (world_source_.hasPreferredWorld()) {
        if (scenario_.dimensions == 3) {
          tiers.push_back(&wider_margin_tier_);
        } else {
          tiers.push_back(&margin_tier_);
          if (hidden_continuation_m_ > 0.0) tiers.push_back(&continuation_tier_);
        }
      }
      // Declared before the answer: when a preferred world answers, the plain map's search beside it is stopped, and
      // joined only after the answer is out (it runs at a lower priority and may take a while to see the stop).
      std::optional<Beside> plain;
      std::optional<planner::PlanResult> result = solveInTurn(request, algorithm, tiers, budget, stop, plain);
      if (!result) return;  // answered
      spdlog::info("request {}: {} {} in {:.3f} s, {} iterations, {} vertices, cost {:.2f} m", request.request_id(), result->planner,
                   result->solved ? "solved" : "failed", result->stats.time_s, result->stats.iterations, result->stats.vertices, result->cost);
      msg::Path path = nodes::toMsg(*result, request.request_id(), clock().nowNs());
      if (result->solved && !nodes::asksForAShorterRoute(request)) rememberPath(*result, request);
      if (!result->solved)
        path.failure(fmt::format("no path within the time budget ({:.2f} s, {} iterations)", budget, result->stats.iterations));
      paths_.publish(path);
    } catch (const std::exception& e) {
      fail(request, e.what());
    }
  }

  // A world tried before the plain map, with its share of the budget (nodes::WorldTier).
  struct Tier : nodes::WorldTier {
    Tier(bool preferred, bool continued, const char* what) : preferred(preferred), continued(continued), what(what) {}
    bool preferred;    // on the preferred map: 2-D with the unknown margin, 3-D with the wider surface margin
    bool continued;    // with seen surfaces continued into hidden space
    const char* what;  // for the log
  };

  // The plain map's search on a thread of its own, beside the worlds tried before it (solveInTurn).
  struct Beside {
    std::optional<planner::PlanResult> result;  // none: `failure` says why (no world, or the search threw)
    std::string failure;
    std::jthread thread;  // last: stopped and joined before what it writes goes
  };

  // Why a world tried before the plain map was not searched.
  enum class Skipped { no, start_blocked, no_route };

  static constexpr int kBesideNice = 5;  // solveInTurn: the nice value the plain map's search beside the others adds

  // Raises the calling thread's nice value by `by` (Linux keeps it per thread), at most to 19; a failure leaves it.
  static void lowerThisThreadsPriority(int by) {
    const auto tid = static_cast<id_t>(::gettid());
    errno = 0;
    const int now = ::getpriority(PRIO_PROCESS, tid);
    if (errno == 0) ::setpriority(PRIO_PROCESS, tid, std::min(19, now + by));
  }

  void answerStopped(const msg::PlanRequest& request) {
    fail(request, worker_.stopping() ? "the planner is shutting down" : "superseded by a newer request from the same requester");
  }

  // A world tried before the plain map found no path (or was not searched: `skipped`): logged, its record kept.
  // Returns the seconds of the budget it used.
  double tierFailed(const msg::PlanRequest& request, Tier& tier, Skipped skipped, double searched_s, double share) {
    if (skipped == Skipped::start_blocked) {
      spdlog::info("request {}: the start is not free {}; trying the next world", request.request_id(), tier.what);
      return 0.0;
    }
    if (skipped == Skipped::no_route) {
      spdlog::info("request {}: no lattice route {} ({:.1f} ms); trying the next world", request.request_id(), tier.what, 1e3 * searched_s);
      return searched_s;
    }
    tier.failed();
    spdlog::info("request {}: no path {} in {:.2f} s; trying the next world", request.request_id(), tier.what, share);
    return share;
  }

  // The worlds tried before the plain map in turn, on this thread; the plain map after them, or (plain_beside_preferred)
  // beside them, on a thread of its own, from the start: when they find nothing its answer is ready or nearly, where it
  // used to be started only then (bugtrap_0.4: the continuation world, tried for the first time, failed after 0.28 s
  // and the plain map then took 0.05 s more). A preferred world's path stops it. It runs 5 nice levels lower, so that
  // it takes the core the rest of the system leaves idle (a 2-D mission at speed 4: 83-88 % idle) and not the
  // preferred worlds' time: their lattice searches and shares are bounded in wall time. (Every world on a thread of
  // its own was tried too: with three searches on two cores the lattice searches gave up 54 and 83 times in 44 and 48
  // requests, against 6 in 45 this way, and bugtrap_0.4's scan -> trajectory p99 was 110-757 ms in eleven runs.)
  // nullopt when the request was answered already (no world, a failure, a stop).
  std::optional<planner::PlanResult> solveInTurn(const msg::PlanRequest& request, planner::Planner& algorithm, const std::vector<Tier*>& tiers,
                                                 double budget, std::stop_token stop, std::optional<Beside>& plain) {
    if (!tiers.empty() && params_.plain_beside_preferred) {
      plain.emplace();
      plain->thread = std::jthread([this, &request, plain_algorithm = makeAlgorithm(request.planner()), budget, out = &*plain](std::stop_token own) {
        lowerThisThreadsPriority(kBesideNice);
        try {
          out->result = attemptWithRestarts(request, *plain_algorithm, own, budget, &out->failure);
        } catch (const std::exception& e) {
          out->result.reset();
          out->failure = e.what();
        }
      });
    }
    std::stop_callback stop_plain(stop, [&plain] {  // a newer request, or the shutdown
      if (plain) plain->thread.request_stop();
    });
    const auto answeredStopped = [&]() -> std::optional<planner::PlanResult> {
      answerStopped(request);
      return std::nullopt;
    };
    double spent = 0.0;  // of the budget, by failed searches and lattice searches on the earlier worlds
    for (Tier* tier : tiers) {
      const double room = std::min(params_.preferred_worlds_s, budget) - spent;  // of preferred_worlds_s
      if (room < 0.01) break;
      const double share = std::min(tier->share(budget - spent), room);
      Skipped skipped = Skipped::no;
      const bool stale = world_source_.preferredIsStale();  // before its snapshot: then it was planned on an older map
      auto result = attempt(request, algorithm, stop, tier->preferred, tier->continued ? hidden_continuation_m_ : 0.0, share, &skipped);
      if (!result) return std::nullopt;  // answered (failed)
      if (result->stopped) return answeredStopped();
      if (result->solved) {
        if (const auto crossing = stale ? crossesNewestMap(request, *result) : std::nullopt) {
          // Planned on an older map's preferred world (the newest one's was still being built): what the tracker would
          // refuse is not answered (docs/world-model.md, "A request waits for the map it was asked on").
          spdlog::info("request {}: the path {} crosses what the newest map holds at {}; trying the next world", request.request_id(),
                       tier->what, *crossing);
          spent += result->stats.time_s;
          continue;
        }
        tier->solved(result->stats.time_s);
        if (plain) plain->thread.request_stop();
        return result;
      }
      spent += tierFailed(request, *tier, skipped, result->stats.time_s, share);
    }
    std::optional<planner::PlanResult> result;
    if (plain) {
      plain->thread.join();  // its own time limit is the budget
      if (!plain->result && !stop.stop_requested()) {
        fail(request, plain->failure);
        return std::nullopt;
      }
      result = std::move(plain->result);
    } else {
      result = attemptWithRestarts(request, algorithm, stop, budget - spent);
      if (!result) return std::nullopt;  // answered (failed)
    }
    if (stop.stop_requested() || !result || result->stopped) return answeredStopped();
    return result;
  }

  // Where the path of a world tried before the plain map is blocked on the plain world of the newest map (the edge), or
  // nothing: the preferred worlds may still be the previous map's (WorldSource::buildMap), and the tracker checks the
  // path on the newest.
  std::optional<std::string> crossesNewestMap(const msg::PlanRequest& request, const planner::PlanResult& result) const {
    std::unique_ptr<planner::CollisionWorld> world;
    try {
      world = world_source_.snapshot(nodes::fromMsg(request.start()).position, nodes::fromMsg(request.goal()).position, request.goal_radius());
    } catch (const std::exception&) {
      return std::nullopt;  // the solve's own snapshot said why already
    }
    if (!world) return std::nullopt;
    for (std::size_t i = 1; i < result.path.size(); ++i) {
      const planner::Vec3 &a = result.path[i - 1].position, &b = result.path[i].position;
      if (!world->isSegmentFree(a, b))
        return fmt::format("edge {} -> {} ({:.2f}, {:.2f}, {:.2f}) -> ({:.2f}, {:.2f}, {:.2f})", i - 1, i, a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
    }
    return std::nullopt;
  }

  // One solve on a snapshot of the world; nullopt when there is no world: the request was answered as failed
  // already, or, with `failure` given, not answered and *failure says why. On a world tried before the plain map
  // (`skipped` given) a start that is not free there, or a goal the lattice route search finds closed off, is not
  // searched for: unsolved, with *skipped saying why.
  // With `restart`, the search draws its samples from the request's seed + restart->round, and one that has found
  // nothing for restart->after_s (with kFirstRestartS or more left) ends there, unsolved and `abandoned`
  // (attemptWithRestarts).
  struct Restart {
    double after_s;
    std::uint64_t round;
  };
  std::optional<planner::PlanResult> attempt(const msg::PlanRequest& request, planner::Planner& algorithm, std::stop_token stop,
                                             bool preferred, double continuation_m, double time_limit_s, Skipped* skipped = nullptr,
                                             std::string* failure = nullptr, std::optional<Restart> restart = std::nullopt) {
    auto noWorld = [&](std::string why) -> std::optional<planner::PlanResult> {
      if (failure)
        *failure = std::move(why);
      else
        fail(request, why);
      return std::nullopt;
    };
    const bool tier = skipped != nullptr;  // a world tried before the plain map
    std::unique_ptr<planner::CollisionWorld> world;
    const auto snapshot_began = std::chrono::steady_clock::now();
    try {
      world = world_source_.snapshot(nodes::fromMsg(request.start()).position, nodes::fromMsg(request.goal()).position, request.goal_radius(),
                                     preferred, continuation_m);
    } catch (const std::exception& e) {
      return noWorld(std::string("cannot build the world: ") + e.what());
    }
    // The snapshot's time is not in the result's: in a bugtrap_0.4 replan answered 212 ms after its request, the
    // search took 45 ms (docs/benchmarks/mission.md, 2026-12-06 03:2x). Logged when it is long enough to matter.
    if (const double snapshot_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - snapshot_began).count(); snapshot_s > 0.02)
      spdlog::info("request {}: the world's snapshot took {:.1f} ms{}", request.request_id(), 1e3 * snapshot_s,
                   continuation_m > 0.0 ? " (with seen surfaces continued out of sight)" : "");
    if (!world) return noWorld(worldMissing());
    planner::PlanProblem problem;
    problem.world = world.get();
    problem.start = nodes::fromMsg(request.start());
    // A vehicle right next to a mapped surface is "in collision" with the map's voxels while it physically
    // is not (docs/world-model.md): plan from the nearest free state within the robot radius instead (in 3-D
    // plus the surface margin, by which a map widens observed terrain), and on to half the robot radius of
    // clearance when that is near: a barely free start grazes the voxels with the first edge (nearestFreePosition).
    // Where the map widens terrain, the state must also lead out of it by a free straight segment as long as the reach:
    // the widening leaves free pockets of a few centimetres beside a buried start, with no free edge out of them
    // (nodes::plannerStartOutOfCollision, shared with ddsnav-replan-replay).
    // Not on the 3-D preferred world: a start its wider margin blocks (a vehicle within 3 m of a higher flank, over ground
    // never observed) is the plain map's to move, by the plain margin's reach. Moved here (0.6 and 0.97 m), the paths of
    // two r3d_69 replans from a rest point beside a flank were refused by the smoother at their start ("no local
    // detour", 2026-12-07), and the retries held that replan 0.94 s.
    const bool may_move_start = !(tier && scenario_.dimensions == 3);
    if (may_move_start)
      if (const auto moved = nodes::plannerStartOutOfCollision(*world, problem.start.position, scenario_.robot_radius, world_source_.surfaceMargin())) {
        spdlog::info("request {}: the start ({:.2f}, {:.2f}, {:.2f}) is in collision in the planner's world; planning from the nearest "
                     "free state, {:.2f} m away", request.request_id(), problem.start.position.x(), problem.start.position.y(),
                     problem.start.position.z(), (*moved - problem.start.position).norm());
        problem.start.position = *moved;
      }
    // The preferred world blocks unseen space next to seen surfaces (unknown_margin_m): a vehicle rounding the seen
    // corner of a wall stands in it, deeper than the reach (bugtrap_0.6: the request failed "start ... is in
    // collision" ten times and the mission ended). Not solved there, so the plain map is tried.
    auto notSearched = [&](Skipped why, double seconds) {
      *skipped = why;
      planner::PlanResult not_there;
      not_there.planner = algorithm.name();
      not_there.stats.time_s = seconds;
      return not_there;
    };
    if (tier && !world->isFree(problem.start.position)) return notSearched(Skipped::start_blocked, 0.0);
    problem.goal = nodes::fromMsg(request.goal()).position;
    problem.goal_radius = request.goal_radius();
    // The lattice route (docs/planners.md, "Lattice routes"): milliseconds where the sampler may need a second, it
    // tells a closed world (skipped before the plain map) and guides the samples through an open one.
    std::optional<planner::PlanResult> along_route;  // the lattice route as a path (route_path)
    if (route_lattice_s_ > 0.0) {
      // Bounded by the work done (this thread's CPU time), with a wall cap of three times that: in a mission at speed 4
      // the searches of a request got 10-60 % of a core (bugtrap_0.4, 2026-12-06: 3.5-29.6 ms of CPU in 25-38 ms), and
      // a search bounded in wall time alone gave up before the trap's cells were expanded in every request. The time
      // it takes beyond half the world's share lengthens that share instead of starving the guided search after it.
      planner::CoarseRouteOptions lattice;
      lattice.cpu_time_limit_s = std::min(route_lattice_s_, 0.5 * time_limit_s);
      lattice.time_limit_s = std::min(3.0 * route_lattice_s_, time_limit_s);
      lattice.stop = stop;
      const planner::CoarseRoute route =
          planner::findCoarseRoute(*world, problem.start.position, problem.goal, problem.goal_radius, lattice);
      if (tier && route.outcome == planner::CoarseRoute::Outcome::none) return notSearched(Skipped::no_route, route.time_s);
      if (route.outcome == planner::CoarseRoute::Outcome::found)
        spdlog::info("request {}: lattice route of {:.1f} m in {:.1f} ms ({:.1f} ms of CPU; {} cells of {:.2f} m) guides the samples",
                     request.request_id(), route.length_m, 1e3 * route.time_s, 1e3 * route.cpu_s, route.expanded, route.cell_m);
      time_limit_s = std::max(time_limit_s - std::min(route.time_s, 0.5 * time_limit_s), 1e-3);
      if (route.outcome == planner::CoarseRoute::Outcome::gave_up && !stop.stop_requested()) {
        // On a world tried before the plain map the unguided sampler then gets only as long as the lattice took, as when
        // the route is no path (below): of the 91 lattices that gave up in the mission logs up to 2026-12-06, 78 were
        // followed by their preferred world finding no path in the rest of its share (0.06-0.1 s each; bugtrap_0.4,
        // stunnel_0.5; the other 13 include the plain map's own), and the plain map beside it or the next world answered.
        if (tier) time_limit_s = std::min(time_limit_s, std::max(route.time_s, kRouteSamplerFloorS));
        spdlog::info("request {}: no lattice route within {:.1f} ms ({:.1f} ms on this thread's CPU; {} cells of {:.2f} m); sampling "
                     "without a guide for {:.0f} ms", request.request_id(), 1e3 * route.time_s, 1e3 * route.cpu_s, route.expanded,
                     route.cell_m, 1e3 * time_limit_s);
      }
      if (route.outcome == planner::CoarseRoute::Outcome::found && params_.route_path) {
        along_route = planner::resultAlongRoute(*world, route, problem);
        if (!along_route) {
          // On a world tried before the plain map the sampler then gets as long as the route took: alone it rarely
          // finishes there in a share (bugtrap_0.4, 2026-12-06: in none of a mission's requests), and a replan whose two
          // such worlds each spent their share (0.09 and 0.1 s) on it was answered 212 ms after its request, by the plain
          // map's search beside them, done in 48 ms.
          if (tier) time_limit_s = std::min(time_limit_s, std::max(route.time_s, kRouteSamplerFloorS));
          spdlog::info("request {}: the lattice route is no path in this world's checks; the sampler searches on its own for {:.0f} ms",
                       request.request_id(), 1e3 * time_limit_s);
        }
        // The sampler gets half as long as the lattice took: a path it finds in that time that is shorter wins. Half, since
        // it rarely does in 2-D: in the 2-D missions of 2026-12-06 03:2x (round 3) it found a path no longer than the
        // route in 3 of 338 attempts given as long as the route took, a longer one in 57, none in 278, and took up to half
        // of each answer's wait.
        if (along_route) time_limit_s = std::min(time_limit_s, std::max(0.5 * route.time_s, kRouteSamplerFloorS));
      }
      planner::guideAlong(problem, route, params_.guide_bias);
    }
    if (problem.guide.empty() && previous_path_bias_ > 0.0 && request.improve_for_s() <= 0.0) previousPathGuide(problem);
    problem.vehicle = scenario_.vehicle;
    problem.kinodynamic = kinodynamic_;
    problem.seed = request.seed() + (restart ? restart->round * kRestartSeedStride : 0);
    problem.time_limit_s = time_limit_s;
    // A request may ask for improvement itself: the tracker does when no change waits on the answer (its first plan, a
    // shorter route while it flies on), never for a blocked trajectory, whose answer's latency counts.
    const double improve_for_s = request.improve_for_s() > 0.0 ? request.improve_for_s() : params_.improve_for_s;
    problem.anytime = improve_for_s > 0.0;
    problem.improve_for_s = improve_for_s;
    problem.stop = stop;
    if (restart) {
      const auto search_began = std::chrono::steady_clock::now();
      problem.abandon_unsolved = [search_began, time_limit_s, after_s = restart->after_s] {
        const double searched_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - search_began).count();
        return searched_s >= after_s && time_limit_s - searched_s >= kFirstRestartS;
      };
    }
    planner::PlanResult sampled = algorithm.solve(problem);
    if (!along_route) return sampled;
    planner::PlanResult answer = planner::shorterAnswer(std::move(sampled), std::move(*along_route));
    if (answer.planner != algorithm.name())
      spdlog::info("request {}: {} found no shorter path in {} iterations; answering with the lattice route, {:.1f} m", request.request_id(),
                   algorithm.name(), answer.stats.iterations, answer.cost);
    return answer;
  }

  void rememberPath(const planner::PlanResult& result, const msg::PlanRequest& request) {
    std::vector<planner::Vec3> positions;
    positions.reserve(result.path.size());
    for (const auto& state : result.path) positions.push_back(state.position);
    std::lock_guard lock(previous_path_mutex_);
    previous_path_ = std::move(positions);
    previous_goal_ = nodes::fromMsg(request.goal()).position;
  }

  // The last path answered as the samples' guide (planner::guideAlongPath), when it was for this goal.
  void previousPathGuide(planner::PlanProblem& problem) const {
    std::vector<planner::Vec3> path;
    {
      std::lock_guard lock(previous_path_mutex_);
      if ((previous_goal_ - problem.goal).norm() > std::max(problem.goal_radius, 1e-6)) return;
      path = previous_path_;
    }
    planner::guideAlongPath(problem, path, previous_path_bias_);
  }

  // Shortest time the sampler gets beside a route found in less (attempt).
  static constexpr double kRouteSamplerFloorS = 0.005;

  // The plain map's search (attempt) is begun again from scratch, with other samples and on the newest map, when it has
  // found nothing for kFirstRestartS, then for twice as long each time, within `time_limit_s` in all
  // (attemptWithRestarts), while a second or more of the budget is left: in a 5 s budget at 1 s and 3 s. A sampler's
  // time to a first solution has a long tail, and the map under it changes: on an indoor floor with doors (2026-12-07)
  // requests failed after their whole 5 s budget (0.9-1.1 million iterations; one after a round of 1 s and one of 4 s)
  // and their retries 0.25-0.3 s later, from a start a little farther on and on a newer map, were solved in 0.11-0.14 s;
  // the searches that succeed take 5-150 ms on terrain and up to 0.5 s on that floor. A restart loses the tree grown so
  // far (one at 0.5 s took 1.04 s in all); doubling bounds what that costs a search that needed the time. In the
  // simulator the clock is held while the planner lags (pacing), so the rounds there search the same map: they did not
  // prevent those failures (docs/world-model.md, "A search that finds nothing: begun again").
  static constexpr double kFirstRestartS = 1.0;
  static constexpr std::uint64_t kRestartSeedStride = 0x9E3779B9u;  // a restart's seed: far from the requests' own

  // The plain map's search with restarts (kFirstRestartS); the result counts the time and iterations of every round.
  std::optional<planner::PlanResult> attemptWithRestarts(const msg::PlanRequest& request, planner::Planner& algorithm, std::stop_token stop,
                                                         double time_limit_s, std::string* failure = nullptr) {
    const auto began = std::chrono::steady_clock::now();
    std::uint64_t earlier_iterations = 0;
    Restart restart{kFirstRestartS, 0};
    for (;;) {
      const double left_s = time_limit_s - std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
      const std::uint64_t map_number = world_source_.plainMapNumber();  // the snapshot's, or an older one
      auto result = attempt(request, algorithm, stop, /*preferred=*/false, 0.0, std::max(left_s, 1e-3), nullptr, failure, restart);
      if (!result) return result;
      result->stats.iterations += earlier_iterations;
      if (!result->abandoned) {
        result->stats.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
        return result;
      }
      const std::uint64_t round_iterations = result->stats.iterations - earlier_iterations;
      earlier_iterations = result->stats.iterations;
      const std::uint64_t newest = world_source_.plainMapNumber();
      spdlog::info("request {}: no path after {:.2f} s ({} iterations, {} vertices){}: searching again from scratch with other samples{}",
                   request.request_id(), result->stats.time_s, round_iterations, result->stats.vertices,
                   map_number > 0 ? fmt::format(" on map {}", map_number) : std::string(),
                   newest > map_number ? fmt::format(", on map {}", newest) : std::string());
      restart.after_s *= 2;
      ++restart.round;
    }
  }

  const Params params_;
  const planner::Scenario scenario_;
  const nodes::WorldKind kind_;
  const bool kinodynamic_;
  const std::map<std::string, std::vector<std::string>> planner_options_;
  const double unknown_margin_m_, hidden_continuation_m_, route_lattice_s_;  // the parameters, or their defaults for the scenario
  const double previous_path_bias_;
  // The last path answered (its states' positions) and its goal: previousPathGuide. Written by the worker, read by the
  // searches beside it.
  mutable std::mutex previous_path_mutex_;
  std::vector<planner::Vec3> previous_path_;
  planner::Vec3 previous_goal_ = planner::Vec3::Zero();
  nodes::WorldSource world_source_;
  bus::Publisher<msg::Path> paths_;
  std::map<std::uint64_t, std::uint32_t> last_request_;  // requester (publication handle) -> its last request id
  struct Deferred {
    msg::PlanRequest request;
    std::shared_ptr<planner::Planner> algorithm;
    std::int64_t since_ns = 0;  // clock time it came
  };
  std::map<std::uint64_t, Deferred> deferred_;  // requests waiting for the world, by requester (serveDeferred)
  // The worlds tried before the plain map (the worker's).
  Tier margin_tier_{true, true, "keeping clear of unseen space next to seen surfaces"};
  Tier continuation_tier_{false, true, "with seen surfaces continued out of sight"};
  Tier wider_margin_tier_{true, false, "keeping clear of unseen space under seen terrain nearby (preferred_surface_margin_m)"};
  std::optional<runtime::Timer> deferred_timer_;  // polls while a request waits
  runtime::Worker worker_{"planner"};  // after what its jobs use: stopped and joined before they go
  bus::Subscription requests_;
};

}  // namespace

DDSNAV_COMPONENT(PlannerComponent, "planner")
