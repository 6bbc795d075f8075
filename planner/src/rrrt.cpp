// RRRT, retraction-based RRT (after Zhang & Manocha 2008). A plain RRT extension that hits an obstacle
// is not thrown away: the tree grows up to the contact state q_c (the last free state on the edge) and
// then retracts the sample onto the obstacle's boundary: it repeatedly moves along the tangent plane at
// the contact, towards the sample,
//   q' = q + s * t/|t|,   t = (q_rand - q) - ((q_rand - q) . n) n,   n = (q - p)/|q - p|,
// p the nearest obstacle surface point (obstaclesNear), s <= range/4, and projects q' back to clearance
// `margin` from that surface: q' <- p' + (robot_radius + margin) (q' - p')/|q' - p'|. Each free step is a
// tree edge. The tree thus slides along obstacle boundaries, which is what finds narrow passages.
// Geometric only.
#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/run.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::planner {
namespace {

class RrrtPlanner final : public Planner {
 public:
  std::string name() const override { return "rrrt"; }

  PlanResult solve(const PlanProblem& problem) override {
    PlannerRun run(problem, name(), false);
    const CollisionWorld& world = run.world;
    const Steering steering = Steering::geometric(defaultRange(world));
    const double resolution = world.checkResolution();
    const double margin = 2.0 * resolution;
    while (run.nextIteration()) {
      const Vec3 target = run.sample(kGoalBias);
      const int nearest = run.tree.nearest(target);
      const State from = run.tree.node(nearest).state;
      const State to = steering.steer(from, target);
      const double length = (to.position - from.position).norm();
      if (length < 1e-9) continue;
      if (world.isSegmentFree(from.position, to.position)) {
        run.addNode(to, nearest, run.tree.node(nearest).cost + length);
        continue;
      }
      // Contact: the last free state on the way to the sample, within one check resolution.
      const Vec3 q = lastFreeState(world, from.position, to.position, resolution);
      int node = nearest;  // retract from the contact state, or from the tree when it is already there
      if ((q - from.position).norm() > margin && world.isSegmentFree(from.position, q)) {
        node = run.addNode(State{q, edgeHeading(from.position, q, from.heading)}, nearest, run.tree.node(nearest).cost + (q - from.position).norm());
      }
      retract(run, node, target, steering.range() / 4.0, margin);
    }
    return run.finish();
  }

 private:
  static constexpr double kGoalBias = 0.05;
  static constexpr int kRetractionSteps = 4;

  // Walks from `a` (free) towards `b`, skipping ahead by the clearance (every state closer than the
  // clearance is free), and refines the last stretch at the check resolution.
  static Vec3 lastFreeState(const CollisionWorld& world, const Vec3& a, const Vec3& b, double resolution) {
    const double length = (b - a).norm();
    const Vec3 direction = (b - a) / length;
    double free_until = 0.0, s = 0.0;
    while (true) {
      const double c = world.clearance(a + direction * s);
      if (!(c > 0.0) || !world.isFree(a + direction * s)) break;
      free_until = s;
      if (s >= length) return b;
      s = std::min(length, s + std::max(resolution, c));
    }
    // The contact lies in (free_until, s]: march it at the resolution.
    for (double t = free_until + resolution; t < s && world.isFree(a + direction * t); t += resolution) free_until = t;
    return a + direction * free_until;
  }

  void retract(PlannerRun& run, int node, const Vec3& target, double max_step, double margin) {
    const CollisionWorld& world = run.world;
    const double r = world.robotRadius();
    for (int k = 0; k < kRetractionSteps; ++k) {
      const State at = run.tree.node(node).state;
      const auto contact = world.obstaclesNear(at.position, r + 4.0 * margin);
      if (contact.empty() || contact.front().distance <= 0.0) return;  // touching the bounds, not an obstacle
      const Vec3 normal = (at.position - contact.front().nearest_point) / contact.front().distance;
      const Vec3 v = target - at.position;
      Vec3 tangent = v - v.dot(normal) * normal;
      if (world.dimensions() == 2) tangent.z() = 0.0;
      const double t = tangent.norm();
      if (t < margin) return;  // the sample is straight behind the obstacle: nothing to slide towards
      Vec3 next = at.position + tangent * (std::min(max_step, t) / t);
      // Back onto the boundary offset by the robot radius plus a margin.
      const auto surface = world.obstaclesNear(next, std::max(max_step, r + 4.0 * margin) + r);
      if (!surface.empty() && surface.front().distance > 0.0) {
        const Vec3 out = (next - surface.front().nearest_point) / surface.front().distance;
        if (surface.front().distance < r + margin || surface.front().distance > r + 4.0 * margin) {
          next = surface.front().nearest_point + out * (r + 2.0 * margin);
        }
      }
      const double length = (next - at.position).norm();
      if (length < margin || !world.isSegmentFree(at.position, next)) return;
      node = run.addNode(State{next, edgeHeading(at.position, next, at.heading)}, node, run.tree.node(node).cost + length);
    }
  }
};

}  // namespace

std::unique_ptr<Planner> makeRrrtPlanner() { return std::make_unique<RrrtPlanner>(); }

}  // namespace ddsnav::planner
