// OMPL planners on ddsnav's CollisionWorld, so ddsnav-bench compares them side by side in one grid.
// Every OMPL header of the project is included here only (they are slow to compile).
//
// Geometric (ompl:rrt, ompl:rrtconnect, ompl:rrtstar, ompl:bitstar): R^d position space; the state
// validity checker is world.isFree and the motion validator world.isSegmentFree, i.e. the very checks our
// planners use, at the same resolution.
//
// Kinodynamic (ompl:control-rrt, ompl:sst, ompl:est, ompl:pdst): state (position in R^d, heading in SO2),
// control (v in [0, v_max], omega in [-omega_max, omega_max], and vz in [-vz_max, vz_max] in 3-D), the
// unicycle integrated exactly over arcs. Every control is held for exactly one edge duration dt, checked
// at propagation steps no longer than the world's check resolution (same density as our segment checks).
#include "bench_run.hpp"

#include "ddsnav/planner/unicycle.hpp"

#include <ompl/base/Goal.h>
#include <ompl/base/MotionValidator.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/ProjectionEvaluator.h>
#include <ompl/base/goals/GoalSampleableRegion.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/base/spaces/SO2StateSpace.h>
#include <ompl/control/PathControl.h>
#include <ompl/control/SpaceInformation.h>
#include <ompl/control/planners/est/EST.h>
#include <ompl/control/planners/pdst/PDST.h>
#include <ompl/control/planners/rrt/RRT.h>
#include <ompl/control/planners/sst/SST.h>
#include <ompl/control/spaces/RealVectorControlSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/rrt/RRT.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

namespace ddsnav::bench {

namespace ob = ompl::base;
namespace oc = ompl::control;
namespace og = ompl::geometric;
using planner::CollisionWorld;
using planner::Vec3;

namespace {

using Clock = std::chrono::steady_clock;

const std::vector<std::string> kGeometric = {"ompl:rrt", "ompl:rrtconnect", "ompl:rrtstar", "ompl:bitstar"};
const std::vector<std::string> kKinodynamic = {"ompl:control-rrt", "ompl:sst", "ompl:est", "ompl:pdst"};

// Position of a state: the R^d state itself (geometric) or the R^d subspace of (R^d, SO2) (control).
Vec3 positionOf(const ob::State* s, int dims, bool compound) {
  const double* v = compound ? s->as<ob::CompoundState>()->as<ob::RealVectorStateSpace::StateType>(0)->values
                             : s->as<ob::RealVectorStateSpace::StateType>()->values;
  return Vec3(v[0], v[1], dims == 3 ? v[2] : 0.0);
}

void setPosition(ob::State* s, const Vec3& p, int dims, bool compound) {
  double* v = compound ? s->as<ob::CompoundState>()->as<ob::RealVectorStateSpace::StateType>(0)->values
                       : s->as<ob::RealVectorStateSpace::StateType>()->values;
  for (int i = 0; i < dims; ++i) v[i] = p[i];
}

double& headingOf(ob::State* s) { return s->as<ob::CompoundState>()->as<ob::SO2StateSpace::StateType>(1)->value; }
double headingOf(const ob::State* s) { return s->as<ob::CompoundState>()->as<ob::SO2StateSpace::StateType>(1)->value; }

// Goal: a ball of goal_radius around the goal position (heading free). Also notes when a planner first
// meets a state inside it, which is the time to first solution for planners without a solution callback.
class PositionGoal : public ob::GoalSampleableRegion {
 public:
  PositionGoal(const ob::SpaceInformationPtr& si, const Vec3& goal, double radius, int dims, bool compound,
               Clock::time_point start)
      : ob::GoalSampleableRegion(si), goal_(goal), dims_(dims), compound_(compound), start_(start) {
    setThreshold(radius);
  }
  double distanceGoal(const ob::State* s) const override { return (positionOf(s, dims_, compound_) - goal_).norm(); }
  bool isSatisfied(const ob::State* s, double* distance) const override {
    const bool satisfied = ob::GoalRegion::isSatisfied(s, distance);
    if (satisfied && first_seen_s_ < 0.0) first_seen_s_ = std::chrono::duration<double>(Clock::now() - start_).count();
    return satisfied;
  }
  void sampleGoal(ob::State* s) const override {
    setPosition(s, goal_, dims_, compound_);
    if (compound_) headingOf(s) = rng_.uniformReal(-M_PI, M_PI);
  }
  // One goal state: the planners that pull every available goal sample up front (BIT*, RRT* through
  // PlannerInputStates) would otherwise loop over 2^32 samples.
  unsigned int maxSampleCount() const override { return 1; }
  double firstSeen() const { return first_seen_s_; }

 private:
  Vec3 goal_;
  int dims_;
  bool compound_;
  Clock::time_point start_;
  mutable double first_seen_s_ = -1.0;
  mutable ompl::RNG rng_;
};

// Straight-segment motion check, exactly the one our planners use.
class SegmentValidator : public ob::MotionValidator {
 public:
  SegmentValidator(const ob::SpaceInformationPtr& si, const CollisionWorld& world, int dims)
      : ob::MotionValidator(si), world_(world), dims_(dims) {}
  bool checkMotion(const ob::State* a, const ob::State* b) const override {
    const bool ok = world_.isSegmentFree(positionOf(a, dims_, false), positionOf(b, dims_, false));
    ok ? ++valid_ : ++invalid_;
    return ok;
  }
  bool checkMotion(const ob::State* a, const ob::State* b, std::pair<ob::State*, double>& last_valid) const override {
    const Vec3 pa = positionOf(a, dims_, false), pb = positionOf(b, dims_, false);
    const int steps = std::max(1, static_cast<int>(std::ceil((pb - pa).norm() / world_.checkResolution())));
    for (int i = 1; i <= steps; ++i) {
      if (!world_.isFree(pa + (pb - pa) * (static_cast<double>(i) / steps))) {
        last_valid.second = static_cast<double>(i - 1) / steps;
        if (last_valid.first) si_->getStateSpace()->interpolate(a, b, last_valid.second, last_valid.first);
        ++invalid_;
        return false;
      }
    }
    ++valid_;
    return true;
  }

 private:
  const CollisionWorld& world_;
  int dims_;
};

// Grid projection onto the position, for EST and PDST.
class PositionProjection : public ob::ProjectionEvaluator {
 public:
  PositionProjection(const ob::StateSpace* space, int dims, double cell) : ob::ProjectionEvaluator(space), dims_(dims), cell_(cell) {}
  unsigned int getDimension() const override { return static_cast<unsigned int>(dims_); }
  void defaultCellSizes() override { cellSizes_.assign(static_cast<std::size_t>(dims_), cell_); }
  void project(const ob::State* s, Eigen::Ref<Eigen::VectorXd> out) const override {
    const Vec3 p = positionOf(s, dims_, true);
    for (int i = 0; i < dims_; ++i) out[i] = p[i];
  }

 private:
  int dims_;
  double cell_;
};

// Counts uniform samples: the iteration count of planners that draw one per iteration but do not report
// iterations themselves (RRT, RRT-Connect, control RRT, SST).
class CountingSampler : public ob::StateSampler {
 public:
  CountingSampler(const ob::StateSpace* space, ob::StateSamplerPtr inner, std::int64_t* count)
      : ob::StateSampler(space), inner_(std::move(inner)), count_(count) {}
  void sampleUniform(ob::State* s) override {
    ++*count_;
    inner_->sampleUniform(s);
  }
  void sampleUniformNear(ob::State* s, const ob::State* near, double distance) override {
    inner_->sampleUniformNear(s, near, distance);
  }
  void sampleGaussian(ob::State* s, const ob::State* mean, double stddev) override {
    inner_->sampleGaussian(s, mean, stddev);
  }

 private:
  ob::StateSamplerPtr inner_;
  std::int64_t* count_;
};

void countSamples(ob::StateSpace& space, std::int64_t* count) {
  space.setStateSamplerAllocator([count](const ob::StateSpace* sp) {
    return std::make_shared<CountingSampler>(sp, sp->allocDefaultStateSampler(), count);
  });
}

ob::RealVectorBounds boundsOf(const CollisionWorld& world, int dims) {
  ob::RealVectorBounds b(static_cast<unsigned int>(dims));
  for (int i = 0; i < dims; ++i) {
    b.setLow(static_cast<unsigned int>(i), world.boundsMin()[i]);
    b.setHigh(static_cast<unsigned int>(i), world.boundsMax()[i]);
  }
  return b;
}

std::int64_t iterationsOf(const ob::Planner& planner) {
  const auto& props = planner.getPlannerProgressProperties();
  const auto it = props.find("iterations INTEGER");
  if (it == props.end()) return -1;
  try {
    return std::stoll(it->second());
  } catch (const std::exception&) {
    return -1;
  }
}

void silenceOmplOnce() {
  static bool done = false;
  if (done) return;
  ompl::msg::setLogLevel(ompl::msg::LOG_ERROR);
  done = true;
}

// Sets up and runs `planner` on `pdef` within the time limit and records what every OMPL run reports the same
// way: wall time from `start_time`, validity checks, exact solution, iterations (the planner's own counter, else
// the uniform samples drawn) and the number of vertices.
RunRecord solveAndRecord(ob::Planner& planner, const ob::ProblemDefinitionPtr& pdef, const CollisionWorld& world,
                         double time_limit_s, Clock::time_point start_time, std::int64_t samples) {
  planner.setProblemDefinition(pdef);
  planner.setup();
  RunRecord r;
  const std::uint64_t checks_before = world.validityChecks();
  const ob::PlannerStatus status = planner.solve(ob::timedPlannerTerminationCondition(time_limit_s));
  r.time_s = std::chrono::duration<double>(Clock::now() - start_time).count();
  r.validity_checks = world.validityChecks() - checks_before;
  r.solved = status == ob::PlannerStatus::EXACT_SOLUTION && pdef->hasExactSolution();
  r.exact = r.solved;
  r.iterations = iterationsOf(planner);
  if (r.iterations < 0 && samples > 0) r.iterations = samples;
  ob::PlannerData data(planner.getSpaceInformation());
  planner.getPlannerData(data);
  r.vertices = static_cast<std::int64_t>(data.numVertices());
  return r;
}

RunRecord runGeometric(const std::string& name, const planner::Scenario& scenario, const CollisionWorld& world,
                       const planner::PlanProblem& problem) {
  const int dims = world.dimensions();
  auto space = std::make_shared<ob::RealVectorStateSpace>(static_cast<unsigned int>(dims));
  space->setBounds(boundsOf(world, dims));
  std::int64_t samples = 0;
  countSamples(*space, &samples);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker([&world, dims](const ob::State* s) { return world.isFree(positionOf(s, dims, false)); });
  si->setMotionValidator(std::make_shared<SegmentValidator>(si, world, dims));
  si->setup();

  const Clock::time_point start_time = Clock::now();
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  ob::ScopedState<> start(space);
  setPosition(start.get(), problem.start.position, dims, false);
  pdef->addStartState(start);
  auto goal = std::make_shared<PositionGoal>(si, problem.goal, problem.goal_radius, dims, false, start_time);
  pdef->setGoal(goal);
  auto objective = std::make_shared<ob::PathLengthOptimizationObjective>(si);
  // Without --anytime any solution satisfies the objective, so the optimising planners stop at the first.
  objective->setCostThreshold(problem.anytime ? ob::Cost(0.0) : ob::Cost(std::numeric_limits<double>::infinity()));
  pdef->setOptimizationObjective(objective);
  double first_solution_s = -1.0;
  pdef->setIntermediateSolutionCallback([&](const ob::Planner*, const std::vector<const ob::State*>&, const ob::Cost) {
    if (first_solution_s < 0.0) first_solution_s = std::chrono::duration<double>(Clock::now() - start_time).count();
  });

  ob::PlannerPtr planner;
  if (name == "ompl:rrt") planner = std::make_shared<og::RRT>(si);
  else if (name == "ompl:rrtconnect") planner = std::make_shared<og::RRTConnect>(si);
  else if (name == "ompl:rrtstar") planner = std::make_shared<og::RRTstar>(si);
  else planner = std::make_shared<og::BITstar>(si);
  RunRecord r = solveAndRecord(*planner, pdef, world, problem.time_limit_s, start_time, samples);
  r.kinodynamic = false;
  if (r.solved) {
    auto& path = *pdef->getSolutionPath()->as<og::PathGeometric>();
    r.cost = path.length();
    // Time to first solution: the solution callback (RRT*, BIT*), else the goal probe (RRT, RRT-Connect;
    // RRT-Connect only meets the goal once its trees join, so fall back to the end of solve()).
    r.time_to_first_s = first_solution_s >= 0.0 ? first_solution_s : (name == "ompl:rrt" ? goal->firstSeen() : r.time_s);
    if (r.time_to_first_s < 0.0) r.time_to_first_s = r.time_s;
    r.valid = true;
    for (std::size_t i = 0; i + 1 < path.getStateCount(); ++i) {
      if (!world.isSegmentFree(positionOf(path.getState(i), dims, false), positionOf(path.getState(i + 1), dims, false))) {
        r.valid = false;
        r.invalid_reason = "edge " + std::to_string(i) + " in collision";
        break;
      }
    }
  }
  (void)scenario;
  return r;
}

RunRecord runKinodynamic(const std::string& name, const planner::Scenario& scenario, const CollisionWorld& world,
                         const planner::PlanProblem& problem) {
  if (!problem.vehicle) {
    throw std::invalid_argument(name + " needs the scenario's vehicle block (" + scenario.source + ")");
  }
  const planner::VehicleLimits& limits = *problem.vehicle;
  const int dims = world.dimensions();
  auto position_space = std::make_shared<ob::RealVectorStateSpace>(static_cast<unsigned int>(dims));
  position_space->setBounds(boundsOf(world, dims));
  auto space = std::make_shared<ob::CompoundStateSpace>();
  space->addSubspace(position_space, 1.0);
  space->addSubspace(std::make_shared<ob::SO2StateSpace>(), 0.5);
  space->lock();
  std::int64_t samples = 0;
  countSamples(*space, &samples);
  const planner::ForwardRegion region = planner::forwardRegion(limits, dims);
  space->registerDefaultProjection(std::make_shared<PositionProjection>(space.get(), dims, region.reach));

  const unsigned int control_dims = dims == 3 ? 3u : 2u;
  auto cspace = std::make_shared<oc::RealVectorControlSpace>(space, control_dims);
  ob::RealVectorBounds cbounds(control_dims);
  cbounds.setLow(0, 0.0);
  cbounds.setHigh(0, limits.v_max);
  cbounds.setLow(1, -limits.omega_max);
  cbounds.setHigh(1, limits.omega_max);
  if (dims == 3) {
    cbounds.setLow(2, -limits.vz_max);
    cbounds.setHigh(2, limits.vz_max);
  }
  cspace->setBounds(cbounds);

  auto si = std::make_shared<oc::SpaceInformation>(space, cspace);
  si->setStateValidityChecker([&world, dims](const ob::State* s) { return world.isFree(positionOf(s, dims, true)); });
  // Exact unicycle arc over `duration` (one propagation step).
  si->setStatePropagator([dims](const ob::State* from, const oc::Control* control, double duration, ob::State* to) {
    const double* u = control->as<oc::RealVectorControlSpace::ControlType>()->values;
    const Vec3 p = positionOf(from, dims, true);
    const double theta = headingOf(from);
    const double v = u[0], omega = u[1];
    Vec3 q = p;
    if (std::abs(omega) < 1e-9) {
      q.x() += v * duration * std::cos(theta);
      q.y() += v * duration * std::sin(theta);
    } else {
      q.x() += v / omega * (std::sin(theta + omega * duration) - std::sin(theta));
      q.y() -= v / omega * (std::cos(theta + omega * duration) - std::cos(theta));
    }
    if (dims == 3) q.z() += u[2] * duration;
    setPosition(to, q, dims, true);
    headingOf(to) = planner::wrapAngle(theta + omega * duration);
  });
  const unsigned int steps = static_cast<unsigned int>(
      std::max(1.0, std::ceil(std::hypot(region.reach, region.max_climb) / world.checkResolution())));
  si->setPropagationStepSize(limits.dt / steps);
  si->setMinMaxControlDuration(steps, steps);  // every control lasts exactly dt: one edge of our planners
  si->setup();

  const Clock::time_point start_time = Clock::now();
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  ob::ScopedState<> start(space);
  setPosition(start.get(), problem.start.position, dims, true);
  headingOf(start.get()) = planner::wrapAngle(problem.start.heading);
  pdef->addStartState(start);
  auto goal = std::make_shared<PositionGoal>(si, problem.goal, problem.goal_radius, dims, true, start_time);
  pdef->setGoal(goal);
  double first_solution_s = -1.0;
  pdef->setIntermediateSolutionCallback([&](const ob::Planner*, const std::vector<const ob::State*>&, const ob::Cost) {
    if (first_solution_s < 0.0) first_solution_s = std::chrono::duration<double>(Clock::now() - start_time).count();
  });

  ob::PlannerPtr planner;
  if (name == "ompl:control-rrt") {
    planner = std::make_shared<oc::RRT>(si);
  } else if (name == "ompl:sst") {
    auto sst = std::make_shared<oc::SST>(si);
    // OMPL's defaults (0.2 / 0.1) are sized for unit worlds; scale them to one edge of this vehicle.
    sst->setSelectionRadius(0.5 * region.reach);
    sst->setPruningRadius(0.25 * region.reach);
    planner = sst;
  } else if (name == "ompl:est") {
    planner = std::make_shared<oc::EST>(si);
  } else {
    planner = std::make_shared<oc::PDST>(si);
  }
  RunRecord r = solveAndRecord(*planner, pdef, world, problem.time_limit_s, start_time, samples);
  r.kinodynamic = true;
  if (r.solved) {
    r.time_to_first_s = first_solution_s >= 0.0 ? first_solution_s : goal->firstSeen();
    if (r.time_to_first_s < 0.0) r.time_to_first_s = r.time_s;
    auto& control_path = *pdef->getSolutionPath()->as<oc::PathControl>();
    // The edges as our planners see them: the chords between the states one dt apart. A chord turns
    // (omega_k + omega_k+1) dt / 2 from the previous one, so OMPL's arcs satisfy our R+ by construction.
    std::vector<planner::State> chords;
    for (std::size_t i = 0; i < control_path.getStateCount(); ++i) {
      const Vec3 p = positionOf(control_path.getState(i), dims, true);
      const double heading = chords.empty() ? problem.start.heading : planner::edgeHeading(chords.back().position, p, chords.back().heading);
      chords.push_back(planner::State{p, heading});
    }
    const planner::PathCheck check = planner::checkUnicyclePath(chords, region, nullptr);
    // Collision and cost on the arcs themselves: every propagation step (what OMPL checked).
    oc::PathControl dense(control_path);
    dense.interpolate();
    bool free = true;
    r.cost = 0.0;
    for (std::size_t i = 0; i < dense.getStateCount(); ++i) {
      const Vec3 p = positionOf(dense.getState(i), dims, true);
      free = free && world.isFree(p);
      if (i > 0) r.cost += (p - positionOf(dense.getState(i - 1), dims, true)).norm();
    }
    r.valid = check.ok && free;
    r.invalid_reason = !check.ok ? check.reason : (free ? "" : "arc state in collision");
  }
  return r;
}

}  // namespace

bool omplAvailable() { return true; }

std::vector<std::string> omplPlannerNames() {
  std::vector<std::string> all = kGeometric;
  all.insert(all.end(), kKinodynamic.begin(), kKinodynamic.end());
  return all;
}

bool isOmplKinodynamic(const std::string& name) {
  return std::find(kKinodynamic.begin(), kKinodynamic.end(), name) != kKinodynamic.end();
}

RunRecord runOmpl(const std::string& name, const planner::Scenario& scenario, const CollisionWorld& world,
                  const planner::PlanProblem& problem) {
  silenceOmplOnce();
  const bool geometric = std::find(kGeometric.begin(), kGeometric.end(), name) != kGeometric.end();
  if (!geometric && !isOmplKinodynamic(name)) {
    std::string known;
    for (const auto& n : omplPlannerNames()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown OMPL planner '" + name + "' (known: " + known + ")");
  }
  RunRecord r = geometric ? runGeometric(name, scenario, world, problem) : runKinodynamic(name, scenario, world, problem);
  r.planner = name;
  r.scenario = scenario.name;
  r.seed = problem.seed;
  if (r.solved && r.iterations > 0) r.pous = static_cast<double>(r.vertices) / static_cast<double>(r.iterations);
  return r;
}

}  // namespace ddsnav::bench
