// APGD-RRT*: RRT* whose samples descend an artificial potential before the tree grows towards them
// (after Qureshi & Ayaz's potential-guided RRT*). The potential (Khatib) is
//   U(x) = k_a |x - x_goal| + 1/2 k_r sum_o (1/rho_o - 1/rho_0)^2   for rho_o < rho_0,
// rho_o the distance from x to obstacle o's surface (from obstaclesNear). Its negative gradient is
//   F(x) = k_a (x_goal - x)/|x_goal - x| + k_r sum_o (1/rho_o - 1/rho_0) / rho_o^2 * (x - p_o)/rho_o,
// p_o the nearest surface point. A sample takes K steps x <- x + lambda F/|F|, stopping early at a step
// that would end in collision. k_r = k_a rho_0^3 / 4 makes repulsion equal attraction at rho_0 / 2.
// Geometric only: the tree reports kinodynamic = false.
#include "ddsnav/planner/planners.hpp"
#include "ddsnav/planner/rrtstar.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::planner {
namespace {

class ApgdRrtStarPlanner final : public RrtStarPlanner {
 public:
  std::string name() const override { return "apgd-rrtstar"; }

 protected:
  bool kinodynamicCapable() const override { return false; }

  Vec3 shapeSample(PlannerRun& run, const Vec3& sample) override {
    const CollisionWorld& world = run.world;
    const Vec3& goal = run.problem.goal;
    if ((sample - goal).norm() < 1e-9) return sample;  // the goal-biased sample needs no guidance
    const double diagonal = defaultRange(world) * 5.0;
    const double rho0 = std::max(5.0 * world.robotRadius(), 0.02 * diagonal);  // influence distance
    const double lambda = 0.01 * diagonal;                                    // descent step
    const double k_att = 1.0;
    const double k_rep = k_att * rho0 * rho0 * rho0 / 4.0;
    Vec3 x = sample;
    for (int step = 0; step < kSteps; ++step) {
      Vec3 force = Vec3::Zero();
      const Vec3 to_goal = goal - x;
      const double goal_distance = to_goal.norm();
      if (goal_distance < lambda) break;
      force += k_att * to_goal / goal_distance;
      for (const NearbyObstacle& o : world.obstaclesNear(x, rho0 + world.robotRadius())) {
        // Distance measured from the robot's boundary, so the potential keeps the whole body away.
        const double rho = std::max(o.distance - world.robotRadius(), 1e-3);
        if (rho >= rho0 || o.distance <= 0.0) continue;
        const Vec3 away = (x - o.nearest_point) / o.distance;
        force += k_rep * (1.0 / rho - 1.0 / rho0) / (rho * rho) * away;
      }
      if (world.dimensions() == 2) force.z() = 0.0;
      const double magnitude = force.norm();
      if (magnitude < 1e-12) break;
      const Vec3 next = x + lambda * force / magnitude;
      if (!world.isFree(next)) break;
      x = next;
    }
    return x;
  }

 private:
  static constexpr int kSteps = 5;
};

}  // namespace

std::unique_ptr<Planner> makeApgdRrtStarPlanner() { return std::make_unique<ApgdRrtStarPlanner>(); }

}  // namespace ddsnav::planner
