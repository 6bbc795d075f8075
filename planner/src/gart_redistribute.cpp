// GART's dynamic cost metric and bidirectional potential field redistribution (Algorithm 1, lines 4-13).
#include "ddsnav/planner/gart.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

namespace ddsnav::planner {

namespace {

// Cap a displacement's length.
Vec3 capped(const Vec3& v, double max_length) {
  const double n = v.norm();
  return n > max_length && n > 0.0 ? Vec3(v * (max_length / n)) : v;
}

Vec3 flatten(Vec3 v, int dimensions) {
  if (dimensions == 2) v.z() = 0.0;
  return v;
}

// Obstacles within range, with those the robot could not pass between merged into one: the paper's
// obstacle counting sees one obstacle per continuous edge, so primitives that touch or overlap (a wall
// built from several boxes) must not count as "several obstacles" with a gap between them. Two margin
// nodes closer than the robot's diameter leave no passable gap; the nearer one represents both.
std::vector<NearbyObstacle> distinctObstacles(const Vec3& p, const CollisionWorld& world, double range) {
  std::vector<NearbyObstacle> seen = world.obstaclesNear(p, range);  // nearest first
  const double min_gap = 2.0 * world.robotRadius();
  // Compacted in place (the kept ones stay in order at the front): no second vector per candidate.
  std::size_t kept = 0;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    const Vec3 m = flatten(seen[i].nearest_point, world.dimensions());
    bool merged = false;
    for (std::size_t j = 0; j < kept; ++j) {
      if ((flatten(seen[j].nearest_point, world.dimensions()) - m).norm() <= min_gap) {
        merged = true;
        break;
      }
    }
    if (!merged) seen[kept++] = seen[i];
  }
  seen.resize(kept);
  return seen;
}

bool sameState(const Vec3& a, const Vec3& b) { return (a - b).norm() < 1e-9; }

// wrapAngle for the difference of two angles: within (-2 pi, 2 pi) one shift by 2 pi gives exactly what
// std::remainder gives (the subtraction is exact there), at a fraction of its cost; else wrapAngle.
double wrapSmallAngle(double a) {
  constexpr double kPi = std::numbers::pi;
  if (!(std::abs(a) < 2.0 * kPi)) return wrapAngle(a);
  if (a > kPi) return a - 2.0 * kPi;
  if (a <= -kPi) return a + 2.0 * kPi;
  return a;
}

// Event 1's reach search along one direction: the longest of the edge lengths `fractions` (of J, longest
// first; only those above `at_least`) whose edge from `parent` is free; 0 when none is. The paper's
// J(a) = max J(theta) over J, 3J/4, J/2, J/4 (the default list); event1_min_edge extends the list by
// halving. The edges along one direction are prefixes of each other, so "free" is monotone in the length:
// after the longest (most often the answer), the shortest is checked (blocked: every longer one is too),
// then a bisection finds the longest free one, the answer a longest-first scan gives with fewer checks.
// The direction's sine and cosine are computed once; positions are built exactly as driveUnicycle builds them.
// Event 1's reach fractions of J, longest first (a fixed array: built once per blocked sample, no allocation).
struct ReachFractions {
  std::array<double, 40> value{};
  int count = 0;
  std::size_t size() const { return static_cast<std::size_t>(count); }
  double operator[](int i) const { return value[static_cast<std::size_t>(i)]; }
};

double longestFreeFraction(const State& parent, double turn, double climb, double at_least,
                           const ReachFractions& fractions, const CollisionWorld& world,
                           const ForwardRegion& region) {
  turn = std::clamp(turn, -region.max_turn, region.max_turn);
  const double heading = wrapAngle(parent.heading + turn);
  const double c = std::cos(heading), s = std::sin(heading);
  auto endAt = [&](double fraction) {
    const double length = std::clamp(fraction * region.reach, 0.0, region.reach);
    const double z = region.dimensions == 3 ? std::clamp(climb * fraction, -region.max_climb, region.max_climb) : 0.0;
    return Vec3(parent.position + Vec3(length * c, length * s, z));
  };
  auto isFreeAt = [&](double fraction) { return world.isSegmentFree(parent.position, endAt(fraction)); };
  int count = 0;  // fractions above at_least: fractions[0 .. count-1], longest first
  while (count < static_cast<int>(fractions.size()) && fractions[count] > at_least) ++count;
  if (count == 0) return 0.0;
  if (isFreeAt(fractions[0])) return fractions[0];
  if (count == 1 || !isFreeAt(fractions[count - 1])) return 0.0;
  int blocked = 0, free = count - 1;  // invariant: fractions[blocked] blocked, fractions[free] free
  while (free - blocked > 1) {
    const int mid = (blocked + free) / 2;
    if (isFreeAt(fractions[mid])) free = mid;
    else blocked = mid;
  }
  return fractions[free];
}

// The reach fractions of event 1: J, 3J/4, J/2, J/4, then halving while the edge stays at least
// `min_edge` metres long.
ReachFractions reachFractions(const ForwardRegion& region, double min_edge) {
  ReachFractions f;
  for (double v : {1.0, 0.75, 0.5, 0.25}) f.value[static_cast<std::size_t>(f.count++)] = v;
  while (f[f.count - 1] * 0.5 * region.reach >= min_edge && f.count < 40) {
    f.value[static_cast<std::size_t>(f.count)] = f[f.count - 1] * 0.5;
    ++f.count;
  }
  return f;
}

}  // namespace

double gartControlEffort(const State& from, const Vec3& target, const ForwardRegion& region,
                         double turn_weight) {
  // Called for each of the k nearest nodes on every iteration, so it computes turnTowards(from, target)
  // by hand: one hypot shared with the distance, and the angle wrap without std::remainder (same values).
  const Vec3 d = target - from.position;
  const double horizontal = std::hypot(d.x(), d.y());
  const double edge_heading = horizontal <= kNoDirectionLength ? from.heading : std::atan2(d.y(), d.x());
  const double turn = std::abs(wrapSmallAngle(edge_heading - from.heading));
  if (turn > region.max_turn) return std::numeric_limits<double>::infinity();
  const double distance = region.dimensions == 3 ? d.norm() : horizontal;
  const double normalised_turn = region.max_turn > 0.0 ? turn / region.max_turn : 0.0;
  return turn_weight * normalised_turn + distance / region.reach;
}

GartForce gartObstacleForce(const Vec3& p, const CollisionWorld& world, const ForwardRegion& region,
                            const GartOptions& options) {
  GartForce force;
  const double range = options.detection_range * region.reach;
  const std::vector<NearbyObstacle> obstacles = distinctObstacles(p, world, range);
  force.obstacles = static_cast<int>(obstacles.size());
  const double max_push = options.max_push * region.reach;
  if (obstacles.size() >= 2 && !options.event2) return force;
  if (obstacles.size() == 1 && !options.event3) return force;
  if (obstacles.size() >= 2) {
    // Event 2, attraction: a_f = k1 * sum_i (O_i - a), k1 = attraction_gain / N. With gain 1 the candidate
    // moves to the centroid of the nearest margin nodes: between two walls, onto the middle of the gap.
    Vec3 sum = Vec3::Zero();
    for (const NearbyObstacle& o : obstacles) sum += flatten(o.nearest_point - p, world.dimensions());
    force.displacement = capped(sum * (options.attraction_gain / obstacles.size()), max_push);
    force.event = GartEvent::kAttraction;
  } else if (obstacles.size() == 1) {
    // Event 3, repulsion: r_f = k2 / |a - O| along (a - O)/|a - O|, k2 = repulsion_gain * J_dm^2.
    const Vec3 away = flatten(p - obstacles.front().nearest_point, world.dimensions());
    const double distance = away.norm();
    if (distance > 1e-9) {
      const double k2 = options.repulsion_gain * range * range;
      force.displacement = capped(away * (k2 / (distance * distance)), max_push);
    }
    force.event = GartEvent::kRepulsion;
  }
  return force;
}

std::vector<GartCandidate> gartRedistribute(const State& parent, const Vec3& sample, const Vec3& goal,
                                            const CollisionWorld& world, const ForwardRegion& region,
                                            const GartOptions& options) {
  std::vector<GartCandidate> out;
  gartRedistribute(parent, sample, goal, world, region, options, out);
  return out;
}

void gartRedistribute(const State& parent, const Vec3& sample, const Vec3& goal, const CollisionWorld& world,
                      const ForwardRegion& region, const GartOptions& options, std::vector<GartCandidate>& out) {
  out.clear();
  // Raw candidates: the sample projected into R+(parent), or event 1's two max-turn states (at most two:
  // a fixed array, so an iteration allocates nothing here).
  struct {
    std::array<GartCandidate, 2> items;
    std::size_t count = 0;
    bool empty() const { return count == 0; }
    const GartCandidate& front() const { return items[0]; }
    void push_back(const GartCandidate& c) { items[count++] = c; }
    const GartCandidate* begin() const { return items.data(); }
    const GartCandidate* end() const { return items.data() + count; }
  } raw;
  const State projected = steerUnicycle(parent, sample, region);
  if (!sameState(projected.position, parent.position) && world.isSegmentFree(parent.position, projected.position)) {
    GartCandidate c;
    c.state = projected;
    raw.push_back(c);
  } else if (options.event1 && !sameState(projected.position, parent.position)) {
    // Event 1: turn away from the blocked direction, one candidate per side. Directions are tried from the
    // sample's towards the maximum turn; along each the candidate reaches as far as is free (J, 3J/4, J/2,
    // J/4: the paper's J(a) = max J(theta)). The first direction free at full reach J ends the search;
    // otherwise the direction of the longest free edge wins (the smaller turn on ties).
    const double blocked_turn = turnTowards(parent, projected.position);
    const double climb = projected.position.z() - parent.position.z();
    const int steps = std::max(1, options.event1_turn_steps);
    const double min_edge = options.event1_min_edge > 0.0 ? options.event1_min_edge * world.robotRadius() : region.reach;
    const ReachFractions fractions = reachFractions(region, min_edge);
    for (int side : {-1, +1}) {
      const double limit = side * region.max_turn;
      double found_turn = 0.0;
      double found_fraction = 0.0;
      for (int k = 1; k <= steps && found_fraction < 1.0; ++k) {
        const double turn = blocked_turn + (limit - blocked_turn) * k / steps;
        const double fraction = longestFreeFraction(parent, turn, climb, found_fraction, fractions, world, region);
        if (fraction > found_fraction) {
          found_turn = turn;
          found_fraction = fraction;
        }
      }
      if (found_fraction <= 0.0) continue;
      const State found =
          driveUnicycle(parent, found_turn, found_fraction * region.reach, climb * found_fraction, region);
      if (!raw.empty() && sameState(raw.front().state.position, found.position)) continue;
      GartCandidate c;
      c.state = found;
      c.from_collision = true;
      raw.push_back(c);
    }
  }

  // Events 2 / 3 and goal attraction on every raw candidate; each result is projected back into R+(parent)
  // and kept only when its edge is free, else the raw (already free) candidate stands.
  for (GartCandidate c : raw) {
    const Vec3 p = c.state.position;
    if (!options.event2 && !options.event3 && !options.goal_attraction) {
      out.push_back(c);  // nothing to redistribute with (the ablation's "no field" variant)
      continue;
    }
    const GartForce force = gartObstacleForce(p, world, region, options);
    c.field = force.event;
    Vec3 to_goal = flatten(goal - p, world.dimensions());
    const double goal_distance = to_goal.norm();
    const double goal_step = options.goal_attraction ? std::min(goal_distance, options.goal_gain * region.reach) : 0.0;
    const Vec3 goal_pull = goal_distance > 1e-9 ? Vec3(to_goal * (goal_step / goal_distance)) : Vec3::Zero();
    const Vec3 target = p + force.displacement + goal_pull;
    if (!sameState(target, p)) {
      const State moved = steerUnicycle(parent, target, region);
      if (!sameState(moved.position, parent.position) && world.isSegmentFree(parent.position, moved.position)) {
        c.state = moved;
        c.redistributed = true;
      }
    }
    bool duplicate = false;
    for (const GartCandidate& o : out) duplicate = duplicate || sameState(o.state.position, c.state.position);
    if (!duplicate) out.push_back(c);
  }
}

}  // namespace ddsnav::planner
